"""``comms.model = "csma"``: the state messages flooded over one shared 802.11a channel.

The routed model's flooding (each message relayed once, for h hops, over the links in the
transmitter's routing table) with the channel's capacity: every transmission — a robot's own
message, a relay, an OLSR HELLO or TC — has a start time (jitter, carrier sense, DIFS,
backoff) and an airtime, and a reception fails when the interference of the other frames on
the air drowns it (:mod:`swarmgames.comms.channel`). Delivery, arrival times and hence the
information age come from the simulated times; a message that arrives after the decision
(``decide_after_s``) is used from the next decision on.

The received powers come from the run's radio model (the provider's channel: path loss, and
with shadowing or fading on, one draw per pair and stage). OLSR's own frames share the air at
the rates the OLSR model sends them: every robot a HELLO per ``hello_interval_s`` and, when
the model sends TCs, a TC per ``tc_interval_s``, each at a uniform random time of the control
period, sized by RFC 3626's formats from the robot's 1-hop neighbours.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from swarmgames.comms.beliefs import BeliefTable
from swarmgames.comms.channel import Mac, simulate
from swarmgames.comms.load import offered_load
from swarmgames.comms.models import BeliefComms
from swarmgames.comms.wire import ofdm_airtime_s
from swarmgames.network.olsr.tables import sorted_contains
from swarmgames.network.olsr.wire import hello_size, tc_size
from swarmgames.network.propagation import PropagationModel

__all__ = ["CsmaComms", "interference_range"]


def interference_range(model: PropagationModel, floor_dbm: float) -> float:
    """Distance at which a frame's mean received power falls to ``floor_dbm``, metres (the
    random channel's margin added: beyond it, a frame is negligible interference)."""
    lo, hi = 1.0, 1e7
    margin = 0.0
    if model.random:
        margin = float(model.mean_rx_power(np.array([model.max_range()]))[0])
        margin = model.radio.rx_threshold_dbm - margin
    for _ in range(100):
        mid = np.sqrt(lo * hi)
        if float(model.mean_rx_power(np.array([mid]))[0]) + margin >= floor_dbm:
            lo = mid
        else:
            hi = mid
    return hi


