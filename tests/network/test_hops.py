"""Hop statistics by compiled breadth-first searches (swarmgames.network.hops)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import csgraph, csr_array

from swarmgames.network.hops import hop_statistics


def _all_pairs(n: int, edges: np.ndarray) -> tuple[float, int]:
    """The former computation: scipy's all-pairs distance matrix, reachable pairs."""
    if len(edges) == 0:
        return 0.0, 0
    graph = csr_array((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    dist = csgraph.shortest_path(graph, directed=False, unweighted=True)
    hops = dist[np.isfinite(dist) & (dist > 0)]
    return (float(hops.mean()), int(hops.max())) if hops.size else (0.0, 0)


def _graph(n: int, p: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    i, j = np.triu_indices(n, 1)
    keep = rng.random(i.size) < p
    return np.column_stack([i[keep], j[keep]])


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 60), st.floats(0.0, 0.3), st.integers(0, 10_000))
def test_equal_to_the_all_pairs_matrix_bit_for_bit(n, p, seed):
    edges = _graph(n, p, seed)
    assert hop_statistics(n, edges) == _all_pairs(n, edges)


def test_a_geometric_swarm_of_800_as_scipy():
    rng = np.random.default_rng(1)
    xy = rng.uniform(0, 8000, size=(800, 2))
    d = np.linalg.norm(xy[:, None] - xy[None], axis=-1)
    i, j = np.nonzero(np.triu(d < 370, 1))
    edges = np.column_stack([i, j])
    assert hop_statistics(800, edges) == _all_pairs(800, edges)


@pytest.mark.parametrize(
    ("n", "edges", "want"),
    [
        (1, np.zeros((0, 2), int), (0.0, 0)),  # one robot
        (3, np.zeros((0, 2), int), (0.0, 0)),  # nobody linked
        (4, np.array([[0, 1], [2, 3]]), (1.0, 1)),  # partitioned swarm
        (4, np.array([[1, 0], [2, 1]]), (4 / 3, 2)),  # either order, isolated robot 3
    ],
)
def test_edge_cases(n, edges, want):
    assert hop_statistics(n, edges) == pytest.approx(want)


def test_the_same_on_any_number_of_threads():
    import numba

    edges = _graph(300, 0.01, 3)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = hop_statistics(300, edges)
    finally:
        numba.set_num_threads(before)
    assert hop_statistics(300, edges) == one


def test_above_exact_up_to_a_path_is_searched_from_evenly_spaced_sources():
    # A path of 101 nodes from sources 0, 50, 100: eccentricities 100, 50, 100, and the mean
    # over the pairs from those sources (sum of distances 5050, 2550, 5050 over 3 * 100 pairs).
    n = 101
    edges = np.column_stack([np.arange(n - 1), np.arange(1, n)])
    mean, far = hop_statistics(n, edges, exact_up_to=100, sources=3)
    assert far == 100
    assert mean == pytest.approx((5050 + 2550 + 5050) / 300)
    assert hop_statistics(n, edges, exact_up_to=n, sources=3) == _all_pairs(n, edges)
