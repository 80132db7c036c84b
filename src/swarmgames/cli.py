"""The ``swarmgames`` command line: a thin layer over the Python API.

Exit codes: 0 success, 1 the run failed (or the capability is not available), 2 usage or
configuration error (bad option, invalid scenario file, unknown name, existing output folder),
130 interrupted by Ctrl-C, SIGTERM or SIGHUP (a run keeps and writes its completed stages).
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

import click

from swarmgames import __version__
from swarmgames.allocator import reuse_freed_memory
from swarmgames.errors import (
    ConfigError,
    InputDataError,
    RunFolderError,
    SwarmgamesError,
)
from swarmgames.names import BACKENDS, COMMS_MODELS

__all__ = ["cli", "main", "script"]

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2

#: Errors that mean "the user asked for something invalid" (exit 2); all other
#: SwarmgamesErrors mean "the run failed" (exit 1).
_USAGE_ERRORS = (ConfigError, InputDataError, RunFolderError)


def _fail(exc: BaseException) -> NoReturn:
    code = EXIT_USAGE if isinstance(exc, _USAGE_ERRORS) else EXIT_FAILED
    click.secho(f"Error: {exc}", fg="red", err=True)
    sys.exit(code)


def _guarded(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Turn swarmgames errors into a one-line message and the documented exit code."""
    import functools

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except SwarmgamesError as exc:
            _fail(exc)
        except KeyboardInterrupt:
            click.secho("Interrupted; files already written are complete.", err=True)
            sys.exit(130)

    return wrapper


def _interactive() -> bool:
    return sys.stderr.isatty()


def _progress(description: str, enabled: bool):
    from swarmgames.sim.progress import ProgressBar

    return ProgressBar(description, enabled)


def _console():
    from rich.console import Console

    return Console()


def _open_run_folder(out: Path | None, default_name: str, force: bool):
    from swarmgames.runfolder import RunFolder

    return RunFolder(out if out is not None else Path("runs") / default_name, force=force)


def _parse_integers(text: str, option: str, minimum: int, what: str) -> list[int]:
    """The integers of ``option N,N,...``; a one-line error (exit 2) unless they are all
    ``>= minimum``."""
    try:
        chosen = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        chosen = []
    if not chosen or min(chosen) < minimum:
        raise ConfigError(f"{option}: must be comma-separated {what} >= {minimum} (got {text!r})")
    return chosen


def _parse_seeds(text: str) -> list[int]:
    """The seeds of ``--seeds S,S,...``; a usage error (exit 2) unless they are integers >= 0."""
    return _parse_integers(text, "--seeds", 0, "seeds")


out_option = click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Output folder (default: runs/<name>/).",
)
force_option = click.option(
    "--force", is_flag=True, help="Write into an existing non-empty output folder."
)
set_option = click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="SECTION.FIELD=VALUE",
    help="Override a configuration field, e.g. --set swarm.n_robots=20 (repeatable).",
)


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="swarmgames")
def cli() -> None:
    """Decentralised UAV swarm control with graphical games over time-varying networks.

    Each UAV reads its neighbourhood from its own (OLSR) routing table, solves its local
    graphical game by mean-field inference and acts; swarmgames measures payoff, coverage,
    equilibrium quality, communication and compute cost. Start with `swarmgames run`.
    """


# ----------------------------------------------------------------------------- run


@cli.command()
@click.argument("scenario", required=False)
@out_option
@force_option
@set_option
@click.option("--seed", type=click.IntRange(min=0), default=None, help="Override the seed.")
@click.option(
    "--resume",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    metavar="DIR",
    help="Continue the interrupted run in DIR from its last checkpoint (no SCENARIO, --set, "
    "--seed, --out or --force).",
)
@click.option("--no-progress", is_flag=True, help="Do not show a progress bar.")
@_guarded
def run(
    scenario: str | None,
    out: Path | None,
    force: bool,
    overrides: tuple[str, ...],
    seed: int | None,
    resume: Path | None,
    no_progress: bool,
) -> None:
    """Run a mission: SCENARIO is a built-in name (default: coverage) or a TOML file.

    Writes config.toml, trajectory.csv, metrics.csv, swarm.csv, manifest.json, plots, an
    animation and summary.json into the run folder, and prints a summary. The tables grow
    stage by stage: whatever stops a run, its completed stages are kept, and --resume DIR
    continues it to the end, bit for bit as if it had never stopped.

    \b
    Examples:
      swarmgames run
      swarmgames run coverage-oracle --seed 3 --out runs/oracle
      swarmgames run my.toml --set swarm.n_robots=20 --set game.solver=best_response
      swarmgames run --resume runs/coverage
    """
    from swarmgames.config import resolve_scenario
    from swarmgames.sim import resume as resume_run
    from swarmgames.sim import run as run_mission

    show = not no_progress and _interactive()
    if resume is not None:
        given = [
            name
            for name, value in (
                ("SCENARIO", scenario),
                ("--set", overrides),
                ("--seed", seed is not None),
                ("--out", out),
                ("--force", force),
            )
            if value
        ]
        if given:
            raise click.UsageError(
                f"--resume continues a run with the configuration it started with; "
                f"{', '.join(given)} cannot be given with it"
            )
        result = resume_run(resume, progress=show)
        folder = result.folder
    else:
        extra = (*overrides, f"seed={seed}") if seed is not None else overrides
        _report_broken_plugins()
        config = resolve_scenario(scenario, extra)  # validated before the folder is created
        folder = _open_run_folder(out, config.name, force)
        try:
            result = run_mission(config, out=folder, progress=show)
        except BaseException:
            folder.discard_if_empty()  # only the folders this run created, and only if empty
            raise
    _console().print(result.summary_table())
    click.echo(f"Wrote {len(folder.written)} files to {folder.path}/")
    if result.interrupted:
        click.secho(
            "Interrupted: the completed stages were written; continue with "
            f"`swarmgames run --resume {folder.path}`.",
            err=True,
        )
        sys.exit(130)


