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

__all__ = ["compute_routes"]


def _first_per_key(keys: np.ndarray, *cols: np.ndarray) -> tuple[np.ndarray, ...]:
    uk, first = np.unique(keys, return_index=True)
    return (uk, *(c[first] for c in cols))


def compute_routes(
    n_nodes: int,
    sym_owner: np.ndarray,
    sym_neigh: np.ndarray,
    th_owner: np.ndarray,
    th_neigh: np.ndarray,
    th_two_hop: np.ndarray,
    tp_owner: np.ndarray | None = None,
    tp_dest: np.ndarray | None = None,
    tp_last: np.ndarray | None = None,
    max_hops: int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every node's routing table.

    Parameters
    ----------
    n_nodes : int
        Number of nodes N.
    sym_owner, sym_neigh : ndarray of int
        Valid symmetric links ``(r, j)``.
    th_owner, th_neigh, th_two_hop : ndarray of int
        Valid 2-hop tuples ``(r, j, x)`` (``j`` a symmetric neighbour of ``r``).
    tp_owner, tp_dest, tp_last : ndarray of int, optional
        Valid topology tuples held by ``r``: ``dest`` is reachable from ``last`` in one hop.
    max_hops : int, optional
        Stop the iteration at this hop count.

    Returns
    -------
    owner, dest, hops, next_hop : ndarray
        Routes sorted by ``(owner, dest)``.
    """
    n = np.int64(n_nodes)
    sym_owner = sym_owner.astype(np.int64)
    k1 = sym_owner * n + sym_neigh
    k1, nh1 = _first_per_key(k1, np.asarray(sym_neigh, dtype=np.int64))
    keys = [k1]
    hops = [np.ones(k1.size, dtype=np.int16)]
    nexts = [nh1]
    # 2 hops: the relay must itself be routed at 1 hop.
    if th_owner.size and (max_hops is None or max_hops >= 2):
        k2 = th_owner.astype(np.int64) * n + th_two_hop
        relay = th_owner.astype(np.int64) * n + th_neigh
        ok = np.isin(relay, k1) & ~np.isin(k2, k1) & (th_two_hop != th_owner)
        k2, nh2 = _first_per_key(k2[ok], np.asarray(th_neigh, dtype=np.int64)[ok])
        keys.append(k2)
        hops.append(np.full(k2.size, 2, dtype=np.int16))
        nexts.append(nh2)
    all_k = np.concatenate(keys)
    order = np.argsort(all_k)
    all_k = all_k[order]
    all_h = np.concatenate(hops)[order]
    all_n = np.concatenate(nexts)[order]
    if tp_owner is not None and tp_owner.size and all_k.size:
        tp_o = tp_owner.astype(np.int64)
        kd = tp_o * n + tp_dest
        kl = tp_o * n + tp_last
        valid = tp_dest != tp_owner
        kd, kl = kd[valid], kl[valid]
        h = 2
        while max_hops is None or h < max_hops:
            idx = np.minimum(np.searchsorted(all_k, kl), all_k.size - 1)
            at_h = (all_k[idx] == kl) & (all_h[idx] == h)
            if not at_h.any():
                break
            pos = np.searchsorted(all_k, kd)
            known = (pos < all_k.size) & (all_k[np.minimum(pos, all_k.size - 1)] == kd)
            new = at_h & ~known
            if not new.any():
                break
            nk, nn = _first_per_key(kd[new], all_n[idx[new]])
            all_k = np.concatenate([all_k, nk])
            order = np.argsort(all_k)
            all_k = all_k[order]
            all_h = np.concatenate([all_h, np.full(nk.size, h + 1, dtype=np.int16)])[order]
            all_n = np.concatenate([all_n, nn])[order]
            h += 1
    return (
        (all_k // n).astype(np.int32),
        (all_k % n).astype(np.int32),
        all_h,
        all_n.astype(np.int32),
    )
