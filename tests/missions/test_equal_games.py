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
    same = batch.equal_games
    assert same is not None and same.games.size == (2 if moved else 1)
    np.testing.assert_array_equal(pot.unary(batch), _alone(pot, batch))
    np.testing.assert_array_equal(pot.owner_unary(batch), _alone(pot, batch, owner_only=True))


def _source(batch, pot):
    from swarmgames.game.potentials import pair_weights

    return pot.pair_source(batch, pair_weights(batch, 1e-3, "mean"), np.float32)


@pytest.mark.parametrize("moved", [False, True])
def test_ranked_pair_tables_are_the_tables_reordered_and_shared_bit_for_bit(moved):
    batch, pot = _dense(9, -100.0, "compiled")
    if moved:
        batch = _moved(batch, 4)
    src = _source(batch, pot)
    head, rank = src.shared()
    assert head.tolist() == ([0, 0, 0, 0, 4, 0, 0, 0, 0] if moved else [0] * 9)
    own = src.table(np.arange(9))
    ranked = src.ranked_table(np.arange(9))
    for b in range(9):
        order = np.argsort(rank[b])
        assert np.array_equal(ranked[b], own[b][order][:, :, order])
        assert np.array_equal(ranked[b], ranked[head[b]])
    # Ranked by robot: the variable of robot m holds rank m in every game.
    assert np.array_equal(np.take_along_axis(np.asarray(batch.members), np.argsort(rank), 1),
                          np.tile(np.arange(9), (9, 1)))  # fmt: skip


def test_dense_games_solve_alike_alone_and_on_their_shared_table():
    from swarmgames.game import evaluate_payoffs, mean_field

    batch, pot = _dense(12, -100.0, "compiled")
    pay = evaluate_payoffs(batch, pot, 1.0, 1e-3, dtype=np.float32, pair_weighting="mean")
    assert pay.pair_source is not None
    together = mean_field(pay, 50.0, engine="compiled")
    for b in range(batch.n_games):
        alone = mean_field(pay.select([b]), 50.0, engine="compiled")
        assert np.array_equal(alone.marginals[0], together.marginals[b])
    # And to float32 rounding as on the held tables (each game's own order).
    held = evaluate_payoffs(batch, pot, 1.0, 1e-3, dtype=np.float32, pair_weighting="mean")
    held = type(held)(held.unary, held.pair_table(), held.action_mask, held.mask, held.owner,
                      held.members)  # fmt: skip
    np.testing.assert_allclose(mean_field(held, 50.0).marginals, together.marginals, atol=1e-4)


def test_dense_stage_results_do_not_depend_on_its_batches():
    """With tables on demand, games holding the same robots share ranked tables inside a
    batch; the games' results must not depend on which games are batched together."""
    from swarmgames.game import StageProblem, make_solver, solve

    batch, pot = _dense(16, -100.0, "compiled")
    states = np.asarray(batch.states)[0, np.argsort(np.asarray(batch.members)[0])]
    mission = build(parse_config({"swarm": {"n_robots": 16}}))
    snap = disk_snapshot(states[:, :2], 1000.0)
    solver = make_solver("mean_field", dtype="float32", engine="compiled")
    runs = [
        solve(StageProblem.ideal(snap, 1, states, mission.action_model, pot, solver, buckets=b), 0)
        for b in (1, 5)
    ]
    for field in ("actions", "payoff", "local_regret", "global_regret", "iterations"):
        assert np.array_equal(getattr(runs[0], field), getattr(runs[1], field)), field


@pytest.mark.parametrize("moved", [False, True])
@pytest.mark.parametrize("crowding", [0.0, 3.0])
def test_shared_float64_pair_tables_equal_each_game_alone(moved, crowding):
    cov = {"move_cost_db": 0.0, "separation_m": 30.0, "separation_cost_db": crowding}
    mission = build(parse_config({"swarm": {"n_robots": 9}, "coverage": cov}))
    pos = np.random.default_rng(1).uniform(-40, 40, size=(9, 2))
    states = np.column_stack([pos, np.full(9, 50.0)])
    batch = local_games(disk_snapshot(pos, 1000.0), 1, states, mission.action_model)
    pot = mission.potentials
    if moved:
        batch = _moved(batch, 4)
    shared = pot.pair_table(batch, np.float64)
    valid = np.asarray(batch.action_mask) & np.asarray(batch.mask)[..., None]
    for b in range(batch.n_games):
        alone = pot.pair_table(batch.select([b]), np.float64)[0]
        ok = valid[b][:, :, None, None] & valid[b][None, None, :, :]
        assert np.array_equal(shared[b][ok], alone[ok])


