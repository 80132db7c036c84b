"""TopologySnapshot: the immutable routing-table view the rest of the system reads."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.topology import TopologySnapshot


def _line3() -> TopologySnapshot:
    # 0 - 1 - 2 in a line: 0 reaches 2 in two hops via 1.
    hops = np.array([[0, 1, 2], [1, 0, 1], [2, 1, 0]], dtype=float)
    nxt = np.array([[-1, 1, 1], [0, -1, 2], [1, 1, -1]])
    return TopologySnapshot.from_hop_matrix(3.0, hops, nxt)


def test_neighbourhood_contains_self_and_respects_h():
    snap = _line3()
    # Paper section II.A: N_i(h) = {j : Hops(i, j) <= h}, and i belongs to N_i.
    assert snap.neighbourhood(0, 1).tolist() == [0, 1]
    assert snap.neighbourhood(0, 2).tolist() == [0, 1, 2]
    m = snap.neighbourhood_matrix(1).toarray()
    assert m.tolist() == [[True, True, False], [True, True, True], [False, True, True]]


def test_hop_matrix_and_degree():
    snap = _line3()
    assert snap.hop_matrix().tolist() == [[0, 1, 2], [1, 0, 1], [2, 1, 0]]
    assert snap.degree().tolist() == [1, 2, 1]
    assert snap.next_hop[snap.owner == 0].tolist() == [1, 1]


def test_arrays_are_read_only_and_sorted():
    snap = TopologySnapshot(0.0, 3, owner=[2, 0, 0], dest=[0, 2, 1], hops=[1, 1, 1])
    assert snap.owner.tolist() == [0, 0, 2] and snap.dest.tolist() == [1, 2, 0]
    with pytest.raises(ValueError, match="read-only"):
        snap.hops[0] = 5
    assert snap.next_hop.tolist() == [-1, -1, -1]


def test_isolated_and_single_robot():
    snap = TopologySnapshot.from_hop_matrix(0.0, np.zeros((1, 1)))
    assert snap.n_entries == 0
    assert snap.neighbourhood(0, 2).tolist() == [0]
    iso = TopologySnapshot.from_hop_matrix(0.0, np.full((3, 3), np.inf))
    assert iso.degree().tolist() == [0, 0, 0]
    assert iso.hop_matrix().tolist() == [[0, -1, -1], [-1, 0, -1], [-1, -1, 0]]


@pytest.mark.parametrize("seed", range(6))
def test_neighbourhood_rows_are_each_robots_sorted_table_row_and_itself(seed):
    # N_i(h) from the definition: i and every destination of i's table within h hops,
    # sorted; robots with no entries (isolated) hold themselves alone.
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 40))
    hops = rng.integers(1, 5, (n, n)).astype(float)
    hops[rng.random((n, n)) < 0.6] = np.inf
    hops[rng.integers(0, n, 3)] = np.inf  # some isolated rows
    snap = TopologySnapshot.from_hop_matrix(0.0, hops)
    for h in (1, 2, 3):
        indptr, indices = snap.neighbourhood_rows(h)
        assert indptr.dtype == np.int64 and indices.dtype == np.int32
        for i in range(n):
            want = sorted({i, *np.flatnonzero(hops[i] <= h).tolist()})
            assert indices[indptr[i] : indptr[i + 1]].tolist() == want
        m = snap.neighbourhood_matrix(h)
        assert m.toarray().tolist() == [[j in set(indices[indptr[i] : indptr[i + 1]]) for j
                                         in range(n)] for i in range(n)]  # fmt: skip


def test_networkx_export():
    g = _line3().to_networkx(h=2)
    assert g.number_of_nodes() == 3 and g.number_of_edges() == 6
    assert g.edges[0, 2]["hops"] == 2


def test_shape_mismatch_is_an_error():
    with pytest.raises(ValueError, match="hops must have shape"):
        TopologySnapshot(0.0, 2, owner=[0], dest=[1], hops=[1, 1])


def test_bad_h():
    with pytest.raises(ValueError, match="h must be >= 1"):
        _line3().neighbourhood_matrix(0)
    with pytest.raises(ValueError, match="h must be >= 1"):
        _line3().neighbourhood_rows(0)


@pytest.mark.parametrize(
    ("owner", "dest", "hops", "next_hop", "message"),
    [
        ([0], [3], [1], None, r"dest must be robot ids in \[0, 3\) \(got 3 in entry 0\)"),
        ([-1], [1], [1], None, r"owner must be robot ids in \[0, 3\)"),
        ([0], [1], [0], None, r"hops must be whole numbers in \[1, 32767\] \(got 0 "),
        ([0], [1], [-1], None, r"hops must be whole numbers"),
        ([0], [1], [40000], None, r"hops must be whole numbers in \[1, 32767\]"),
        ([0], [1], [1.5], None, r"hops must be whole numbers"),
        ([0], [1], [1], [7], r"next_hop must be robot ids in \[-1, 3\)"),
        ([1], [1], [1], None, r"route to itself \(robot 1\)"),
        ([0, 0], [1, 1], [1, 2], None, r"the route 0 -> 1 appears twice"),
    ],
)
def test_snapshots_refuse_tables_no_routing_table_can_hold(owner, dest, hops, next_hop, message):
    # Tables from a user's provider are checked where they enter: nothing wraps around in
    # int16, nothing indexes out of range later.
    with pytest.raises(ValueError, match=message):
        TopologySnapshot(0.0, 3, owner, dest, hops, next_hop)
