"""Crash-safe run folders: stages appended as they complete, a manifest, checkpoints, and
``swarmgames run --resume`` ending bit for bit as an uninterrupted run (issue: nothing lost).
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

import swarmgames
from swarmgames.cli import cli
from swarmgames.config import parse_config
from swarmgames.errors import RunFolderError
from swarmgames.runfolder import RunFolder
from swarmgames.sim import NotResumableError, build_mission, resume, run
from swarmgames.sim.journal import read_manifest
from swarmgames.sim.runner import build_loop

from .conftest import DiskOracle
from .test_signals import ANNOUNCING_CLI

#: Columns that are wall times, different in any two runs.
TIMINGS = ("solve_ms", "integrate_ms", "refine_ms")
TABLES = ("trajectory.csv", "metrics.csv", "swarm.csv")

# Routed messages with bursty loss, fading, GPS error and a crash: every random stream of a
# run (network jitter and fading, the game, the channel, the faults) is in the state.
HARD = {
    "name": "hard",
    "swarm": {"n_robots": 6},
    "sim": {"duration_s": 14.0, "warmup_s": 3.0, "animation": False},
    "network": {"hops": 2, "radio": {"nakagami_m": 2.0}},
    "comms": {"model": "routed", "loss_model": "gilbert_elliott", "loss_rate": 0.1},
    "faults": {"crash": [[8.0, 2]], "gps_error_m": 1.0},
}


def _config(data=HARD, **sim):
    data = json.loads(json.dumps(data))
    data["sim"].update(sim)
    return parse_config(data)


def assert_same_run(a: Path, b: Path) -> None:
    """``a`` and ``b`` hold the same run: the trajectory and the swarm table byte for byte,
    the metrics table value for value but the wall-time columns, the summary but wall
    times."""
    for name in ("trajectory.csv", "swarm.csv"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    ma, mb = pd.read_csv(a / "metrics.csv"), pd.read_csv(b / "metrics.csv")
    assert list(ma.columns) == list(mb.columns)
    keep = [c for c in ma.columns if c not in TIMINGS]
    pd.testing.assert_frame_equal(ma[keep], mb[keep], check_exact=True)
    sa, sb = (json.loads((p / "summary.json").read_text()) for p in (a, b))
    timing = {
        "wall_s",
        "median_solve_ms",
        "median_integrate_ms",
        "median_refine_ms",
        "median_stage_ms",
    }
    assert {k: v for k, v in sa.items() if k not in timing} == {
        k: v for k, v in sb.items() if k not in timing
    }


class StopAfter:
    """A mission wrapper that raises ``exc`` in stage ``k`` (0-based), once."""

    def __init__(self, mission, k, exc=KeyboardInterrupt):
        self._m, self._k, self._exc, self._calls = mission, k, exc, 0

    def __getattr__(self, name):
        return getattr(self._m, name)

    def swarm_metrics(self, states, previous, t):
        self._calls += 1
        if self._calls == self._k + 1:
            raise self._exc("stopped in a test")
        return self._m.swarm_metrics(states, previous, t)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted hard run."""
    out = tmp_path_factory.mktemp("ref") / "run"
    run(_config(), out=out, progress=False)
    return out


def test_the_folder_has_a_manifest_and_no_checkpoint_when_complete(reference):
    m = read_manifest(reference)
    assert m["status"] == "complete" and m["stages_completed"] == m["stages_planned"] == 14
    assert not m["resumable"] and not (reference / "checkpoint").exists()
    for name in TABLES:  # the manifest's rows and bytes are the files'
        assert m["tables"][name]["bytes"] == (reference / name).stat().st_size
        assert m["tables"][name]["rows"] == len(pd.read_csv(reference / name))
    assert m["tables"]["trajectory.csv"]["rows"] == 15 * 6  # the start, then every stage


def test_streamed_tables_equal_the_tables_of_the_result(tmp_path):
    # The tables appended stage by stage are those RunResult.write writes at once.
    res = run(_config(), out=tmp_path / "a", progress=False)
    res.write(RunFolder(tmp_path / "b"), animation=False)
    for name in TABLES:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