# ----------------------------------------------------------------------------- reproduce

FIGURES = (
    "fig1",
    "fig2",
    "fig2-scale",
    "coverage-scale",
    "comms",
    "comms-cost",
    "comms-ns3",
    "all",
)


@cli.command()
@click.argument("figure", type=click.Choice(FIGURES))
@out_option
@force_option
@set_option
@click.option(
    "--backend",
    type=click.Choice(["olsr", "oracle", "ns3"]),
    default="olsr",
    show_default=True,
    help="Network backend of Figure 1.",
)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option(
    "--seeds",
    default=None,
    metavar="S,S,...",
    help="Seeds of every variant of `comms` (default 0,1,2), `fig2-scale` and "
    "`coverage-scale` (default 0-4).",
)
@click.option(
    "--sizes",
    default=None,
    metavar="N,N,...",
    help="Swarm sizes of `fig2-scale` (default 10,20,50,100,200,500,1000) and "
    "`coverage-scale` (default 7,100,1000,10000).",
)
@click.option(
    "--variants",
    default=None,
    metavar="V,V,...",
    help="game.virtual_mean settings of `fig2-scale` (default eq3,outside,exact,off); "
    "controllers of `coverage-scale` (default game,game-nolink,lloyd).",
)
@click.option(
    "--jobs",
    type=click.IntRange(min=1),
    default=None,
    help="Runs of `fig2-scale` and `coverage-scale` at once (default: the CPU count).",
)
@click.option(
    "--executor",
    type=click.Choice(["local", "ray"]),
    default="local",
    show_default=True,
    help="Where `fig2-scale` and `coverage-scale` run: local processes, or Ray.",
)
@click.option("--address", default=None, metavar="ADDR", help="Ray cluster (--executor ray).")
@click.option("--no-progress", is_flag=True, help="Do not show a progress bar.")
@_guarded
def reproduce(
    figure: str,
    out: Path | None,
    force: bool,
    overrides: tuple[str, ...],
    backend: str,
    seed: int,
    seeds: str | None,
    sizes: str | None,
    variants: str | None,
    jobs: int | None,
    executor: str,
    address: str | None,
    no_progress: bool,
) -> None:
    """Reproduce the paper's figures.

    \b
    fig1  average direct neighbours and hop count of 7 UAVs (line and hexagon)
          against their spacing, read from settled OLSR tables
    fig2  (a) average payoff of a robot against time for 3, 5, 7, 10 and 20 UAVs,
          with and without virtual mean neighbours; (b) local-game solve time and
          payoff-integration time against swarm size; with ideal delivery, as in the
          paper (--set comms.model=routed for routed state messages)
    comms coverage, regret, settling, information age and bytes of the default
          scenario with ideal delivery, routed delivery at 0-50 % loss and routed
          delivery with 1 and 2 robots crashing at mid-mission, over --seeds
    comms-cost  payload bytes per robot and stage of local games, a centralised
          controller and swarm-wide flooding for N = 10 ... 10 000, over --seeds
    comms-ns3  delivery ratio and age on arrival by hop count of the built-in routed
          flooding and of UDP packets in ns-3, and OLSR's control traffic as the
          built-in model counts it and as ns-3 sends it, on the recorded static_20
          and waypoint_20 traces, ns-3 runs --seeds + 1 (needs ns-3)
    fig2-scale  virtual mean neighbours at scale: the fig2-scale scenario (constant
          density, neighbourhoods of 3 hops and more) for --sizes x --variants x
          --seeds on the sweep machinery, resumable; results, aggregate (95 %
          intervals) and paired tables, figures against N (docs/results.md)
    coverage-scale  the coverage-large preset at constant density for --sizes
          (default 7,100,1000,10000) x --seeds under the game, the game without
          its link term (coverage.link_term = "off") and Lloyd, on the sweep machinery,
          resumable; coverage, components, links lost, hops, stage time and bytes
          per run, aggregate and paired tables, coverage-scale.png (docs/results.md)
    all   fig1 and fig2, into OUT/fig1 and OUT/fig2

    --set overrides apply to the scenario the figures start from (fig2-scale: to the
    fig2-scale scenario, before it is rescaled to each size; coverage-scale: to the
    coverage-large preset, before each size and variant).
    """
    from swarmgames.config import resolve_scenario

    if figure == "fig2-scale":
        _reproduce_fig2_scale(
            out, overrides, seeds, sizes, variants, jobs, executor, address, no_progress
        )
        return
    if figure == "coverage-scale":
        _reproduce_coverage_scale(
            out, overrides, seeds, sizes, variants, jobs, executor, address, no_progress
        )
        return
    base = resolve_scenario(None, overrides)
    root = out if out is not None else Path("runs") / ("figures" if figure == "all" else figure)
    if figure == "all":
        folders = {f: _open_run_folder(root / f, f, force) for f in ("fig1", "fig2")}
    else:
        folders = {figure: _open_run_folder(root, figure, force)}
    progress = not no_progress and _interactive()
    if "fig1" in folders:
        from swarmgames.experiments.fig1 import reproduce_fig1

        with _progress(f"Figure 1 ({backend})", progress) as tick:
            res1 = reproduce_fig1(
                backend, seed=seed, config=base.network, out=folders["fig1"], progress=tick
            )
        for layout, steps in res1.steps().items():
            where = ", ".join(f"{a:g}/{b:g}" for a, b in steps)
            click.echo(f"Figure 1, {layout}: direct neighbours change between {where} m")
        click.echo(
            f"Figure 1 ({backend}): {len(res1.to_frame())} points -> {folders['fig1'].path}/"
        )
    if "fig2" in folders:
        from swarmgames.experiments.fig2 import reproduce_fig2

        ideal = resolve_scenario(None, ("comms.model='ideal'", *overrides))  # the paper's
        res2 = reproduce_fig2(base=ideal, seed=seed, progress=progress)
        res2.write(folders["fig2"])
        click.echo(f"Figure 2: {len(res2.summaries)} runs -> {folders['fig2'].path}/")
    if folders.keys() & {"comms", "comms-cost", "comms-ns3"}:
        chosen = _parse_seeds(seeds or "0,1,2")
    if "comms-cost" in folders:
        from swarmgames.experiments.comms_cost import comms_cost

        res4 = comms_cost(seeds=chosen)
        res4.write(folders["comms-cost"])
        click.echo(f"Communication cost: {len(res4.frame)} rows -> {folders['comms-cost'].path}/")
    if "comms-ns3" in folders:
        from swarmgames.experiments.comms_ns3 import compare_control_traffic, compare_delivery

        c = base.comms
        res5 = compare_delivery(
            runs=[k + 1 for k in chosen],
            hops=base.network.hops,
            jitter_s=c.jitter_s,
            hop_delay_s=c.hop_delay_s,
            decide_after_s=c.decide_after_s,
        )
        res5.write(folders["comms-ns3"])
        res6 = compare_control_traffic(runs=[k + 1 for k in chosen])
        res6.write(folders["comms-ns3"])
        click.echo(
            f"Delivery and OLSR traffic, built-in and ns-3: {len(res5.frame)} + "
            f"{len(res6.frame)} rows -> {folders['comms-ns3'].path}/"
        )
    if "comms" in folders:
        from swarmgames.experiments.comms import reproduce_comms

        res3 = reproduce_comms(base=base, seeds=chosen, progress=progress)
        res3.write(folders["comms"])
        click.echo(f"Communication: {len(res3.runs)} runs -> {folders['comms'].path}/")


