"""docs/examples/moving_target.py: a one-file mission whose target moves with the stage time."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import swarmgames
from swarmgames.config import parse_config
from swarmgames.game.local import local_games
from swarmgames.missions import (
    ENTRY_POINT_GROUP,
    check_mission,
    register_mission,
    unregister_mission,
)
from swarmgames.sim import build_mission

from ..sim.conftest import DiskOracle

EXAMPLES = Path(__file__).resolve().parents[2] / "docs" / "examples"
FILE = EXAMPLES / "moving_target.py"


@pytest.fixture(scope="module")
def example():
    """The example, loaded from its file as a plug-in's module (the package never imports it)."""
    spec = importlib.util.spec_from_file_location("moving_target_example", FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def registered(example):
    register_mission(example.ENTRY, replace=True)
    yield example.ENTRY
    unregister_mission("moving_target")


def _config(**sim):
    return parse_config(
        {
            "scenario": "moving_target",
            "swarm": {"n_robots": 4},
            "sim": {"duration_s": 20.0, "warmup_s": 2.0, "animation": False, **sim},
        }
    )


def test_the_example_conforms(registered):
    mission = build_mission(_config())
    check_mission(mission)
    assert mission.state_dim == 3  # position only: no clock in the state


def test_the_unary_reads_the_stage_time_not_the_states(registered):
    config = _config()
    mission = build_mission(config)
    states = mission.initial_states(4, np.random.default_rng(0))
    snap = DiskOracle().reset(states)
    model, pot = mission.action_model, mission.potentials
    early = pot.unary(local_games(snap, 1, states, model, t=2.0))
    late = pot.unary(local_games(snap, 1, states, model, t=40.0))
    assert early.shape == late.shape and np.all(np.isfinite(early) & np.isfinite(late))
    assert not np.allclose(early, late)
    # Reference: the stay action (0) scores minus the distance to p(t + control period), the
    # circle's point at angle omega (t + period) (default section: centre (-200, 0), 100 m,
    # 0.05 rad/s; sim.control_period_s = 1 s).
    angle = 0.05 * (40.0 + 1.0)
    target = np.array([-200.0, 0.0]) + 100.0 * np.array([np.cos(angle), np.sin(angle)])
    expected = -np.linalg.norm(states[:, :2] - target, axis=1)
    np.testing.assert_allclose(late[:, 0, 0], expected, rtol=1e-12)


def test_the_metrics_measure_the_target_at_their_stage_time(registered):
    mission = build_mission(_config())
    states = np.array([[-100.0, 0.0, 30.0], [-200.0, 0.0, 30.0]])
    # At t = 0 the target is at (-100, 0); a quarter turn later (t = pi / 2 / 0.05) at (-200, 100).
    assert mission.swarm_metrics(states, None, 0.0)["target_distance_m"] == pytest.approx(50.0)
    quarter = np.pi / 2 / 0.05
    got = mission.robot_metrics(states, quarter)["target_distance_m"]
    np.testing.assert_allclose(got, [np.hypot(100.0, 100.0), 100.0])


def test_a_short_run_closes_on_the_target(registered, tmp_path):
    config = _config()
    result = swarmgames.run(config, out=tmp_path / "r", progress=False, provider=DiskOracle())
    distance = result.to_frame()["target_distance_m"]
    assert distance.iloc[-1] < distance.iloc[0]
    # The games see the stage time: the swarm follows the moving target, not where it was
    # at t = 0 (which would leave it about 100 m behind and falling back).
    assert distance.iloc[-1] < 40.0
    assert "target_distance_m" in result.to_frame("metrics")
    assert result.summary["target_distance_end_m"] == pytest.approx(distance.iloc[-1])


def test_the_cli_runs_the_example_as_an_installed_plugin(tmp_path):
    # An installed distribution on the path: its entry point names the example's module.
    info = tmp_path / "moving_target-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: moving-target\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        f"[{ENTRY_POINT_GROUP}]\nmoving_target = moving_target:ENTRY\n"
    )
    scenario = tmp_path / "track.toml"
    scenario.write_text(
        'name = "track"\nscenario = "moving_target"\n[swarm]\nn_robots = 3\n'
        "[sim]\nduration_s = 6.0\nwarmup_s = 2.0\nanimation = false\n"
        '[network]\nbackend = "oracle"\n[moving_target]\nradius_m = 80.0\n'
    )
    tree = str(Path(swarmgames.__file__).resolve().parents[1])
    path = os.pathsep.join([str(tmp_path), str(EXAMPLES), tree])
    command = ["run", str(scenario), "--no-progress", "--out", str(tmp_path / "out")]
    ran = subprocess.run(
        [sys.executable, "-m", "swarmgames", *command],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": path},
        cwd=tmp_path,
        timeout=300,
    )
    assert ran.returncode == 0, ran.stderr
    header = (tmp_path / "out" / "swarm.csv").read_text().splitlines()[0]
    assert "target_distance_m" in header
