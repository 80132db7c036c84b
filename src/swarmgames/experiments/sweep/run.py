"""``swarmgames.sweep``: plan a sweep, run what is not finished, write its tables and plots.

The sweep's folder ``DIR`` holds

* ``sweep.json`` (what was asked: the scenario, the factors and their levels, the seeds,
  ``zip``) and the base scenario's ``config.toml``, written before any run;
* ``runs/<name>/``, one run folder per run (what ``swarmgames run`` writes; names from
  :func:`~swarmgames.experiments.sweep.grid.folder_name`);
* ``results.csv``: one row per run, the factors, ``seed``, ``status`` (``complete``,
  ``failed`` or ``interrupted``), ``error``, ``folder`` and the run's summary;
* ``aggregate.csv`` and ``paired.csv`` (:mod:`~swarmgames.experiments.sweep.stats`) and one
  ``<metric>.png`` per plotted figure (:func:`~swarmgames.experiments.sweep.plots.plot_metric`).

Running the same sweep again resumes it: a run whose folder's manifest says ``complete`` and
whose files match the manifest (:func:`~swarmgames.sim.journal.verify_run`) is read, not run;
``running`` or ``interrupted`` ones are continued from their checkpoint
(:func:`swarmgames.resume`; from scratch when they have none) and ``failed`` ones run again.
A folder whose files do not match its manifest is never aggregated: it is run again, and
the reason is reported (``results.attrs["rerun"]``, printed by the command). A run folder
whose ``config.toml`` is not the configuration the sweep would run stops the sweep before
anything runs.
"""

from __future__ import annotations

import difflib
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import pandas as pd

from swarmgames.config import ScenarioConfig, resolve_scenario, to_toml
from swarmgames.config.io import load_config, toml_literal
from swarmgames.errors import ConfigError, RunFolderError
from swarmgames.experiments.sweep.executors import (
    EXECUTORS,
    RunTask,
    default_jobs,
    import_ray,
    run_tasks,
)
from swarmgames.experiments.sweep.grid import SweepPlan, factors_from_mapping, plan_sweep
from swarmgames.experiments.sweep.stats import (
    META,
    aggregate,
    figure_columns,
    paired_differences,
)
from swarmgames.runfolder import RunFolder

__all__ = ["DEFAULT_METRICS", "RUNS", "SWEEP_FILE", "sweep", "write_tables"]

SWEEP_FILE = "sweep.json"
#: The folder of the run folders inside the sweep's folder.
RUNS = "runs"
#: The figure plotted when none is asked for: the first of these the runs have.
DEFAULT_METRICS = ("coverage_end_dbm", "mean_payoff_end")
FORMAT = 1


@dataclass(frozen=True)
class _Found:
    """What a run's folder holds: nothing to reuse, a complete run, or one to continue."""

    kind: Literal["new", "done", "resume"]
    summary: Mapping[str, Any] | None = None
    why: str = ""  # why a folder that held a run is run again


