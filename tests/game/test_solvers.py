"""Tests of the solver registry and the stage entry point."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.config import GameConfig
from swarmgames.game import (
    SOLVERS,
    GameSolution,
    MeanFieldSolver,
    Solver,
    StageProblem,
    make_solver,
    solve,
)
from swarmgames.sim.controllers import solver_from_config
from tests.game.helpers import MODEL, POT, random_games
from tests.game.helpers import swarm as _swarm


@pytest.mark.parametrize(
    ("name", "centralised"), [*((s, False) for s in SOLVERS), ("mean_field", True)]
)
def test_every_solver_returns_a_valid_action_per_robot(name, centralised):
    pos, snap = _swarm(8)
    cfg = GameConfig(solver="centralised" if centralised else name, alpha_b=0.5, beta=20.0)
    cfg = cfg.model_copy(update={"max_profiles": 10**7})
    solver = solver_from_config(cfg)
    assert solver.name == name and isinstance(solver, Solver)
    out = solve(
        StageProblem.ideal(
            snap, 1, pos, MODEL, POT, solver, centralised=centralised, keep_games=True
        ),
        0,
    )
    assert out.actions.shape == (8,)
    valid = MODEL.valid(pos)
    assert np.all(valid[np.arange(8), out.actions])
    np.testing.assert_allclose(out.next_states, MODEL.apply(pos)[np.arange(8), out.actions])
    sol = out.solution
    assert isinstance(sol, GameSolution) and sol.solve_time_s >= 0
    assert sol.to_frame().shape[0] == out.batch.n_games
    if centralised:
        assert out.batch.n_games == 1 and out.batch.n_vars == 8
    else:
        assert out.batch.n_games == 8


def test_make_solver_takes_plain_parameters_and_rejects_unknown_ones():
    assert make_solver("exact", max_profiles=10).max_profiles == 10
    with pytest.raises(ValueError, match="solver must be one of"):
        make_solver("annealing")
    with pytest.raises(ValueError, match=r"solver 'random' takes no parameter 'beta'"):
        make_solver("random", beta=1.0)


def test_sampled_actions_are_reproducible_and_follow_the_marginal():
    batch, pot = random_games(0, 400, 3, 4, ragged=False)
    solver = MeanFieldSolver(alpha_b=0.0, beta=1.0, action_choice="sample")
    a1 = solver.solve(batch, pot, rng=5)
    a2 = solver.solve(batch, pot, rng=np.random.default_rng(5))
    np.testing.assert_array_equal(a1.actions, a2.actions)
    # With one game repeated, the draws follow Q_owner (chi-square style tolerance).
    one = batch.select([0] * 4000)
    sol = solver.solve(one, pot.select([0] * 4000), rng=1)
    freq = np.bincount(sol.actions, minlength=4) / 4000
    np.testing.assert_allclose(freq, sol.marginals[0, 0], atol=0.04)


def test_solver_parameters_are_validated():
    with pytest.raises(ValueError, match=r"beta must be > 0 and finite \(got 0.0\)"):
        MeanFieldSolver(beta=0.0)
    with pytest.raises(ValueError, match=r"delta must be > 0"):
        MeanFieldSolver(delta=-1.0)
    with pytest.raises(ValueError, match=r"action_choice must be 'argmax' or 'sample'"):
        MeanFieldSolver(action_choice="mode")  # type: ignore[arg-type]


def test_config_rejects_unknown_solver_and_bad_values():
    from swarmgames.errors import ConfigError

    with pytest.raises((ConfigError, ValueError)):
        GameConfig(solver="annealing")  # type: ignore[arg-type]
    with pytest.raises((ConfigError, ValueError)):
        GameConfig(beta=0.0)
    with pytest.raises((ConfigError, ValueError)):
        GameConfig(delta=0.0)


@pytest.mark.parametrize("engine", ["auto", "compiled", "blas", "sequential"])
def test_game_config_engine_reaches_the_mean_field_solver(engine):
    assert solver_from_config(GameConfig(engine=engine)).engine == engine
    assert solver_from_config(GameConfig(solver="centralised", engine=engine)).engine == engine
