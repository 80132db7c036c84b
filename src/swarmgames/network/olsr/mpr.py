"""Multipoint-relay (MPR) selection, RFC 3626 section 8.3.1 as ns-3 implements it.

Vectorised over every node of the swarm at once: the input is the flat list of
``(owner, neighbour, two_hop)`` triples of all owners, the output the flat set of
``(owner, mpr)`` pairs.

For every owner ``r`` (N = its symmetric neighbours with willingness != WILL_NEVER, N2 = the
strict 2-hop neighbours reachable through N):

1. all neighbours with willingness WILL_ALWAYS are MPRs;
2. every neighbour that is the only one reaching some node of N2 is an MPR;
3. while a node of N2 is uncovered, add the neighbour with the highest willingness, then the
   highest reachability (number of still-uncovered N2 nodes it reaches). ns-3's tie-break on the
   neighbour's degree never fires (it looks the degree up under the wrong address), so ties go
   to the neighbour heard first; the optional redundancy pruning is not done (docs/reference.md
   section 3).

References
----------
.. [1] RFC 3626 section 8.3.1.
.. [2] ns-3 3.44 ``olsr-routing-protocol.cc``, ``RoutingProtocol::MprComputation``.
"""

from __future__ import annotations

import numpy as np

from swarmgames.arrays import sorted_unique

__all__ = ["WILL_ALWAYS", "WILL_NEVER", "select_mprs"]

WILL_NEVER = 0
WILL_ALWAYS = 7


def select_mprs(
    n_robots: int,
    sym_owner: np.ndarray,
    sym_neigh: np.ndarray,
    sym_order: np.ndarray,
    owner: np.ndarray,
    neigh: np.ndarray,
    two_hop: np.ndarray,
    willingness: int = 3,
    sym_willingness: np.ndarray | None = None,
) -> np.ndarray:
    """MPR sets of every node.

    Parameters
    ----------
    n_robots : int
        Number of nodes N.
    sym_owner, sym_neigh : ndarray of int, shape (S,)
        Symmetric 1-hop neighbour pairs ``(r, j)``, unique.
    sym_order : ndarray of float, shape (S,)
        Order in which ``r`` first heard ``j`` (ties in step 3 go to the smallest).
    owner, neigh, two_hop : ndarray of int, shape (T,)
        Unique 2-hop triples ``(r, j, x)``: ``r`` reaches ``x`` through its symmetric neighbour
        ``j``; ``x`` is neither ``r`` nor a symmetric neighbour of ``r``.
    willingness : int
        Willingness of every node (0 never, 3 default, 7 always).
    sym_willingness : ndarray of int, shape (S,), optional
        Willingness advertised by each neighbour ``j`` of the pair ``(r, j)``; overrides
        ``willingness`` (as in ns-3's MPR unit test, where neighbours differ).

    Returns
    -------
    ndarray of int64
        Sorted keys ``r * N + m`` of the selected MPRs ``m`` of every ``r``.

    Examples
    --------
    A line 0 - 1 - 2: node 0 must pick 1 (the only route to 2).

    >>> select_mprs(3, np.array([0, 1, 1, 2]), np.array([1, 0, 2, 1]), np.zeros(4),
    ...             np.array([0, 2]), np.array([1, 1]), np.array([2, 0])).tolist()
    [1, 7]
    """
    n = np.int64(n_robots)
    sym_keys = sym_owner.astype(np.int64) * n + sym_neigh
    will = (
        np.full(sym_keys.size, willingness, dtype=np.int64)
        if sym_willingness is None
        else np.asarray(sym_willingness, dtype=np.int64)
    )
    # Step 1: WILL_ALWAYS neighbours. WILL_NEVER neighbours are not in N at all.
    always = sorted_unique(sym_keys[will == WILL_ALWAYS])
    rj = owner.astype(np.int64) * n + neigh
    srt = np.argsort(sym_keys)
    sym_sorted = sym_keys[srt]
    pos = np.minimum(np.searchsorted(sym_sorted, rj), max(sym_sorted.size - 1, 0))
    known = (sym_sorted.size > 0) & (sym_sorted[pos] == rj) if rj.size else np.zeros(0, bool)
    trip_will = np.where(known, will[srt][pos] if sym_sorted.size else 0, 0)
    keep = trip_will != WILL_NEVER
    owner, neigh, two_hop, rj = owner[keep], neigh[keep], two_hop[keep], rj[keep]
    if owner.size == 0:
        return always
    rx = owner.astype(np.int64) * n + two_hop
    rj_u, rj_inv = np.unique(rj, return_inverse=True)
    rx_u, rx_inv = np.unique(rx, return_inverse=True)
    # Step 2: sole routes.
    routes_per_rx = np.bincount(rx_inv, minlength=rx_u.size)
    is_mpr = np.isin(rj_u, always)
    is_mpr[rj_inv[routes_per_rx[rx_inv] == 1]] = True
    # Tie-break order of each candidate (r, j): first heard; and its willingness.
    idx = np.minimum(np.searchsorted(sym_sorted, rj_u), sym_sorted.size - 1)
    order = np.asarray(sym_order, dtype=float)[srt][idx]
    cand_will = will[srt][idx]
    cand_owner = rj_u // n
    while True:
        covered = np.zeros(rx_u.size, dtype=bool)
        covered[rx_inv[is_mpr[rj_inv]]] = True
        uncovered = ~covered[rx_inv]
        if not uncovered.any():
            break
        reach = np.bincount(rj_inv[uncovered], minlength=rj_u.size)
        live = reach > 0
        cand = np.flatnonzero(live)
        # Per owner: max willingness, then max reachability, then first heard.
        pick = np.lexsort(
            (rj_u[cand], order[cand], -reach[cand], -cand_will[cand], cand_owner[cand])
        )
        first = np.r_[True, cand_owner[cand[pick]][1:] != cand_owner[cand[pick]][:-1]]
        is_mpr[cand[pick][first]] = True
    return np.union1d(rj_u[is_mpr], always)