def _reproduce_fig2_scale(
    out, overrides, seeds, sizes, variants, jobs, executor, address, no_progress
) -> None:
    from swarmgames.config import resolve_scenario
    from swarmgames.experiments import fig2_scale
    from swarmgames.experiments.sweep import factors_from_assignments

    if address is not None and executor != "ray":
        raise click.UsageError("--address is the address of a Ray cluster: give --executor ray")
    root = out if out is not None else Path("runs") / "fig2-scale"
    base = resolve_scenario(fig2_scale.SCENARIO, overrides)
    chosen = {
        "sizes": fig2_scale.DEFAULT_SIZES
        if sizes is None
        else _parse_integers(sizes, "--sizes", 1, "swarm sizes"),
        "seeds": (0, 1, 2, 3, 4) if seeds is None else _parse_seeds(seeds),
        "variants": fig2_scale.VARIANTS
        if variants is None
        else factors_from_assignments([f"{fig2_scale.VARIANT_COLUMN}={variants}"])[
            fig2_scale.VARIANT_COLUMN
        ],
    }
    res = _run_study("fig2-scale", fig2_scale.reproduce_fig2_scale, root, chosen, base,
                     jobs, executor, address, no_progress)  # fmt: skip
    _report_runs(res.results, root, ["coverage_end_dbm"], "fig2-scale")


def _reproduce_coverage_scale(
    out, overrides, seeds, sizes, variants, jobs, executor, address, no_progress
) -> None:
    from swarmgames.config import resolve_scenario
    from swarmgames.experiments import coverage_scale

    if address is not None and executor != "ray":
        raise ConfigError(f"--address: is a Ray cluster's, for --executor ray (got {address!r})")
    root = out if out is not None else Path("runs") / "coverage-scale"
    chosen = {
        "sizes": coverage_scale.DEFAULT_SIZES
        if sizes is None
        else _parse_integers(sizes, "--sizes", 1, "swarm sizes"),
        "seeds": (0, 1, 2, 3, 4) if seeds is None else _parse_seeds(seeds),
        "variants": coverage_scale.VARIANTS
        if variants is None
        else [v.strip() for v in variants.split(",")],
    }
    base = resolve_scenario(coverage_scale.SCENARIO, overrides)
    res = _run_study("coverage-scale", coverage_scale.reproduce_coverage_scale, root, chosen,
                     base, jobs, executor, address, no_progress)  # fmt: skip
    _report_runs(res.runs, root, list(coverage_scale.HEADLINE), "coverage-scale")


def _run_study(name, reproduce, root, chosen, base, jobs, executor, address, no_progress):
    """``reproduce(root, **chosen, ...)`` of a study over sizes × seeds × variants, with a
    progress bar when interactive; returns its result."""
    total = len(chosen["sizes"]) * len(chosen["seeds"]) * len(chosen["variants"])
    with _progress(f"{name} ({total} runs)", not no_progress and _interactive()) as tick:
        return reproduce(root, **chosen, base=base, jobs=jobs, executor=executor,
                         address=address, progress=tick)  # fmt: skip


# ----------------------------------------------------------------------------- sweep


