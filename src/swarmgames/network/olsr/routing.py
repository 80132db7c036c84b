"""Routing-table computation, RFC 3626 section 10, vectorised over every node of the swarm.

For each node ``r``:

1. every symmetric neighbour ``j`` gets a route ``(dest=j, next=j, hops=1)``;
2. every strict 2-hop neighbour ``x`` (reached through a symmetric neighbour ``j``, not ``r``,
   not already routed) gets ``(x, next=j, 2)``;
3. for ``h = 2, 3, ...``: every topology tuple ``(dest, last)`` whose ``last`` is routed at ``h``
   hops and whose ``dest`` is not routed yet gives ``(dest, next(last), h + 1)``; repeat until
   nothing is added.

Where several candidates give the same destination the first in node order wins (ns-3 keeps
the first it iterates over; any choice is a shortest route).

References
----------
.. [1] RFC 3626 section 10 (routing table calculation).
.. [2] ns-3 3.44 ``RoutingProtocol::RoutingTableComputation``.
"""

from __future__ import annotations

import numpy as np

from swarmgames.network.olsr import tables
from swarmgames.network.olsr.tables import KeySet, sorted_contains

__all__ = ["TupleTopology", "compute_routes"]


def _first_per_key(keys: np.ndarray, *cols: np.ndarray) -> tuple[np.ndarray, ...]:
    uk, first = np.unique(keys, return_index=True)
    return (uk, *(c[first] for c in cols))


