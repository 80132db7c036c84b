"""Tests of the virtual mean neighbours (paper eq. 3)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from swarmgames.game import DisplacementActions, local_games, neighbourhood_means, reaches_outside
from swarmgames.network import TopologySnapshot


def _line(n: int) -> TopologySnapshot:
    idx = np.arange(n)
    return TopologySnapshot.from_hop_matrix(0.0, np.abs(idx[:, None] - idx[None, :]))


def test_virtual_mean_matches_eq3_on_a_hand_built_line():
    # Line 0-1-2-3-4, h = 1. Robot 1's local game: N_1 = {0, 1, 2}. N_0 = {0, 1} ⊆ N_1 stays
    # real; N_2 = {1, 2, 3} reaches robot 3 outside N_1, so robot 2 becomes the virtual mean
    # S̄_2 = (S_1 + S_2 + S_3) / 3 (eq. 3).
    states = np.array([[0.0, 0.0], [10.0, 1.0], [20.0, 4.0], [35.0, 7.0], [50.0, 9.0]])
    batch = local_games(_line(5), 1, states, DisplacementActions.headings(1.0, 4), owners=[1])
    assert batch.members[0].tolist() == [1, 0, 2]
    assert batch.is_virtual[0].tolist() == [False, False, True]
    np.testing.assert_allclose(batch.states[0, 0], states[1])
    np.testing.assert_allclose(batch.states[0, 1], states[0])
    np.testing.assert_allclose(batch.states[0, 2], (states[1] + states[2] + states[3]) / 3)
    # The actions of the virtual robot move its virtual state.
    np.testing.assert_allclose(batch.next_states[0, 2, 1], batch.states[0, 2] + [1.0, 0.0])


def test_virtual_mean_switched_off_keeps_reported_states():
    states = np.arange(10.0).reshape(5, 2)
    model = DisplacementActions.headings(1.0, 4)
    batch = local_games(_line(5), 1, states, model, owners=[1], virtual_mean=False)
    assert not batch.is_virtual.any()
    np.testing.assert_allclose(batch.states[0], states[[1, 0, 2]])


def test_h2_on_a_line_virtualises_only_the_far_members():
    # h = 2 (paper): N_2 = {0..4} on a line of 6; N_4 = {2..5} reaches 5; N_3 = {1..5} too;
    # N_0 = {0, 1, 2} and N_1 = {0..3} stay inside.
    batch = local_games(
        _line(6), 2, np.zeros((6, 2)), DisplacementActions.headings(1.0, 4), owners=[2]
    )
    virt = dict(zip(batch.members[0].tolist(), batch.is_virtual[0].tolist(), strict=True))
    assert virt == {2: False, 0: False, 1: False, 3: True, 4: True}


def test_neighbourhood_means_requires_non_empty_rows():
    a = sp.csr_array(np.array([[1, 0], [0, 0]], dtype=bool))
    with pytest.raises(ValueError, match="robot 1 has an empty one"):
        neighbourhood_means(a, np.zeros((2, 1)))


def test_reaches_outside_ignores_padding():
    members = np.array([[0, 1, -1]])
    mask = members >= 0
    nbh = np.array([[[0, 1, -1], [0, 1, 5], [7, 8, 9]]])
    assert reaches_outside(members, mask, nbh).tolist() == [[False, True, False]]