@cli.command()
@click.argument("scenario", required=False)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="SECTION.FIELD=V1,V2,...",
    help="A factor and its values (repeatable): TOML values as in `run --set`, split at the "
    "commas outside brackets and quotes, e.g. --set 'faults.crash=[[5.0,1]],[]'.",
)
@click.option(
    "--seeds", default="0,1,2", show_default=True, metavar="S,S,...", help="Seeds of every point."
)
@click.option(
    "--zip",
    "zipped",
    is_flag=True,
    help="Pair the i-th values of every --set instead of crossing them (same counts, or one).",
)
@click.option(
    "--jobs",
    type=click.IntRange(min=1),
    default=None,
    help="Runs at once (default: the CPU count; 1 runs in this process).",
)
@click.option(
    "--executor",
    type=click.Choice(["local", "ray"]),
    default="local",
    show_default=True,
    help="Local processes, or Ray (pip install 'swarmgames[ray]').",
)
@click.option(
    "--address",
    default=None,
    metavar="ADDR",
    help="Ray cluster to connect to (--executor ray; default: a local Ray of --jobs CPUs).",
)
@click.option(
    "--out",
    required=True,
    type=click.Path(file_okay=False, path_type=Path),
    help="The sweep's folder; the same command again resumes it.",
)
@click.option(
    "--metric",
    "metrics",
    multiple=True,
    metavar="NAME",
    help="Summary figure to plot (repeatable; default: coverage_end_dbm, else mean_payoff_end).",
)
@click.option(
    "--run-figures",
    is_flag=True,
    help="Also write every run's timeseries.png, paths.png and animation.gif (off: the "
    "runs' tables and summaries, and the sweep's own figures).",
)
@click.option("--no-progress", is_flag=True, help="Do not show a progress bar.")
@_guarded
def sweep(
    scenario: str | None,
    overrides: tuple[str, ...],
    seeds: str,
    zipped: bool,
    jobs: int | None,
    executor: str,
    address: str | None,
    out: Path,
    metrics: tuple[str, ...],
    run_figures: bool,
    no_progress: bool,
) -> None:
    """Run SCENARIO (a built-in name or a TOML file; default: coverage) over the grid of the
    --set values times the --seeds, one run folder per run.

    Every combination is checked against the configuration schema before the first run.
    Writes into OUT: sweep.json, the base config.toml, runs/<name>/ (run folders as `run`
    writes them, without figures unless --run-figures), results.csv (one row per run: the
    factors, the seed, status, error, the run's summary), aggregate.csv (per combination
    and figure: n, mean, std, 95 % interval), paired.csv (each level minus a factor's first
    level on the same seeds) and a plot per --metric. A failed run is recorded with its
    error and the sweep goes on. The same command again resumes: complete runs are read,
    interrupted ones continued, failed ones
    rerun. Exit 1 if a run failed, 130 if interrupted.

    \b
    Examples:
      swarmgames sweep --set swarm.n_robots=5,7,10 --seeds 0,1,2 --out runs/size
      swarmgames sweep coverage-oracle --set comms.loss_rate=0.0,0.2 \\
          --set network.backend=olsr,oracle --jobs 2 --out runs/loss
      swarmgames sweep --set swarm.n_robots=5,10 --set game.beta=1.0,2.0 --zip --out runs/z
      swarmgames sweep --set 'faults.crash=[],[[30.0,0]]' --metric median_global_regret \\
          --out runs/crash
      swarmgames sweep --executor ray --address auto --set swarm.n_robots=10,20 --out /shared/s
    """
    from swarmgames.experiments.sweep import factors_from_assignments
    from swarmgames.experiments.sweep import sweep as run_sweep

    if address is not None and executor != "ray":
        raise click.UsageError("--address is the address of a Ray cluster: give --executor ray")
    chosen = _parse_seeds(seeds)
    results = run_sweep(
        scenario,
        factors_from_assignments(overrides),
        chosen,
        zip=zipped,
        jobs=jobs,
        executor=executor,
        address=address,
        out=out,
        progress=not no_progress and _interactive(),
        metrics=list(metrics) or None,
        run_figures=run_figures,
    )
    _report_runs(results, out, list(metrics), "swarmgames sweep")


def _report_runs(results, out: Path, metrics: list[str], title: str) -> None:
    """Print a sweep's table and counts, the first failures, and exit 130 if it was
    interrupted, 1 if a run failed."""
    _console().print(_sweep_table(results, metrics, title))
    counts = results["status"].value_counts()
    click.echo(
        f"{len(results)} runs: "
        + ", ".join(f"{counts.get(s, 0)} {s}" for s in ("complete", "failed", "interrupted"))
        + f" -> {out}/"
    )
    for folder, why in results.attrs.get("rerun", {}).items():
        click.secho(f"run again: {folder}: {why}", fg="yellow", err=True)
    failed = results[results["status"] == "failed"]
    for _, row in failed.head(5).iterrows():
        click.secho(f"failed: {row['folder']}: {row['error']}", fg="red", err=True)
    if counts.get("interrupted", 0):
        click.secho(
            "Interrupted: the finished runs are kept and the tables written; run the same "
            "command again to resume.",
            err=True,
        )
        sys.exit(130)
    if len(failed):
        sys.exit(EXIT_FAILED)


def _estimate(mean: float, low: float, high: float) -> str:
    """``mean [low, high]``, the interval left out where it is undefined (one run)."""
    import math

    return f"{mean:.4g}" if math.isnan(low) else f"{mean:.4g} [{low:.4g}, {high:.4g}]"