@dataclass(eq=False)
class CsmaComms(BeliefComms):
    """State messages flooded over a shared CSMA/CA channel into belief tables (module
    docstring).

    Parameters
    ----------
    n_robots, state_dim, hops : int
    propagation : PropagationModel
        The radio: the received power of every pair.
    rate_mbps : float
        PHY rate of every frame, Mbit/s.
    jitter_s : float
        Every message frame waits a uniform random time in ``[0, jitter_s]`` before it
        contends for the channel, seconds.
    period_s : float
        The control period: OLSR's frames are spread over it, seconds.
    hello_interval_s : float or None
        OLSR's HELLO interval, seconds; None without OLSR (the other providers send nothing).
    tc_interval_s : float or None
        OLSR's TC interval, seconds; None when the OLSR model sends no TCs (HELLO-only).
    loss_rate : float
        Probability that a message the channel delivered is lost all the same (i.i.d.).
    mac : Mac
        The channel's timing and reception thresholds.
    decide_after_s, max_age_s, dead_reckoning, gps_error_m, context, averaged_rows
        Keyword only, see :class:`~swarmgames.comms.models.BeliefComms`.

    Examples
    --------
    Three UAVs in a line, 300 m apart: with the 40 ms jitter nothing collides.

    >>> from swarmgames.topology import TopologySnapshot
    >>> pos = np.array([[0.0, 0, 30], [300, 0, 30], [600, 0, 30]])
    >>> hops = np.array([[0, 1, 2], [1, 0, 1], [2, 1, 0]])
    >>> snap = TopologySnapshot.from_hop_matrix(0.0, hops)
    >>> comms = CsmaComms(3, 3, 2)
    >>> _, stats = comms.exchange(0.0, snap, pos, np.random.default_rng(0))
    >>> stats.messages_received.tolist(), stats.messages_forwarded.tolist()
    ([2, 2, 2], [1, 2, 1])
    """

    propagation: PropagationModel = field(default_factory=PropagationModel)
    rate_mbps: float = 6.0
    jitter_s: float = 0.04
    period_s: float = 1.0
    hello_interval_s: float | None = 2.0
    tc_interval_s: float | None = None
    loss_rate: float = 0.0
    mac: Mac = field(default_factory=Mac)
    _reach: float = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._reach = interference_range(self.propagation, self.mac.floor_dbm)
        super().__post_init__()

    def state(self) -> dict:
        """What the robots remember between stages: the belief tables (immutable)."""
        return {"table": self.table}

    def restore(self, state: dict) -> None:
        """Continue from ``state`` (taken by :meth:`state`)."""
        table = state["table"]
        if table.n_robots != self.n_robots:
            raise ValueError(
                f"this state is of {table.n_robots} robots; the model has {self.n_robots}"
            )
        self.table = table

    def _air(self, pos: np.ndarray, rng: np.random.Generator):
        """Every pair within the interference range: CSR rows sorted by (u, v), and the
        received power of each, dBm."""
        from scipy.spatial import cKDTree

        n = pos.shape[0]
        pairs = cKDTree(pos).query_pairs(self._reach, output_type="ndarray").astype(np.int64)
        a, b = pairs[:, 0], pairs[:, 1]
        d = np.sqrt(np.einsum("ij,ij->i", pos[a] - pos[b], pos[a] - pos[b]))
        one_way = self.propagation.rx_power(d, rng, pairs=(np.minimum(a, b), np.maximum(a, b)))
        u, v = np.concatenate([a, b]), np.concatenate([b, a])
        order = np.argsort(u * n + v)
        u, v = u[order], v[order]
        power = np.concatenate([one_way, one_way])[order]
        indptr = np.concatenate([[0], np.cumsum(np.bincount(u, minlength=n))])
        return indptr, u, v, power

    def _control(self, snapshot, t: float, active: np.ndarray, rng: np.random.Generator):
        """OLSR's frames of the control period from ``t``: (node, ready time, airtime)."""
        n = active.size
        one = np.asarray(snapshot.hops) == 1
        k = np.bincount(np.asarray(snapshot.owner)[one], minlength=n)
        nodes, sizes = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
        if self.hello_interval_s is not None:
            rate = self.period_s / self.hello_interval_s
            hello = np.flatnonzero(active & (rng.random(n) < rate))
            nodes.append(hello)
            sizes.append(hello_size(np.minimum(k[hello], 1), k[hello]))
        if self.tc_interval_s is not None:
            tc = np.flatnonzero(
                active & (k > 0) & (rng.random(n) < self.period_s / self.tc_interval_s)
            )
            nodes.append(tc)
            sizes.append(tc_size(k[tc]))
        node = np.concatenate(nodes)
        ready = t + self.period_s * rng.random(node.size)
        return node, ready, ofdm_airtime_s(np.concatenate(sizes), self.rate_mbps)

    def deliver(self, t, snapshot, states, composed, rng, active):
        """Simulate the stage's frames on the channel; the first receptions, with their
        simulated arrival times, are the new belief entries."""
        n = states.shape[0]
        pos = states[:, :3]
        indptr, u, v, power = self._air(pos, rng)
        one = np.asarray(snapshot.hops) == 1
        listed = np.sort(
            np.asarray(snapshot.owner)[one].astype(np.int64) * n + np.asarray(snapshot.dest)[one]
        )
        link = sorted_contains(listed, u * n + v)
        ctl_node, ctl_ready, ctl_air = self._control(snapshot, t, active, rng)
        air = ofdm_airtime_s(composed.sizes, self.rate_mbps)
        res = simulate(
            indptr,
            v,
            power,
            link,
            np.full(n, float(t)),
            air,
            composed.sizes,
            ttl=self.reach,
            jitter_s=self.jitter_s,
            seed=int(rng.integers(0, 2**63)),
            loss_rate=self.loss_rate,
            active=active,
            control_node=ctl_node,
            control_ready_s=ctl_ready,
            control_airtime_s=ctl_air,
            mac=self.mac,
            rx_threshold_dbm=self.propagation.radio.rx_threshold_dbm,
        )
        s = res.sender
        new = BeliefTable(
            n,
            res.receiver,
            s,
            np.full(s.size, float(t)),
            res.arrival,
            composed.reported[s],
            composed.mean[s],
            composed.nbh[s].astype(np.int32),
        )
        sizes = composed.sizes
        sensed = power >= self.propagation.radio.rx_threshold_dbm
        counters = {
            "messages_sent": res.sent,
            "messages_forwarded": res.forwarded,
            "messages_received": np.bincount(res.receiver, minlength=n).astype(np.int64),
            "bytes_sent": res.sent * sizes,
            "bytes_forwarded": res.bytes_forwarded,
            "bytes_received": np.bincount(res.receiver, weights=sizes[s], minlength=n).astype(
                np.int64
            ),
            "channel_load": offered_load(u[sensed], v[sensed], res.airtime, self.decide_after_s),
        }
        return new, counters
