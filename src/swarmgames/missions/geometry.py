"""Swarm geometry that several missions measure: radio links by distance, their components,
close pairs.

Every function takes positions ``(N, >= 2)`` (only x, y, z are used, when present) and finds
the pairs it needs with a KD-tree (:class:`scipy.spatial.cKDTree`), so the cost grows with the
number of close pairs, not with N².
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

__all__ = ["close_pairs", "link_components", "link_pairs"]


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
