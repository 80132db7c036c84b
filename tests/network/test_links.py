"""Link graph from the reception model: KD-tree candidates vs a brute-force reference."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from swarmgames.network.links import link_graph
from swarmgames.network.parameters import RadioParameters
from swarmgames.network.propagation import PropagationModel, friis_rx_power


def _brute_force(pos):
    d = np.linalg.norm(pos[:, None] - pos[None], axis=-1)
    ok = friis_rx_power(d) >= -82.0
    i, j = np.nonzero(np.triu(ok, 1))
    return set(zip(i.tolist(), j.tolist(), strict=True))


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 25), st.just(3)), elements=st.floats(0, 1500)))
def test_kdtree_graph_equals_all_pairs(pos):
    g = link_graph(pos)
    assert set(zip(g.i.tolist(), g.j.tolist(), strict=True)) == _brute_force(pos)
    assert np.array_equal(g.adjacency().toarray(), g.adjacency().toarray().T)


def test_hard_cut_at_368_84_m():
    # docs/reference.md section 2/4: linked at 368.5 m, gone at 369 m.
    g = link_graph(np.array([[0.0, 0, 0], [368.5, 0, 0], [368.5 + 369.0, 0, 0]]))
    assert g.n_links == 1
    assert g.neighbours(1).tolist() == [0]


def test_degenerate_layouts():
    assert link_graph(np.zeros((1, 3))).n_links == 0  # one robot
    assert link_graph(np.zeros((0, 3))).n_links == 0
    g = link_graph(np.zeros((3, 3)))  # co-located robots hear each other
    assert g.n_links == 3
    assert g.degree().tolist() == [2, 2, 2]


def test_shadowed_graph_is_seeded_and_symmetric():
    rng = np.random.default_rng(0)
    pos = rng.uniform(0, 1500, (60, 3))
    model = PropagationModel(RadioParameters(shadowing_sigma_db=5.7))
    a = link_graph(pos, model, np.random.default_rng(3))
    b = link_graph(pos, model, np.random.default_rng(3))
    assert np.array_equal(a.i, b.i) and np.array_equal(a.j, b.j)
    adj = a.adjacency().toarray()
    assert np.array_equal(adj, adj.T)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 30), st.lists(st.tuples(st.integers(0, 29), st.integers(0, 29)), max_size=80))
def test_from_pairs_is_scipys_csr_of_both_directions(n, pairs):
    # The CSR arrays and the sorted pairs, against scipy building the same matrix (duplicate
    # pairs merged, rows sorted).
    import scipy.sparse as sp

    from swarmgames.network.links import LinkGraph

    ij = np.array([(i, j) for i, j in pairs if i < n and j < n and i != j], dtype=np.int64)
    i, j = (ij[:, 0], ij[:, 1]) if ij.size else (np.zeros(0, int), np.zeros(0, int))
    g = LinkGraph.from_pairs(n, i, j)
    a, b = np.minimum(i, j), np.maximum(i, j)
    order = np.lexsort((b, a))
    assert np.array_equal(g.i, a[order]) and np.array_equal(g.j, b[order])
    ref = sp.csr_array((np.ones(2 * a.size, bool), (np.r_[a, b], np.r_[b, a])), shape=(n, n))
    ref.sort_indices()
    assert np.array_equal(g.indptr, ref.indptr) and np.array_equal(g.indices, ref.indices)
    assert g.indptr.dtype == np.int32 and g.indices.dtype == np.int32
