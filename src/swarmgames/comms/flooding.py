"""Routed delivery: every robot's state message flooded over the links that exist now.

A message leaves its sender once per control period and is rebroadcast, hop after hop, up to
``ttl`` hops (the neighbourhood radius h). A hop from robot u to robot v needs the link to
exist physically at that moment (v within the radio range of u at the current positions)
*and* in u's routing table (v a 1-hop, symmetric neighbour of u): the usable links are the
``adjacency`` matrix. Each robot that receives a message for the first time at depth d < ttl
forwards it once; a copy heard again is not forwarded again. With the i.i.d. loss model every
transmission u→v of every message is lost with probability p, independently, so a robot that
hears c transmitters of a new message at one depth gets it with probability 1 − p^c. The
depth of the first reception is the number of hops the message travelled, and the latency is
that many times the per-hop latency (a configured delay plus the frame's airtime,
:mod:`swarmgames.comms.wire`).

Everything is vectorised over all the messages of a stage at once: the frontier of every
message is a row of one sparse matrix, and one sparse product per hop moves them all.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from swarmgames.arrays import freeze_fields

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


def _isin_sorted(keys: np.ndarray, sorted_set: np.ndarray) -> np.ndarray:
    if sorted_set.size == 0:
        return np.zeros(keys.shape, dtype=bool)
    pos = np.minimum(np.searchsorted(sorted_set, keys), sorted_set.size - 1)
    return sorted_set[pos] == keys


def flood(
    adjacency: sp.csr_array,
    ttl: int,
    sizes: np.ndarray,
    *,
    loss_rate: float = 0.0,
    rng: np.random.Generator | None = None,
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
    loss_rate : float
        Probability that one transmission is lost, in [0, 1].
    rng : numpy.random.Generator
        Draws of the losses (one uniform per new (message, receiver) pair and hop, in
        (sender, receiver) order); needed when ``loss_rate > 0``.
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
    src = np.flatnonzero(senders)
    adj = sp.csr_array(adjacency, dtype=np.int32)
    frontier = sp.csr_array(
        (np.ones(src.size, dtype=np.int32), (src, src)), shape=(n, n), dtype=np.int32
    )
    reached = np.sort(src.astype(np.int64) * n + src)
    forwarded = np.zeros(n, dtype=np.int64)
    bytes_forwarded = np.zeros(n, dtype=np.int64)
    got: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for depth in range(1, int(ttl) + 1):
        if depth > 1:  # robots that first heard a message one hop ago relay it once
            msg, relay = frontier.nonzero()
            np.add.at(forwarded, relay, 1)
            np.add.at(bytes_forwarded, relay, sizes[msg])
        heard = sp.coo_array(frontier @ adj)
        keys = heard.row.astype(np.int64) * n + heard.col
        order = np.argsort(keys, kind="stable")
        keys, count = keys[order], heard.data[order]
        new = ~_isin_sorted(keys, reached)
        keys, count = keys[new], count[new]
        if loss_rate > 0 and keys.size:
            keys = keys[rng.random(keys.size) < 1.0 - float(loss_rate) ** count]
        if keys.size == 0:
            break
        msg, node = np.divmod(keys, n)
        got.append((node, msg, np.full(keys.size, depth, dtype=np.int64)))
        reached = np.union1d(reached, keys)
        frontier = sp.csr_array(
            (np.ones(keys.size, dtype=np.int32), (msg, node)), shape=(n, n), dtype=np.int32
        )
    if got:
        receiver, sender, hops = (np.concatenate(parts) for parts in zip(*got, strict=True))
        order = np.lexsort((sender, receiver))
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
