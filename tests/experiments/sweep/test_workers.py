"""Sweeps that survive their workers: a worker killed mid-run fails only its run, the pool
is rebuilt for the others, and no worker outlives the sweep's process."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

import swarmgames
from swarmgames.runfolder import LOCK_FILE

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")


def _sweep(tmp_path: Path, seeds: str) -> tuple[list[str], Path]:
    scenario = tmp_path / "slow.toml"
    scenario.write_text(
        'name = "slow"\n[swarm]\nn_robots = 4\n[sim]\nduration_s = 40.0\nanimation = false\n'
    )
    out = tmp_path / "s"
    cmd = [sys.executable, "-m", "swarmgames", "sweep", str(scenario), "--seeds", seeds]
    return [*cmd, "--jobs", "2", "--out", str(out), "--no-progress"], out


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(Path(swarmgames.__file__).parents[1])}


def _running(out: Path) -> dict[Path, int]:
    """Run folders with a stage done and still running, and the pid of their writer."""
    found = {}
    for m in out.glob("runs/*/manifest.json"):
        try:
            manifest = json.loads(m.read_text())
            pid = int((m.parent / LOCK_FILE).read_text().split()[1])
        except (OSError, ValueError, KeyError, IndexError):
            continue
        if manifest["status"] == "running" and manifest["stages_completed"] >= 1:
            found[m.parent] = pid
    return found


def _wait_for(condition, timeout: float = 240.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError("timed out")


def _alive(pid: int) -> bool:
    stat = Path(f"/proc/{pid}/stat")
    if stat.parent.parent.is_dir() and Path("/proc/self").exists():
        try:  # a zombie left for a parent that never reaps it is gone
            return stat.read_text().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
        except OSError:
            return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_a_worker_killed_mid_run_fails_only_its_run_and_resume_retries_it(tmp_path):
    cmd, out = _sweep(tmp_path, "0,1,2,3")
    proc = subprocess.Popen(
        cmd, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        victim, pid = next(iter(_wait_for(lambda: _running(out)).items()))
        os.kill(pid, signal.SIGKILL)
        _, err = proc.communicate(timeout=600)
    finally:
        proc.kill()
    assert proc.returncode == 1, err
    assert "Traceback" not in err
    results = pd.read_csv(out / "results.csv")
    failed = results[results["status"] == "failed"]
    assert list(failed["folder"]) == [f"runs/{victim.name}"], results[["folder", "status"]]
    assert f"pid {pid}" in failed["error"].iloc[0] and "WorkerDied" in failed["error"].iloc[0]
    assert (results.drop(failed.index)["status"] == "complete").all()
    again = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    final = pd.read_csv(out / "results.csv")
    assert (final["status"] == "complete").all()
    # Only the failed run ran again: the others' summaries are those read back.
    keep = [c for c in final.columns if "ms" not in c and c not in ("wall_s", "error")]
    others = final.index != failed.index[0]
    pd.testing.assert_frame_equal(
        final.loc[others, keep], results.loc[others, keep], check_dtype=False
    )


def test_no_worker_survives_the_sweep_process(tmp_path):
    cmd, out = _sweep(tmp_path, "0,1,2,3")
    proc = subprocess.Popen(
        cmd, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        workers = _wait_for(lambda: (r := _running(out)) and len(r) == 2 and r)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
    finally:
        proc.kill()
    gone = _wait_for(lambda: not any(_alive(p) for p in workers.values()), timeout=30)
    assert gone
    time.sleep(2)  # and none went on to start another run
    assert len(list(out.glob("runs/*"))) == 2