@pytest.mark.parametrize("stop_at", [0, 1, 6, 13])
def test_interrupted_then_resumed_equals_uninterrupted(tmp_path, reference, stop_at):
    cfg = _config()
    mission = StopAfter(build_mission(cfg), stop_at)
    out = tmp_path / "run"
    res = run(cfg, out=out, progress=False, mission=mission)
    assert res.interrupted and res.summary["stages"] == stop_at
    m = read_manifest(out)
    assert m["status"] == "interrupted" and m["resumable"] and m["checkpoint_stage"] == stop_at
    assert json.loads((out / "summary.json").read_text())["interrupted"] is True
    assert len(pd.read_csv(out / "swarm.csv")) == stop_at  # every completed stage kept
    done = resume(out, progress=False, mission=build_mission(cfg))
    assert not done.interrupted and done.summary["stages"] == 14
    assert read_manifest(out)["status"] == "complete"
    assert_same_run(out, reference)


def test_resume_after_a_sparse_checkpoint_reruns_the_stages_after_it(tmp_path):
    cfg = _config(checkpoint_every=4)
    full = tmp_path / "full"
    run(cfg, out=full, progress=False)
    out = tmp_path / "run"
    run(cfg, out=out, progress=False, mission=StopAfter(build_mission(cfg), 10))
    m = read_manifest(out)
    assert m["stages_completed"] == 10 and m["checkpoint_stage"] == 8
    resume(out, progress=False, mission=build_mission(cfg))
    assert_same_run(out, full)


def test_a_failing_stage_keeps_the_completed_ones(tmp_path):
    cfg = _config()
    out = tmp_path / "run"
    with pytest.raises(ZeroDivisionError):
        run(
            cfg,
            out=out,
            progress=False,
            mission=StopAfter(build_mission(cfg), 5, ZeroDivisionError),
        )
    m = read_manifest(out)
    assert m["status"] == "failed" and "ZeroDivisionError" in m["error"]
    assert m["stages_completed"] == 5 and len(pd.read_csv(out / "swarm.csv")) == 5
    assert len(pd.read_csv(out / "trajectory.csv")) == 5 * 6


def test_a_run_without_checkpoints_is_kept_and_its_summary_rebuilt(tmp_path):
    cfg = _config(checkpoint_every=0)
    out = tmp_path / "run"
    run(cfg, out=out, progress=False, mission=StopAfter(build_mission(cfg), 7))
    (out / "summary.json").unlink()  # as a kill -9 leaves it
    m = read_manifest(out)
    assert not m["resumable"] and m["not_resumable_because"] == "sim.checkpoint_every = 0"
    with pytest.raises(NotResumableError, match="rebuilt from its 7 completed stages"):
        resume(out, progress=False, mission=build_mission(cfg))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stages"] == 7 and summary["interrupted"] is True


def test_a_provider_without_state_is_not_resumable(tmp_path):
    cfg = _config()
    out = tmp_path / "run"
    run(
        cfg,
        out=out,
        progress=False,
        provider=DiskOracle(),
        mission=StopAfter(build_mission(cfg), 3),
    )
    m = read_manifest(out)
    assert (
        not m["resumable"] and "'test-disk' has no state()/restore()" in m["not_resumable_because"]
    )
    with pytest.raises(RunFolderError, match=r"network provider given to swarmgames.run"):
        resume(out, progress=False, mission=build_mission(cfg))
    with pytest.raises(NotResumableError, match="has no state"):
        resume(out, progress=False, mission=build_mission(cfg), provider=DiskOracle())


def test_resume_refuses_what_it_cannot_continue(tmp_path, reference):
    with pytest.raises(RunFolderError, match="is complete"):
        resume(reference, progress=False)
    with pytest.raises(RunFolderError, match="no run folder"):
        resume(tmp_path / "nothing", progress=False)
    (tmp_path / "empty").mkdir()
    with pytest.raises(RunFolderError, match=r"has no manifest.json"):
        resume(tmp_path / "empty", progress=False)
    cfg = _config()
    out = tmp_path / "run"
    run(cfg, out=out, progress=False, mission=StopAfter(build_mission(cfg), 4))
    with pytest.raises(RunFolderError, match=r"mission object given to swarmgames.run"):
        resume(out, progress=False)
    text = (out / "config.toml").read_text()
    (out / "config.toml").write_text(text.replace("seed = 0", "seed = 1"))
    with pytest.raises(RunFolderError, match=r"config.toml does not match the manifest"):
        resume(out, progress=False, mission=build_mission(cfg))
    (out / "config.toml").write_text(text)
    with open(out / "swarm.csv", "r+b") as fh:  # a table cut shorter than its checkpoint
        fh.truncate(10)
    with pytest.raises(RunFolderError, match=r"swarm.csv does not match the manifest"):
        resume(out, progress=False, mission=build_mission(cfg))


