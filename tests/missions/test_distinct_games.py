"""Games holding the same robots in the same states share one unary computation, bit for bit.

The reference is each game computed alone (a batch of one game, where nothing is shared):
the coverage unary of eq. 5 (M. Fernando et al., ICRA 2022 workshop) depends on the set of
the other variables' states, not on their order, so every path must give the same bits.
"""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.config import parse_config
from swarmgames.game import LocalGameBatch, local_games
from swarmgames.missions.coverage.distinct import distinct_games
from swarmgames.missions.coverage.mission import build
from tests.game.helpers import disk_snapshot


def _dense(n, floor, kernel, seed=0):
    """Every robot within range of every other: all n games hold all n robots."""
    cov = {"move_cost_db": 0.0, "kernel": kernel, "signal_floor_dbm": floor}
    mission = build(parse_config({"swarm": {"n_robots": n}, "coverage": cov}))
    pos = np.random.default_rng(seed).uniform(-60, 60, size=(n, 2))
    states = np.column_stack([pos, np.full(n, 50.0)])
    batch = local_games(disk_snapshot(pos, 1000.0), 1, states, mission.action_model)
    return batch, mission.potentials


def _moved(batch: LocalGameBatch, game: int) -> LocalGameBatch:
    """``batch`` with one member's state seen 1 m off in game ``game`` (a stale belief)."""
    states = np.array(batch.states)
    nxt = np.array(batch.next_states)
    states[game, 2, 0] += 1.0
    nxt[game, 2, :, 0] += 1.0
    return LocalGameBatch(
        batch.owner, batch.members, batch.mask, states, batch.is_virtual, nxt,
        batch.action_mask,
    )  # fmt: skip


def _alone(pot, batch, owner_only=False):
    rows = []
    for b in range(batch.n_games):
        one = batch.select([b])
        rows.append(pot.owner_unary(one)[0] if owner_only else pot.unary(one)[0])
    return np.stack(rows)


@pytest.mark.parametrize(
    ("floor", "kernel"), [(None, "auto"), (-100.0, "compiled"), (-100.0, "numpy")]
)
@pytest.mark.parametrize("moved", [False, True])
def test_shared_unary_equals_each_game_alone(floor, kernel, moved):
    batch, pot = _dense(9, floor, kernel)
    if moved:
        batch = _moved(batch, 4)
    ids = 2 * np.asarray(batch.members) + batch.is_virtual
    same = distinct_games(ids, batch.mask, batch.states, batch.next_states, batch.action_mask)
    assert same is not None and same.games.size == (2 if moved else 1)
    np.testing.assert_array_equal(pot.unary(batch), _alone(pot, batch))
    np.testing.assert_array_equal(pot.owner_unary(batch), _alone(pot, batch, owner_only=True))


def test_games_with_other_robots_or_states_are_not_shared():
    ids = np.array([[1, 2, -1], [2, 1, -1], [1, 2, 3], [1, 3, -1]])
    mask = ids >= 0
    states = np.zeros((4, 3, 2))
    d = distinct_games(ids, mask, states)
    assert d.games.tolist() == [0, 2, 3]  # game 1 is game 0 in another order
    assert d.source[1].tolist() == [1, 0, -1]
    states[1, 0, 0] = 0.5  # robot 2 seen elsewhere in game 1: no longer the same game
    assert distinct_games(ids, mask, states) is None
