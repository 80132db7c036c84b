"""MPR selection: the cases of ns-3's OLSR MPR unit test and RFC 3626 section 8.3.1.

Source: ns-3 ``src/olsr/test/olsr-routing-protocol-test-suite.cc`` (``OlsrMprTestCase``),
addresses 10.0.0.k mapped to node k - 1; node 0 (10.0.0.1) computes its MPR set.
"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.network.olsr.mpr import WILL_ALWAYS, WILL_NEVER, select_mprs

N = 9


def _mprs(neighbours, two_hop, will=None):
    """MPRs of node 0 given its neighbours [(node, willingness)] and 2-hop [(via, node)]."""
    sym_n = np.array([j for j, _ in neighbours])
    sym_w = np.array([w for _, w in neighbours])
    via = np.array([j for j, _ in two_hop], dtype=int)
    x = np.array([k for _, k in two_hop], dtype=int)
    keys = select_mprs(
        N,
        np.zeros(sym_n.size, dtype=int),
        sym_n,
        np.arange(sym_n.size, dtype=float),
        np.zeros(via.size, dtype=int),
        via,
        x,
        sym_willingness=sym_w,
    )
    return sorted((keys % N).tolist())


def test_ns3_square_selects_one_mpr():
    # 1 -- 2 / 1 -- 3 / 2,3 -- 4: one MPR (2 or 3) (ns-3 OlsrMprTestCase, case 1).
    mprs = _mprs([(1, 3), (2, 3)], [(1, 3), (2, 3)])
    assert len(mprs) == 1 and mprs[0] in (1, 2)


def test_ns3_sole_route_wins():
    # + 2 -- 5: node 2 (index 1) is the only route to 5 and covers 4 too (case 2).
    assert _mprs([(1, 3), (2, 3)], [(1, 3), (2, 3), (1, 4)]) == [1]


def test_ns3_two_sole_routes():
    # + 3 -- 6: both 2 and 3 are needed (case 3).
    assert _mprs([(1, 3), (2, 3)], [(1, 3), (2, 3), (1, 4), (2, 5)]) == [1, 2]


def test_ns3_will_always_neighbour_is_mpr():
    # + 7 with WILL_ALWAYS: MPR set {2, 3, 7} (case 4).
    mprs = _mprs([(1, 3), (2, 3), (6, WILL_ALWAYS)], [(1, 3), (2, 3), (1, 4), (2, 5)])
    assert mprs == [1, 2, 6]


def test_ns3_will_never_neighbour_is_not_mpr():
    # + 8 (WILL_NEVER) -- 9: 8 is not selected; MPR set stays {2, 3, 7} (case 5).
    mprs = _mprs(
        [(1, 3), (2, 3), (6, WILL_ALWAYS), (7, WILL_NEVER)],
        [(1, 3), (2, 3), (1, 4), (2, 5), (7, 8)],
    )
    assert mprs == [1, 2, 6]


def test_tie_goes_to_first_heard_neighbour():
    # ns-3's degree tie-break never fires (docs/reference.md section 3): equal reachability -> the
    # neighbour heard first.
    keys = select_mprs(
        5,
        np.zeros(2, int),
        np.array([1, 2]),
        np.array([5.0, 1.0]),
        np.zeros(2, int),
        np.array([1, 2]),
        np.array([3, 3]),
    )
    assert (keys % 5).tolist() == [2]


def test_willingness_before_reachability():
    # RFC 3626 8.3.1 step 4: highest willingness first, then reachability.
    keys = select_mprs(
        6,
        np.zeros(2, int),
        np.array([1, 2]),
        np.array([0.0, 1.0]),
        np.zeros(4, int),
        np.array([1, 1, 2, 2]),
        np.array([3, 4, 3, 4]),
        sym_willingness=np.array([3, 6]),
    )
    assert (keys % 6).tolist() == [2]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 6), st.integers(7, 14)), min_size=1, max_size=30))
def test_mpr_set_covers_every_two_hop_node(edges):
    # RFC 3626 8.3.1: every strict 2-hop neighbour is reached through some MPR.
    edges = sorted(set(edges))
    via = np.array([a for a, _ in edges])
    x = np.array([b for _, b in edges])
    nbrs = np.unique(via)
    keys = select_mprs(
        15,
        np.zeros(nbrs.size, int),
        nbrs,
        np.arange(nbrs.size, dtype=float),
        np.zeros(via.size, int),
        via,
        x,
    )
    mprs = set((keys % 15).tolist())
    assert mprs <= set(nbrs.tolist())
    covered = {b for a, b in edges if a in mprs}
    assert covered == set(x.tolist())


def test_uniform_willingness_never_and_always():
    args = (
        4,
        np.zeros(2, int),
        np.array([1, 2]),
        np.zeros(2),
        np.zeros(1, int),
        np.array([1]),
        np.array([3]),
    )
    assert select_mprs(*args, willingness=WILL_NEVER).size == 0
    assert (select_mprs(*args, willingness=WILL_ALWAYS) % 4).tolist() == [1, 2]
