"""Every bad input is one clear line: limits when reading TOML, integer bounds, coordinates
the radio model can hold, values echoed short, problems counted, a non-finite payoff named."""

from __future__ import annotations

import re

import annotated_types as at
import numpy as np
import pytest
from click.testing import CliRunner

from swarmgames.cli import cli
from swarmgames.config import parse_config
from swarmgames.config.io import MAX_PROBLEMS
from swarmgames.errors import ConfigError, InputDataError, PayoffError

from .test_config_invalid import FIELDS


def _one_line(res, code=2):
    assert res.exit_code == code, res.output
    assert "Traceback" not in res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1, res.output
    return lines[0]


@pytest.mark.parametrize("command", [["config", "check"], ["run", "--no-progress"]])
def test_a_toml_file_nested_100000_deep_is_one_line(tmp_path, command):
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    args = [*command, str(path)] + (["--out", str(tmp_path / "o")] if "run" in command else [])
    line = _one_line(CliRunner().invoke(cli, args))
    assert "nest at most 32 deep" in line
    assert not (tmp_path / "o").exists()


def test_a_toml_file_too_large_is_one_line(tmp_path):
    path = tmp_path / "big.toml"
    path.write_text(f'name = "{"x" * 10_000_000}"\n')
    line = _one_line(CliRunner().invoke(cli, ["config", "check", str(path)]))
    assert "must be at most 1048576 bytes" in line and len(line) < 300


def test_a_huge_value_is_echoed_cut_short():
    with pytest.raises(ConfigError) as info:
        parse_config({"swarm": {"n_robots": "x" * 10_000_000}})
    text = str(info.value)
    assert "swarm.n_robots" in text and "(10000002 characters)" in text and len(text) < 500


def test_many_unknown_keys_list_twenty_then_a_count():
    data = {f"key{i}": 1 for i in range(50_000)}
    with pytest.raises(ConfigError) as info:
        parse_config(data)
    text = str(info.value)
    assert text.startswith("invalid configuration: 50000 problems")
    assert len(info.value.errors) == MAX_PROBLEMS + 1
    assert info.value.errors[-1] == f"... and {50_000 - MAX_PROBLEMS} more problems"
    assert len(text) < 5000


def test_every_integer_field_has_bounds_the_kernels_hold():
    ints = [(path, info) for _, path, info in FIELDS if info.annotation is int]
    assert ints
    for path, info in ints:
        upper = [m.le for m in info.metadata if isinstance(m, at.Le)]
        upper += [m.lt for m in info.metadata if isinstance(m, at.Lt)]
        assert upper and max(upper) <= 2**63 - 1, path


@pytest.mark.parametrize(
    ("assignment", "field"),
    [("seed=1180591620717411303424", "seed"), ("game.max_iter=10000000000000", "game.max_iter")],
)
def test_an_integer_too_large_is_one_line(tmp_path, assignment, field):
    args = ["run", "--no-progress", "--set", assignment, "--out", str(tmp_path / "o")]
    line = _one_line(CliRunner().invoke(cli, args))
    assert f"{field}: must be <=" in line


def test_a_start_centre_that_overflows_the_radio_model_is_refused(tmp_path):
    args = ["run", "--set", "swarm.start_center_m=[1e200, 0]", "--out", str(tmp_path / "o")]
    line = _one_line(CliRunner().invoke(cli, args))
    assert "swarm.start_center_m.0: must be <= 10000000.0 (got 1e+200)" in line


def test_a_trace_coordinate_that_overflows_the_radio_model_is_refused(tmp_path):
    from swarmgames.network.trace import read_positions

    path = tmp_path / "positions.csv"
    path.write_text("t,node,x,y,z\n0,0,0,0,0\n0,1,1e300,0,0\n")
    with pytest.raises(InputDataError, match=r"line 3, column x: must be within \+-1e\+07 m"):
        read_positions(path)


def test_a_non_finite_payoff_at_run_time_names_mission_robot_and_stage(tmp_path):
    import dataclasses

    import swarmgames
    from swarmgames.game import FunctionPotentials
    from swarmgames.sim import build_mission
    from swarmgames.sim.journal import read_manifest

    cfg = parse_config(
        {
            "scenario": "rendezvous",
            "swarm": {"n_robots": 3},
            "sim": {"duration_s": 6.0, "animation": False},
        }
    )
    mission = build_mission(cfg)
    calls = []

    def unary(states):
        calls.append(1)
        u = -np.linalg.norm(states[..., :2], axis=-1)
        return np.full_like(u, np.nan) if len(calls) > 2 else u

    broken = dataclasses.replace(mission, potentials=FunctionPotentials(unary))
    out = tmp_path / "run"
    with pytest.raises(PayoffError) as info:
        swarmgames.run(cfg, out=out, progress=False, mission=broken)
    text = str(info.value)
    assert "\n" not in text
    found = re.match(r"mission 'rendezvous', stage (\d+) \(t = [\d.]+ s\): unary potential", text)
    assert found and "is not finite (nan) for local game of robot" in text, text
    manifest = read_manifest(out)  # the completed stages are kept
    stage = int(found.group(1))
    assert stage >= 2 and manifest["status"] == "failed"
    assert manifest["stages_completed"] == stage - 1
