"""``swarmgames.sweep`` end to end on tiny runs: the files, a failed run recorded while the
sweep goes on, resuming (finished runs skipped, interrupted ones continued), the same numbers
from one process, two processes and Ray, interruption by SIGTERM, and the errors."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

import swarmgames
from swarmgames.config import parse_config
from swarmgames.errors import BackendUnavailableError, ConfigError, RunFolderError
from swarmgames.experiments.sweep import aggregate, executors, paired_differences
from swarmgames.runfolder import LOCK_FILE
from swarmgames.sim.journal import RunJournal, read_manifest

#: Three robots, four stages: a run takes a fraction of a second.
TINY = {
    "name": "tiny",
    "swarm": {"n_robots": 3},
    "sim": {"duration_s": 4.0, "warmup_s": 2.0, "animation": False},
}
BASE = parse_config(TINY)
GRID = {"swarm.n_robots": [3, 4]}
SEEDS = [0, 1]
#: Summary columns that are wall times, different in any two runs.
TIMINGS = [
    "wall_s",
    "median_solve_ms",
    "median_integrate_ms",
    "median_refine_ms",
    "median_stage_ms",
]


def _same_numbers(a: pd.DataFrame, b: pd.DataFrame) -> None:
    pd.testing.assert_frame_equal(a.drop(columns=TIMINGS), b.drop(columns=TIMINGS))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The tiny sweep, in this process."""
    out = tmp_path_factory.mktemp("sweep") / "ref"
    return out, swarmgames.sweep(BASE, GRID, SEEDS, jobs=1, out=out)


@pytest.fixture
def executed(monkeypatch):
    """The tasks executed (in this process: jobs=1)."""
    tasks = []
    real = executors.execute

    def counting(task):
        tasks.append(task)
        return real(task)

    monkeypatch.setattr(executors, "execute", counting)
    return tasks


def test_a_sweep_writes_a_run_folder_per_run_and_its_tables(reference):
    out, res = reference
    assert sorted(p.name for p in out.iterdir() if p.name != LOCK_FILE) == [
        "aggregate.csv",
        "config.toml",
        "coverage_end_dbm.png",
        "paired.csv",
        "paired_coverage_end_dbm.png",
        "results.csv",
        "runs",
        "sweep.json",
    ]
    assert list(res.columns[:6]) == [
        "swarm.n_robots",
        "seed",
        "status",
        "error",
        "folder",
        "scenario",
    ]
    assert res[["swarm.n_robots", "seed"]].values.tolist() == [[3, 0], [3, 1], [4, 0], [4, 1]]
    assert (res["status"] == "complete").all() and (res["n_robots"] == res["swarm.n_robots"]).all()
    for row in res.itertuples():
        folder = out / row.folder
        assert folder.parent == out / "runs"
        assert read_manifest(folder)["status"] == "complete"
        assert json.loads((folder / "summary.json").read_text())["seed"] == row.seed
        assert "n_robots = " + str(row[1]) in (folder / "config.toml").read_text()
    assert (out / "results.csv").read_text() == res.to_csv(index=False)
    assert (out / "aggregate.csv").read_text() == aggregate(res).to_csv(index=False)
    agg = pd.read_csv(out / "aggregate.csv")
    assert set(agg["swarm.n_robots"]) == {3, 4} and (agg["n"] <= 2).all()
    assert (out / "paired.csv").read_text() == paired_differences(res).to_csv(index=False)
    paired = pd.read_csv(out / "paired.csv")
    assert set(paired["factor"]) == {"swarm.n_robots"} and set(paired["baseline"]) == {3}
    spec = json.loads((out / "sweep.json").read_text())
    assert spec["factors"] == {"swarm.n_robots": ["3", "4"]} and spec["seeds"] == SEEDS


def test_runs_are_those_of_swarmgames_run(reference):
    _, res = reference
    one = swarmgames.run(
        BASE.with_overrides({"swarm.n_robots": 4, "seed": 1}), None, progress=False
    )
    row = res.iloc[3].to_dict()
    for key, value in one.summary.items():
        if key not in TIMINGS and key != "seed":
            assert row[key] == value or (value is None and pd.isna(row[key])), key


def test_two_processes_give_the_same_results(reference, tmp_path):
    _, ref = reference
    _same_numbers(swarmgames.sweep(BASE, GRID, SEEDS, jobs=2, out=tmp_path / "two"), ref)


def test_ray_gives_the_same_results(reference, tmp_path):
    pytest.importorskip("ray")
    _, ref = reference
    res = swarmgames.sweep(BASE, GRID, SEEDS, jobs=1, executor="ray", out=tmp_path / "ray")
    _same_numbers(res, ref)


def test_without_ray_the_error_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray fails
    with pytest.raises(BackendUnavailableError, match=r"pip install 'swarmgames\[ray\]'"):
        swarmgames.sweep(BASE, GRID, SEEDS, executor="ray", out=tmp_path / "s")
    assert not (tmp_path / "s").exists()  # checked before anything is written


