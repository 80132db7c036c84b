"""The result of a run: tables, summary, plots and the files of the run folder."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import pandas as pd

from swarmgames.missions.protocol import (
    METRICS_COLUMNS,
    NETWORK_COLUMNS,
    TRAJECTORY_COLUMNS,
    MissionHooks,
)

__all__ = [
    "METRICS_COLUMNS",
    "NETWORK_COLUMNS",
    "TRAJECTORY_COLUMNS",
    "RunResult",
    "summarise",
]


def _trajectory(log) -> pd.DataFrame:
    s, n = log.actions.shape
    t_all = np.append(log.times, log.times[-1] + log.period_s if s else log.warmup_s)
    pos = log.states  # (S + 1, N, D)
    act = np.vstack([log.actions, np.full((1, n), -1)])  # no action after the last stage
    return pd.DataFrame(
        {
            "t": np.repeat(t_all, n),
            "robot": np.tile(np.arange(n), s + 1),
            "x": pos[..., 0].ravel(),
            "y": pos[..., 1].ravel(),
            "z": pos[..., 2].ravel(),
            "action": act.ravel(),
        }
    )


def _metrics(log) -> pd.DataFrame:
    s, n = log.actions.shape
    cols: dict[str, Any] = {"t": np.repeat(log.times, n), "robot": np.tile(np.arange(n), s)}
    names = METRICS_COLUMNS[2:] + [k for k in log.per_robot if k not in METRICS_COLUMNS]
    for name in names:
        arr = log.per_robot.get(name)
        cols[name] = (arr if arr is not None else np.zeros((s, n))).ravel()
    return pd.DataFrame(cols)


def _swarm(log) -> pd.DataFrame:
    cols: dict[str, Any] = {"t": log.times}
    names = ["mean_payoff"] + [k for k in log.swarm if k not in ("mean_payoff", *NETWORK_COLUMNS)]
    for name in names + [c for c in NETWORK_COLUMNS if c in log.swarm]:
        cols[name] = log.swarm.get(name, np.zeros(0))  # no stage: no mean_payoff either
    return pd.DataFrame(cols)


def _finite_median(values) -> float | None:
    """Median of the finite values, or None (no stage, nothing finite)."""
    if values is None:
        return None
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else None


def _finite_max(values) -> float | None:
    """Largest finite value, None if there is none."""
    v = np.asarray([] if values is None else values, dtype=float)
    v = v[np.isfinite(v)]
    return float(v.max()) if v.size else None


def _finite_mean(values) -> float | None:
    """Mean of the finite values, or None (no stage, or nothing finite)."""
    if values is None:
        return None
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(v.mean()) if v.size else None


def summarise(log, config, mission, wall_s: float) -> dict[str, Any]:
    """Headline numbers of a run (``summary.json``); the mission's own (its ``summary`` hook,
    if any) follow the payoff."""
    s, n = log.actions.shape
    # A robot moves in a stage when its position changes (the action set may have several
    # actions that keep it in place, or none: a coasting UAV still moves).
    disp = np.linalg.norm(np.diff(log.states[..., :3], axis=0), axis=-1)  # (S, N)
    moving = disp > 1e-6
    any_moving = moving.any(axis=1)
    still_from = s - int(np.argmax(any_moving[::-1])) if any_moving.any() else 0
    if s and not any_moving.any():
        still_from = 0
    settled = bool(s and not any_moving[-1])
    pr = log.per_robot
    sw = log.swarm

    mp = sw.get("mean_payoff", np.zeros(0))
    p0, p1 = (float(mp[0]), float(mp[-1])) if len(mp) else (None, None)
    summary_hook = MissionHooks.of(mission).summary
    own = dict(summary_hook(log.times, dict(sw))) if summary_hook is not None else {}
    osc = sw.get("oscillation", np.zeros(0))
    lr = pr.get("local_regret", np.zeros((0, n)))
    gr = pr.get("global_regret", np.zeros((0, n)))
    er = pr.get("expost_regret", np.zeros((0, n)))
    return {
        "scenario": config.name,
        "mission": getattr(mission, "name", config.scenario),
        "seed": config.seed,
        "controller": config.sim.controller,
        "solver": config.game.solver,
        "network": config.network.backend,
        "virtual_mean": config.game.virtual_mean,
        "n_robots": n,
        "stages": s,
        "interrupted": bool(log.interrupted),
        "mean_payoff_start": p0,
        "mean_payoff_end": p1,
        **own,
        "consensus": settled,
        "settled_at_s": float(log.times[still_from]) if settled and s else None,
        "moving_robots_last_stage": int(moving[-1].sum()) if s else 0,
        "mean_oscillation": float(np.mean(osc)) if len(osc) else None,
        "max_oscillation": float(np.max(osc)) if len(osc) else None,
        "median_local_regret": _finite_median(lr),
        "fraction_local_regret_zero": (
            float(np.mean(lr[np.isfinite(lr)] <= 1e-9)) if np.isfinite(lr).any() else None
        ),
        "median_global_regret": _finite_median(gr),
        "median_expost_regret": _finite_median(er),
        "mean_hops_end": float(sw["mean_hops"][-1]) if s else None,
        "max_hops_end": int(sw["max_hops"][-1]) if s else None,
        "components_end": int(sw["components"][-1]) if s else None,
        "comms": config.comms.model,
        "mean_info_age_s": _finite_mean(pr.get("info_age_s")),
        "mean_fresh_fraction": _finite_mean(pr.get("fresh_fraction")),
        "bytes_per_robot_stage": _finite_mean(sw.get("bytes_per_robot")),
        "olsr_bytes_per_robot_stage": _finite_mean(sw.get("olsr_bytes_per_robot")),
        "max_channel_load": _finite_max(sw.get("channel_load")),
        "robots_failed": int((~pr["alive"][-1]).sum()) if s and "alive" in pr else 0,
        "robots_without_radio": (
            int((pr["alive"][-1] & ~pr["radio"][-1]).sum()) if s and "radio" in pr else 0
        ),
        "median_solve_ms": _finite_median(pr.get("solve_ms")),
        "median_integrate_ms": _finite_median(pr.get("integrate_ms")),
        "median_refine_ms": _finite_median(pr.get("refine_ms")),
        "median_stage_ms": float(1e3 * np.median(log.stage_s)) if s else None,
        "wall_s": float(wall_s),
    }


@dataclass(eq=False)
class RunResult:
    """Outcome of :func:`swarmgames.run`.

    Attributes
    ----------
    config : ScenarioConfig
        The resolved configuration.
    trajectory, metrics, swarm : pandas.DataFrame
        The tables of ``trajectory.csv``, ``metrics.csv`` and ``swarm.csv``.
    links : list of ndarray
        1-hop links ``(E, 2)`` at every stage.
    summary : dict
        Headline numbers (``summary.json``).
    mission : Mission
        The mission that ran (its drawing hooks serve the plots).
    folder : RunFolder or None
        Where the files were written.
    """

    config: Any
    trajectory: pd.DataFrame
    metrics: pd.DataFrame
    swarm: pd.DataFrame
    links: list
    summary: dict
    mission: Any
    folder: Any = None
    files: list = field(default_factory=list)

    @property
    def interrupted(self) -> bool:
        """Whether Ctrl-C stopped the run early."""
        return bool(self.summary.get("interrupted"))

    @classmethod
    def from_log(cls, log, config, mission, wall_s: float) -> RunResult:
        """Assemble the tables and the summary from a :class:`~swarmgames.sim.loop.StageLog`."""
        return cls(
            config=config,
            trajectory=_trajectory(log),
            metrics=_metrics(log),
            swarm=_swarm(log),
            links=log.links,
            summary=summarise(log, config, mission, wall_s),
            mission=mission,
        )

    @classmethod
    def load(cls, folder, mission=None) -> RunResult:
        """A run folder read back: its configuration, its tables (in whichever format
        ``sim.tables`` wrote them, complete or not) and its summary (empty if the run wrote
        none). The 1-hop links of each stage are not kept in a run folder: ``links`` is empty,
        so ``plot_paths`` draws no links. A folder with a ``manifest.json`` (one that
        :func:`swarmgames.run` wrote) is first checked against it
        (:func:`~swarmgames.sim.journal.verify_run`); every file read is data (TOML, CSV,
        Parquet, JSON).

        Parameters
        ----------
        folder : RunFolder, str or Path
        mission : Mission, optional
            For the plots: the run's mission object if it was not a registered one (default:
            built from the configuration).

        Raises
        ------
        ConfigError, InputDataError
            An unreadable ``config.toml``, table or ``summary.json`` (one line naming it).
        RunFolderError
            A file that does not match the folder's manifest (one line naming it).
        """
        import json
        from pathlib import Path

        from swarmgames.config import load_config
        from swarmgames.errors import InputDataError
        from swarmgames.missions import get_mission
        from swarmgames.sim.journal import MANIFEST, verify_run
        from swarmgames.sim.tables import read_table

        path = Path(getattr(folder, "path", folder))
        if (path / MANIFEST).exists():
            verify_run(path)
        config = load_config(path / "config.toml")
        summary: dict = {}
        if (path / "summary.json").is_file():
            try:
                summary = json.loads((path / "summary.json").read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise InputDataError(f"cannot read {path / 'summary.json'}: {exc}") from None
        return cls(
            config=config,
            trajectory=read_table(path, "trajectory"),
            metrics=read_table(path, "metrics"),
            swarm=read_table(path, "swarm"),
            links=[],
            summary=summary,
            mission=mission if mission is not None else get_mission(config.scenario).build(config),
            folder=folder,
        )

    def to_frame(self, table: Literal["swarm", "metrics", "trajectory"] = "swarm") -> pd.DataFrame:
        """One of the run's tables as a DataFrame (default: the per-stage swarm table)."""
        tables = {"swarm": self.swarm, "metrics": self.metrics, "trajectory": self.trajectory}
        if table not in tables:
            raise ValueError(f"table must be one of {sorted(tables)} (got {table!r})")
        return tables[table].copy()

    def plot(self):
        """Time series of the run (payoff, coverage, regret, network); a matplotlib Figure."""
        from swarmgames.sim.plots import plot_timeseries

        return plot_timeseries(self)

    def plot_paths(self):
        """Paths of the robots over the mission's background with the final links; a
        matplotlib Figure."""
        from swarmgames.sim.plots import plot_paths

        return plot_paths(self)

    def write(self, folder, animation: bool = True, frames: int = 60) -> list:
        """Write config.toml, the CSVs, the PNGs, animation.gif and summary.json."""
        from swarmgames.config import to_toml

        written = [
            folder.write_text("config.toml", to_toml(self.config)),
            folder.write_csv("trajectory.csv", self.trajectory),
            folder.write_csv("metrics.csv", self.metrics),
            folder.write_csv("swarm.csv", self.swarm),
        ]
        self.files = written + self.write_outputs(folder, animation, frames)
        return self.files

    def write_outputs(
        self, folder, animation: bool = True, frames: int = 60, progress=None, figures=True
    ) -> list:
        """Write what is made from the tables at the end: the PNGs, animation.gif and
        summary.json (a run's journal has appended the tables stage by stage).

        ``progress``, if given, is called as ``progress(done, total)`` after each figure and
        each frame of the animation (one unit each); ``figures=False`` writes the summary
        alone (the runs of a sweep), without importing matplotlib."""

        def tick(done: int, total: int) -> None:
            if progress is not None:
                progress(done, total)

        written = []
        if len(self.swarm) and figures:
            total = 2 + (min(int(frames), len(self.swarm)) if animation else 0)
            fig = self.plot()
            written.append(folder.save_figure("timeseries.png", fig))
            tick(1, total)
            fig = self.plot_paths()
            written.append(folder.save_figure("paths.png", fig))
            tick(2, total)
            if animation:
                from swarmgames.sim.animation import render_gif

                cap = int(1e6 * self.config.sim.animation_max_mb)
                gif = render_gif(
                    self, frames, max_bytes=cap, progress=lambda k, m: tick(2 + k, 2 + m)
                )
                written.append(folder.write_bytes("animation.gif", gif))
        written.append(folder.write_json("summary.json", self.summary))
        self.folder = folder
        self.files = written
        return written

    def summary_table(self):
        """The summary as a rich Table (printed at the end of a run)."""
        from rich.table import Table

        table = Table(title=f"swarmgames run: {self.config.name}", show_header=False)
        table.add_column("quantity")
        table.add_column("value", justify="right")
        for key, val in self.summary.items():
            if isinstance(val, float):
                val = f"{val:.4g}"
            table.add_row(key, str(val))
        return table
