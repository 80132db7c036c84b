"""The benchmark suite behind ``swarmgames bench``: how a stage's cost grows with the swarm.

:func:`run_suite` times, as medians over repeats, on constant-density coverage missions
(:func:`~swarmgames.config.scaling.scaled_config`: the ROI grows with N, the 20 m grid
cell stays):

* ``stage`` — a full stage (network advance + every local game, integration included +
  motion) for N = 10, 100, 1 000 and 10 000 robots (``quick``: up to 1 000), with its peak
  traced memory;
* ``integrate`` — payoff integration (unary and pairwise potentials) per robot-action,
  ``integrate_s / (N A)``;
* ``local_game`` — one local-game solve, amortised over the stage's N games;
* ``olsr_advance`` — one control period of the built-in OLSR provider (HELLO-only, h = 2);

and ratios measured in the same run:

* ``batched_vs_single`` — solving the stage's local games (N = 1 000, or the largest size
  up to it) in their batches against one by one, with each mean-field engine (compiled and
  numpy BLAS; the compiled record also carries ``ratio_vs_numpy_single``, its batch against
  numpy one by one);
* ``batched_vs_single_random`` — the same on 1 000 random games of 8 variables and 9 actions
  (the engine's own benchmark, :func:`~swarmgames.bench.game.bench_local_game`);
* ``decide_batched_vs_single`` — a robot's whole decision (its local game built from its
  messages, integrated and solved) for every robot of the stage in batches, against robots
  deciding one at a time, as each UAV does on board;
* ``olsr_vs_ns3`` — the built-in OLSR against ns-3 on the same positions trace (full
  protocol, TCs included), when ns-3 is installed and not ``quick`` (importing ns-3 takes
  about 10 s);
* ``slope`` — the least-squares slope of log(stage time) against log(N) for N >= 100;
* ``takeoff`` — a stage of the *default* scenario (``swarmgames run --set
  swarm.n_robots=300``: the take-off disc grown for the swarm, no signal floor, float64), its
  traced peak memory next to the estimate of :mod:`swarmgames.sim.memory`; and, unless
  ``quick``, the dense case: the same robots on the 25 m disc, every one within range of
  every other (``dense``: K = N);
* ``dense_stage`` — unless ``quick``, the ``stage`` benchmark's scenario (float32, signal
  floor) for the same robots on a ROI of :data:`DENSE_AREA_M2` per UAV, every one within
  range of every other: the target's dense stage, with the parts of a ``stage`` record.
* ``mission`` — a whole run of the ``coverage-large`` preset (1 000 UAVs, 60 stages) with
  every output, split into the stage loop and the outputs, and its in-run stage against the
  ``stage`` record of the same N (:mod:`swarmgames.bench.mission`; not ``quick``);
* ``env_vs_mpe`` and ``env_single`` — the learning environment's throughput: the vector
  environment (N = 7 with E = 64 envs, N = 30 with E = 16) against PettingZoo's MPE
  ``simple_spread`` with as many agents, and one env against the same env measuring every
  step as a run does (:mod:`swarmgames.bench.env`; when the ``env`` extra is installed);
* ``target`` — each target of :data:`TARGETS` whose record was measured: the value, the
  limit and whether it was met (reported, never asserted). Every target of time is a ratio
  of two times measured in the same run (a stage against its physical estimate, the slope,
  the routed messages' share of a stage, a whole run's outputs against its stage loop):
  absolute times on a shared machine vary several-fold with its load.

Every ``stage`` record also carries the physical estimate of its work,
:math:`N \\bar K A G + N \\bar K^2 A^2 \\bar s` simple operations (``G`` cells in a
variable's window, :math:`\\bar s` mean-field sweeps per game) at 1 ns each on the machine
(``physical_s``), and the ratio of the measured stage to it.

Timings are wall-clock medians of :func:`~swarmgames.bench.timing.measure` on one process;
they depend on the machine and its load, so they are never asserted in tests.
"""

from __future__ import annotations

import os
import resource
import time
import tracemalloc
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from swarmgames.allocator import reusing_freed_memory
from swarmgames.bench.comms import channel_vs_ns3, exchange_record
from swarmgames.bench.game import bench_local_game
from swarmgames.bench.mission import MISSION_ROBOTS, mission_record
from swarmgames.bench.stage import StageBench
from swarmgames.game.stage import evaluate_games, plan_stage

__all__ = [
    "QUICK_SIZES",
    "SIZES",
    "TAKEOFF_ROBOTS",
    "TARGETS",
    "BenchResult",
    "Target",
    "run_suite",
]


@dataclass(frozen=True)
class Target:
    """A performance target: ``field`` of the ``benchmark`` record at ``n_robots`` (every
    size from ``min_n`` when None) at most ``limit``."""

    name: str
    benchmark: str
    field: str
    limit: float
    unit: str
    n_robots: int | None = None
    min_n: int = 0