def _sweep_table(results, metrics: list[str], title: str):
    """Mean and 95 % interval of the plotted metrics per combination, as a rich Table."""
    from rich.table import Table

    from swarmgames.experiments.sweep import aggregate
    from swarmgames.experiments.sweep.run import DEFAULT_METRICS
    from swarmgames.experiments.sweep.stats import factor_columns, varied_factors

    agg = aggregate(results)
    shown = metrics or [m for m in DEFAULT_METRICS if m in set(agg["metric"])][:1]
    factors, varied = factor_columns(results), varied_factors(results)
    table = Table(title=f"{title}: mean [95 % interval] over the seeds")
    for col in (*varied, "n", *shown):
        table.add_column(col, justify="right")
    rows = agg[agg["metric"].isin(shown)]
    for key, group in rows.groupby(factors, sort=False) if factors else [((), rows)]:
        levels = dict(zip(factors, key, strict=True))
        cells = {r.metric: _estimate(r.mean, r.ci_low, r.ci_high) for r in group.itertuples()}
        table.add_row(
            *(str(levels[c]) for c in varied),
            str(group["n"].max()),
            *(cells.get(m, "") for m in shown),
        )
    return table


# ----------------------------------------------------------------------------- network


@cli.group()
def network() -> None:
    """Replay position traces through the network layer and compare backends."""


positions_option = click.option(
    "--positions",
    required=True,
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="CSV with columns t,node,x,y,z (metres, seconds); a row holds until the node's next.",
)
sample_option = click.option(
    "--sample-every",
    type=click.FloatRange(min=0, min_open=True),
    default=0.5,
    show_default=True,
    help="Sampling interval of the routing tables, seconds.",
)


seeds_option = click.option(
    "--seed",
    "seeds",
    type=click.IntRange(min=0, max=2**31 - 2),
    multiple=True,
    default=(0,),
    show_default=True,
    help="Seed of the run; repeat it for several runs (their files go into seed-<SEED>/).",
)


def _each_seed(folder, seeds: tuple[int, ...], one) -> None:
    """``one(seed, run_folder) -> (summary line, failure)`` for every seed: with one seed into
    ``folder`` itself, with several into ``folder/seed-<SEED>/``, listed in ``runs.csv``.

    A run whose ns-3 aborted (``failure``: the one-line reason) has written what it
    completed; it is reported in one line and the other seeds go on. Exit 1 if one failed.
    """
    from swarmgames.runfolder import RunFolder

    seeds = tuple(dict.fromkeys(seeds))
    rows, failed = [], 0
    for seed in seeds:
        sub = folder if len(seeds) == 1 else RunFolder(folder.path / f"seed-{seed}")
        try:
            line, failure = one(seed, sub)
        finally:
            if sub is not folder:
                sub.close()
        click.echo(line)
        if failure is not None:
            failed += 1
            prefix = "Error" if len(seeds) == 1 else f"failed: seed {seed}"
            click.secho(f"{prefix}: {failure}", fg="red", err=True)
        rows.append(
            {
                "seed": seed,
                "folder": "." if sub is folder else f"seed-{seed}",
                "status": "complete" if failure is None else "failed",
                "error": failure or "",
            }
        )
    if len(seeds) > 1:
        import pandas as pd

        folder.write_csv("runs.csv", pd.DataFrame(rows))
    if failed:
        sys.exit(EXIT_FAILED)


def _check_sampling(trace, sample_every: float) -> None:
    """--sample-every bounded before anything is allocated (a 1 ns period over an hour)."""
    from swarmgames.experiments.replay import check_sampling

    try:
        check_sampling(trace, sample_every)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--sample-every") from None


@network.command()
@positions_option
@click.option("--backend", type=click.Choice(BACKENDS), default="olsr", show_default=True)
@sample_option
@seeds_option
@out_option
@force_option
@set_option
@click.option("--no-progress", is_flag=True, help="Do not show a progress bar.")
@_guarded
def replay(
    positions: Path,
    backend: str,
    sample_every: float,
    seeds: tuple[int, ...],
    out: Path | None,
    force: bool,
    overrides: tuple[str, ...],
    no_progress: bool,
) -> None:
    """Replay a positions trace and write every robot's hop counts (hops.csv), a per-time
    summary (summary.csv) and a plot.

    Radio and OLSR parameters come from the default scenario, changed with --set, e.g.
    --set network.radio.tx_power_dbm=20. With several --seed, each seed's files go into
    seed-<SEED>/ and runs.csv lists the runs; a run whose ns-3 aborts keeps its samples, is
    reported in one line, and the others go on (exit 1).
    """
    from swarmgames.config import resolve_scenario
    from swarmgames.experiments.replay import replay as replay_trace
    from swarmgames.network.trace import read_positions

    cfg = resolve_scenario(None, overrides).network
    trace = read_positions(positions)  # validate before creating the folder
    _check_sampling(trace, sample_every)
    folder = _open_run_folder(out, f"replay-{positions.stem}", force)

    def one(seed: int, sub) -> tuple[str, str | None]:
        with _progress(f"replay ({backend})", not no_progress and _interactive()) as tick:
            res = replay_trace(
                trace,
                backend,
                sample_every=sample_every,
                seed=seed,
                config=cfg,
                out=sub,
                progress=tick,
            )
        s = res.summary
        line = (
            f"{backend}: {trace.n_robots} robots, {len(s)} samples, {len(res.hops)} routes; "
            f"mean degree {s['mean_degree'].mean():.3f}, mean hops {s['mean_hops'].mean():.3f} "
            f"-> {sub.path}/"
        )
        return line, res.failure

    _each_seed(folder, seeds, one)