def compute_routes(
    n_robots: int,
    sym_owner: np.ndarray,
    sym_neigh: np.ndarray,
    th_owner: np.ndarray,
    th_neigh: np.ndarray,
    th_two_hop: np.ndarray,
    topology=None,
    max_hops: int | None = None,
    strict: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every node's routing table.

    Parameters
    ----------
    n_robots : int
        Number of nodes N.
    sym_owner, sym_neigh : ndarray of int
        Valid symmetric links ``(r, j)``.
    th_owner, th_neigh, th_two_hop : ndarray of int
        Valid 2-hop tuples ``(r, j, x)`` (``j`` a symmetric neighbour of ``r``).
    topology : TupleTopology or object with ``advertised(keys)``, optional
        Valid topology tuples: ``advertised(owner * N + last)`` returns, for each tuple of
        ``owner`` with that ``last``, the index of the key and the tuple's ``dest``.
    max_hops : int, optional
        Stop the iteration at this hop count.
    strict : bool, default False
        The 2-hop tuples are strict already (:func:`~.twohop.strict_two_hop`: ``j`` a
        symmetric neighbour of ``r``, ``x`` neither ``r`` nor a symmetric neighbour of it),
        so they are not filtered again; the routes are the same.

    Returns
    -------
    owner, dest, hops, next_hop : ndarray
        Routes sorted by ``(owner, dest)``.
    """
    n = np.int64(n_robots)
    sym_owner = sym_owner.astype(np.int64)
    k1 = sym_owner * n + sym_neigh
    k1, nh1 = _first_per_key(k1, np.asarray(sym_neigh, dtype=np.int64))
    keys = [k1]
    hops = [np.ones(k1.size, dtype=np.int16)]
    nexts = [nh1]
    # 2 hops: the relay must itself be routed at 1 hop.
    if th_owner.size and (max_hops is None or max_hops >= 2):
        k2 = th_owner.astype(np.int64) * n + th_two_hop
        nh2 = np.asarray(th_neigh)
        if not strict:
            relay = th_owner.astype(np.int64) * n + th_neigh
            ok = sorted_contains(k1, relay) & ~sorted_contains(k1, k2) & (th_two_hop != th_owner)
            k2, nh2 = k2[ok], nh2[ok]
        k2, nh2 = _first_per_key(k2, nh2.astype(np.int64))
        keys.append(k2)
        hops.append(np.full(k2.size, 2, dtype=np.int16))
        nexts.append(nh2)
    all_k = np.concatenate(keys)
    order = np.argsort(all_k)
    all_k = all_k[order]
    all_h = np.concatenate(hops)[order]
    all_n = np.concatenate(nexts)[order]
    if topology is not None and all_k.size:
        all_k, all_h, all_n = _topology_routes(n, all_k, all_h, all_n, topology, max_hops)
    return (
        (all_k // n).astype(np.int32),
        (all_k % n).astype(np.int32),
        all_h,
        all_n.astype(np.int32),
    )


class TupleTopology:
    """Topology tuples given as flat arrays ``(owner, dest, last)``: ``owner`` knows that
    ``dest`` is one hop from ``last``."""

    def __init__(self, n_robots: int, owner: np.ndarray, dest: np.ndarray, last: np.ndarray):
        n = np.int64(n_robots)
        valid = dest != owner
        kl = (owner.astype(np.int64) * n + last)[valid]
        order = np.argsort(kl, kind="stable")
        self.kl = kl[order]
        self.dest = np.asarray(dest, dtype=np.int64)[valid][order]

    def advertised(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For owner/last keys ``owner * N + last``: index into ``keys`` and destination of
        every matching tuple."""
        lo = np.searchsorted(self.kl, keys, "left")
        hi = np.searchsorted(self.kl, keys, "right")
        counts = hi - lo
        total = int(counts.sum())
        src = np.repeat(np.arange(keys.size), counts)
        pos = (
            np.repeat(lo, counts) + np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
        )
        return src, self.dest[pos]


def _topology_routes(n, all_k, all_h, all_n, topology, max_hops):
    """RFC 10 step 3, level by level: only topology tuples whose ``last`` was routed at the
    previous level are examined, so the cost is linear in the number of tuples used."""
    if n * n <= tables.DENSE_LIMIT:
        return _topology_routes_dense(n, all_k, all_h, all_n, topology, max_hops)
    known = KeySet(int(n * n))
    known.add(all_k)
    frontier = all_k[all_h == 2]
    frontier_next = all_n[all_h == 2]
    new_k, new_h, new_n = [], [], []
    h = 2
    while frontier.size and (max_hops is None or h < max_hops):
        src, dest = topology.advertised(frontier)
        if src.size == 0:
            break
        owner = frontier[src] // n
        cand = owner * n + dest
        cand_next = frontier_next[src]
        fresh = (dest != owner) & ~known.contains(cand)
        if not fresh.any():
            break
        cand, cand_next = _first_per_key(cand[fresh], cand_next[fresh])
        new_k.append(cand)
        new_h.append(np.full(cand.size, h + 1, dtype=np.int16))
        new_n.append(cand_next)
        known.add(cand)
        frontier, frontier_next = cand, cand_next
        h += 1
    if not new_k:
        return all_k, all_h, all_n
    all_k = np.concatenate([all_k, *new_k])
    order = np.argsort(all_k, kind="stable")
    return (
        all_k[order],
        np.concatenate([all_h, *new_h])[order],
        np.concatenate([all_n, *new_n])[order],
    )


def _topology_routes_dense(n, all_k, all_h, all_n, topology, max_hops):
    """Same as :func:`_topology_routes` with dense (N * N) hop / next-hop arrays: membership
    and first-candidate-wins are then O(1) per candidate and the output comes out sorted."""
    size = int(n * n)
    hop = np.zeros(size, dtype=np.int16)
    nxt = np.full(size, -1, dtype=np.int32)
    hop[all_k] = all_h
    nxt[all_k] = all_n
    claim = np.empty(size, dtype=np.int32)
    frontier = all_k[all_h == 2]
    h = 2
    while frontier.size and (max_hops is None or h < max_hops):
        src, dest = topology.advertised(frontier)
        if src.size == 0:
            break
        owner = frontier[src] // n
        cand = owner * n + dest
        fresh = (dest != owner) & (hop[cand] == 0)
        cand, src = cand[fresh], src[fresh]
        if cand.size == 0:
            break
        idx = np.arange(cand.size, dtype=np.int32)
        claim[cand[::-1]] = idx[::-1]
        first = claim[cand] == idx
        cand, src = cand[first], src[first]
        hop[cand] = h + 1
        nxt[cand] = nxt[frontier[src]]
        frontier = cand
        h += 1
    keys = np.flatnonzero(hop)
    return keys.astype(np.int64), hop[keys], nxt[keys].astype(np.int64)
