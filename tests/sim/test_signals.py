"""SIGTERM and SIGHUP stop a run like Ctrl-C: completed stages kept, written, exit 130."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pandas as pd
import pytest

import swarmgames
from swarmgames.sim.signals import INTERRUPT_SIGNALS, signals_interrupt

pytestmark = pytest.mark.skipif(
    not hasattr(signal, "SIGHUP"), reason="POSIX signals (SIGTERM, SIGHUP)"
)


@pytest.mark.parametrize("sig", INTERRUPT_SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_signal_raises_keyboard_interrupt_and_handlers_come_back(sig):
    before = signal.getsignal(sig)
    with pytest.raises(KeyboardInterrupt, match=signal.Signals(sig).name), signals_interrupt():
        os.kill(os.getpid(), sig)
        signal.sigtimedwait([], 0)  # the handler runs at the next bytecode; give it one
    assert signal.getsignal(sig) is before


def test_outside_the_main_thread_nothing_is_installed():
    seen = []

    def worker():
        with signals_interrupt():
            seen.append(signal.getsignal(signal.SIGTERM))

    before = signal.getsignal(signal.SIGTERM)
    t = threading.Thread(target=worker)
    t.start()
    t.join()
    assert seen == [before]


# The CLI in a fresh process whose progress callback announces every completed stage, so the
# signal is sent after the first stage without guessing how long start-up takes.
ANNOUNCING_CLI = """
import sys
import swarmgames.sim.runner as runner

class Announce:
    def __init__(self, description, enabled, total=None):
        pass
    def __enter__(self):
        return lambda done, total=None: print(f"stage {done}", flush=True)
    def __exit__(self, *exc):
        pass

runner.ProgressBar = Announce
from swarmgames.cli import main
main(sys.argv[1:])
"""


@pytest.mark.parametrize("sig", INTERRUPT_SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_signal_mid_run_keeps_the_completed_stages(tmp_path, sig):
    out = tmp_path / "run"
    tree = str(Path(swarmgames.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([tree, os.environ.get("PYTHONPATH", "")])}
    args = ["--out", str(out), "--no-progress", "--set", "sim.duration_s=600"]
    args += ["--set", "network.backend=oracle", "--set", "sim.animation=false"]
    proc = subprocess.Popen(
        [sys.executable, "-c", ANNOUNCING_CLI, "run", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        first = proc.stdout.readline()
        assert first.startswith("stage "), first + proc.stderr.read()
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "Interrupted" in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interrupted"] is True
    trajectory = pd.read_csv(out / "trajectory.csv")
    assert trajectory["t"].nunique() >= 2  # the start and at least one completed stage
    assert trajectory["t"].nunique() < 600  # stopped long before the end


# ctypes reports the exception it drops, which is what this test makes happen.
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_a_signal_whose_exception_c_code_swallowed_still_stops_the_run(monkeypatch):
    """The handler's KeyboardInterrupt raised inside a ctypes callback (as while Numba
    compiles) is printed and dropped by ctypes; the stage loop raises it after the stage."""
    import ctypes

    from swarmgames.config import parse_config
    from swarmgames.sim.loop import StageLoop

    callback = ctypes.CFUNCTYPE(None)(lambda: os.kill(os.getpid(), signal.SIGTERM))
    real_step = StageLoop.step

    def step(self):
        record = real_step(self)
        if self.stage == 2:
            callback()  # the signal arrives inside C code; ctypes drops the exception
        return record

    monkeypatch.setattr(StageLoop, "step", step)
    config = parse_config({"sim": {"duration_s": 6.0, "warmup_s": 0.0, "animation": False}})
    res = swarmgames.run(config, progress=False)
    assert res.summary["interrupted"] is True
    assert res.summary["stages"] == 2


# The CLI in a fresh process that receives SIGTERM while it draws the paths figure.
SIGTERM_IN_FIGURES = """
import os, signal, sys, time
from swarmgames.sim.result import RunResult

real = RunResult.plot_paths

def plot_paths(self):
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(1)
    return real(self)

RunResult.plot_paths = plot_paths
from swarmgames.cli import main
main(sys.argv[1:])
"""


def test_sigterm_while_figures_are_written_keeps_the_promise(tmp_path):
    from .test_resume import assert_same_run

    tree = str(Path(swarmgames.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([tree, os.environ.get("PYTHONPATH", "")])}
    args = ["--no-progress", "--set", "sim.duration_s=4", "--set", "swarm.n_robots=4"]
    args += ["--set", "sim.animation=false"]
    full = tmp_path / "full"
    ref = subprocess.run(
        [sys.executable, "-m", "swarmgames", "run", "--out", str(full), *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert ref.returncode == 0, ref.stderr
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-c", SIGTERM_IN_FIGURES, "run", "--out", str(out), *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 130, proc.stderr
    assert "Traceback" not in proc.stderr and f"--resume {out}" in proc.stderr
    assert json.loads((out / "summary.json").read_text())["interrupted"] is True
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "interrupted" and manifest["resumable"]
    resumed = subprocess.run(
        [sys.executable, "-m", "swarmgames", "run", "--resume", str(out), "--no-progress"],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert resumed.returncode == 0, resumed.stderr
    assert_same_run(out, full)
    assert (out / "paths.png").is_file()
