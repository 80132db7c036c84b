"""The stage time of a batch of local games: kept by every operation that derives a batch."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.game import DisplacementActions, LocalGameBatch
from swarmgames.game.equilibrium import owner_deviations
from swarmgames.game.expost import expost_games
from swarmgames.game.local import (
    broadcast,
    build_local_game,
    build_local_games,
    centralised_game,
    gather_views,
    local_games,
    receive,
)
from swarmgames.network import TopologySnapshot
from tests.game.helpers import random_games

MODEL = DisplacementActions.headings(1.0, 4)
STATES = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
SNAP = TopologySnapshot.from_hop_matrix(0.0, np.array([[0, 1, 2], [1, 0, 1], [2, 1, 0]]))


def test_a_batch_built_outside_a_run_is_at_time_zero():
    batch, _ = random_games(0, 3, 3, 4)
    assert batch.t == 0.0
    assert local_games(SNAP, 1, STATES, MODEL).t == 0.0


@pytest.mark.parametrize("mode", ["eq3", "outside", "exact", "off"])
def test_every_builder_sets_the_stage_time(mode):
    t = 12.5
    assert local_games(SNAP, 1, STATES, MODEL, virtual_mean=mode, t=t).t == t
    messages = broadcast(SNAP, 1, STATES)
    views = gather_views(messages, context=mode == "exact")
    assert build_local_games(views, MODEL, virtual_mean=mode, t=t).t == t
    view = receive(messages, 1, context=mode == "exact")
    assert build_local_game(view, MODEL, virtual_mean=mode, t=t).t == t
    assert centralised_game(SNAP, 1, STATES, MODEL, t=t).t == t
    assert expost_games(gather_views(messages), STATES, MODEL, t=t).t == t


def test_derived_batches_keep_the_stage_time():
    batch = local_games(SNAP, 1, STATES, MODEL, t=7.0)
    assert batch.select([0, 2]).t == 7.0
    assert batch.trim().t == 7.0
    assert LocalGameBatch.concat([batch, batch.select([1])]).t == 7.0
    assert owner_deviations(batch, np.zeros(3, dtype=int)).t == 7.0


def test_concat_refuses_batches_of_different_times():
    a = local_games(SNAP, 1, STATES, MODEL, t=1.0)
    b = local_games(SNAP, 1, STATES, MODEL, t=2.0)
    with pytest.raises(ValueError, match=r"share the stage time t \(got \[1\.0, 2\.0\]\)"):
        LocalGameBatch.concat([a, b])


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), "1.0", True, None])
def test_a_time_that_is_not_a_finite_number_is_rejected(bad):
    with pytest.raises(ValueError, match="t must be a finite number of seconds"):
        local_games(SNAP, 1, STATES, MODEL, t=bad)
