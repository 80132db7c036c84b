"""The global regret from true games whose non-owner variables are held at their realised
actions equals the one from the whole true games, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.config import resolve_scenario
from swarmgames.game import make_solver
from swarmgames.game.equilibrium import global_regret, owner_deviations
from swarmgames.game.local import broadcast, build_local_games
from swarmgames.sim.controllers import solver_from_config
from swarmgames.sim.runner import build_loop, build_mission
from tests.game.helpers import MODEL, POT
from tests.game.helpers import swarm as _swarm


def _both(solver, batch, potentials, actions):
    full = global_regret(solver.evaluate(batch, potentials), actions)
    held = owner_deviations(batch, actions)
    return full, global_regret(solver.evaluate(held, potentials), actions), held


def test_random_potentials():
    pos, snap = _swarm(15, 5)
    batch = build_local_games(broadcast(snap, 2, pos).views(), MODEL, virtual_mean=False)
    rng = np.random.default_rng(0)
    actions = np.array([rng.choice(np.flatnonzero(batch.action_mask[i, 0])) for i in range(15)])
    full, held, games = _both(make_solver("mean_field", alpha_b=0.5), batch, POT, actions)
    np.testing.assert_array_equal(full, held)
    assert np.array_equal(games.action_mask[:, 0], batch.action_mask[:, 0])
    assert (games.action_mask[:, 1:].sum(axis=2) == batch.mask[:, 1:]).all()  # one each


@pytest.mark.parametrize(
    ("scenario", "overrides"),
    [
        # the windowed compiled kernel and the pair source, float32
        ("coverage-large", ["swarm.n_robots=80"]),
        # the full-grid unary and the pair table, float64 (the golden runs' path)
        ("coverage", ["swarm.n_robots=20", "network.backend='oracle'"]),
    ],
)
def test_coverage_potentials(scenario, overrides):
    cfg = resolve_scenario(scenario, overrides)
    mission = build_mission(cfg)
    states, loop, _ = build_loop(cfg, mission, None)
    loop.start(states)
    for _ in range(2):
        loop.step()
    view = loop.observe()
    messages = broadcast(view.snapshot, cfg.network.hops, view.states)
    batch = build_local_games(messages.views(), mission.action_model, virtual_mean=False)
    # Random valid actions: the stage's own actions leave most regrets at 0.
    rng = np.random.default_rng(1)
    actions = np.array([rng.choice(np.flatnonzero(m)) for m in batch.action_mask[:, 0]])
    solver = solver_from_config(cfg.game)
    full, held, _ = _both(solver, batch, mission.potentials, actions)
    assert np.isfinite(full).all() and (full > 0).any()
    np.testing.assert_array_equal(full, held)


@pytest.mark.parametrize(
    ("scenario", "overrides"),
    [
        ("coverage-large", ["swarm.n_robots=80"]),  # owner rows alone by the compiled kernel
        ("coverage-large", ["swarm.n_robots=80", "coverage.kernel='numpy'"]),
        ("coverage-large", ["swarm.n_robots=80", "coverage.separation_mode='unary'"]),
        ("coverage", ["swarm.n_robots=20", "network.backend='oracle'"]),  # full grid
        # the pairwise crowding penalty off, and games weighted by their size
        ("coverage", ["swarm.n_robots=20", "coverage.separation_m=0.0"]),
        ("coverage", ["swarm.n_robots=20", "game.pair_weighting='mean'"]),
    ],
)
def test_owner_payoffs_are_the_owner_rows_of_the_whole_evaluation(scenario, overrides):
    from swarmgames.game.equilibrium import OwnerPayoffs, owner_payoffs
    from swarmgames.game.potentials import evaluate_payoffs

    cfg = resolve_scenario(scenario, overrides)
    mission = build_mission(cfg)
    states, loop, _ = build_loop(cfg, mission, None)
    loop.start(states)
    loop.step()
    view = loop.observe()
    messages = broadcast(view.snapshot, cfg.network.hops, view.states)
    batch = build_local_games(messages.views(), mission.action_model, virtual_mean=False)
    g = cfg.game
    whole = OwnerPayoffs.of(
        evaluate_payoffs(batch, mission.potentials, g.alpha_a, g.alpha_b, dtype=g.dtype)
    )
    rows = owner_payoffs(batch, mission.potentials, g.alpha_a, g.alpha_b, dtype=g.dtype)
    assert rows.unary.dtype == whole.unary.dtype
    np.testing.assert_array_equal(rows.unary, whole.unary)
    if whole.pair is not None:  # the owners' table rows alone: the same bits (signs of 0 too)
        assert rows.pair.dtype == whole.pair.dtype
        assert rows.pair.tobytes() == whole.pair.tobytes()
    rng = np.random.default_rng(2)
    actions = np.array([rng.choice(np.flatnonzero(m)) for m in batch.action_mask[:, 0]])
    np.testing.assert_array_equal(global_regret(rows, actions), global_regret(whole, actions))
    np.testing.assert_array_equal(
        mission.potentials.owner_unary(batch), mission.potentials.unary(batch)[:, 0]
    )


@pytest.mark.parametrize("overrides", [[], ["swarm.n_robots=20", "network.backend='oracle'"]])
def test_ex_post_owner_rows_are_those_of_the_whole_evaluation(overrides):
    # The ex-post games hold every member but the owner at one action: the owners' rows
    # (the table's row 0 alone, the owners' unary alone) give the whole evaluation's bits.
    from swarmgames.game import expost_games
    from swarmgames.game.equilibrium import OwnerPayoffs, owner_payoffs
    from swarmgames.game.potentials import evaluate_payoffs

    cfg = resolve_scenario("coverage", overrides)
    mission = build_mission(cfg)
    states, loop, _ = build_loop(cfg, mission, None)
    loop.start(states)
    loop.step()
    view = loop.observe()
    messages = broadcast(view.snapshot, cfg.network.hops, view.states)
    rng = np.random.default_rng(3)
    n = view.states.shape[0]
    nxt = np.asarray(mission.action_model.apply(view.states[:, None]))[:, 0]
    reached = nxt[np.arange(n), rng.integers(0, nxt.shape[1], n)]
    batch = expost_games(messages.views(), reached, mission.action_model)
    g = cfg.game
    whole = OwnerPayoffs.of(
        evaluate_payoffs(batch, mission.potentials, g.alpha_a, g.alpha_b, dtype=g.dtype)
    )
    rows = owner_payoffs(batch, mission.potentials, g.alpha_a, g.alpha_b, dtype=g.dtype)
    assert rows.unary.tobytes() == whole.unary.tobytes()
    assert rows.pair.tobytes() == whole.pair.tobytes()