#: The targets: stage cost against its physical estimate, growth, memory, the comms layer's
#: share, a whole run's outputs against its stage loop; every one of time a ratio measured
#: in the same run. The dense stage (300 UAVs all within range) is the ``dense_stage``
#: record (not ``--quick``): the ``stage`` benchmark's scenario, float32, on a small ROI.
TARGETS = (
    Target("stage vs physical estimate", "stage", "ratio_to_physical", 2.0, "x", min_n=1_000),
    Target("slope of stage time against N", "slope", "value", 1.05, ""),
    Target("peak memory at N = 10 000", "stage", "peak_mb", 1024.0, "MiB", n_robots=10_000),
    Target("dense stage vs physical estimate", "dense_stage", "ratio_to_physical", 2.0, "x"),
    Target("dense stage memory", "dense_stage", "peak_mb", 2048.0, "MiB"),
    Target("routed comms share of a stage", "routed_comms", "share_of_stage", 0.15, "", min_n=100),
    Target("csma comms share, N = 1 000", "csma_comms", "share_of_stage", 0.20, "", n_robots=1_000),
    Target(
        "csma comms share, N = 10 000", "csma_comms", "share_of_stage", 0.25, "", n_robots=10_000
    ),
    Target(
        "csma exchange vs ns-3's packets (time ratio)", "csma_vs_ns3", "csma_per_ns3", 0.02, "x"
    ),
    Target(
        "MPE agent-steps per the vector env's, N = 7, E = 64",
        "env_vs_mpe",
        "mpe_per_swarmgames",
        1.0,
        "x",
        n_robots=7,
    ),
    Target(
        "MPE agent-steps per the vector env's, N = 7, E = 64 (stretch)",
        "env_vs_mpe",
        "mpe_per_swarmgames",
        1 / 3,
        "x",
        n_robots=7,
    ),
    Target(
        "MPE agent-steps per the vector env's, N = 30, E = 16",
        "env_vs_mpe",
        "mpe_per_swarmgames",
        2.0,
        "x",
        n_robots=30,
    ),
    Target(
        "one env measuring every step per the default step (steps/s)",
        "env_single",
        "measured_per_default",
        0.2,
        "x",
    ),
    Target(
        "whole mission's outputs vs its stage loop (coverage-large)",
        "mission",
        "outputs_vs_loop",
        0.5,
        "x",
        n_robots=1_000,
    ),
)

#: Seconds per simple operation of the physical estimate (10^8 operations in 0.1 s).
OP_S = 1e-9

SIZES = (10, 100, 1_000, 10_000)
QUICK_SIZES = (10, 100, 1_000)
#: Timed stages per size (after one untimed stage). On a shared two-core machine one stage's
#: time varies by ±15 % from stage to stage with the same work, so the medians take enough
#: stages to stand for the run: about 1 s at N = 1 000 and 5 s at 10 000.
REPEATS = {10: 7, 100: 7, 1_000: 9, 10_000: 5}


def _fmt_s(sec: float) -> str:
    if not np.isfinite(sec):
        return "-"
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("µs", 1e-6)):
        if sec >= scale or unit == "µs":
            return f"{sec / scale:.3g} {unit}"
    return f"{sec:.3g} s"  # pragma: no cover


