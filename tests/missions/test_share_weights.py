"""``coverage.move_cost_share_db`` and ``coverage.alpha_b_share``: the move cost and the link
weight stated per UAV share of the ROI, derived from the swarm size, and the ``coverage-large``
preset built on them."""

from __future__ import annotations

import sys

import pandas as pd
import pytest

from swarmgames.config import ScenarioConfig, parse_config, resolve_scenario, to_data, to_toml
from swarmgames.errors import ConfigError
from swarmgames.sim import run

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 only
    import tomli as tomllib


@pytest.mark.parametrize("n", [7, 100, 1000, 10_000])
def test_the_preset_divides_its_shares_by_the_swarm_size(n):
    cfg = resolve_scenario("coverage-large", [f"swarm.n_robots={n}"])
    assert cfg.mission.move_cost_share_db == 0.0007 and cfg.mission.alpha_b_share == 0.00007
    assert cfg.mission.move_cost_db == 0.0007 / n
    assert cfg.game.alpha_b == 0.00007 / n
    assert cfg.game.virtual_mean == "off"


def test_the_values_measured_at_100_uavs_are_the_preset_there():
    # docs/coverage.md, "What limits coverage at scale": move cost 7e-6 dB, alpha_b 7e-7.
    cfg = resolve_scenario("coverage-large", ["swarm.n_robots=100"])
    assert (cfg.mission.move_cost_db, cfg.game.alpha_b) == (7e-6, 7e-7)


def test_an_override_of_the_size_derives_the_weights_again():
    cfg = resolve_scenario("coverage-large").with_overrides({"swarm.n_robots": 100})
    assert (cfg.mission.move_cost_db, cfg.game.alpha_b) == (0.0007 / 100, 0.00007 / 100)


def test_the_preset_round_trips_with_the_derived_weights_left_out():
    cfg = resolve_scenario("coverage-large", ["swarm.n_robots=100"])
    text = to_toml(cfg)
    assert "move_cost_db" not in text and "alpha_b =" not in text
    assert "move_cost_share_db = 0.0007" in text and "alpha_b_share = 7e-05" in text
    assert parse_config(tomllib.loads(text)) == cfg
    assert parse_config(to_data(cfg)) == cfg
    assert "# move_cost_db = 7e-06   (derived)" in to_toml(cfg, annotated=True)


def test_without_the_shares_the_weights_are_as_given():
    cfg = ScenarioConfig()
    assert cfg.mission.move_cost_share_db is None and cfg.mission.alpha_b_share is None
    assert (cfg.mission.move_cost_db, cfg.game.alpha_b) == (0.01, 0.001)
    cfg = resolve_scenario("coverage", ["swarm.n_robots=20"])
    assert (cfg.mission.move_cost_db, cfg.game.alpha_b) == (0.01, 0.001)


@pytest.mark.parametrize(
    ("given", "message"),
    [
        (
            "coverage.move_cost_db=0.01",
            "coverage.move_cost_share_db derives coverage.move_cost_db from swarm.n_robots, so "
            "it is mutually exclusive with it: remove coverage.move_cost_db, or "
            "coverage.move_cost_share_db (got coverage.move_cost_share_db = 0.0007, "
            "coverage.move_cost_db = 0.01)",
        ),
        (
            "game.alpha_b=0.001",
            "coverage.alpha_b_share derives game.alpha_b from swarm.n_robots, so it is "
            "mutually exclusive with it: remove game.alpha_b, or coverage.alpha_b_share (got "
            "coverage.alpha_b_share = 7e-05, game.alpha_b = 0.001)",
        ),
    ],
)
def test_a_derived_weight_given_as_well_is_an_error(given, message):
    with pytest.raises(ConfigError) as info:
        resolve_scenario("coverage-large", [given])
    assert message in str(info.value)


@pytest.mark.parametrize(
    ("given", "message"),
    [
        ("coverage.move_cost_share_db=-1.0", "coverage.move_cost_share_db"),
        ("coverage.alpha_b_share=-1.0", "coverage.alpha_b_share"),
    ],
)
def test_a_negative_share_is_refused(given, message):
    with pytest.raises(ConfigError, match=message):
        resolve_scenario("coverage-large", [given])


def test_a_zero_link_share_needs_the_crowding_penalty_off_the_pairs():
    with pytest.raises(ConfigError, match=r"got game.alpha_b = 0 from coverage.alpha_b_share"):
        resolve_scenario("coverage-large", ["coverage.alpha_b_share=0.0"])
    cfg = resolve_scenario(
        "coverage-large", ["coverage.alpha_b_share=0.0", "coverage.separation_mode='unary'"]
    )
    assert cfg.game.alpha_b == 0.0


def _first_stages(tmp_path, name, overrides):
    # Seed 5: its 100 UAVs take off as one connected swarm (most seeds leave a few out of range).
    config = resolve_scenario(
        "coverage-large",
        [
            "swarm.n_robots=100",
            "seed=5",
            "sim.duration_s=15.0",
            "sim.animation=false",
            "sim.global_regret=false",
            *overrides,
        ],
    )
    run(config, out=tmp_path / name, progress=False)
    return pd.read_csv(tmp_path / name / "swarm.csv")


def test_a_seeded_100_uav_swarm_gains_coverage_and_stays_connected(tmp_path):
    # The preset as shipped: from one connected take-off the swarm spreads, gaining coverage in
    # every one of its first 15 stages (more than 2 dB in all), and stays one component.
    swarm = _first_stages(tmp_path, "shares", [])
    assert (swarm["components"] == 1).all()
    assert (swarm["coverage"].diff().dropna() > 0).all()
    assert swarm["coverage"].iloc[-1] - swarm["coverage"].iloc[0] > 2.0
    # The same swarm with the default scenario's fixed weights (0.01 dB, 0.001, as shares at
    # 100 UAVs) and virtual means: no move pays the move cost, and the swarm gains nothing.
    fixed = ["coverage.move_cost_share_db=1.0", "coverage.alpha_b_share=0.1"]
    still = _first_stages(tmp_path, "fixed", [*fixed, "game.virtual_mean='eq3'"])
    assert still["coverage"].iloc[-1] - still["coverage"].iloc[0] < 0.5