@network.command()
@positions_option
@click.option(
    "--backends",
    default="olsr,ns3",
    show_default=True,
    help="Comma-separated backends to compare.",
)
@sample_option
@click.option(
    "--warmup",
    type=click.FloatRange(min=0),
    default=0.0,
    show_default=True,
    help="Leave samples before this many seconds out of the agreement.",
)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@out_option
@force_option
@set_option
@_guarded
def compare(
    positions: Path,
    backends: str,
    sample_every: float,
    warmup: float,
    seed: int,
    out: Path | None,
    force: bool,
    overrides: tuple[str, ...],
) -> None:
    """Run several backends on the same trace and report how far their routing tables agree.

    The first backend is the reference. Writes per_time.csv, confusion.csv, hops_<backend>.csv,
    agreement.png and summary.json. A backend whose ns-3 aborts is reported and left out, the
    others are compared (exit 1).
    """
    from swarmgames.config import resolve_scenario
    from swarmgames.experiments.compare import compare as compare_backends
    from swarmgames.network.trace import read_positions

    names = [b.strip() for b in backends.split(",") if b.strip()]
    unknown = [b for b in names if b not in BACKENDS]
    if unknown or len(names) < 2:
        raise click.BadParameter(
            f"must name at least two of {', '.join(BACKENDS)} (got {backends!r})",
            param_hint="--backends",
        )
    cfg = resolve_scenario(None, overrides).network
    trace = read_positions(positions)
    _check_sampling(trace, sample_every)
    folder = _open_run_folder(out, f"compare-{positions.stem}", force)
    res = compare_backends(
        trace, names, sample_every=sample_every, config=cfg, seed=seed, warmup_s=warmup
    )
    res.write(folder)
    summary = res.summary()
    from rich.table import Table

    table = Table(title=f"agreement with {summary['reference']} ({trace.n_robots} robots)")
    for col in ("backend", "all entries", "within 2 hops", "entries", "wall time (s)"):
        table.add_column(col, justify="right")
    for name in res.backends:
        agree = summary["agreement"].get(name)
        table.add_row(
            name,
            "reference" if agree is None else f"{100 * agree['overall']:.2f} %",
            "" if agree is None else f"{100 * agree['within_2_hops']:.2f} %",
            "" if agree is None else str(agree["entries"]),
            f"{summary['wall_time_s'][name]:.2f}",
        )
    _console().print(table)
    click.echo(f"Wrote {folder.path}/")
    for name, why in res.failed.items():
        click.secho(f"failed: {name}: {why}", fg="red", err=True)
    if res.failed:
        sys.exit(EXIT_FAILED)


# ----------------------------------------------------------------------------- bench


@cli.command()
@click.option("--quick", is_flag=True, help="N = 10, 100, 1 000 and no ns-3 (under two minutes).")
@click.option(
    "--sizes",
    default=None,
    metavar="N,N,...",
    help="Swarm sizes of the full-stage benchmark (default 10,100,1000,10000).",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Threads of the payoff integration (default: 2 on machines with two cores or more).",
)
@click.option(
    "--takeoff",
    type=click.IntRange(min=0, max=100_000),
    default=300,
    show_default=True,
    help="Robots of the default-scenario take-off benchmarks (0 = none); the dense cases, every "
    "robot within range (the default scenario's and the float32 dense_stage of the targets), "
    "run without --quick.",
)
@click.option(
    "--mission",
    type=click.IntRange(min=0, max=100_000),
    default=None,
    help="Robots of the whole-mission benchmark (swarmgames run coverage-large with every "
    "output; default 1000, none with --quick; 0 = none).",
)
@click.option(
    "--env/--no-env",
    "env",
    default=None,
    help="The learning environment's throughput against PettingZoo's MPE (default: when the "
    "env extra is installed).",
)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@out_option
@force_option
@_guarded
def bench(
    quick: bool,
    sizes: str | None,
    workers: int | None,
    takeoff: int,
    mission: int | None,
    env: bool | None,
    seed: int,
    out: Path | None,
    force: bool,
) -> None:
    """Time payoff integration, local-game solving, full stages at constant density and the
    OLSR advance against swarm size, with batched / one-by-one and built-in OLSR / ns-3 ratios,
    the learning environment against PettingZoo's MPE, and (without --quick) a whole
    1 000-UAV mission with every output.

    Writes bench.json, bench.csv and bench.png (cost against N on log-log axes with the fitted
    slope) and prints a table.
    """
    from swarmgames.bench import run_suite

    parsed = None if sizes is None else _parse_integers(sizes, "--sizes", 1, "robot counts")
    folder = _open_run_folder(out, "bench", force)
    result = run_suite(
        quick,
        folder,
        progress=True,
        sizes=parsed,
        seed=seed,
        workers=workers,
        takeoff=takeoff,
        mission=mission,
        env=env,
    )
    _console().print(result.table())
    click.echo(f"Wrote {folder.path}/")


# ----------------------------------------------------------------------------- learn