@dataclass
class BenchResult:
    """Records of one run of the suite.

    Attributes
    ----------
    records : list of dict
        One dict per measurement; every record has ``benchmark`` and ``n_robots``; timings
        are seconds (``median_s``), memory MiB.
    meta : dict
        Machine and run information (quick, sizes, numpy version, wall time).
    """

    records: list[dict[str, Any]] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)

    def to_frame(self):
        """All records as a pandas DataFrame (one row per record)."""
        import pandas as pd

        return pd.DataFrame(self.records)

    def _of(self, name: str) -> list[dict[str, Any]]:
        return [r for r in self.records if r["benchmark"] == name]

    @property
    def slope(self) -> float:
        """Fitted slope of log(stage time) against log(N) (NaN with fewer than two sizes)."""
        rec = self._of("slope")
        return float(rec[0]["value"]) if rec else float("nan")

    def table(self):
        """The results as a ``rich.table.Table``."""
        from rich.table import Table

        t = Table(title="swarmgames bench" + (" (quick)" if self.meta.get("quick") else ""))
        cols = ("N", "stage", "advance", "integrate", "solve", "per game", "peak MiB")
        for col in (*cols, "vs est.", "target"):
            t.add_column(col, justify="right")
        games = {r["n_robots"]: r for r in self._of("local_game")}
        adv = {r["n_robots"]: r for r in self._of("olsr_advance")}
        stage_targets = {
            r["n_robots"]: r
            for r in self._of("target")
            if r["of"] == "stage" and r["field"] == "ratio_to_physical"
        }
        for r in self._of("stage"):
            n = r["n_robots"]
            tg = stage_targets.get(n)
            t.add_row(
                f"{n:,}",
                _fmt_s(r["median_s"]),
                _fmt_s(adv.get(n, {}).get("median_s", np.nan)),
                _fmt_s(r["integrate_s"]),
                _fmt_s(r["solve_s"]),
                _fmt_s(games.get(n, {}).get("median_s", np.nan)),
                f"{r['peak_mb']:.0f}",
                f"{r['ratio_to_physical']:.1f}x" if "ratio_to_physical" in r else "-",
                "-" if tg is None else f"{_verdict(tg)} (<= {tg['limit']:g}x)",
            )
        notes = [f"slope (N >= 100): {self.slope:.2f}"]
        for r in self._of("target"):
            if r["of"] == "stage" and r["field"] == "ratio_to_physical":
                continue
            notes.append(
                f"target {r['target']}"
                + (f" (N = {r['n_robots']:,})" if r["of"] == "routed_comms" else "")
                + f": {r['value']:.3g} <= {r['limit']:g} {r['unit']} {_verdict(r)}"
            )
        for r in self._of("integrate"):
            if r["n_robots"] == max(x["n_robots"] for x in self._of("integrate")):
                notes.append(
                    f"integration per robot-action at N = {r['n_robots']:,}: "
                    f"{_fmt_s(r['median_s'])}"
                )
        kinds = {
            "batched_vs_single": "coverage games",
            "batched_vs_single_random": "random K = 8 games",
            "decide_batched_vs_single": "coverage decisions: build + integrate + solve",
        }
        rows = [r for name in kinds for r in self._of(name)]
        for r in rows:
            kind = kinds[r["benchmark"]]
            engine = r.get("engine", "blas")
            notes.append(
                f"batched vs one by one ({r['n_games']} {kind}, {engine}): "
                f"{r['ratio']:.1f}x ({_fmt_s(r['batched_per_game_s'])} vs "
                f"{_fmt_s(r['single_per_game_s'])} per game)"
            )
            if "ratio_vs_numpy_single" in r:
                notes.append(
                    f"  compiled batch vs numpy one by one ({kind}): "
                    f"{r['ratio_vs_numpy_single']:.0f}x"
                )
        for model in ("routed", "csma"):
            for r in self._of(f"{model}_comms"):
                notes.append(
                    f"{model} comms exchange at N = {r['n_robots']:,}: "
                    f"{_fmt_s(r['median_s'])} ({100 * r['share_of_stage']:.1f} % of a stage)"
                )
        for r in self._of("csma_vs_ns3"):
            if "ratio" in r:
                notes.append(
                    f"csma vs ns-3 packets ({r['trace']}, {r['n_robots']} UAVs): "
                    f"{r['ratio']:.0f}x faster per exchange ({_fmt_s(r['csma_s'])} vs "
                    f"{_fmt_s(r['ns3_s'])})"
                )
        for r in self._of("takeoff"):
            what = "all in range" if r["dense"] else "default take-off"
            notes.append(
                f"default scenario, N = {r['n_robots']:,}, {what} (K ≈ "
                f"{r['neighbours_mean'] + 1:.0f}): {_fmt_s(r['median_s'])} per stage, peak "
                f"{r['peak_mb']:.0f} MiB traced (estimate {r['estimate_mb']:.0f} MiB, with the "
                f"network's tables {r['estimate_network_mb']:.0f} MiB)"
            )
        for r in self._of("dense_stage"):
            notes.append(
                f"dense stage, N = {r['n_robots']:,} within range (K ≈ "
                f"{r['neighbours_mean'] + 1:.0f}, float32): {_fmt_s(r['median_s'])} = advance "
                f"{_fmt_s(r['advance_s'])} + unary {_fmt_s(r['integrate_s'])} + solve "
                f"{_fmt_s(r['solve_s'])} + the rest; {r['sweeps_mean']:.0f} sweeps per game, "
                f"{r['ratio_to_physical']:.2f} of the physical estimate; peak "
                f"{r['peak_mb']:.0f} MiB traced"
            )
        for r in self._of("mission"):
            vs = f", {r['stage_vs_bench']:.1f}x the bench's" if "stage_vs_bench" in r else ""
            notes.append(
                f"whole mission (coverage-large, N = {r['n_robots']:,}, {r['stages']} stages, "
                f"every output): {r['total_s']:.1f} s = {r['loop_s']:.1f} s of stages + "
                f"{r['outputs_s']:.1f} s of outputs; stage in the run "
                f"{_fmt_s(r['median_stage_s'])}{vs}"
            )
        for r in self._of("env_vs_mpe"):
            vs = ""
            if "mpe_agent_steps_per_s" in r:
                vs = f" vs MPE simple_spread {r['mpe_agent_steps_per_s']:,.0f}"
            parts = ", ".join(
                f"{k[6:]} {100 * v:.0f} %" for k, v in r.items() if k.startswith("share_")
            )
            notes.append(
                f"vector env, N = {r['n_robots']}, E = {r['num_envs']}: "
                f"{r['agent_steps_per_s']:,.0f} agent-steps/s{vs} ({parts})"
            )
        for r in self._of("env_single"):
            notes.append(
                f"one env, N = {r['n_robots']}: {r['steps_per_s']:.0f} steps/s, measuring "
                f"every step {r['measured_steps_per_s']:.0f} steps/s"
            )
        for r in self._of("olsr_vs_ns3"):
            if r.get("skipped"):
                notes.append(f"olsr vs ns-3: skipped ({r['skipped']})")
            else:
                notes.append(
                    f"olsr vs ns-3 ({r['n_robots']} nodes, {r['sim_seconds']:g} s): "
                    f"{_fmt_s(r['olsr_s'])} vs {_fmt_s(r['ns3_s'])}, ns-3 / olsr = "
                    f"{r['ratio']:.1f}x"
                )
        t.caption = "\n".join(notes)
        return t

    def plot(self):
        """Stage cost against N on log-log axes with the fitted slope (matplotlib Figure)."""
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.0, 4.2))
        st = self._of("stage")
        n = np.array([r["n_robots"] for r in st], dtype=float)
        if n.size:
            y = np.array([r["median_s"] for r in st])
            ax.loglog(n, y, "o", color="C0", label="full stage")
            fit = self._of("slope")
            if fit:
                f = fit[0]
                xs = np.geomspace(f["from_n"], f["to_n"], 20)
                ax.loglog(
                    xs,
                    np.exp(f["intercept"]) * xs ** f["value"],
                    "-",
                    color="C0",
                    alpha=0.6,
                    label=f"fit, slope {f['value']:.2f}",
                )
            for key, color, label in (
                ("integrate_s", "C1", "integration"),
                ("solve_s", "C2", "local games (solve)"),
                ("advance_s", "C3", "network advance"),
            ):
                ax.loglog(n, [r[key] for r in st], "--", color=color, marker=".", label=label)
        ax.set_xlabel("robots N (constant density)")
        ax.set_ylabel("wall time per stage (s)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        return fig

    def write(self, folder) -> list[Path]:
        """Write ``bench.json``, ``bench.csv`` and ``bench.png`` into ``folder`` (a
        :class:`~swarmgames.runfolder.RunFolder` or a path, created if missing)."""

        from swarmgames.runfolder import RunFolder

        folder = RunFolder.of(folder, force=True)
        paths = [
            folder.write_json("bench.json", {"meta": self.meta, "records": self.records}),
            folder.write_csv("bench.csv", self.to_frame()),
        ]
        paths.append(folder.save_figure("bench.png", self.plot()))
        return paths


def _verdict(rec: dict[str, Any]) -> str:
    return "pass" if rec["met"] else "FAIL"


def _targets(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """A ``target`` record for every target of :data:`TARGETS` that has its record."""
    out = []
    for tg in TARGETS:
        for r in records:
            if r["benchmark"] != tg.benchmark or tg.field not in r:
                continue
            n = r.get("n_robots")
            if (tg.n_robots is not None and n != tg.n_robots) or (n or 0) < tg.min_n:
                continue
            value = float(r[tg.field])
            name = tg.name
            if tg.benchmark == "slope":
                name += f", N = {r['from_n']:,} ... {r['to_n']:,}"
            out.append(
                {
                    "benchmark": "target",
                    "target": name,
                    "of": tg.benchmark,
                    "field": tg.field,
                    "n_robots": n,
                    "value": value,
                    "limit": tg.limit,
                    "unit": tg.unit,
                    "met": bool(value <= tg.limit),
                }
            )
    return out


def _window_cells(config) -> float:
    """G, the grid cells of a variable's window (0 without a signal floor): the disc of
    radius :math:`R_F + s` in cells (:mod:`swarmgames.missions.coverage.window`)."""
    from swarmgames.missions.coverage.signal import SignalModel
    from swarmgames.missions.coverage.window import floor_distance_sq

    cov, sw = config.mission, config.swarm
    if getattr(cov, "signal_floor_dbm", None) is None:
        return 0.0
    sig = SignalModel(cov.t0_dbm, cov.l0_db, cov.path_exponent, cov.reference_distance_m)
    reach = np.sqrt(max(floor_distance_sq(sig, cov.signal_floor_dbm) - sw.altitude_m**2, 0.0))
    rho = (reach + sw.step_m) / cov.grid_cell_m + np.sqrt(0.5)
    return float(np.pi * rho**2)


def _have_env() -> bool:
    """Whether the ``env`` extra (pettingzoo, gymnasium) is installed."""
    try:
        import swarmgames.env  # noqa: F401
    except ImportError:
        return False
    return True


def _numba_version() -> str | None:
    try:
        import numba
    except ImportError:
        return None
    return numba.__version__


def _say(progress: bool, msg: str) -> None:
    if progress:
        from rich.console import Console

        Console(stderr=True).print(f"[dim]bench[/dim] {msg}")


def _stage_records(
    n: int, repeats: int, seed: int, workers: int, config=None
) -> tuple[list[dict], StageBench]:
    """Time ``repeats`` stages at N = ``n`` (the first, untimed stage measures memory), of
    the constant-density scenario or of ``config``."""
    tracemalloc.start()
    try:
        sb = StageBench(n, config=config, seed=seed, workers=workers)
        t0 = time.perf_counter()
        sb.step()
        first_s = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    sb.parts = type(sb.parts)()
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sb.step()
        samples.append(time.perf_counter() - t0)
    med = sb.parts.medians()
    n_actions = int(sb.mission.action_model.n_actions)
    k_mean = med["neighbours"] + 1.0
    ops = (
        n * k_mean * n_actions * _window_cells(sb.config)
        + n * (k_mean * n_actions) ** 2 * med["iterations"]
    )
    stage = {
        "benchmark": "stage",
        "n_robots": n,
        "median_s": float(np.median(samples)),
        "iqr_s": float(np.subtract(*np.percentile(samples, [75, 25]))),
        "repeats": repeats,
        "advance_s": med["advance_s"],
        "integrate_s": med["integrate_s"],
        "solve_s": med["solve_s"],
        "neighbours_mean": med["neighbours"],
        "sweeps_mean": med["iterations"],
        "physical_ops": ops,
        "physical_s": ops * OP_S,
        "ratio_to_physical": float(np.median(samples)) / (ops * OP_S) if ops else float("nan"),
        "setup_s": sb.setup_s,
        "first_stage_s": first_s,
        "peak_mb": peak / 2**20,
        "rss_max_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "grid_cells": int(sb.mission.roi.n_cells) if hasattr(sb.mission, "roi") else None,
        "backend": sb.config.network.backend,
        "workers": workers,
    }
    return [
        stage,
        {
            "benchmark": "integrate",
            "n_robots": n,
            "median_s": med["integrate_s"] / (n * n_actions),
            "unit": "per robot-action",
        },
        {
            "benchmark": "local_game",
            "n_robots": n,
            "median_s": med["solve_s"] / n,
            "unit": "per local game, amortised over the stage",
        },
        {
            "benchmark": "olsr_advance",
            "n_robots": n,
            "median_s": med["advance_s"],
            "hello_only": bool(getattr(sb.provider, "hello_only", False)),
            "unit": "per control period",
        },
    ], sb


#: Robots of the take-off benchmarks, and the stages timed (after the measured one).
TAKEOFF_ROBOTS, TAKEOFF_REPEATS = 300, 2

#: ROI area per UAV of the dense stage, m²: N = 300 UAVs take off from the ROI's disc of
#: 338 m across (``swarm.start_max_neighbours = 0``: not grown for the swarm), less than the
#: 368.84 m radio range, so every UAV is within range of every other.
DENSE_AREA_M2 = 300.0


def _dense_stage_record(n: int, seed: int, workers: int) -> dict:
    """The ``stage`` benchmark's scenario (float32, signal floor) with every UAV within
    range of every other (:data:`DENSE_AREA_M2`): one untimed stage, then one timed."""
    from swarmgames.config import scaled_config

    cfg = scaled_config(n, area_per_robot_m2=DENSE_AREA_M2, workers=workers)
    cfg = cfg.with_overrides({"swarm.start_max_neighbours": 0})  # the disc is not grown
    rec = _stage_records(n, 1, seed, workers, config=cfg)[0][0]
    return {**rec, "benchmark": "dense_stage", "area_per_robot_m2": DENSE_AREA_M2}


def _takeoff_record(n: int, dense: bool, repeats: int, seed: int) -> dict:
    """A stage of the default scenario with ``n`` robots from its default take-off disc
    (``dense``: the 25 m disc whatever N, so every robot is within range of every other):
    the traced peak of the first stage (its OLSR advance included), the median time of it and
    ``repeats`` more, and the estimates of :func:`~swarmgames.sim.memory.estimate_memory`:
    the stage's (``estimate_mb``), and the run's without the interpreter and the stages kept
    (``estimate_network_mb``: the stage and the network's tables, what the traced peak
    holds)."""
    from swarmgames.config import resolve_scenario
    from swarmgames.sim.memory import estimate_memory

    over = [f"swarm.n_robots={n}"] + (["swarm.start_max_neighbours=0"] if dense else [])
    sb = StageBench(n, config=resolve_scenario("coverage", over), seed=seed)
    tracemalloc.start()
    try:
        t0 = time.perf_counter()
        sb.step()
        samples = [time.perf_counter() - t0]
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    for _ in range(repeats):
        t0 = time.perf_counter()
        sb.step()
        samples.append(time.perf_counter() - t0)
    est = estimate_memory(sb.config, sb.mission, whole_run=False)
    run = estimate_memory(sb.config, sb.mission)
    beside = {"interpreter and libraries", "stages kept and written"}
    med = sb.parts.medians()
    return {
        "benchmark": "takeoff",
        "n_robots": n,
        "dense": dense,
        "median_s": float(np.median(samples)),
        "repeats": len(samples),
        "integrate_s": med["integrate_s"],
        "solve_s": med["solve_s"],
        "neighbours_mean": med["neighbours"],
        "takeoff_radius_m": float(sb.mission.takeoff.radius_m),
        "peak_mb": peak / 2**20,
        "estimate_mb": est.total_bytes / 2**20,
        "estimate_network_mb": sum(b for name, b in run.parts if name not in beside) / 2**20,
        "estimate_vars": est.n_vars,
        "rss_max_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }


def _engines() -> tuple[str, ...]:
    """Mean-field engines compared by the batching benchmarks: the compiled one (when Numba
    is installed) and the numpy BLAS reference."""
    from swarmgames.game.meanfield import compiled_available

    return ("compiled", "blas") if compiled_available() else ("blas",)


def _batched_vs_single(sb: StageBench, n_single: int, seed: int, engine: str) -> dict:
    """Solve the stage's local games in their batches and ``n_single`` of them one by one,
    with the mean-field ``engine`` (batched: best of 3; one by one: mean, after one untimed
    solve of each kind, so that compilation is not timed)."""
    ctrl = sb.controller
    problem = sb.problem()
    messages, groups = plan_stage(problem)
    pays = [
        evaluate_games(problem, messages, owners, virtual_mean=ctrl.virtual_mean)[1]
        for owners in groups
    ]
    solver = replace(ctrl.solver, engine=engine)
    solver.solve_payoffs(pays[0].select(slice(0, 1)), sb.rng)
    for p in pays:
        solver.solve_payoffs(p, sb.rng)
    batched = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for p in pays:
            solver.solve_payoffs(p, sb.rng)
        batched = min(batched, time.perf_counter() - t0)
    n_games = sum(p.shape[0] for p in pays)
    rng = np.random.default_rng(seed)
    picks = rng.choice(n_games, size=min(n_single, n_games), replace=False)
    offsets = np.cumsum([0] + [p.shape[0] for p in pays])
    singles = []
    for g in picks:
        part = int(np.searchsorted(offsets, g, side="right") - 1)
        one = pays[part].select(slice(g - offsets[part], g - offsets[part] + 1))
        t0 = time.perf_counter()
        solver.solve_payoffs(one, sb.rng)
        singles.append(time.perf_counter() - t0)
    per_batched = batched / n_games
    per_single = float(np.mean(singles))
    return {
        "benchmark": "batched_vs_single",
        "engine": engine,
        "n_robots": sb.n_robots,
        "n_games": int(n_games),
        "n_single": len(singles),
        "batched_per_game_s": per_batched,
        "single_per_game_s": per_single,
        "median_s": per_batched,
        "ratio": per_single / per_batched,
    }


def _decide_batched_vs_single(sb: StageBench, n_single: int, seed: int) -> dict:
    """A robot's whole decision — its local game built from its messages, integrated and
    solved — for every robot of the stage in their batches, against ``n_single`` robots each
    deciding alone (what one UAV computes on board), with the solver's engine. The messages
    (what the robots received) are computed once, outside both timings."""
    from swarmgames.game.meanfield import resolve_engine

    ctrl = sb.controller
    problem = sb.problem()
    messages, groups = plan_stage(problem)

    def decide(owners) -> None:
        for group in owners:
            _, pay, _, _ = evaluate_games(problem, messages, group, virtual_mean=ctrl.virtual_mean)
            ctrl.solver.solve_payoffs(pay, sb.rng)

    rng = np.random.default_rng(seed)
    picks = rng.choice(sb.n_robots, size=min(n_single, sb.n_robots), replace=False)
    decide([picks[:1]])
    batched = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        decide(groups)
        batched = min(batched, time.perf_counter() - t0)
    singles = []
    for i in picks:
        t0 = time.perf_counter()
        decide([np.array([i])])
        singles.append(time.perf_counter() - t0)
    per_batched = batched / sb.n_robots
    per_single = float(np.mean(singles))
    return {
        "benchmark": "decide_batched_vs_single",
        "engine": resolve_engine(ctrl.solver.engine),
        "n_robots": sb.n_robots,
        "n_games": sb.n_robots,
        "n_single": len(singles),
        "batched_per_game_s": per_batched,
        "single_per_game_s": per_single,
        "median_s": per_batched,
        "ratio": per_single / per_batched,
    }


def _cross_ratios(records: list[dict[str, Any]]) -> None:
    """Add to each compiled record the one-by-one time of the numpy (BLAS) engine on the same
    games and ``ratio_vs_numpy_single``: the compiled batch against solving each game alone
    with numpy."""
    for kind in ("batched_vs_single", "batched_vs_single_random"):
        by = {r["engine"]: r for r in records if r["benchmark"] == kind}
        if "compiled" in by and "blas" in by:
            c, b = by["compiled"], by["blas"]
            c["numpy_single_per_game_s"] = b["single_per_game_s"]
            c["ratio_vs_numpy_single"] = b["single_per_game_s"] / c["batched_per_game_s"]


def _olsr_vs_ns3(n: int, sim_seconds: float, seed: int) -> dict:
    """The built-in OLSR (full protocol) and ns-3 on the same drifting-swarm trace."""
    from swarmgames.bench.network import random_swarm
    from swarmgames.config import NetworkConfig
    from swarmgames.network.ns3_import import ns3_available
    from swarmgames.network.ns3_process import shared_process
    from swarmgames.sim.providers import provider_from_config

    rec: dict[str, Any] = {"benchmark": "olsr_vs_ns3", "n_robots": n, "sim_seconds": sim_seconds}
    if not ns3_available():
        rec["skipped"] = "ns-3 not installed"
        return rec
    shared_process()  # the ns-3 process and its ~10 s import are not compared
    rng = np.random.default_rng(seed)
    start = random_swarm(n, 6.0, seed=rng)
    heading = rng.uniform(0, 2 * np.pi, n)
    vel = 2.0 * np.c_[np.cos(heading), np.sin(heading), np.zeros(n)]
    times, hops = {}, {}
    for backend in ("olsr", "ns3"):
        t0 = time.perf_counter()
        # Full tables: OLSR with TCs, as ns-3 always runs it.
        prov = provider_from_config(NetworkConfig(backend=backend), n, seed, full_tables=True)
        prov.reset(start, 0.0)
        snap = None
        for k in range(1, int(sim_seconds) + 1):
            snap = prov.advance(float(k), start + vel * k)
        times[backend] = time.perf_counter() - t0
        hops[backend] = snap.hop_matrix()
        close = getattr(prov, "close", None)
        if callable(close):
            close()
    off = ~np.eye(n, dtype=bool)
    rec.update(
        olsr_s=times["olsr"],
        ns3_s=times["ns3"],
        median_s=times["olsr"],
        ratio=times["ns3"] / times["olsr"],
        route_agreement=float(np.mean(hops["olsr"][off] == hops["ns3"][off])),
    )
    return rec


def run_suite(
    quick: bool = False,
    out=None,
    progress: bool = True,
    *,
    sizes: Sequence[int] | None = None,
    repeats: int | None = None,
    n_single: int | None = None,
    ns3: bool | None = None,
    seed: int = 0,
    workers: int | None = None,
    takeoff: int | None = None,
    dense: bool | None = None,
    mission: int | None = None,
    mission_stages: int | None = None,
    env: bool | None = None,
) -> BenchResult:
    """Run the benchmark suite (module notes) and optionally write it.

    Parameters
    ----------
    quick : bool
        N = 10, 100, 1 000 and no ns-3 comparison (under two minutes on a 2-core machine).
    out : RunFolder, str or Path, optional
        Where to write ``bench.json``, ``bench.csv`` and ``bench.png``.
    progress : bool
        Print a line per benchmark on stderr.
    sizes : sequence of int, optional
        Swarm sizes (default :data:`SIZES`, or :data:`QUICK_SIZES` when ``quick``).
    repeats : int, optional
        Timed stages per size (default :data:`REPEATS`, 3 for other sizes).
    n_single : int, optional
        Games solved one by one for the batching ratio (default 200, quick 100).
    ns3 : bool, optional
        Compare with ns-3 (default: when installed and not ``quick``).
    seed : int
    workers : int, optional
        Threads of the windowed integral (``coverage.workers``); default: 2 where the machine
        has two cores or more (the numbers of ``docs/bench.md``), else 1.
    takeoff : int, optional
        Robots of the ``takeoff`` and ``dense_stage`` benchmarks (default
        :data:`TAKEOFF_ROBOTS`; 0 = none).
    dense : bool, optional
        Also the dense cases, every robot within range: the default scenario's take-off and
        the ``dense_stage`` record (default: not ``quick``; about a minute at 300 robots).
    mission : int, optional
        Robots of the whole-mission record (``coverage-large`` with every output; default
        :data:`~swarmgames.bench.mission.MISSION_ROBOTS`, none when ``quick``; 0 = none).
    mission_stages : int, optional
        Its stages (default: the preset's 60).
    env : bool, optional
        The learning environment's throughput records (default: when the ``env`` extra is
        installed).

    Returns
    -------
    BenchResult
    """
    t_start = time.perf_counter()
    sizes = tuple(QUICK_SIZES if quick else SIZES) if sizes is None else tuple(sizes)
    if not sizes or any(int(n) < 1 for n in sizes):
        raise ValueError(f"sizes must be robot counts >= 1 (got {sizes})")
    n_single = (100 if quick else 200) if n_single is None else int(n_single)
    if workers is None:
        workers = 2 if (os.cpu_count() or 1) >= 2 else 1
    records: list[dict[str, Any]] = []
    ratio_bench = None
    for n in sizes:
        reps = REPEATS.get(n, 3) if repeats is None else int(repeats)
        _say(progress, f"stage, N = {n:,} ({reps} repeats)")
        recs, sb = _stage_records(int(n), reps, seed, int(workers))
        records.extend(recs)
        records.append(exchange_record(sb, "routed", recs[0]["median_s"], reps, seed))
        records.append(exchange_record(sb, "csma", recs[0]["median_s"], reps, seed))
        _say(progress, f"  {_fmt_s(recs[0]['median_s'])} per stage")
        if n <= 1_000:
            ratio_bench = sb
        del sb
    for engine in _engines():
        if ratio_bench is not None:
            _say(progress, f"batched vs one by one, N = {ratio_bench.n_robots:,}, {engine}")
            records.append(_batched_vs_single(ratio_bench, n_single, seed, engine))
        _say(progress, f"batched vs one by one, random games (K = 8, A = 9), {engine}")
        rnd = bench_local_game(
            min(1000, 10 * n_single),
            8,
            9,
            seed,
            beta=50.0,
            n_single=n_single,
            dtype=np.float32,
            engine=engine,
        )
        records.append(
            {
                "benchmark": "batched_vs_single_random",
                "engine": engine,
                "n_robots": rnd["n_games"],
                "n_games": rnd["n_games"],
                "n_single": min(n_single, rnd["n_games"]),
                "batched_per_game_s": rnd["batched_per_game_ms"] / 1e3,
                "single_per_game_s": rnd["single_per_game_ms"] / 1e3,
                "median_s": rnd["batched_per_game_ms"] / 1e3,
                "ratio": rnd["speedup"],
            }
        )
    if ratio_bench is not None:
        _say(progress, f"whole decisions batched vs one by one, N = {ratio_bench.n_robots:,}")
        records.append(_decide_batched_vs_single(ratio_bench, n_single, seed))
    del ratio_bench
    _cross_ratios(records)
    st = [r for r in records if r["benchmark"] == "stage" and r["n_robots"] >= 100]
    if len(st) < 2:
        st = [r for r in records if r["benchmark"] == "stage"]
    if len(st) >= 2:
        x = np.log([r["n_robots"] for r in st])
        y = np.log([r["median_s"] for r in st])
        slope, intercept = np.polyfit(x, y, 1)
        records.append(
            {
                "benchmark": "slope",
                "n_robots": int(st[-1]["n_robots"]),
                "value": float(slope),
                "intercept": float(intercept),
                "from_n": int(st[0]["n_robots"]),
                "to_n": int(st[-1]["n_robots"]),
            }
        )
    takeoff = TAKEOFF_ROBOTS if takeoff is None else int(takeoff)
    for crowded in (False, True) if takeoff > 0 else ():
        if crowded and not (not quick if dense is None else dense):
            continue
        what = "every robot within range" if crowded else "the default take-off disc"
        _say(progress, f"default scenario, N = {takeoff:,} from {what}")
        rec = _takeoff_record(takeoff, crowded, 0 if crowded else TAKEOFF_REPEATS, seed)
        records.append(rec)
        _say(progress, f"  {_fmt_s(rec['median_s'])} per stage, peak {rec['peak_mb']:.0f} MiB")
        if crowded:
            _say(progress, f"dense stage, N = {takeoff:,} within range (float32, floor)")
            rec = _dense_stage_record(takeoff, seed, workers)
            records.append(rec)
            _say(progress, f"  {_fmt_s(rec['median_s'])} per stage, peak {rec['peak_mb']:.0f} MiB")
    mission = (0 if quick else MISSION_ROBOTS) if mission is None else int(mission)
    if mission > 0:
        _say(progress, f"whole mission: coverage-large, N = {mission:,}, every output")
        rec = mission_record(mission, seed, mission_stages)
        bench_stage = [r for r in records if r["benchmark"] == "stage" and r["n_robots"] == mission]
        if bench_stage:
            rec["stage_vs_bench"] = rec["median_stage_s"] / bench_stage[0]["median_s"]
        rec["outputs_vs_loop"] = rec["outputs_s"] / rec["loop_s"]
        records.append(rec)
        _say(progress, f"  {rec['total_s']:.1f} s ({rec['loop_s']:.1f} s of stages)")
    if env is None:
        env = _have_env()
    if env:
        from swarmgames.bench.env import env_records

        _say(progress, "vector env vs MPE simple_spread, and one env vs measuring every step")
        records.extend(env_records(quick, seed))
    if ns3 is None:
        ns3 = not quick
    if ns3:
        _say(progress, "olsr vs ns-3 (importing ns-3 takes ~10 s)")
        records.append(_olsr_vs_ns3(30, 30.0, seed))
        _say(progress, "shared channel vs ns-3 packets, 40 UAVs within 1 200 m")
        records.append(channel_vs_ns3(seed=seed))
    records.extend(_targets(records))
    result = BenchResult(
        records,
        {
            "quick": bool(quick),
            "sizes": list(sizes),
            "numpy": np.__version__,
            "numba": _numba_version(),
            "wall_s": time.perf_counter() - t_start,
            "scenario": "scaled_config: 70 000 m2 per UAV, 20 m cells, floor -100 dBm",
            "workers": int(workers),
            "reuse_freed_memory": reusing_freed_memory(),
        },
    )
    if out is not None:
        result.write(out)
    return result
