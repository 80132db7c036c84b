"""Routing-table computation, RFC 3626 section 10."""

import numpy as np

from swarmgames.network.olsr.routing import TupleTopology, compute_routes


def _table(res):
    return {(int(o), int(d)): (int(h), int(x)) for o, d, h, x in zip(*res, strict=True)}


def _line_of_four_routes(**kwargs):
    """Node 0's view of the line 0-1-2-3: neighbour 1, 2-hop node 2 via 1, and the topology
    tuple (dest 3, last 2) from 2's TC."""
    return compute_routes(
        4,
        np.array([0]),
        np.array([1]),
        np.array([0]),
        np.array([1]),
        np.array([2]),
        TupleTopology(4, np.array([0]), np.array([3]), np.array([2])),
        **kwargs,
    )


def test_line_of_four_with_topology_tuples():
    # Node 0 of 0-1-2-3: 1 hop to 1, 2 hops to 2 (2-hop set), 3 hops to 3 via the topology
    # tuple (dest 3, last 2) learnt from 2's TC (RFC 10 step 3).
    res = _line_of_four_routes()
    assert _table(res) == {(0, 1): (1, 1), (0, 2): (2, 1), (0, 3): (3, 1)}


def test_two_hop_entry_that_is_also_a_neighbour_stays_one_hop():
    # RFC 10 step 3: strict 2-hop neighbours only.
    res = compute_routes(
        3, np.array([0, 0]), np.array([1, 2]), np.array([0]), np.array([1]), np.array([2])
    )
    assert _table(res) == {(0, 1): (1, 1), (0, 2): (1, 2)}


def test_two_hop_via_non_symmetric_neighbour_is_ignored():
    res = compute_routes(
        3, np.array([], int), np.array([], int), np.array([0]), np.array([1]), np.array([2])
    )
    assert _table(res) == {}


def test_topology_tuple_whose_last_is_unrouted_is_unused():
    res = compute_routes(
        5,
        np.array([0]),
        np.array([1]),
        np.array([], int),
        np.array([], int),
        np.array([], int),
        TupleTopology(5, np.array([0]), np.array([4]), np.array([3])),
    )
    assert _table(res) == {(0, 1): (1, 1)}


def test_max_hops_truncates():
    res = _line_of_four_routes(max_hops=2)
    assert max(h for h, _ in _table(res).values()) == 2
