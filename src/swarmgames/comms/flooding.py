"""Routed delivery: every robot's state message flooded over the links that exist now.

A message leaves its sender once per control period and is rebroadcast, hop after hop, up to
``ttl`` hops (the neighbourhood radius h). A hop from robot u to robot v needs the link to
exist physically at that moment (v within the radio range of u at the current positions)
*and* in u's routing table (v a 1-hop, symmetric neighbour of u): the usable links are the
``adjacency`` matrix. Each robot that receives a message for the first time at depth d < ttl
forwards it once; a copy heard again is not forwarded again. Every transmission u→v of every
message arrives or not by the caller's loss and reception models (``link_success``: i.i.d.
loss, a Gilbert–Elliott burst channel per link, the fading channel's own draw), so a robot
that hears several relays of a new message gets it if one of them arrives. The depth of the
first reception is the number of hops the message travelled, and the latency is
that many times the per-hop latency (a configured delay plus the frame's airtime,
:mod:`swarmgames.comms.wire`).

All the messages of a stage travel at once: one hop expands every (message, holder) pair of
the frontier into its transmissions along the CSR rows of the adjacency, keeps those that
could bring a message to a robot that does not have it yet, draws them (``link_success``)
and merges the first receptions into the sorted set of (message, robot) pairs reached.
The expansion is one compiled pass (:func:`_fresh`): as numpy steps, a hop of a 100-UAV
swarm would be about twenty calls, each costing more than its arithmetic.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit

from swarmgames.arrays import freeze_fields, sorted_unique

__all__ = ["Delivery", "flood"]


@dataclass(frozen=True, eq=False)
class Delivery:
    """Who received whose message in one stage, and what it cost.

    Parameters
    ----------
    receiver, sender : ndarray of int64, shape (R,)
        Each first reception, sorted by (receiver, sender); a robot never receives its own.
    hops : ndarray of int64, shape (R,)
        Depth of the first reception (1 = heard from the sender itself).
    sent, forwarded, received : ndarray of int64, shape (N,)
        Messages each robot sent (its own), forwarded and received (first receptions).
    bytes_sent, bytes_forwarded, bytes_received : ndarray of int64, shape (N,)
        The same in bytes of payload.
    """

    receiver: np.ndarray
    sender: np.ndarray
    hops: np.ndarray
    sent: np.ndarray
    forwarded: np.ndarray
    received: np.ndarray
    bytes_sent: np.ndarray
    bytes_forwarded: np.ndarray
    bytes_received: np.ndarray

    def __post_init__(self) -> None:
        freeze_fields(self)


@njit(cache=True, nogil=True)
def _fresh(indptr, indices, msg, node, reached, n):
    """The transmissions of one hop that could bring a message to a robot without it: for
    every frontier pair ``(msg[p], node[p])`` in order (sorted by message) and every
    neighbour ``v`` of the holder in adjacency order, ``(msg N + v, node[p], v)`` unless
    ``msg N + v`` is in the sorted ``reached``. The robots that hold a message are flagged
    in an array of N entries while its pairs are expanded."""
    total = 0
    for p in range(node.size):
        total += indptr[node[p] + 1] - indptr[node[p]]
    keys = np.empty(total, np.int64)
    tx_u = np.empty(total, np.int64)
    tx_v = np.empty(total, np.int64)
    has = np.zeros(n, np.bool_)
    lo = hi = 0  # the run of the current message in reached
    current = -1
    m = 0
    for p in range(node.size):
        if msg[p] != current:
            for r in range(lo, hi):
                has[reached[r] - current * n] = False
            current = msg[p]
            lo = np.searchsorted(reached, current * n)
            hi = np.searchsorted(reached, (current + 1) * n)
            for r in range(lo, hi):
                has[reached[r] - current * n] = True
        u = node[p]
        base = current * n
        for e in range(indptr[u], indptr[u + 1]):
            v = indices[e]
            if has[v]:
                continue
            keys[m] = base + v
            tx_u[m] = u
            tx_v[m] = v
            m += 1
    return keys[:m], tx_u[:m], tx_v[:m]


def flood(
    adjacency: sp.csr_array,
    ttl: int,
    sizes: np.ndarray,
    *,
    link_success: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    senders: np.ndarray | None = None,
) -> Delivery:
    """Flood every sender's message over ``adjacency`` for at most ``ttl`` hops.

    Parameters
    ----------
    adjacency : sparse (N, N)
        ``[u, v]`` nonzero where u can transmit to v now.
    ttl : int
        Largest number of hops, >= 1.
    sizes : ndarray of int, shape (N,)
        Payload of each robot's message, bytes.
    link_success : callable ``(u, v) -> ndarray of bool``, optional
        Whether each transmission from ``u[k]`` to ``v[k]`` arrives (the loss and reception
        models draw here); called once per hop with every transmission of that hop that
        could bring a message to a robot that does not have it yet, in (message,
        transmitter, receiver) order. Default: every transmission arrives.
    senders : ndarray of bool, shape (N,), optional
        Robots that send a message this stage (default: all).

    Returns
    -------
    Delivery

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> line = sp.csr_array(np.array([[0, 1, 0], [1, 0, 1], [0, 1, 0]]))
    >>> d = flood(line, 2, np.array([10, 10, 10]))
    >>> list(zip(d.receiver.tolist(), d.sender.tolist(), d.hops.tolist()))
    [(0, 1, 1), (0, 2, 2), (1, 0, 1), (1, 2, 1), (2, 0, 2), (2, 1, 1)]
    >>> d.forwarded.tolist()  # every first reception at depth 1 is relayed once (TTL 2)
    [1, 2, 1]
    """
    n = adjacency.shape[0]
    sizes = np.asarray(sizes, dtype=np.int64)
    if senders is None:
        senders = np.ones(n, dtype=bool)
    adj = sp.csr_array(adjacency)
    adj.sort_indices()
    indptr, indices = np.asarray(adj.indptr, dtype=np.int64), np.asarray(adj.indices, np.int64)
    msg = np.flatnonzero(senders).astype(np.int64)  # the frontier: (message, holder) pairs
    node = msg.copy()
    reached = np.sort(msg * n + node)
    forwarded = np.zeros(n, dtype=np.int64)
    bytes_forwarded = np.zeros(n, dtype=np.int64)
    got: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for depth in range(1, int(ttl) + 1):
        if depth > 1:  # robots that first heard a message one hop ago relay it once
            forwarded += np.bincount(node, minlength=n)
            bytes_forwarded += np.bincount(node, weights=sizes[msg], minlength=n).astype(np.int64)
        keys, tx_u, tx_v = _fresh(indptr, indices, msg, node, reached, np.int64(n))
        if link_success is not None and keys.size:
            ok = np.asarray(link_success(tx_u, tx_v), dtype=bool)
            keys = keys[ok]
        keys = sorted_unique(keys)
        if keys.size == 0:
            break
        msg, node = np.divmod(keys, n)
        got.append((node, msg, np.full(keys.size, depth, dtype=np.int64)))
        # ``keys`` are sorted, unique and new: merged in, the same array as np.union1d.
        reached = np.insert(reached, np.searchsorted(reached, keys), keys)
    if got:
        receiver, sender, hops = (np.concatenate(parts) for parts in zip(*got, strict=True))
        order = np.argsort(receiver * n + sender)  # unique pairs: lexsort's order
        receiver, sender, hops = receiver[order], sender[order], hops[order]
    else:
        receiver = sender = hops = np.zeros(0, dtype=np.int64)
    received = np.bincount(receiver, minlength=n).astype(np.int64)
    bytes_received = np.bincount(receiver, weights=sizes[sender], minlength=n).astype(np.int64)
    sent = senders.astype(np.int64)
    return Delivery(
        receiver=receiver,
        sender=sender,
        hops=hops,
        sent=sent,
        forwarded=forwarded,
        received=received,
        bytes_sent=sent * sizes,
        bytes_forwarded=bytes_forwarded,
        bytes_received=bytes_received,
    )