def test_a_failed_run_is_recorded_and_the_sweep_goes_on(tmp_path):
    # 7 robots in one clique give 9**7 joint profiles: the exact solver refuses at stage 1.
    res = swarmgames.sweep(
        BASE,
        {"game.solver": ["mean_field", "exact"], "swarm.n_robots": [3, 7]},
        [0],
        jobs=1,
        out=tmp_path / "s",
    )
    assert res["status"].tolist() == ["complete", "complete", "complete", "failed"]
    failed = res.iloc[3]
    assert failed["error"].startswith("ConfigError: game.solver = 'exact' cannot solve this stage")
    assert pd.isna(failed["coverage_end_dbm"])
    # Its folder keeps the stages it completed, and the same error.
    manifest = read_manifest(tmp_path / "s" / failed["folder"])
    assert (manifest["status"], manifest["error"]) == ("failed", failed["error"])
    agg = aggregate(res)
    row = agg[(agg["game.solver"] == "exact") & (agg["swarm.n_robots"] == 7)]
    assert (row["n"] == 0).all()  # no complete run to describe


def test_the_same_sweep_again_skips_finished_runs_and_reruns_failed_ones(tmp_path, executed):
    grid = {"game.solver": ["mean_field", "exact"], "swarm.n_robots": [3, 7]}
    first = swarmgames.sweep(BASE, grid, [0], jobs=1, out=tmp_path / "s")
    assert len(executed) == 4
    again = swarmgames.sweep(BASE, grid, [0], jobs=1, out=tmp_path / "s")
    assert [Path(t.folder).name for t in executed[4:]] == [first.iloc[3]["folder"][5:]]
    pd.testing.assert_frame_equal(again, first)  # the finished runs read back as they were


def test_an_interrupted_sweep_resumes_to_the_uninterrupted_results(
    reference, tmp_path, monkeypatch, executed
):
    _, ref = reference
    real, calls = RunJournal.stage, []

    def stop_once(self, record, loop):
        calls.append(1)
        if len(calls) == 6:  # stage 2 of the second run
            raise KeyboardInterrupt("stopped in a test")
        real(self, record, loop)

    monkeypatch.setattr(RunJournal, "stage", stop_once)
    out = tmp_path / "s"
    cut = swarmgames.sweep(BASE, GRID, SEEDS, jobs=1, out=out)
    assert cut["status"].tolist() == ["complete", "interrupted", "interrupted", "interrupted"]
    assert len(executed) == 2  # the sweep stopped after the interrupted run
    manifest = read_manifest(out / cut.iloc[1]["folder"])
    assert manifest["status"] == "interrupted" and manifest["resumable"]
    assert (out / "results.csv").is_file() and (out / "aggregate.csv").is_file()

    done = swarmgames.sweep(BASE, GRID, SEEDS, jobs=1, out=out)
    assert [t.resume for t in executed[2:]] == [True, False, False]
    _same_numbers(done, ref)


def test_a_run_folder_of_another_configuration_stops_the_sweep_before_it_runs(reference, tmp_path):
    out, _ = reference
    longer = BASE.with_overrides({"sim.duration_s": 5.0})
    with pytest.raises(RunFolderError, match="holds a run of another configuration"):
        swarmgames.sweep(longer, GRID, SEEDS, jobs=1, out=out)


def test_a_folder_that_holds_no_sweep_is_not_used(tmp_path):
    (tmp_path / "mine.txt").write_text("keep")
    with pytest.raises(RunFolderError, match="is not empty and holds no sweep"):
        swarmgames.sweep(BASE, GRID, SEEDS, jobs=1, out=tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.txt"]


def test_metrics_are_plotted_and_an_unknown_one_named_after_the_tables(reference):
    out, _ = reference
    swarmgames.sweep(BASE, GRID, SEEDS, jobs=1, out=out, metrics=["mean_payoff_end", "stages"])
    assert (out / "mean_payoff_end.png").stat().st_size > 0 and (out / "stages.png").is_file()
    with pytest.raises(ConfigError, match=r"metric: .*did you mean 'coverage_end_dbm'"):
        swarmgames.sweep(BASE, GRID, SEEDS, jobs=1, out=out, metrics=["coverage_end_dmb"])


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"executor": "dask"}, "executor: must be one of local, ray"),
        ({"address": "auto"}, "address: is the address of a Ray cluster"),
        ({"jobs": 0}, "jobs: must be an integer >= 1"),
        ({"metrics": "stages"}, "metrics: must be a list"),
    ],
)
def test_bad_options(tmp_path, options, message):
    with pytest.raises(ConfigError, match=message):
        swarmgames.sweep(BASE, GRID, SEEDS, out=tmp_path / "s", **options)
    assert not (tmp_path / "s").exists()


