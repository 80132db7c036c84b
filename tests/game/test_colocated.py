"""Seeded tie-breaking of co-located robots (swarmgames.game.colocated)."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.game.colocated import colocated_groups, separate_colocated


def test_groups_link_within_the_tolerance_transitively():
    st = np.array([[0.0, 0.0], [4e-7, 0.0], [8e-7, 0.0], [1.0, 0.0], [1.0, 0.0], [3.0, 0.0]])
    groups = colocated_groups(st)
    assert [g.tolist() for g in groups] == [[0, 1, 2], [3, 4]]


def test_no_coinciding_robots_change_nothing_and_draw_nothing():
    rng = np.random.default_rng(3)
    st = rng.random((50, 3)) * 100
    acts = rng.integers(0, 9, 50)
    q = rng.dirichlet(np.ones(9), 50)
    state = rng.bit_generator.state
    out = separate_colocated(st, acts, q, np.ones((50, 9), bool), rng)
    np.testing.assert_array_equal(out, acts)
    assert rng.bit_generator.state == state


@pytest.mark.parametrize("size", [2, 5, 9, 20])
def test_a_group_takes_distinct_actions_in_order_of_preference(size):
    q = np.tile(np.array([0.05, 0.4, 0.1, 0.2, 0.05, 0.05, 0.05, 0.05, 0.05]), (size, 1))
    mask = np.ones((size, 9), bool)
    out = separate_colocated(np.zeros((size, 3)), np.ones(size, int), q, mask, 1)
    ranked = [1, 3, 2, 0, 4, 5, 6, 7, 8]
    counts = np.bincount(out, minlength=9)
    # Each action used once before any is used twice, the preferred ones first.
    want = np.bincount(np.array(ranked)[np.arange(size) % 9], minlength=9)
    np.testing.assert_array_equal(counts, want)


def test_invalid_actions_are_never_assigned():
    mask = np.ones((4, 5), bool)
    mask[:, [1, 2]] = False
    q = np.full((4, 5), 0.2)
    out = separate_colocated(np.zeros((4, 2)), np.zeros(4, int), q, mask, 0)
    assert set(out.tolist()) <= {0, 3, 4}
    assert len(set(out[:3].tolist())) == 3


def test_the_order_among_the_robots_is_seeded():
    q = np.tile([0.5, 0.3, 0.2], (3, 1))
    args = (np.zeros((3, 2)), np.zeros(3, int), q, np.ones((3, 3), bool))
    draws = {tuple(separate_colocated(*args, seed).tolist()) for seed in range(20)}
    assert len(draws) > 1
    assert separate_colocated(*args, 7).tolist() == separate_colocated(*args, 7).tolist()
