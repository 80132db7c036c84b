"""Tests of the plug-in conformance checks."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.game import (
    DisplacementActions,
    FunctionPotentials,
    check_action_model,
    check_potentials,
    local_games,
)
from swarmgames.game.capabilities import PotentialCapabilities
from tests.game.helpers import disk_snapshot, random_games

POS = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [30.0, 0.0]])
MODEL = DisplacementActions.headings(1.0, 4)


def _batch():
    return local_games(disk_snapshot(POS, 15.0), 1, POS, MODEL)


def test_well_behaved_plug_ins_pass():
    pot = FunctionPotentials(lambda s: -np.abs(s[..., 0]), lambda a, b: a[..., 1] * b[..., 1])
    check_potentials(pot, _batch())
    batch, table = random_games(0, 1, 2, 2)  # tables are bound to their batch: one game
    check_potentials(table, batch)
    check_action_model(MODEL, POS)


def test_potential_mixing_games_is_caught():
    class Leaky:
        capabilities = PotentialCapabilities()

        def unary(self, batch):
            s = batch.next_states[..., 0]
            return s - s.mean()  # normalised by a statistic over the whole batch

        def pairwise(self, batch):
            return None

    with pytest.raises(ValueError, match="unary of a game depends on the other games"):
        check_potentials(Leaky(), _batch())


def test_potential_with_wrong_shape_or_missing_method_is_caught():
    class NoPair:
        def unary(self, batch):
            return np.zeros(batch.action_mask.shape)

    with pytest.raises(ValueError, match=r"callable pairwise\(batch\)"):
        check_potentials(NoPair(), _batch())
    bad = FunctionPotentials(lambda s: np.zeros(3))
    with pytest.raises(ValueError, match="unary potentials must have shape"):
        check_potentials(bad, _batch())


def test_action_model_problems_are_caught():
    class Trapped:
        n_actions = 2

        def apply(self, states):
            return np.repeat(states[..., None, :], 2, axis=-2)

        def valid(self, states):
            return np.zeros((*states.shape[:-1], 2), dtype=bool)

    with pytest.raises(ValueError, match=r"leaves state 0 \(\[0.0, 0.0\]\) no valid action"):
        check_action_model(Trapped(), POS)

    class Wrong:
        n_actions = 3

        def apply(self, states):
            return states[..., None, :]

    with pytest.raises(ValueError, match=r"apply\(\) must return shape \(4, 3, 2\)"):
        check_action_model(Wrong(), POS)