def test_loop_state_restored_into_a_fresh_loop_gives_the_same_records():
    cfg = _config()
    mission = build_mission(cfg)
    states, loop, _ = build_loop(cfg, mission, None)
    loop.start(states)
    for _ in range(5):
        loop.step()
    saved = loop.state()
    ahead = [loop.step() for _ in range(6)]
    _, fresh, _ = build_loop(cfg, mission, None)
    fresh.restore(saved)
    again = [fresh.step() for _ in range(6)]
    for a, b in zip(ahead, again, strict=True):
        assert a.t == b.t and np.array_equal(a.after, b.after)
        assert np.array_equal(a.actions, b.actions) and np.array_equal(a.links, b.links)
        for name in a.robot:
            if name not in TIMINGS:
                np.testing.assert_array_equal(a.robot[name], b.robot[name], err_msg=name)


def test_cli_resume(tmp_path, reference):
    cfg = _config()
    out = tmp_path / "run"
    run(cfg, out=out, progress=False, mission=StopAfter(build_mission(cfg), 6))
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["custom_mission"] = False  # as if the CLI had run it (the mission is registered)
    (out / "manifest.json").write_text(json.dumps(manifest))
    runner = CliRunner()
    res = runner.invoke(cli, ["run", "--resume", str(out), "--no-progress"])
    assert res.exit_code == 0, res.output
    assert_same_run(out, reference)
    res = runner.invoke(cli, ["run", "--resume", str(out), "--no-progress"])
    assert res.exit_code == 2 and "is complete" in res.output
    res = runner.invoke(cli, ["run", "--resume", str(out), "--set", "seed=1"])
    assert res.exit_code == 2 and "--set cannot be given with it" in res.output
    res = runner.invoke(cli, ["run", "--resume", str(out), "--seed", "0"])
    assert res.exit_code == 2 and "--seed cannot be given with it" in res.output


def _cli(args, **kwargs):
    tree = str(Path(swarmgames.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([tree, os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen(
        [sys.executable, "-c", ANNOUNCING_CLI, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        **kwargs,
    )


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_killed_run_keeps_its_stages_and_resumes_byte_identical(tmp_path, sig):
    args = ["--no-progress", "--set", "sim.duration_s=40", "--set", "sim.animation=false"]
    full = tmp_path / "full"
    proc = _cli(["run", "--out", str(full), *args])
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    out = tmp_path / "run"
    proc = _cli(["run", "--out", str(out), *args])
    try:
        for _ in range(8):  # a few stages complete, then the signal
            line = proc.stdout.readline()
            assert line.startswith("stage "), line + proc.stderr.read()
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == (130 if sig == signal.SIGTERM else -signal.SIGKILL), err
    m = read_manifest(out)
    assert m["status"] == ("interrupted" if sig == signal.SIGTERM else "running")
    done = m["stages_completed"]
    assert 8 <= done < 40
    swarm = pd.read_csv(out / "swarm.csv")  # every completed stage is readable
    assert len(swarm) >= done and len(pd.read_csv(out / "metrics.csv")) >= done * 7
    proc = _cli(["run", "--resume", str(out), "--no-progress"])
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    assert_same_run(out, full)
    assert not (out / "checkpoint").exists()
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


def test_deferred_interrupt_keeps_a_stage_whole(tmp_path):
    # A signal that arrives while a stage is being appended waits until it is appended.
    from swarmgames.sim.signals import deferred_interrupts

    cfg = _config()
    out = tmp_path / "run"
    from swarmgames.sim import journal as journal_module

    original = journal_module.RunJournal.stage

    def stage_with_signal(self, record, loop):
        if self.stages == 2:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)
        original(self, record, loop)

    journal_module.RunJournal.stage = stage_with_signal
    try:
        res = run(cfg, out=out, progress=False)
    finally:
        journal_module.RunJournal.stage = original
    assert res.interrupted and res.summary["stages"] == 3
    assert len(pd.read_csv(out / "swarm.csv")) == 3
    assert read_manifest(out)["checkpoint_stage"] == 3
    assert deferred_interrupts is not None