@cli.command()
@click.argument("scenario", default="coverage")
@set_option
@click.option(
    "--envs",
    type=click.IntRange(min=1, max=4096),
    default=16,
    show_default=True,
    help="Swarms stepped together (E); the policy learns from all E x N robots.",
)
@click.option(
    "--reward",
    type=click.Choice(["payoff", "team", "difference"]),
    default="difference",
    show_default=True,
    help="Each robot's reward (docs/env.md).",
)
@click.option(
    "--minutes",
    type=click.FloatRange(min=0.0, min_open=True),
    default=30.0,
    show_default=True,
    help="Wall-clock training budget.",
)
@click.option(
    "--agent-steps",
    type=click.IntRange(min=1),
    default=None,
    help="Stop after this many agent-steps instead, if sooner.",
)
@click.option(
    "--eval-seeds",
    default="100,101,102,103,104",
    show_default=True,
    metavar="S,S,...",
    help="Seeds of the evaluation episodes.",
)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@out_option
@force_option
@_guarded
def learn(
    scenario: str,
    overrides: tuple[str, ...],
    envs: int,
    reward: str,
    minutes: float,
    agent_steps: int | None,
    eval_seeds: str,
    seed: int,
    out: Path | None,
    force: bool,
) -> None:
    """Train PPO (stable-baselines3, one policy shared by every robot) on the vector
    environment of SCENARIO (default: coverage with 7 UAVs for 30 stages, the recipe of
    docs/env.md), then fly a random policy, the game controller and the trained policy on
    the evaluation seeds.

    Writes model.zip, normalize.pkl, curve.csv (agent-steps and mean episode reward
    against time), evaluation.csv (return and the mission's metric per policy and seed)
    and summary.json, and prints the comparison. Needs the rl extra (pip install
    "swarmgames[rl]").
    """
    import pandas as pd

    seeds = _parse_integers(eval_seeds, "--eval-seeds", 0, "seeds")
    from swarmgames.env.recipe import compare, recipe_config, train_ppo

    config = recipe_config(scenario, overrides)  # every override checked before training
    folder = _open_run_folder(out, "learn", force)
    console = _console()

    def say(wall, steps, mean):
        console.print(
            f"[dim]learn[/dim] {wall:6.0f} s  {steps:>10,} agent-steps  reward {mean:.4g}"
        )

    trained = train_ppo(
        config,
        num_envs=envs,
        reward=reward,
        minutes=minutes,
        agent_steps=agent_steps,
        seed=seed,
        progress=say,
    )
    trained.save(folder.path)
    folder.write_csv(
        "curve.csv", pd.DataFrame(trained.curve, columns=["wall_s", "agent_steps", "mean_reward"])
    )
    rows = pd.DataFrame(compare(trained, config, seeds=seeds, reward=reward))
    folder.write_csv("evaluation.csv", rows)
    metric = next(c for c in rows.columns if c not in ("policy", "seed", "return"))
    table = rows.groupby("policy", sort=False).agg(["mean", "std"])
    summary = {
        "scenario": scenario,
        "overrides": list(overrides),
        "envs": envs,
        "reward": reward,
        "agent_steps": trained.agent_steps,
        "train_s": trained.wall_s,
        "metric": metric,
        "policies": {
            p: {"return": [float(r["return"]["mean"]), float(r["return"]["std"])],
                metric: [float(r[metric]["mean"]), float(r[metric]["std"])]}
            for p, r in table.iterrows()
        },
    }  # fmt: skip
    folder.write_json("summary.json", summary)
    for name, stats in summary["policies"].items():
        ret, val = stats["return"], stats[metric]
        click.echo(
            f"{name:8s} return {ret[0]:10.4g} ± {ret[1]:.3g}   {metric} {val[0]:.2f} ± {val[1]:.2f}"
        )
    click.echo(
        f"trained {trained.agent_steps:,} agent-steps in {trained.wall_s:.0f} s; "
        f"wrote {folder.path}/"
    )


# ----------------------------------------------------------------------------- config


@cli.group()
def config() -> None:
    """Show and check scenario configurations."""


@config.command("show")
@click.argument("scenario", required=False)
@set_option
@click.option(
    "--annotated", is_flag=True, help="Comment every field with its unit and allowed range."
)
@_guarded
def config_show(scenario: str | None, overrides: tuple[str, ...], annotated: bool) -> None:
    """Print the resolved configuration of SCENARIO (a built-in name or a TOML file; default:
    coverage) as TOML, every field included."""
    from swarmgames.config import resolve_scenario, to_toml

    click.echo(to_toml(resolve_scenario(scenario, overrides), annotated=annotated), nl=False)


@config.command("check")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@_guarded
def config_check(file: Path) -> None:
    """Validate a scenario FILE: exit 0 if valid, 2 with one line per problem if not."""
    from swarmgames.config import load_config
    from swarmgames.sim.memory import check_memory

    cfg = load_config(file)
    est = check_memory(cfg)
    click.echo(
        f"{file}: valid (scenario {cfg.name!r}, {cfg.swarm.n_robots} robots; estimated peak "
        f"memory {est.total_gib:.2g} GiB)"
    )


@config.command("list")
def config_list() -> None:
    """List the built-in scenarios, each with a one-line description."""
    from swarmgames.config import builtin_scenarios
    from swarmgames.config.io import scenario_description

    names = builtin_scenarios()
    width = max(map(len, names))
    for name in names:
        click.echo(f"{name:<{width}}  {scenario_description(name)}")


# ----------------------------------------------------------------------------- missions


@cli.group()
def missions() -> None:
    """List the registered missions and check a mission plug-in."""


@missions.command("list")
def missions_list() -> None:
    """List the registered missions (built-in and installed plug-ins)."""
    from swarmgames.missions import get_mission, mission_names

    for name in mission_names():
        click.echo(f"{name:<12} {get_mission(name).description}")
    _report_broken_plugins()


def _report_broken_plugins() -> None:
    """One line on stderr per installed mission plug-in that cannot be loaded."""
    from swarmgames.missions import broken_plugins

    for why in broken_plugins().values():
        click.secho(f"Warning: {why}", fg="yellow", err=True)


