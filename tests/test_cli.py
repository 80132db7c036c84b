"""Command-line behaviour: exit codes 0 (ok), 1 (failed / not available), 2 (usage)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from click.testing import CliRunner

from swarmgames.cli import cli


@pytest.fixture
def runner():
    return CliRunner()


def test_help_lists_every_subcommand(runner):
    res = runner.invoke(cli, ["--help"])
    assert res.exit_code == 0
    for cmd in ("run", "reproduce", "sweep", "network", "bench", "config"):
        assert cmd in res.output


def test_mistyped_subcommand_suggests_close_match(runner):
    res = runner.invoke(cli, ["rnu"])
    assert res.exit_code == 2
    assert "Did you mean 'run'?" in res.output


def test_config_show_prints_resolved_toml(runner):
    res = runner.invoke(cli, ["config", "show"])
    assert res.exit_code == 0
    assert "[network.olsr]" in res.output and "hello_interval_s = 2.0" in res.output


def test_config_check_valid_and_invalid(runner, tmp_path):
    good = tmp_path / "good.toml"
    good.write_text("[swarm]\nn_robots = 5\n")
    res = runner.invoke(cli, ["config", "check", str(good)])
    assert res.exit_code == 0 and "valid" in res.output

    bad = tmp_path / "bad.toml"
    bad.write_text("[swarm]\nn_robots = -5\n")
    res = runner.invoke(cli, ["config", "check", str(bad)])
    assert res.exit_code == 2
    assert "swarm.n_robots: must be >= 1 (got -5)" in res.output
    assert "Traceback" not in res.output


def test_bad_virtual_mean_exits_2_naming_field_rule_and_value(runner):
    res = runner.invoke(cli, ["config", "show", "--set", "game.virtual_mean='mean'"])
    assert res.exit_code == 2
    assert "game.virtual_mean: must be one of 'eq3', 'outside', 'exact', 'off'" in res.output
    assert "(got 'mean')" in res.output and "Traceback" not in res.output


@pytest.mark.parametrize(
    ("scenario", "controller", "offers"),
    [("rendezvous", "lloyd", "none"), ("coverage", "voronoi", "'lloyd'")],
)
def test_config_check_names_the_baselines_a_mission_offers(
    runner, tmp_path, scenario, controller, offers
):
    bad = tmp_path / "bad.toml"
    bad.write_text(f'scenario = "{scenario}"\n[sim]\ncontroller = "{controller}"\n')
    res = runner.invoke(cli, ["config", "check", str(bad)])
    assert res.exit_code == 2
    assert (
        f"sim.controller must be 'game', 'mpc' or a baseline of mission '{scenario}' (it "
        f"offers: {offers}) (got '{controller}')"
    ) in res.output
    assert "Traceback" not in res.output


def test_config_show_prints_the_old_switch_as_the_variant_name(runner):
    res = runner.invoke(cli, ["config", "show", "--set", "game.virtual_mean=false"])
    assert res.exit_code == 0 and 'virtual_mean = "off"' in res.output


def test_unknown_scenario_exits_2_with_suggestion(runner):
    res = runner.invoke(cli, ["config", "show", "coverag"])
    assert res.exit_code == 2
    assert "did you mean 'coverage'" in res.output


def test_bad_option_value_exits_2(runner, tmp_path):
    res = runner.invoke(cli, ["reproduce", "fig9"])
    assert res.exit_code == 2


def test_console_entry_point_via_python_m():
    res = subprocess.run(
        [sys.executable, "-m", "swarmgames", "config", "check", "/nonexistent/x.toml"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 2
    assert "configuration file not found" in res.stderr
    assert "Traceback" not in res.stderr


@pytest.mark.parametrize(
    ("error", "code"),
    [
        ("ConfigError", 2),
        ("InputDataError", 2),
        ("RunFolderError", 2),
        ("BackendUnavailableError", 1),
    ],
)
def test_errors_map_to_documented_exit_codes(runner, error, code):
    import click

    import swarmgames.errors as errors
    from swarmgames.cli import _guarded

    exc_type = getattr(errors, error)

    @click.command()
    @_guarded
    def failing() -> None:
        raise exc_type("something is wrong")

    res = runner.invoke(failing, [])
    assert res.exit_code == code
    assert "Error:" in res.output and "Traceback" not in res.output


# ----------------------------------------------------------------------------- end to end

HEX = "tests/data/ns3/hex_expand/positions.csv"  # recorded ns-3 trace (docs/reference.md section 4)


def test_run_writes_folder_and_refuses_to_overwrite(runner, tmp_path):
    out = tmp_path / "run"
    args = [
        "run",
        "--out",
        str(out),
        "--no-progress",
        "--set",
        "sim.duration_s=5",
        "--set",
        "sim.warmup_s=3",
        "--set",
        "sim.animation=false",
    ]
    res = runner.invoke(cli, args)
    assert res.exit_code == 0, res.output
    for name in ("config.toml", "trajectory.csv", "metrics.csv", "swarm.csv", "summary.json"):
        assert (out / name).is_file()
    assert "coverage_end_dbm" in res.output
    # The resolved configuration is the one that ran.
    assert "duration_s = 5.0" in (out / "config.toml").read_text()

    again = runner.invoke(cli, args)
    assert again.exit_code == 2 and "--force" in again.output
    forced = runner.invoke(cli, [*args, "--force"])
    assert forced.exit_code == 0


def test_run_with_invalid_override_creates_nothing(runner, tmp_path):
    out = tmp_path / "never"
    res = runner.invoke(cli, ["run", "--out", str(out), "--set", "swarm.n_robots=0"])
    assert res.exit_code == 2
    assert "swarm.n_robots: must be >= 1 (got 0)" in res.output
    assert not out.exists()


def _failing_run(monkeypatch):
    import swarmgames.sim

    def fail(*args, **kwargs):
        raise RuntimeError("the run broke")

    monkeypatch.setattr(swarmgames.sim, "run", fail)


def test_failed_run_keeps_the_users_empty_out_folder(runner, tmp_path, monkeypatch):
    _failing_run(monkeypatch)
    mine = tmp_path / "mine"
    mine.mkdir()
    res = runner.invoke(cli, ["run", "--out", str(mine), "--no-progress"])
    assert isinstance(res.exception, RuntimeError)
    assert mine.is_dir()  # the user made it: a failed run never removes it


def test_failed_run_removes_the_folders_it_created(runner, tmp_path, monkeypatch):
    _failing_run(monkeypatch)
    res = runner.invoke(cli, ["run", "--out", str(tmp_path / "a" / "b"), "--no-progress"])
    assert isinstance(res.exception, RuntimeError)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", [".", "..", ".hidden"])
def test_a_name_that_leaves_runs_is_rejected(runner, tmp_path, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(f'name = "{name}"\n')
    res = runner.invoke(cli, ["run", "s.toml", "--no-progress"])
    assert res.exit_code == 2
    assert "name: must be a folder name inside runs/" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]  # nothing written


def test_out_below_a_file_is_one_line(runner, tmp_path):
    (tmp_path / "f").write_text("mine")
    res = runner.invoke(cli, ["run", "--out", str(tmp_path / "f" / "run"), "--no-progress"])
    assert res.exit_code == 2
    assert res.output.startswith("Error: cannot write into output folder")
    assert len(res.output.strip().splitlines()) == 1 and "Traceback" not in res.output
    assert (tmp_path / "f").read_text() == "mine"


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (["config", "show", "--set", "sim.warmup_s=nan"], "sim.warmup_s: must be a finite number"),
        (["config", "show", "--set", "swarm.n_robot=3"], "did you mean 'n_robots'?"),
        (
            ["run", "--set", "network.olsr.hello_interval_s=0.5"],
            "network.olsr: max_jitter_s must be < hello_interval_s (got 0.5 >= 0.5)",
        ),
        (["run", "--set", "sim.warmup_s=1e12"], "sim.warmup_s: must be <= 1000000.0"),
        (["config", "check", "nan.toml"], "network.radio.tx_power_dbm: must be a finite number"),
        (["run", "latin1.toml"], "not UTF-8 text"),
        (["config", "show", "folder.toml"], "it is a folder"),
        (["network", "replay", "--positions", "latin1.csv"], "not UTF-8 text"),
        (["network", "replay", "--positions", "huge.csv"], "column node: must be < 100000"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(runner, tmp_path, monkeypatch, args, line):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "nan.toml").write_text("[network.radio]\ntx_power_dbm = nan\n")
    (tmp_path / "latin1.toml").write_bytes(b'name = "caf\xe9"\n')
    (tmp_path / "folder.toml").mkdir()
    (tmp_path / "latin1.csv").write_bytes(b"t,node,x,y,z\n0,0,\xff,0,0\n")
    (tmp_path / "huge.csv").write_text("t,node,x,y,z\n0,0,0,0,0\n0,1000000000,0,0,0\n")
    res = runner.invoke(cli, [*args, "--out", "o"] if args[0] != "config" else args)
    assert res.exit_code == 2, res.output
    assert res.output.startswith("Error: ") and line in res.output
    assert len(res.output.strip().splitlines()) == 1 and "Traceback" not in res.output
    assert not (tmp_path / "o").exists()


def test_network_replay_and_compare(runner, tmp_path):
    res = runner.invoke(
        cli,
        [
            "network",
            "replay",
            "--positions",
            HEX,
            "--backend",
            "oracle",
            "--out",
            str(tmp_path / "rep"),
        ],
    )
    assert res.exit_code == 0, res.output
    assert (tmp_path / "rep" / "hops.csv").read_text().startswith("t,node,dest,hops\n")
    res = runner.invoke(
        cli,
        [
            "network",
            "compare",
            "--positions",
            HEX,
            "--backends",
            "olsr,oracle",
            "--out",
            str(tmp_path / "cmp"),
        ],
    )
    assert res.exit_code == 0, res.output
    assert (tmp_path / "cmp" / "summary.json").is_file()


def test_network_replay_bad_trace_exits_2(runner, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,node,x,y,z\n0,0,0,0,0\n0,1,nan,0,0\n")
    res = runner.invoke(
        cli, ["network", "replay", "--positions", str(bad), "--out", str(tmp_path / "o")]
    )
    assert res.exit_code == 2
    assert "Traceback" not in res.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("command", [["replay"], ["compare", "--backends", "olsr,oracle"]])
def test_network_sample_every_is_bounded_before_anything_is_allocated(runner, tmp_path, command):
    # Regression: --sample-every 1e-9 over a trace allocated billions of sample times.
    res = runner.invoke(
        cli,
        ["network", *command, "--positions", HEX, "--sample-every", "1e-9", "--out", "o"],
    )
    assert res.exit_code == 2, res.output
    assert "--sample-every" in res.output and "hop rows" in res.output
    assert "Traceback" not in res.output
    assert not (tmp_path / "o").exists()


def test_network_compare_needs_two_backends(runner, tmp_path):
    res = runner.invoke(cli, ["network", "compare", "--positions", HEX, "--backends", "olsr"])
    assert res.exit_code == 2 and "at least two" in res.output


def test_reproduce_fig1(runner, tmp_path):
    res = runner.invoke(
        cli, ["reproduce", "fig1", "--backend", "oracle", "--out", str(tmp_path / "f1")]
    )
    assert res.exit_code == 0, res.output
    assert (tmp_path / "f1" / "fig1.csv").is_file() and (tmp_path / "f1" / "fig1.png").is_file()


def test_bench_writes_results(runner, tmp_path):
    out = tmp_path / "bench"
    res = runner.invoke(
        cli,
        ["bench", "--quick", "--sizes", "5,10", "--takeoff", "25", "--no-env", "--out", str(out)],
    )
    assert res.exit_code == 0, res.output
    for name in ("bench.json", "bench.csv", "bench.png"):
        assert (out / name).is_file()
    records = json.loads((out / "bench.json").read_text())["records"]
    takeoff = [r for r in records if r["benchmark"] == "takeoff"]
    assert [(r["n_robots"], r["dense"]) for r in takeoff] == [(25, False)]  # --quick: no dense


@pytest.mark.parametrize("sizes", ["0,10", "ten", ","])
def test_bench_rejects_bad_sizes(runner, tmp_path, sizes):
    res = runner.invoke(cli, ["bench", "--sizes", sizes, "--out", str(tmp_path / "b")])
    assert res.exit_code == 2 and "--sizes" in res.output
    assert not (tmp_path / "b").exists()


def test_run_that_fails_before_writing_leaves_no_folder(runner, tmp_path):
    # 7 robots in one clique give 9**7 joint profiles: the exact solver refuses at stage 1.
    out = tmp_path / "exact"
    res = runner.invoke(
        cli, ["run", "--out", str(out), "--no-progress", "--set", "game.solver=exact"]
    )
    assert res.exit_code == 2 and "exact" in res.output
    assert not out.exists()


@pytest.mark.parametrize("mission", ["rendezvous", "flocking"])
def test_every_builtin_mission_runs_from_the_cli(runner, tmp_path, mission):
    out = tmp_path / mission
    args = ["run", mission, "--out", str(out), "--no-progress"]
    args += ["--set", "sim.duration_s=4.0", "--set", "sim.animation_frames=2"]
    res = runner.invoke(cli, args)
    assert res.exit_code == 0, res.output
    for name in ("config.toml", "trajectory.csv", "metrics.csv", "swarm.csv", "summary.json"):
        assert (out / name).stat().st_size > 0
    for name in ("timeseries.png", "paths.png", "animation.gif"):
        assert (out / name).stat().st_size > 0
    assert f'scenario = "{mission}"' in (out / "config.toml").read_text()
    assert f"[{mission}]" in (out / "config.toml").read_text()


@pytest.mark.parametrize("variant", ["outside", "exact", "off"])
def test_run_coverage_with_each_virtual_mean_variant(runner, tmp_path, variant):
    out = tmp_path / variant
    args = ["run", "coverage", "--out", str(out), "--no-progress", "--set", "sim.duration_s=6.0"]
    args += ["--set", "sim.animation=false", "--set", f"game.virtual_mean={variant}"]
    res = runner.invoke(cli, args)
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["virtual_mean"] == variant and summary["stages"] == 6
    assert f'virtual_mean = "{variant}"' in (out / "config.toml").read_text()


def test_missions_list_and_check(runner):
    res = runner.invoke(cli, ["missions", "list"])
    assert res.exit_code == 0
    assert {line.split()[0] for line in res.output.splitlines()} >= {
        "coverage",
        "rendezvous",
        "flocking",
    }
    res = runner.invoke(cli, ["missions", "check", "flocking"])
    assert res.exit_code == 0 and "conforms" in res.output
    res = runner.invoke(cli, ["missions", "check", "rendevous"])
    assert res.exit_code == 2 and "did you mean 'rendezvous'" in res.output


def test_missions_check_reports_a_broken_plugin(runner):
    import numpy as np

    from swarmgames.missions import MissionEntry, register_mission, unregister_mission
    from swarmgames.section import Section

    class Broken:
        name, state_dim, potentials, action_model = "broken", 3, None, None

        def initial_states(self, n, rng):
            return np.zeros((n, 2))

        def swarm_metrics(self, states, previous, t):
            return {}

    register_mission(MissionEntry("broken", Section, lambda cfg: Broken()), replace=True)
    try:
        res = runner.invoke(cli, ["missions", "check", "broken"])
    finally:
        unregister_mission("broken")
    assert res.exit_code == 1
    assert "initial_states must return shape (4, 3)" in res.output


# ----------------------------------------------------------------------------- sweep

TINY = 'name = "tiny"\n[swarm]\nn_robots = 3\n[sim]\nduration_s = 4.0\nwarmup_s = 2.0\n'
TINY += "animation = false\n"


def _sweep(runner, tmp_path, *args):
    (tmp_path / "tiny.toml").write_text(TINY)
    out = tmp_path / "s"
    cmd = ["sweep", str(tmp_path / "tiny.toml"), "--out", str(out), "--jobs", "1", "--no-progress"]
    return runner.invoke(cli, [*cmd, *args]), out


def test_sweep_end_to_end(runner, tmp_path):
    # A comma inside brackets belongs to the value: two levels, one crash and none.
    args = ["--set", "faults.crash=[[3.0,1]],[]", "--set", "swarm.n_robots=3,4", "--seeds", "0,1"]
    res, out = _sweep(runner, tmp_path, *args, "--metric", "mean_payoff_end")
    assert res.exit_code == 0, res.output
    assert "8 runs: 8 complete, 0 failed, 0 interrupted" in res.output
    assert "mean_payoff_end" in res.output and "[[3.0, 1]]" in res.output  # the summary table
    for name in ("results.csv", "aggregate.csv", "paired.csv", "mean_payoff_end.png"):
        assert (out / name).stat().st_size > 0, name
    results = (out / "results.csv").read_text()
    assert results.startswith("faults.crash,swarm.n_robots,seed,status,error,folder,")
    assert '"[[3.0, 1]]",3,0,complete' in results
    # Run again: every run is read back, none run.
    stamp = {p: p.stat().st_mtime_ns for p in out.glob("runs/*/summary.json")}
    again, _ = _sweep(runner, tmp_path, *args)
    assert again.exit_code == 0, again.output
    assert {p: p.stat().st_mtime_ns for p in out.glob("runs/*/summary.json")} == stamp


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (
            ["--set", "swarm.n_robots=3,0"],
            "sweep point swarm.n_robots=0: swarm.n_robots: must be >= 1",
        ),
        (["--set", "swarm.n_robot=3,4"], "did you mean 'n_robots'?"),
        (["--set", "faults.crash=[[3.0,1]"], "faults.crash: missing closing ']'"),
        (["--set", "comms.loss_rate=0.1,nan"], "comms.loss_rate: must be a finite number"),
        (["--set", "a.b=1,2", "--set", "c.d=1,2,3", "--zip"], "--zip pairs the i-th values"),
        (["--seeds", "0,x"], "--seeds"),
        (["--address", "auto"], "--address is the address of a Ray cluster"),
        (["--jobs", "0"], "--jobs"),
    ],
)
def test_sweep_rejects_bad_input_before_any_run(runner, tmp_path, args, line):
    res, out = _sweep(runner, tmp_path, *args)
    assert res.exit_code == 2, res.output
    assert line in res.output and "Traceback" not in res.output
    assert not out.exists()


def test_sweep_with_a_failed_run_exits_1_after_the_others(runner, tmp_path):
    # 7 robots in one clique give 9**7 joint profiles: the exact solver refuses.
    res, _ = _sweep(
        runner,
        tmp_path,
        "--set",
        "swarm.n_robots=7",
        "--set",
        "game.solver=mean_field,exact",
        "--seeds",
        "0",
    )
    assert res.exit_code == 1, res.output
    assert "2 runs: 1 complete, 1 failed" in res.output
    assert "failed: runs/game.solver=exact" in res.output and "max_profiles" in res.output


def test_sweep_without_ray_exits_1_with_the_pip_command(runner, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)
    res, out = _sweep(runner, tmp_path, "--executor", "ray")
    assert res.exit_code == 1
    assert "pip install 'swarmgames[ray]'" in res.output and not out.exists()


def test_run_with_a_refinement_and_a_bad_refinement(runner, tmp_path):
    out = tmp_path / "r"
    args = ["run", "coverage", "--out", str(out), "--set", "game.refine=best_response"]
    args += ["--set", "sim.duration_s=4.0", "--set", "sim.animation=false"]
    res = runner.invoke(cli, args)
    assert res.exit_code == 0, res.output
    metrics = (out / "metrics.csv").read_text().splitlines()
    assert "expost_regret" in metrics[0] and "refine_sweeps" in metrics[0]
    bad = runner.invoke(cli, ["run", "coverage", "--out", str(tmp_path / "b"), "--set",
                              "game.refine=nash"])  # fmt: skip
    assert bad.exit_code == 2
    assert "game.refine" in bad.output and "Traceback" not in bad.output


def test_config_list_describes_every_scenario(runner):
    res = runner.invoke(cli, ["config", "list"])
    assert res.exit_code == 0
    lines = res.output.splitlines()
    assert lines[0].split()[0] == "coverage" and "default" in lines[0]
    assert all(len(line.split()) > 3 for line in lines)


def test_a_setting_without_effect_is_one_line_naming_both_fields(runner):
    res = runner.invoke(
        cli, ["config", "show", "--set", "comms.model=ideal", "--set", "comms.loss_rate=0.4"]
    )
    assert res.exit_code == 2
    assert "comms.loss_rate" in res.output and "comms.model = 'ideal'" in res.output
    assert "(got 0.4)" in res.output and len(res.output.strip().splitlines()) == 1


def _command(*args: str, code: str | None = None) -> subprocess.CompletedProcess:
    from pathlib import Path

    import swarmgames

    tree = str(Path(swarmgames.__file__).resolve().parents[1])
    argv = ["-c", code] if code is not None else ["-m", "swarmgames"]
    return subprocess.run(
        [sys.executable, *argv, *args],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": tree},
    )


def test_the_command_ends_with_its_status_and_all_its_output(tmp_path):
    # python -m swarmgames ends without the interpreter's teardown: the same status, every
    # line flushed, exit handlers run.
    ok = _command("--version")
    assert ok.returncode == 0 and ok.stdout.startswith("swarmgames, version")
    bad = _command("config", "check", str(tmp_path / "missing.toml"))
    assert bad.returncode == 2 and "Error" in bad.stderr
    # Called from code, a command's SystemExit comes back to the caller.
    code = (
        "import atexit, sys\nfrom swarmgames.cli import main\n"
        "atexit.register(lambda: print('handler ran'))\n"
        "try:\n    main(['--version'])\nexcept SystemExit as exc:\n"
        "    print('caught', exc.code)\nsys.exit(3)\n"
    )
    res = _command(code=code)
    assert res.returncode == 3
    assert res.stdout.splitlines()[-2:] == ["caught 0", "handler ran"]


def test_learn_trains_and_compares(runner, tmp_path):
    pytest.importorskip("stable_baselines3", reason='pip install "swarmgames[rl]"')
    out = tmp_path / "learn"
    args = ["learn", "--set", "swarm.n_robots=3", "--set", "sim.duration_s=3.0", "--envs", "2"]
    args += ["--agent-steps", "200", "--eval-seeds", "100,101", "--out", str(out)]
    res = runner.invoke(cli, args)
    assert res.exit_code == 0, res.output
    for name in ("model.zip", "normalize.pkl", "curve.csv", "evaluation.csv", "summary.json"):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["policies"]) == {"random", "expert", "trained"}
    assert summary["agent_steps"] >= 200 and "trained" in res.output


def test_learn_rejects_bad_input(runner, tmp_path):
    res = runner.invoke(cli, ["learn", "--set", "swarm.n_robots=0", "--out", str(tmp_path / "l")])
    assert res.exit_code == 2 and "n_robots" in res.output
    res = runner.invoke(cli, ["learn", "--eval-seeds", "a,b", "--out", str(tmp_path / "l")])
    assert res.exit_code == 2 and "--eval-seeds" in res.output
