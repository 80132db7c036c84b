"""``pair_weighting = "mean"``: every pair of a game of K_b robots weighs α_b / (K_b − 1).

The reference is eq. 1 itself (M. Fernando et al., ICRA 2022 workshop): a mean-weighted game
must be, bit for bit, the sum-weighted game of eq. 1 evaluated alone with α_b replaced by its
own weight α_b / (K_b − 1), on every path that builds the pairwise table.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.config import parse_config
from swarmgames.errors import ConfigError
from swarmgames.game import evaluate_payoffs, local_games, make_solver
from swarmgames.game.baselines import best_response
from swarmgames.game.equilibrium import local_regret, owner_payoffs
from swarmgames.game.potentials import pair_weights
from swarmgames.missions.coverage.mission import build
from tests.game.helpers import disk_snapshot, random_games


def test_weights_are_alpha_b_over_the_other_robots_of_each_game():
    batch, _ = random_games(0, 30, 6, 3)
    k = batch.mask.sum(axis=1)
    w = pair_weights(batch, 0.002, "mean")
    assert w.shape == (30,)
    np.testing.assert_array_equal(w, 0.002 / np.maximum(k - 1, 1))
    np.testing.assert_array_equal(pair_weights(batch, 0.002, "sum"), np.full(30, 0.002))
    assert np.all(w[k == 1] == 0.002)  # a lone robot has no pair to weigh


def test_unknown_weighting_and_pair_mask_are_refused():
    batch, _ = random_games(1, 4, 3, 2)
    with pytest.raises(ValueError, match="pair_weighting must be one of 'sum', 'mean'"):
        pair_weights(batch, 0.1, "median")
    masked = type(batch)(
        batch.owner, batch.members, batch.mask, batch.states, batch.is_virtual,
        batch.next_states, batch.action_mask, pair_mask=np.ones((4, 3, 3), bool),
    )  # fmt: skip
    with pytest.raises(ValueError, match="pair_mask"):
        pair_weights(masked, 0.1, "mean")


def _game_by_game(batch, pot, alpha_b, dtype):
    """Game b's tables under eq. 1 with α_b replaced by its own α_b / (K_b − 1)."""
    w = pair_weights(batch, alpha_b, "mean")
    for b in range(batch.n_games):
        pay = evaluate_payoffs(batch, pot, 1.0, float(w[b]), dtype=dtype)
        yield b, pay.select([b])


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_dense_path_is_eq1_with_each_games_weight(dtype):
    batch, pot = random_games(2, 25, 5, 4)
    mean = evaluate_payoffs(batch, pot, 1.0, 0.3, dtype=dtype, pair_weighting="mean")
    for b, alone in _game_by_game(batch, pot, 0.3, dtype):
        np.testing.assert_array_equal(mean.pair[b], alone.pair[0])
        np.testing.assert_array_equal(mean.unary[b], alone.unary[0])


def _coverage(n, seed):
    config = parse_config(
        {
            "swarm": {"n_robots": n},
            "coverage": {"signal_floor_dbm": -100.0, "move_cost_db": 0.0},
        }
    )
    mission = build(config)
    pos = np.random.default_rng(seed).uniform(-300, 300, size=(n, 2))
    states = np.column_stack([pos, np.full(n, 50.0)])
    batch = local_games(disk_snapshot(pos, 250.0), 2, states, mission.action_model)
    return batch, mission.potentials


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_coverage_table_and_on_demand_paths_are_eq1_with_each_games_weight(dtype):
    # float32 serves W on demand (CoveragePairs): its tables must carry the games' weights.
    batch, pot = _coverage(20, 3)
    mean = evaluate_payoffs(batch, pot, 1.0, 0.001, dtype=dtype, pair_weighting="mean")
    on_demand = mean.pair_source is not None
    assert on_demand == (dtype == np.float32)
    games = np.arange(batch.n_games)
    table = mean.pair_source.table(games) if on_demand else mean.pair
    for b, alone in _game_by_game(batch, pot, 0.001, dtype):
        ref = alone.pair_source.table(np.array([0])) if on_demand else alone.pair
        np.testing.assert_array_equal(table[b], ref[0])
    if on_demand:  # the subset of games keeps its weights
        sub = mean.pair_source.select(games[::3])
        np.testing.assert_array_equal(sub.table(np.arange(sub.points.shape[0])), table[::3])


def test_owner_rows_of_the_global_regret_use_the_same_weights():
    batch, pot = _coverage(16, 4)
    whole = evaluate_payoffs(batch, pot, 1.0, 0.001, pair_weighting="mean")
    rows = owner_payoffs(batch, pot, 1.0, 0.001, pair_weighting="mean")
    np.testing.assert_array_equal(rows.pair, whole.pair[:, 0])


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**16))
def test_mean_weighted_games_stay_potential_games(seed):
    # Every pair of a game has one weight, so best response still ends at a pure NE.
    batch, pot = random_games(seed, 12, 5, 3)
    pay = evaluate_payoffs(batch, pot, 1.0, 0.7, pair_weighting="mean")
    x, _, converged = best_response(pay, max_iter=500)
    assert converged.all() and np.all(local_regret(pay, x) == 0)


def test_solver_carries_the_weighting():
    batch, pot = random_games(5, 10, 4, 3)
    solver = make_solver("mean_field", alpha_b=0.5, pair_weighting="mean")
    np.testing.assert_array_equal(
        solver.evaluate(batch, pot).pair,
        evaluate_payoffs(batch, pot, 1.0, 0.5, pair_weighting="mean").pair,
    )


def test_the_centralised_game_refuses_mean_weighting():
    with pytest.raises(ConfigError, match=r"game.pair_weighting = 'mean'.*centralised"):
        parse_config({"game": {"solver": "centralised", "pair_weighting": "mean"}})


def test_a_run_with_mean_weighting_from_the_cli(tmp_path):
    # Three stages of the default scenario: the weighting reaches the games (the payoffs
    # differ from eq. 1's sum) and is recorded in the run's config.toml.
    from click.testing import CliRunner

    from swarmgames.cli import cli
    from swarmgames.sim import RunResult

    out = {}
    for weighting in ("sum", "mean"):
        folder = tmp_path / weighting
        args = ["run", "--out", str(folder), "--no-progress", "--set", "sim.duration_s=3.0"]
        args += ["--set", f"game.pair_weighting={weighting!r}".replace("'", '"')]
        res = CliRunner().invoke(cli, args)
        assert res.exit_code == 0, res.output
        assert f'pair_weighting = "{weighting}"' in (folder / "config.toml").read_text()
        out[weighting] = RunResult.load(folder).to_frame("metrics")
    assert not np.allclose(out["sum"]["payoff"], out["mean"]["payoff"])