def test_sigterm_stops_a_sweep_in_processes_and_the_same_command_resumes(tmp_path):
    # Runs of a few seconds, two at a time: the signal comes while they run.
    scenario = tmp_path / "slow.toml"
    scenario.write_text('name = "slow"\n[sim]\nduration_s = 30.0\nanimation = false\n')
    out = tmp_path / "s"
    cmd = [
        sys.executable,
        "-m",
        "swarmgames",
        "sweep",
        str(scenario),
        "--set",
        "swarm.n_robots=5,6",
    ]
    cmd += ["--seeds", "0", "--jobs", "2", "--out", str(out), "--no-progress"]
    env = {**os.environ, "PYTHONPATH": str(Path(swarmgames.__file__).parents[1])}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120

    def started() -> bool:
        # A stage completed: the kernels are compiled (a signal inside Numba's compiler
        # callbacks is reported by Python as an ignored exception, not by the sweep).
        for m in out.glob("runs/*/manifest.json"):
            try:
                if json.loads(m.read_text())["stages_completed"] >= 1:
                    return True
            except (OSError, ValueError, KeyError):
                pass
        return False

    while not started() and time.monotonic() < deadline:
        time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "run the same command again to resume" in err and "Traceback" not in err
    cut = pd.read_csv(out / "results.csv")
    assert "interrupted" in set(cut["status"]), cut["status"]
    for row in cut[cut["status"] == "interrupted"].itertuples():
        if (out / row.folder / "manifest.json").is_file():  # it had started
            assert read_manifest(out / row.folder)["status"] == "interrupted"
    again = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300, check=False)
    assert again.returncode == 0, again.stderr
    assert (pd.read_csv(out / "results.csv")["status"] == "complete").all()


def test_a_run_folder_written_before_a_field_was_added_is_the_same_run(reference, executed):
    """A ``config.toml`` without a field the schema has gained since (at its default) is the
    configuration the sweep would run: its runs are read, not run again."""
    out, res = reference
    folder = out / res["folder"].iloc[0] / "config.toml"
    text = folder.read_text(encoding="utf-8")
    older = "\n".join(line for line in text.splitlines() if not line.startswith("buckets ="))
    assert older != text
    folder.write_text(older + "\n", encoding="utf-8")
    # As the older swarmgames wrote it: its manifest vouches for that config.toml.
    manifest = json.loads((folder.parent / "manifest.json").read_text())
    manifest["files"]["config.toml"] = {
        "bytes": folder.stat().st_size,
        "sha256": hashlib.sha256(folder.read_bytes()).hexdigest(),
    }
    (folder.parent / "manifest.json").write_text(json.dumps(manifest))
    again = swarmgames.sweep(BASE, GRID, SEEDS, jobs=1, out=out)
    assert executed == []
    _same_numbers(again, res)


def test_runs_of_a_sweep_write_no_figures_unless_asked(reference, tmp_path):
    # A small run's figures and animation cost more than its stages: off by default, while
    # the sweep's own figures stay.
    out, res = reference
    for row in res.itertuples():
        names = {p.name for p in (out / row.folder).iterdir()}
        assert "summary.json" in names and not names & {"timeseries.png", "paths.png"}
    base = BASE.with_overrides({"sim.animation": True})
    drawn = swarmgames.sweep(base, None, [0], jobs=1, out=tmp_path / "s", run_figures=True)
    names = {p.name for p in (tmp_path / "s" / drawn.iloc[0]["folder"]).iterdir()}
    assert {"timeseries.png", "paths.png", "animation.gif"} <= names


def test_paired_differences_hold_outcomes_only_and_are_plotted(reference):
    from swarmgames.experiments.sweep.plots import factor_label, plot_metric, plot_paired

    out, res = reference
    paired = pd.read_csv(out / "paired.csv")
    metrics = set(paired["metric"])
    assert "coverage_end_dbm" in metrics
    assert not metrics & {"n_robots", "stages", "wall_s"}
    assert not any(m.endswith("_ms") for m in metrics)
    assert factor_label("swarm.n_robots") == "swarm.n_robots: Number of UAVs"
    assert factor_label("coverage.no_such_field") == "coverage.no_such_field"
    constant = res.assign(coverage_end_dbm=-93.2, median_global_regret=float("nan"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for metric in ("coverage_end_dbm", "median_global_regret"):
            fig = plot_metric(constant, metric)
            FigureCanvasAgg(fig).draw()
            FigureCanvasAgg(plot_paired(paired_differences(constant), metric)).draw()
    assert fig.axes[0].get_xlabel() == "swarm.n_robots: Number of UAVs"


def test_a_run_whose_files_do_not_match_its_manifest_is_run_again_not_aggregated(
    reference, executed
):
    out, res = reference
    folder = out / res["folder"].iloc[1]
    summary = json.loads((folder / "summary.json").read_text())
    key = next(k for k, v in summary.items() if isinstance(v, float))
    honest = summary[key]
    summary[key] = 451.7  # edited by hand
    (folder / "summary.json").write_text(json.dumps(summary))
    again = swarmgames.sweep(BASE, GRID, SEEDS, jobs=1, out=out)
    assert [t.folder for t in executed] == [str(folder.resolve())]
    assert "summary.json does not match the manifest" in again.attrs["rerun"][res["folder"].iloc[1]]
    assert again[key].iloc[1] == honest
    _same_numbers(again, res)