@missions.command("check")
@click.argument("name")
@set_option
@click.option(
    "--robots", type=click.IntRange(min=2), default=4, show_default=True, help="Test swarm size."
)
@_guarded
def missions_check(name: str, overrides: tuple[str, ...], robots: int) -> None:
    """Run the conformance check (check_mission) on mission NAME, built from the built-in
    scenario of that name if there is one, else from the mission's default section; exit 0 if
    it conforms, 1 with one line per problem if not."""
    from swarmgames.config import builtin_scenarios, parse_config, resolve_scenario
    from swarmgames.config.io import set_path
    from swarmgames.missions import check_mission, get_mission
    from swarmgames.missions.conformance import MissionCheckError

    entry = get_mission(name)
    if name in builtin_scenarios():
        config = resolve_scenario(name, overrides)
    else:
        data: dict[str, Any] = {"name": name, "scenario": name}
        for assignment in overrides:
            set_path(data, assignment)
        config = parse_config(data, source=f"mission {name!r}")
    try:
        check_mission(entry.build(config), n_robots=robots)
    except MissionCheckError as exc:
        click.secho(str(exc), fg="red", err=True)
        sys.exit(EXIT_FAILED)
    click.echo(f"mission {name!r} conforms")


@cli.group()
def comms() -> None:
    """Characterise the communication layer on a position trace."""


@comms.command(name="replay")
@positions_option
@click.option(
    "--backend",
    type=click.Choice(BACKENDS),
    default="olsr",
    show_default=True,
    help="Network whose routing tables carry the messages (ns3: run number = seed + 1).",
)
@click.option(
    "--comms",
    "model",
    type=click.Choice([m for m in COMMS_MODELS if m != "ideal"]),
    default=None,
    help="Communication model (default: the default scenario's, csma; ideal delivers "
    "everything at once).",
)
@click.option("--hops", type=click.IntRange(min=1, max=16), default=2, show_default=True,
              help="h: the neighbourhood radius and the flood's TTL.")  # fmt: skip
@seeds_option
@out_option
@force_option
@set_option
@click.option("--no-progress", is_flag=True, help="Do not show a progress bar.")
@_guarded
def comms_replay(
    positions: Path,
    backend: str,
    model: str | None,
    hops: int,
    seeds: tuple[int, ...],
    out: Path | None,
    force: bool,
    overrides: tuple[str, ...],
    no_progress: bool,
) -> None:
    """Deliver every robot's state message each second of a trace from t = 20 s and measure
    what arrives by the decision (comms.decide_after_s), by hop distance.

    Writes delivery.csv (hops,pairs,delivered,ratio,mean_age_ms), stages.csv (bytes per
    robot and the busiest robot's channel load per stage) and delivery.png. Radio, OLSR and
    comms parameters come from the default scenario, changed with --set. With several --seed,
    each seed's files go into seed-<SEED>/ and runs.csv lists the runs; a run whose ns-3
    aborts keeps its stages, is reported in one line, and the others go on (exit 1).
    """
    from swarmgames.config import resolve_scenario
    from swarmgames.experiments.comms_replay import replay_comms
    from swarmgames.network.trace import read_positions

    extra = (f"network.backend={backend!r}",) + (
        () if model is None else (f"comms.model={model!r}",)
    )
    cfg = resolve_scenario(None, (*overrides, *extra))
    trace = read_positions(positions)  # validate before creating the folder
    folder = _open_run_folder(out, f"comms-replay-{positions.stem}", force)

    def one(seed: int, sub) -> tuple[str, str | None]:
        bar = _progress(f"comms replay ({cfg.comms.model})", not no_progress and _interactive())
        with bar as tick:
            res = replay_comms(
                trace, backend=backend, config=cfg, hops=hops, seed=seed, progress=tick
            )
        res.write(sub)
        by_hop = ", ".join(
            f"{int(r.hops)} hop{'s' if r.hops > 1 else ''} {100 * r.ratio:.1f} % "
            f"({r.mean_age_ms:.1f} ms)"
            for r in res.delivery.itertuples()
        )
        line = (
            f"{res.comms} on {backend}: {trace.n_robots} robots, {len(res.stages)} stages; "
            f"delivered by the decision (age on arrival): {by_hop or 'no pairs'}; "
            f"max channel load {res.stages['channel_load'].max():.2f} -> {sub.path}/"
        )
        return line, res.failure

    _each_seed(folder, seeds, one)


def main(argv: list[str] | None = None, *, quick_exit: bool = False) -> None:
    """Run the command line. The process keeps freed memory for reuse
    (:func:`swarmgames.allocator.reuse_freed_memory`) unless ``SWARMGAMES_MALLOC=system``.

    With ``quick_exit`` (:func:`script`, the ``swarmgames`` command and ``python -m
    swarmgames``), once the command has ended the process ends as Python would (its exit
    handlers run, its output is flushed, the same exit status) but without tearing down the
    interpreter's modules, which takes about 0.5 s after a run (Numba's and LLVM's state,
    matplotlib, pandas). Without it, the command's ``SystemExit`` propagates to the caller."""
    reuse_freed_memory()
    warnings.showwarning = _one_line_warning
    try:
        cli.main(args=argv, prog_name="swarmgames")
    except SystemExit as exc:
        if quick_exit:
            _end_process(exc.code)
        raise


def script() -> None:
    """The ``swarmgames`` console script: :func:`main` with ``quick_exit``."""
    main(quick_exit=True)


def _end_process(code) -> None:
    """End the process with the status of ``SystemExit(code)`` after running its exit
    handlers and flushing its output, without the interpreter's teardown; returns (and the
    process ends as usual) while a thread other than a daemon is still running."""
    import atexit
    import contextlib
    import os
    import threading

    main_thread = threading.main_thread()
    if any(t is not main_thread and not t.daemon for t in threading.enumerate()):
        return
    if code is None:
        status = 0
    elif isinstance(code, int):
        status = code
    else:  # what Python does with a message
        print(code, file=sys.stderr)
        status = 1
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # a closed pipe: nothing more to say
            stream.flush()
    os._exit(status & 0xFF)


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning is one line on standard error, never a source excerpt."""
    click.echo(f"warning: {message}", err=True)
