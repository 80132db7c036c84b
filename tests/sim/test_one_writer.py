"""One writer per run folder: a second `swarmgames run` into the same folder is refused
(exit 2, naming the holder) and the folder stays that of the first run."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd

import swarmgames
from swarmgames.sim.journal import verify_run

from .test_signals import ANNOUNCING_CLI

#: The announcing CLI that, after announcing its first stage, holds the run until a line
#: arrives on its standard input (later stages read the closed input's end at once): the
#: folder is held while the second writer tries, however slowly that one starts on a
#: loaded machine.
HOLDING_CLI = ANNOUNCING_CLI.replace(
    'print(f"stage {done}", flush=True)',
    '(print(f"stage {done}", flush=True), sys.stdin.readline())',
)
assert HOLDING_CLI != ANNOUNCING_CLI


def _cli(args, source=ANNOUNCING_CLI):
    tree = str(Path(swarmgames.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([tree, os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen(
        [sys.executable, "-c", source, *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def test_two_writers_into_one_folder_one_refused_and_the_folder_consistent(tmp_path):
    out = tmp_path / "run"
    common = ["--out", str(out), "--force", "--no-progress", "--set", "swarm.n_robots=4"]
    common += ["--set", "sim.animation=false", "--set", "sim.duration_s=12"]
    first = _cli(["run", *common, "--seed", "0"], HOLDING_CLI)
    try:
        line = first.stdout.readline()
        assert line.startswith("stage "), line + first.stderr.read()
        second = _cli(["run", *common, "--seed", "1"])
        _, err = second.communicate(timeout=120)
        assert second.returncode == 2, err
        assert f"being written by another swarmgames process (pid {first.pid} " in err
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1
        _, err = first.communicate("go\n", timeout=300)
        assert first.returncode == 0, err
    finally:
        first.kill()
    manifest = verify_run(out)  # every file is the first run's
    assert manifest["status"] == "complete" and manifest["seed"] == 0
    assert json.loads((out / "summary.json").read_text())["seed"] == 0
    assert "seed = 0" in (out / "config.toml").read_text()
    trajectory = pd.read_csv(out / "trajectory.csv")
    assert len(trajectory) == 13 * 4