@pytest.mark.parametrize("moved", [False, True])
def test_the_next_batch_takes_the_carried_game_bit_for_bit(monkeypatch, moved):
    """A stage's batches of a dense float64 swarm hold the same game: the second batch takes
    the first's unary rows and pairwise table (its variables reordered) instead of
    computing them, and gets what a fresh computation gives, bit for bit. A game that
    differs (one member seen 1 m off) is still computed."""
    batch, pot = _dense(9, None, "auto")
    if moved:
        batch = _moved(batch, 7)
    first, second = batch.select(np.arange(4)), batch.select(np.arange(4, 9))
    fresh = [_dense(9, None, "auto")[1] for _ in range(2)]
    expect = [(p.unary(b), p.pair_table(b)) for p, b in zip(fresh, (first, second), strict=True)]
    pot.unary(first), pot.pair_table(first)
    tables, grids = [], []
    real_table, real_grid = type(pot)._pair_table, type(pot)._full_grid

    def counted_table(self, b, dtype, games=None):
        tables.append(None if games is None else len(games))
        return real_table(self, b, dtype, games)

    def counted_grid(self, stage, out, *args):
        grids.append(out.shape[0])
        return real_grid(self, stage, out, *args)

    monkeypatch.setattr(type(pot), "_pair_table", counted_table)
    monkeypatch.setattr(type(pot), "_full_grid", counted_grid)
    unary, table = pot.unary(second), pot.pair_table(second)
    assert np.array_equal(unary, expect[1][0]) and np.array_equal(table, expect[1][1])
    assert tables == ([1] if moved else []) and grids == [1 if moved else 0]


@pytest.mark.parametrize("kept", [False, True])
def test_whole_grid_owner_unary_equals_the_unarys_owner_rows(kept):
    # The ex-post regret reads variable 0 of games whose members all differ in state; the
    # whole-grid unary computes only those rows, from a field kept from the stage's games
    # (kept) or computed anew, and must give unary(batch)[:, 0] bit for bit.
    batch, pot = _dense(7, None, "auto")
    for game in range(batch.n_games):
        batch = _moved(batch, game)
    want = pot.unary(batch)[:, 0]
    _, fresh = _dense(7, None, "auto")
    if kept:
        fresh.unary(batch)  # holds a field of every position the owners' rows need
    np.testing.assert_array_equal(fresh.owner_unary(batch), want)


def test_the_ex_post_games_take_the_stages_field_and_its_floats(monkeypatch):
    # The ex-post games stand every robot where one of its actions took it and mask the
    # other members' actions but one: their positions are the stage's, so the owners' rows
    # read the field kept from the stage's unary (no new field), bit for bit the rows of a
    # field computed for them alone.
    from swarmgames.game import expost_games
    from swarmgames.game.local import broadcast

    n = 7
    cov = {"move_cost_db": 0.0, "signal_floor_dbm": None}
    mission = build(parse_config({"swarm": {"n_robots": n}, "coverage": cov}))
    pos = np.random.default_rng(5).uniform(-60, 60, size=(n, 2))
    states = np.column_stack([pos, np.full(n, 50.0)])
    snap = disk_snapshot(pos, 1000.0)
    stage = local_games(snap, 1, states, mission.action_model)
    actions = np.arange(n) % mission.action_model.n_actions
    nxt = np.asarray(stage.next_states)[np.arange(n), 0, actions]
    views = broadcast(snap, 1, states).views(np.arange(n))
    expost = expost_games(views, nxt, mission.action_model).on(stage.stage)
    want = mission.potentials.owner_unary(expost)
    pot = build(parse_config({"swarm": {"n_robots": n}, "coverage": cov})).potentials
    pot.unary(stage)
    calls = []
    field = type(pot.signal).field
    monkeypatch.setattr(type(pot.signal), "field", lambda *a: calls.append(1) or field(*a))
    np.testing.assert_array_equal(pot.owner_unary(expost), want)
    assert calls == []
