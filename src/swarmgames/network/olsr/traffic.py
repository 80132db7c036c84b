"""OLSR's own control traffic, per node, over an interval of simulated time."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmgames.network.olsr.wire import UDP_IP_HEADER

__all__ = ["ControlTraffic"]

_FIELDS = (
    "hello_sent",
    "hello_bytes",
    "tc_sent",
    "tc_bytes",
    "tc_forwarded",
    "tc_forwarded_bytes",
)


@dataclass(frozen=True)
class ControlTraffic:
    """HELLO and TC messages each node put on the air in ``(since, until]``, and their bytes.

    A message counts when it is sent (its build time plus jitter), not when it is built. Bytes
    are OLSR packet bytes (:mod:`~.wire`: packet header, message header, body; the engine sends
    one message per packet), without the UDP/IP headers, which :attr:`udp_ip_bytes` gives.

    Attributes
    ----------
    since, until : float
        The interval, seconds.
    hello_sent, hello_bytes : ndarray of int64, shape (N,)
        HELLOs sent by each node (one per HELLO round, to its 1-hop neighbours) and their bytes.
    tc_sent, tc_bytes : ndarray of int64, shape (N,)
        TCs each node originated (one per TC round while it has MPR selectors) and their bytes.
    tc_forwarded, tc_forwarded_bytes : ndarray of int64, shape (N,)
        TCs of other nodes each node retransmitted as an MPR (RFC 3626 section 3.4.1), bytes.

    All arrays are read-only.
    """

    since: float
    until: float
    hello_sent: np.ndarray
    hello_bytes: np.ndarray
    tc_sent: np.ndarray
    tc_bytes: np.ndarray
    tc_forwarded: np.ndarray
    tc_forwarded_bytes: np.ndarray

    def __post_init__(self) -> None:
        for name in _FIELDS:
            a = np.array(getattr(self, name), dtype=np.int64)
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def messages(self) -> np.ndarray:
        """Messages (= packets) each node sent: HELLOs, TCs originated and forwarded."""
        return self.hello_sent + self.tc_sent + self.tc_forwarded

    @property
    def bytes(self) -> np.ndarray:
        """OLSR packet bytes each node sent, UDP/IP headers excluded."""
        return self.hello_bytes + self.tc_bytes + self.tc_forwarded_bytes

    @property
    def udp_ip_bytes(self) -> np.ndarray:
        """On-air UDP/IPv4 header bytes (28 per packet) each node sent on top of :attr:`bytes`."""
        return UDP_IP_HEADER * self.messages
