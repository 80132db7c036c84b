"""``coverage.area_per_robot_m2``: the ROI and the take-off disc derived from the swarm size,
and the ``coverage-large`` preset built on it."""

from __future__ import annotations

import math
import sys

import pandas as pd
import pytest
from click.testing import CliRunner

from swarmgames.cli import cli
from swarmgames.config import ScenarioConfig, parse_config, resolve_scenario, to_data, to_toml
from swarmgames.config.scaling import scaled_config
from swarmgames.errors import ConfigError
from swarmgames.missions import GaussianROI

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 only
    import tomli as tomllib


def _area_per_robot(cfg: ScenarioConfig) -> tuple[float, float]:
    """ROI area and take-off disc area per UAV of a validated configuration, m²."""
    cov = cfg.mission
    k2 = -2.0 * math.log1p(-cov.confidence)
    n = cfg.swarm.n_robots
    return math.pi * k2 * cov.roi_cov_m2[0][0] / n, math.pi * cfg.swarm.start_radius_m**2 / n


def test_preset_validates_at_the_benchmark_density():
    cfg = resolve_scenario("coverage-large")
    assert cfg.swarm.n_robots == 1000 and cfg.sim.duration_s == 60.0
    assert cfg.mission.area_per_robot_m2 == 70_000.0
    assert cfg.mission.signal_floor_dbm == -100.0 and cfg.game.dtype == "float32"
    assert _area_per_robot(cfg) == pytest.approx((70_000.0, 70_000.0), rel=1e-12)
    assert cfg.swarm.start_center_m == cfg.mission.roi_mean_m == (0.0, 0.0)
    # The benchmark's scenario of 1 000 UAVs, but for the run's length, name and threads, the
    # move cost, link weight and virtual means of tests/missions/test_share_weights.py, and
    # link keeping (docs/coverage.md, "What the presets use").
    bench = scaled_config(1000, workers=2)
    assert (
        cfg.mission.model_copy(
            update={
                "move_cost_db": 0.01,
                "move_cost_share_db": None,
                "alpha_b_share": None,
                "link_term": "signal",
            }
        )
        == bench.mission
    )
    assert cfg.game.model_copy(update={"alpha_b": 0.001, "virtual_mean": "eq3"}) == bench.game
    assert cfg.model_copy(update={"mission": bench.mission, "game": bench.game}) == (
        bench.with_overrides({"sim.duration_s": 60.0, "name": "coverage-large"})
    )


@pytest.mark.parametrize("via", ["set", "with_overrides"])
def test_changing_the_swarm_size_keeps_the_density(via):
    small = resolve_scenario("coverage-large")
    if via == "set":
        big = resolve_scenario("coverage-large", ["swarm.n_robots=10000"])
    else:
        big = small.with_overrides({"swarm.n_robots": 10_000})
    assert big.swarm.n_robots == 10_000
    assert _area_per_robot(big) == pytest.approx(_area_per_robot(small), rel=1e-12)
    cells = [
        GaussianROI(c.mission.roi_mean_m, c.mission.roi_cov_m2, 0.95, 20.0).n_cells
        / c.swarm.n_robots
        for c in (small, big)
    ]
    assert cells == pytest.approx([175.0, 175.0], rel=0.02)


def test_the_preset_round_trips_through_toml_and_data():
    cfg = resolve_scenario("coverage-large")
    text = to_toml(cfg)
    assert "roi_cov_m2" not in text and "start_radius_m" not in text
    assert parse_config(tomllib.loads(text)) == cfg
    assert parse_config(to_data(cfg)) == cfg
    assert "# roi_cov_m2 = [[" in to_toml(cfg, annotated=True)  # shown, as derived
    assert cfg.derived_fields() == {
        "mission": ("roi_cov_m2", "move_cost_db"),
        "swarm": ("start_center_m", "start_radius_m"),
        "game": ("alpha_b",),
    }