def _same_config(path: Path, config: ScenarioConfig) -> bool:
    """Whether the run folder's ``config.toml`` is ``config``, read with today's schema (a
    field added since, at its default, or a value spelt another way is the same run); True
    when there is no readable file (the folder's manifest then decides)."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return True
    if text == to_toml(config):
        return True
    try:
        return to_toml(load_config(path)) == to_toml(config)
    except ConfigError:
        return False


def _inspect(folder: Path, config: ScenarioConfig) -> _Found:
    from swarmgames.sim.journal import MANIFEST, read_manifest, verify_run

    if not folder.exists():
        return _Found("new")
    if not _same_config(folder / "config.toml", config):
        raise RunFolderError(
            f"{folder} holds a run of another configuration (its config.toml is not the one "
            "this sweep runs there); choose another --out"
        )
    if not (folder / MANIFEST).exists():
        return _Found("new")
    try:
        manifest = read_manifest(folder)
    except RunFolderError as exc:
        return _Found("new", why=str(exc))
    if manifest["status"] == "complete":
        try:
            verify_run(folder, manifest)
            summary = json.loads((folder / "summary.json").read_text("utf-8"))
        except (RunFolderError, OSError, ValueError, RecursionError) as exc:
            return _Found("new", why=str(exc)[:300])
        if not isinstance(summary, dict):
            return _Found("new", why=f"{folder / 'summary.json'} is not a summary")
        return _Found("done", summary)
    if manifest["status"] in ("running", "interrupted") and manifest.get("resumable"):
        return _Found("resume")
    return _Found("new")


def _open_root(out: Path) -> RunFolder:
    if out.is_dir() and not (out / SWEEP_FILE).exists() and any(out.iterdir()):
        raise RunFolderError(
            f"output folder {out} is not empty and holds no sweep (no {SWEEP_FILE}); choose "
            "another --out"
        )
    return RunFolder(out, force=True)


def _cell(value: Any) -> Any:
    """A level as a table cell: scalars as they are, arrays as TOML literals."""
    return toml_literal(value) if isinstance(value, tuple) else value


def _results(plan: SweepPlan, outcomes: Sequence[Mapping[str, Any] | None]) -> pd.DataFrame:
    rows = []
    for point, outcome in zip(plan.points, outcomes, strict=True):
        outcome = outcome or {"status": "interrupted", "error": "", "summary": {}}
        factors = {path: _cell(v) for path, v in point.values}
        summary = {k: v for k, v in outcome["summary"].items() if k not in {*factors, *META}}
        rows.append(
            {
                **factors,
                "seed": point.seed,
                "status": outcome["status"],
                "error": outcome["error"] or None,
                "folder": f"{RUNS}/{point.folder}",
                **summary,
            }
        )
    return pd.DataFrame(rows)


def _plot_name(metric: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", metric) + ".png"


def write_tables(
    folder: RunFolder,
    results: pd.DataFrame,
    zipped: bool = False,
    metrics: Sequence[str] | None = None,
) -> list[Path]:
    """Write ``results.csv``, ``aggregate.csv``, ``paired.csv``, one ``<metric>.png`` per
    metric and, where a factor varies, one ``paired_<metric>.png`` per metric into
    ``folder``.

    Parameters
    ----------
    folder : RunFolder
    results : DataFrame
        A sweep's results table.
    zipped : bool
        Its factors were zipped (:func:`~swarmgames.experiments.sweep.stats.paired_differences`).
    metrics : sequence of str, optional
        The figures to plot (default: the first of :data:`DEFAULT_METRICS` the runs have).

    Raises
    ------
    ConfigError
        A metric that is not a figure of the complete runs (the tables are written first).
    """
    paired = paired_differences(results, zipped)
    written = [
        folder.write_csv("results.csv", results),
        folder.write_csv("aggregate.csv", aggregate(results)),
        folder.write_csv("paired.csv", paired),
    ]
    figures = figure_columns(results) if (results["status"] == "complete").any() else []
    if metrics is None:
        metrics = [m for m in DEFAULT_METRICS if m in figures][:1]
    unknown = [m for m in metrics if m not in figures]
    if unknown and figures:
        close = difflib.get_close_matches(unknown[0], figures, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ConfigError(
            f"metric: must be a summary figure of the runs{hint} (got {unknown[0]!r}; figures: "
            f"{', '.join(figures)}); the tables are written, and the same sweep with another "
            "--metric only redraws the plots"
        )
    from swarmgames.experiments.sweep.plots import plot_metric, plot_paired

    for metric in metrics if figures else []:
        written.append(folder.save_figure(_plot_name(metric), plot_metric(results, metric)))
        if (paired["metric"] == metric).any():
            fig = plot_paired(paired, metric)
            written.append(folder.save_figure(_plot_name(f"paired_{metric}"), fig))
    return written


def _check_options(executor: str, address: str | None, jobs: int | None) -> int:
    if executor not in EXECUTORS:
        raise ConfigError(f"executor: must be one of {', '.join(EXECUTORS)} (got {executor!r})")
    if address is not None and executor != "ray":
        raise ConfigError(
            f"address: is the address of a Ray cluster, for executor 'ray' only (got {address!r})"
        )
    if jobs is None:
        return default_jobs()
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ConfigError(f"jobs: must be an integer >= 1 (got {jobs!r})")
    return jobs


def sweep(
    scenario: str | Path | ScenarioConfig | None = None,
    overrides: Mapping[str, Sequence[Any]] | None = None,
    seeds: Sequence[int] = (0, 1, 2),
    *,
    zip: bool = False,
    jobs: int | None = None,
    executor: Literal["local", "ray"] = "local",
    address: str | None = None,
    out: str | Path,
    progress: bool = False,
    metrics: Sequence[str] | None = None,
    run_figures: bool = False,
) -> pd.DataFrame:
    """Run a scenario over a grid of overrides and seeds, one run folder per run, and write
    the results, their statistics and plots (module notes, docs/sweep.md).

    Parameters
    ----------
    scenario : str, Path or ScenarioConfig, optional
        A built-in scenario's name, a TOML file, or a configuration (default: ``coverage``).
    overrides : dict of str to list, optional
        ``{"section.field": [level, ...]}``: the factors, each with the values it takes
        (Python values, checked like a scenario file's). No overrides: the scenario alone,
        over the seeds.
    seeds : sequence of int, default (0, 1, 2)
        Distinct seeds >= 0; every combination runs once per seed (``seed`` of its config).
    zip : bool, default False
        Pair the i-th levels of every factor (all with the same number of levels, or one)
        instead of crossing them.
    jobs : int, optional
        Runs at once (default: the CPUs this process may use). ``1`` runs in this process.
    executor : {"local", "ray"}, default "local"
        Local processes, or Ray (``pip install 'swarmgames[ray]'``).
    address : str, optional
        Ray cluster to connect to (``ray.init(address=...)``); default: a local Ray of
        ``jobs`` CPUs.
    out : str or Path
        The sweep's folder; the same sweep into the same folder resumes it.
    progress : bool, default False
        Show a progress bar over the runs.
    metrics : sequence of str, optional
        Summary figures to plot (default: ``coverage_end_dbm`` if the runs have it, else
        ``mean_payoff_end``).
    run_figures : bool, default False
        Also write each run's ``timeseries.png``, ``paths.png`` and ``animation.gif`` (they
        cost more than the stages of a small run); the sweep's own figures are written
        either way.

    Returns
    -------
    DataFrame
        The results table (``results.csv``): one row per run, in grid order. If Ctrl-C,
        SIGTERM or SIGHUP stopped the sweep, the runs it did not finish say ``status =
        "interrupted"`` and the tables are written for what finished. ``attrs["rerun"]``
        maps the folder of every run that was run again because its folder did not match its
        manifest (or could not be continued) to the reason.

    Raises
    ------
    ConfigError
        A combination the configuration schema rejects, bad seeds, factors or options; before
        anything is written or run.
    RunFolderError
        ``out`` cannot be written, is a non-empty folder that holds no sweep, or holds a run
        folder of another configuration.
    BackendUnavailableError
        ``executor="ray"`` without Ray installed, or a Ray that cannot be started.

    Examples
    --------
    >>> import swarmgames                                                   # doctest: +SKIP
    >>> df = swarmgames.sweep("coverage", {"swarm.n_robots": [5, 10]}, seeds=[0, 1],
    ...                       jobs=1, out="runs/sweep")                     # doctest: +SKIP
    >>> df.groupby("swarm.n_robots")["coverage_end_dbm"].mean()            # doctest: +SKIP
    """
    jobs = _check_options(executor, address, jobs)
    if metrics is not None and (
        isinstance(metrics, str) or not all(isinstance(m, str) for m in metrics)
    ):
        raise ConfigError(f"metrics: must be a list of figure names (got {metrics!r})")
    base = scenario if isinstance(scenario, ScenarioConfig) else resolve_scenario(scenario)
    plan = plan_sweep(base, factors_from_mapping(overrides), seeds, zip)
    if executor == "ray":
        import_ray()
    root = _open_root(Path(out))  # the sweep folder's lock: one sweep writes it
    try:
        runs = root.path.resolve() / RUNS
        found = [_inspect(runs / p.folder, p.config) for p in plan.points]
        root.write_json(
            SWEEP_FILE,
            {
                "format": FORMAT,
                "scenario": base.name
                if scenario is None or isinstance(scenario, ScenarioConfig)
                else str(scenario),
                "factors": {f.path: [toml_literal(v) for v in f.levels] for f in plan.factors},
                "seeds": list(plan.seeds),
                "zip": plan.zip,
                "runs": len(plan.points),
            },
        )
        root.write_text("config.toml", to_toml(base))
        outcomes: list[Mapping[str, Any] | None] = [
            {"status": "complete", "error": "", "summary": f.summary} if f.kind == "done" else None
            for f in found
        ]
        todo = [i for i, f in enumerate(found) if f.kind != "done"]
        rerun = {f"{RUNS}/{plan.points[i].folder}": f.why for i, f in enumerate(found) if f.why}
        tasks = [
            RunTask(
                str(runs / plan.points[i].folder),
                plan.points[i].config,
                found[i].kind == "resume",
                figures=run_figures,
            )
            for i in todo
        ]
        from swarmgames.sim.progress import ProgressBar

        finished = len(plan.points) - len(todo)
        label = f"sweep ({finished} of {len(plan.points)} runs already complete)"
        with ProgressBar(label, progress, total=len(plan.points)) as tick:
            if tick is not None:
                tick(finished)

            def on_done(k: int, outcome: Mapping[str, Any]) -> None:
                nonlocal finished
                outcomes[todo[k]] = outcome
                if outcome.get("note"):
                    rerun[f"{RUNS}/{plan.points[todo[k]].folder}"] = outcome["note"]
                finished += 1
                if tick is not None:
                    tick(finished)

            run_tasks(tasks, on_done, jobs=jobs, executor=executor, address=address)
        results = _results(plan, outcomes)
        results.attrs["rerun"] = rerun
        write_tables(root, results, plan.zip, metrics)
        return results
    finally:
        root.close()
