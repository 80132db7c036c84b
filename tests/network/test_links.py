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