def test_scaled_config_is_built_on_the_setting():
    cfg = scaled_config(1000)
    assert cfg.mission.area_per_robot_m2 == 70_000.0
    # The values scaled_config computed itself before it was built on the setting.
    assert cfg.mission.roi_cov_m2 == ((3718905.7629691726, 0.0), (0.0, 3718905.7629691726))
    assert cfg.swarm.start_radius_m == 4720.3487194131485
    assert cfg.swarm.start_center_m == (0.0, 0.0)
    assert cfg.with_overrides({"swarm.n_robots": 300}) == scaled_config(300).with_overrides(
        {"name": cfg.name}
    )


@pytest.mark.parametrize(
    ("given", "named"),
    [
        (["coverage.roi_cov_m2=[[1e6, 0.0], [0.0, 1e6]]"], "coverage.roi_cov_m2"),
        (["swarm.start_radius_m=100.0"], "swarm.start_radius_m"),
        (["swarm.start_center_m=[5.0, 0.0]"], "swarm.start_center_m"),
    ],
)
def test_derived_fields_given_explicitly_are_an_error(given, named):
    with pytest.raises(ConfigError, match=f"mutually exclusive with them: remove {named}"):
        resolve_scenario("coverage-large", given)


def test_mutual_exclusion_from_the_cli_exits_2_naming_the_fields(tmp_path):
    res = CliRunner().invoke(
        cli,
        [
            "run",
            "coverage-large",
            "--set",
            "coverage.roi_cov_m2=[[1e6, 0.0], [0.0, 1e6]]",
            "--out",
            str(tmp_path / "x"),
        ],
    )
    assert res.exit_code == 2
    assert "coverage.area_per_robot_m2" in res.output and "coverage.roi_cov_m2" in res.output
    assert "Traceback" not in res.output and not (tmp_path / "x").exists()


def test_a_derived_roi_that_cannot_be_gridded_names_the_fields():
    with pytest.raises(ConfigError, match=r"swarm.n_robots = 1: coverage.grid_cell_m must be"):
        resolve_scenario("coverage-large", ["swarm.n_robots=1", "coverage.grid_cell_m=500.0"])


def test_without_the_setting_nothing_is_derived():
    cfg = ScenarioConfig()
    assert cfg.derived_fields() == {} and cfg.mission.area_per_robot_m2 is None
    assert cfg.mission.roi_cov_m2 == ((62500.0, 0.0), (0.0, 62500.0))


def test_a_small_run_of_the_preset_from_the_cli(tmp_path):
    out = tmp_path / "run"
    args = ["run", "coverage-large", "--set", "swarm.n_robots=50", "--set", "sim.duration_s=3.0"]
    args += ["--set", "sim.animation=false", "--out", str(out), "--no-progress"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    cfg = parse_config(tomllib.loads((out / "config.toml").read_text()))
    assert cfg.swarm.n_robots == 50
    assert _area_per_robot(cfg) == pytest.approx((70_000.0, 70_000.0), rel=1e-12)
    trajectory = pd.read_csv(out / "trajectory.csv")
    assert len(trajectory) == 50 * 4
    # Every UAV took off within the derived disc.
    first = trajectory[trajectory["t"] == trajectory["t"].min()]
    assert (first["x"] ** 2 + first["y"] ** 2).max() <= cfg.swarm.start_radius_m**2


def test_memory_estimate_counts_the_windows_not_the_whole_roi():
    # Under a signal floor each variable integrates a disc of about 400 cells: 10 000 UAVs
    # (1.75 M ROI cells) are estimated below a gigabyte or two, not refused.
    from swarmgames.sim.memory import estimate_memory

    small, big = (
        estimate_memory(resolve_scenario("coverage-large", [f"swarm.n_robots={n}"]))
        for n in (1000, 10_000)
    )
    assert small.total_gib < big.total_gib < 2.0
