"""The ``ns3`` communication model: state messages as UDP packets in the ns-3 simulator.

With ``network.backend = "ns3"`` and ``comms.model = "ns3"``, every robot's state message of
every control period is a UDP datagram whose payload is the wire format's bytes
(:func:`~swarmgames.comms.wire.encode_messages`), broadcast through the provider's own ns-3
nodes and relayed for h hops, 2h for ``game.virtual_mean = "exact"``
(:class:`~swarmgames.network.ns3_packets.StateFlood`). ns-3
runs from the stage time t to the decision at ``t + decide_after_s``; the robots decide with
what their sockets received by then. Everything else is the routed model's
(:class:`~swarmgames.comms.models.BeliefComms`): the message contents, the belief tables, the
age limit, dead reckoning and the inboxes.

What comes from ns-3:

* **who receives**: a frame must reach its receiver through ns-3's channel (propagation
  loss, shadowing and fading as the provider configured them, the -82 dBm preamble
  detection) without colliding with another frame (802.11a DCF, hidden terminals, OLSR's own
  packets), from a transmitter whose table lists the receiver as a 1-hop neighbour (the
  routed model's rule); broadcasts get no MAC retransmission;
* **when**: a reception's arrival is ``Simulator::Now()`` at the socket, so a message's age on
  arrival, ``arrival - timestamp``, is the sum over its hops of the jitter, the channel
  access (DIFS, backoff, waiting for the frames ahead in the queue) and the airtime;
* **what it cost**: messages and bytes sent, forwarded and received are counted from the
  datagrams the sockets took and delivered (UDP payload bytes, the wire format's size).

Each transmission, a robot's own message or a relay, first waits a uniform random time in
``[0, jitter_s]`` drawn from the run's communication Generator; without it every robot would
start in the same slot and the messages would collide (RFC 3626 section 3.5 jitters OLSR's
messages for the same reason). A message that arrives after the decision (late relays, long
queues) is kept, and used from the next decision on if nothing newer from its sender
arrived first. Its counters join the stage in which ns-3 delivered it.

References
----------
.. [1] ns-3 3.44 model library, "Sockets APIs" and "Wi-Fi" (DCF) chapters.
.. [2] RFC 3626 section 3.5 (jitter).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from swarmgames.comms.beliefs import BeliefTable
from swarmgames.comms.load import offered_load
from swarmgames.comms.models import BeliefComms, table_links
from swarmgames.comms.wire import decode_messages, encode_messages, ofdm_airtime_s
from swarmgames.network.ns3_backend import Ns3Provider
from swarmgames.network.ns3_packets import PacketReceptions, PacketTransmissions, StateFlood

__all__ = ["Ns3Comms"]


@dataclass(eq=False)
class Ns3Comms(BeliefComms):
    """State messages as UDP packets in ns-3, into belief tables (see the module docstring).

    Parameters
    ----------
    n_robots, state_dim, hops : int
    provider : Ns3Provider
        The run's network; the packets travel between its nodes, with its radio and OLSR.
    jitter_s : float
        Each transmission waits a uniform random time in ``[0, jitter_s]``, seconds.
    decide_after_s, max_age_s, dead_reckoning, gps_error_m
        Keyword only, see :class:`~swarmgames.comms.models.BeliefComms`.

    Attributes
    ----------
    receptions : PacketReceptions or None
        The first receptions of the last exchange, ns-3 timestamps and payloads.
    transmissions : PacketTransmissions or None
        The datagrams the sockets took during the last exchange.

    Notes
    -----
    The sockets are opened at the first exchange after the provider's ``reset`` (the run
    resets the model before the network), and again whenever the provider builds a new
    scenario. ns-3's clock starts at the provider's ``start_time``: arrivals are converted to
    the run's clock by the difference of the two at the stage time.

    Examples
    --------
    >>> from swarmgames.network.ns3_backend import Ns3Provider
    >>> net = Ns3Provider(seed=1)  # doctest: +SKIP
    >>> comms = Ns3Comms(3, 3, 2, net)  # doctest: +SKIP
    >>> pos = np.array([[0.0, 0, 30], [300, 0, 30], [600, 0, 30]])
    >>> snap = (net.reset(pos), net.advance(30.0, pos))[1]  # doctest: +SKIP
    >>> _, stats = comms.exchange(30.0, snap, pos, np.random.default_rng(0))  # doctest: +SKIP
    >>> stats.bytes_sent.tolist()  # doctest: +SKIP
    [75, 75, 75]
    """

    provider: Any = None
    jitter_s: float = 0.04
    receptions: PacketReceptions | None = field(init=False, default=None)
    transmissions: PacketTransmissions | None = field(init=False, default=None)
    _flood: StateFlood | None = field(init=False, default=None, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.provider, Ns3Provider):
            raise TypeError(
                "Ns3Comms needs the run's ns-3 provider (network.backend = 'ns3'), got "
                f"{type(self.provider).__name__}"
            )
        if not self.jitter_s >= 0:
            raise ValueError(f"jitter_s must be >= 0 (got {self.jitter_s})")
        super().__post_init__()

    def reset(self) -> None:
        """Forget every belief; the sockets are reopened at the next exchange."""
        super().reset()
        if self._flood is not None:
            self._flood.close()
        self._flood = None
        self.receptions = self.transmissions = None

    def deliver(self, t, snapshot, states, composed, rng, active):
        """Broadcast the messages in ns-3, run it to the decision and read the sockets."""
        n = states.shape[0]
        if self._flood is None or not self._flood.live:
            self._flood = StateFlood(self.provider, self.reach)
        flood = self._flood
        offset = float(t) - flood.now  # the run's clock minus ns-3's
        buffer, offsets = encode_messages(
            np.arange(n), float(t), composed.reported, composed.mean, composed.report_indptr,
            composed.report_members,
        )  # fmt: skip
        on = sp.diags_array(active.astype(np.int8), dtype=np.int8)
        links = sp.csr_array(on @ table_links(snapshot) @ on)
        links.eliminate_zeros()
        links.sort_indices()
        jitter = rng.uniform(0.0, self.jitter_s, (n, n))
        flood.send(buffer, offsets, active, links.indptr, links.indices, jitter)
        flood.run_until(t + self.decide_after_s - offset)
        rx, tx = flood.drain()
        self.receptions, self.transmissions = rx, tx
        msg = decode_messages(rx.payload, rx.offsets)
        state = msg.state if rx.size.size else np.zeros((0, self.state_dim))
        new = BeliefTable(
            n,
            rx.receiver,
            msg.sender,
            msg.stamp,
            rx.time + offset,
            state,
            msg.mean if rx.size.size else state,
            msg.nbh,
        )
        own = ~tx.relay

        def per_robot(who: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
            return np.bincount(who, weights=weights, minlength=n).astype(np.int64)

        counters = {
            "messages_sent": per_robot(tx.node[own]),
            "messages_forwarded": per_robot(tx.node[~own]),
            "messages_received": per_robot(rx.receiver),
            "bytes_sent": per_robot(tx.node[own], tx.size[own]),
            "bytes_forwarded": per_robot(tx.node[~own], tx.size[~own]),
            "bytes_received": per_robot(rx.receiver, rx.size),
            "channel_load": offered_load(
                links.tocoo().row,
                links.tocoo().col,
                np.bincount(tx.node, weights=ofdm_airtime_s(tx.size), minlength=n),
                self.decide_after_s,
            ),
        }
        return new, counters
