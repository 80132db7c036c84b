"""Swarm geometry that several missions use: radio links by distance, their components,
close pairs, and the crowding penalty of two next positions.

The swarm-level functions take positions ``(N, >= 2)`` (only x, y, z are used, when present)
and find the pairs they need with a KD-tree (:class:`scipy.spatial.cKDTree`), so the cost grows
with the number of close pairs, not with N². :func:`crowding_blocks` works on a batch of local
games and computes only the pairs of variables that can come close.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

__all__ = [
    "CROWDING_CHUNK_ELEMS",
    "CROWDING_COPIES",
    "close_pairs",
    "crowding_blocks",
    "crowding_bytes",
    "link_components",
    "link_pairs",
    "pair_distances",
    "relative_neighbours",
]


def _xyz(positions) -> np.ndarray:
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 2 or pos.shape[1] < 2:
        raise ValueError(f"positions must have shape (N, >= 2) (got {pos.shape})")
    return pos[:, :3]


def link_pairs(positions, range_m: float) -> np.ndarray:
    """Pairs of robots at most ``range_m`` apart, ``(E, 2)`` with ``i < j``, sorted.

    Examples
    --------
    >>> link_pairs([[0, 0, 0], [100, 0, 0], [500, 0, 0]], 368.84).tolist()
    [[0, 1]]
    """
    pos = _xyz(positions)
    if pos.shape[0] < 2:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = cKDTree(pos).query_pairs(float(range_m), output_type="ndarray")
    pairs = np.sort(pairs.astype(np.int64), axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def link_components(positions, range_m: float) -> int:
    """Connected components of the graph whose edges join robots at most ``range_m`` apart.

    Examples
    --------
    >>> link_components([[0, 0, 0], [100, 0, 0], [500, 0, 0]], 368.84)
    2
    """
    pos = _xyz(positions)
    n = pos.shape[0]
    if n == 0:
        return 0
    e = link_pairs(pos, range_m)
    graph = coo_array((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    return int(connected_components(graph, directed=False)[0])


def relative_neighbours(positions, i, j, indptr, indices) -> np.ndarray:
    """Which links of a link graph belong to its relative neighbourhood graph.

    A link (i, j) is a relative neighbour link when no third robot m is closer to both ends
    than they are to each other, :math:`\\max(d_{im}, d_{jm}) < d_{ij}` for no m [1]_. Such a
    witness m is within :math:`d_{ij}` of i, so when the links are the pairs within a range
    it is a neighbour of i: only i's neighbours are searched. The relative neighbourhood
    graph of the pairs within a range contains a Euclidean minimum spanning tree of each of
    the link graph's components, so it has the link graph's components: keeping its links
    keeps every component whole.

    Parameters
    ----------
    positions : array_like, shape (N, >= 2)
        Robot positions (x, y, z used, when present), metres.
    i, j : ndarray of int, shape (E,)
        The links' endpoints.
    indptr, indices : ndarray of int
        The link graph's CSR adjacency (both directions): the neighbours of k are
        ``indices[indptr[k]:indptr[k + 1]]``.

    Returns
    -------
    ndarray of bool, shape (E,)

    References
    ----------
    .. [1] G. T. Toussaint, "The relative neighbourhood graph of a finite planar set",
       Pattern Recognition 12(4), 1980.

    Examples
    --------
    >>> pos = [[0.0, 0.0], [100.0, 0.0], [50.0, 10.0]]
    >>> i, j = np.array([0, 0, 1]), np.array([1, 2, 2])
    >>> relative_neighbours(pos, i, j, np.array([0, 2, 4, 6]), np.array([1, 2, 0, 2, 0, 1]))
    array([False,  True,  True])
    """
    pos = _xyz(positions)
    i, j = np.asarray(i, dtype=np.int64), np.asarray(j, dtype=np.int64)
    indptr, indices = np.asarray(indptr, dtype=np.int64), np.asarray(indices, dtype=np.int64)
    if i.size == 0:
        return np.zeros(0, dtype=bool)
    degree = np.diff(indptr)
    # The neighbours of each link's first end, padded to the largest degree with the end
    # itself (never a witness: its distance to i is 0 and to j is d_ij, not below it).
    slot = np.arange(int(degree.max()))
    take = slot[None, :] < degree[i][:, None]
    cand = np.where(
        take, indices[np.minimum(indptr[i][:, None] + slot, indices.size - 1)], i[:, None]
    )
    d_ij = np.linalg.norm(pos[i] - pos[j], axis=1)
    d_im = np.linalg.norm(pos[cand] - pos[i][:, None], axis=2)
    d_jm = np.linalg.norm(pos[cand] - pos[j][:, None], axis=2)
    return ~np.any(np.maximum(d_im, d_jm) < d_ij[:, None], axis=1)


def close_pairs(positions, distance_m: float) -> int:
    """Number of robot pairs closer than ``distance_m`` (strictly).

    Examples
    --------
    >>> close_pairs([[0, 0, 0], [1, 0, 0], [5, 0, 0]], 2.0)
    1
    """
    pos = _xyz(positions)
    if pos.shape[0] < 2 or distance_m <= 0:
        return 0
    pairs = cKDTree(pos).query_pairs(float(distance_m), output_type="ndarray")
    if len(pairs) == 0:
        return 0
    d = np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1)
    return int(np.count_nonzero(d < distance_m))


#: Largest (pairs, A, A) penalty block :func:`crowding_blocks` computes at once, entries;
#: its temporaries hold three times as many values (the coordinate differences).
CROWDING_CHUNK_ELEMS = 2_000_000

#: float64 temporaries per entry of a :func:`crowding_blocks` block (memory estimates).
CROWDING_COPIES = 5


def crowding_bytes(entries: float) -> float:
    """Working memory of :func:`crowding_blocks` over pairwise tables of ``entries``
    entries, bytes: its largest block's float64 temporaries (for the memory estimates of
    :func:`~swarmgames.sim.memory.estimate_memory`)."""
    return min(entries, CROWDING_CHUNK_ELEMS) * 8.0 * CROWDING_COPIES


def pair_distances(batch, near, max_elems: int, *, first_only: bool = False, real: bool = False):
    """The distances between the next positions of the pairs of distinct valid variables of
    a game that ``near`` selects, for every pair of their actions, in chunks of pairs.

    Parameters
    ----------
    batch : LocalGameBatch
        Uses ``mask``, ``states``, ``next_states`` and ``action_mask`` (and ``is_virtual``
        with ``real``); positions are the first three state columns.
    near : callable
        ``near(gap, s_max)``: which pairs to keep (bool, (P,)) from their current distances
        ``gap`` (P,) and the longest move ``s_max`` of the batch, metres.
    max_elems : int
        Most entries ``P A²`` per chunk (at least one pair per chunk).
    first_only : bool, default False
        Only the pairs whose first variable is variable 0 (the owner's rows).
    real : bool, default False
        Only pairs of robots (no virtual mean).

    Yields
    ------
    games, first, second : ndarray of int, shape (P,)
        Each pair as (game, variable k, variable l); both orders of a pair are listed, and
        every pair is in exactly one chunk.
    gap : ndarray, shape (P,)
        Their current distances, metres.
    distance : ndarray, shape (P, A, A)
        ``distance[p, a, c]``, metres, for k taking a and l taking c, summed x, y, z from
        left to right (np.linalg.norm's values, bit for bit, without its (P, A, A, 3)
        temporaries); a new array the caller may overwrite.
    """
    mask = np.asarray(batch.mask, dtype=bool)
    states = np.asarray(batch.states, dtype=float)[..., :3]
    nxt = np.asarray(batch.next_states, dtype=float)[..., :3]
    k, a = mask.shape[1], nxt.shape[2]
    amask = np.asarray(batch.action_mask, dtype=bool) & mask[..., None]
    disp = np.linalg.norm(nxt - states[:, :, None, :], axis=-1)
    s_max = float(disp[amask].max(initial=0.0))
    var = mask & ~np.asarray(batch.is_virtual, dtype=bool) if real else mask
    pairs = var[:, :, None] & var[:, None, :] & ~np.eye(k, dtype=bool)
    if first_only:
        pairs[:, 1:] = False
    gb, gk, gl = np.nonzero(pairs)
    gap = np.linalg.norm(states[gb, gk] - states[gb, gl], axis=-1)
    keep = near(gap, s_max)
    gb, gk, gl, gap = gb[keep], gk[keep], gl[keep], gap[keep]
    step = max(1, int(max_elems) // max(1, a * a))
    for lo in range(0, gb.size, step):
        cb, ck, cl = gb[lo : lo + step], gk[lo : lo + step], gl[lo : lo + step]
        p, q = nxt[cb, ck], nxt[cb, cl]  # (P, A, 3)
        d = np.square(p[:, :, None, 0] - q[:, None, :, 0])
        for c in (1, 2):
            d += np.square(p[:, :, None, c] - q[:, None, :, c])
        yield cb, ck, cl, gap[lo : lo + step], np.sqrt(d, out=d)


def crowding_blocks(
    batch, distance_m: float, max_elems: int = CROWDING_CHUNK_ELEMS, *, first_only: bool = False
):
    """The crowding penalty :math:`\\max(0, 1 - \\lVert p_k(a) - p_l(c) \\rVert / d)^2` of
    every pair of distinct valid variables of a game that can come within ``d`` of each
    other, for every pair of their actions, in chunks of pairs.

    Only pairs whose current positions are closer than :math:`d + 2 s` (``s`` the longest
    move of the batch) can be penalised, so only their ``(A, A)`` blocks are computed
    (:func:`pair_distances`): the cost grows with the number of close pairs, not with K².
    The blocks come in chunks of at most ``max_elems`` entries, so a dense neighbourhood
    (every pair close, K = 300) needs tens of megabytes, not the ``B K² A²``-sized
    temporaries of one block; each pair's values do not depend on the chunking.

    Parameters
    ----------
    batch : LocalGameBatch
        Uses ``mask``, ``states``, ``next_states`` and ``action_mask``; positions are the
        first three state columns.
    distance_m : float
        d, the distance below which next positions are penalised, metres (> 0).
    max_elems : int, default CROWDING_CHUNK_ELEMS
        Most penalty entries ``P A²`` per chunk (at least one pair per chunk).
    first_only : bool, default False
        Only the pairs whose first variable is variable 0 (the owner's rows), each with the
        values it has among all pairs.

    Yields
    ------
    games, first, second : ndarray of int, shape (P,)
        Each pair as (game, variable k, variable l); both orders of a pair are listed, and
        every pair is in exactly one chunk.
    penalty : ndarray, shape (P, A, A)
        ``penalty[p, a, c]`` for k taking a and l taking c, in [0, 1]; values at invalid
        actions are meaningless.
    """

    def near(gap, s_max):
        return gap < distance_m + 2.0 * s_max + 1e-9

    for cb, ck, cl, _, d in pair_distances(batch, near, max_elems, first_only=first_only):
        d /= distance_m
        np.subtract(1.0, d, out=d)
        np.maximum(d, 0.0, out=d)
        yield cb, ck, cl, np.square(d, out=d)
