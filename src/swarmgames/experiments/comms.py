"""``swarmgames reproduce comms``: what message loss and failures do to the mission.

The default scenario (communication-aware coverage) is run on several seeds with ideal
delivery, with routed delivery at loss rates from 0 to 50 %, and with routed delivery and
robots crashing halfway through the mission. Every figure comes from the runs'
``summary.json``: coverage at the end, median global regret, when the swarm settled (if it
did), the mean information age and freshness of what the robots used, and the state-message
bytes per robot and stage. Each variant is aggregated over the seeds (mean, standard
deviation, n).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from swarmgames.config import ScenarioConfig, to_toml
from swarmgames.errors import ConfigError

__all__ = ["CommsResult", "reproduce_comms"]

#: Loss rates of the routed runs.
DEFAULT_LOSS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)
#: Numbers of robots that crash at the middle of the mission (routed, no loss).
DEFAULT_CRASHES = (1, 2)
#: The summary figures the experiment reports.
FIGURES = (
    "coverage_end_dbm",
    "median_global_regret",
    "settled_at_s",
    "mean_info_age_s",
    "mean_fresh_fraction",
    "bytes_per_robot_stage",
)


@dataclass(eq=False)
class CommsResult:
    """The runs of the experiment.

    Attributes
    ----------
    runs : DataFrame
        One row per run: ``variant``, ``comms``, ``loss_rate``, ``crashed``, ``seed`` and the
        summary figures (``settled_at_s`` NaN when the swarm did not settle).
    config : ScenarioConfig
        The base scenario.
    """

    runs: pd.DataFrame
    config: Any = None
    summaries: list = field(default_factory=list)

    def aggregate(self) -> pd.DataFrame:
        """Per variant: mean, std and n of every figure over the seeds, and the share of runs
        that settled."""
        keys = ["variant", "comms", "loss_rate", "crashed"]
        grp = self.runs.groupby(keys, sort=False)
        out = grp[list(FIGURES)].agg(["mean", "std", "count"])
        out.columns = [f"{a}_{b}".replace("_count", "_n") for a, b in out.columns]
        out["settled_share"] = grp["settled_at_s"].apply(lambda s: float(s.notna().mean()))
        return out.reset_index()

    def plot(self) -> Figure:
        """Coverage, information age and freshness against the loss rate (mean ± std over
        the seeds, ideal delivery as a reference line), and coverage against failures."""
        agg = self.aggregate()
        fig = Figure(figsize=(12, 3.8), layout="constrained")
        axs = fig.subplots(1, 3)
        routed = agg[(agg["comms"] == "routed") & (agg["crashed"] == 0)]
        ideal = agg[agg["comms"] == "ideal"]
        csma = agg[agg["comms"] == "csma"]
        for ax, name, label in (
            (axs[0], "coverage_end_dbm", "coverage at the end (dBm)"),
            (axs[1], "mean_info_age_s", "mean information age (s)"),
        ):
            ax.errorbar(
                100 * routed["loss_rate"],
                routed[f"{name}_mean"],
                yerr=routed[f"{name}_std"].fillna(0.0),
                marker="o",
                capsize=3,
                label="routed",
            )
            if len(ideal):
                ax.axhline(float(ideal[f"{name}_mean"].iloc[0]), ls="--", color="k", label="ideal")
            if len(csma):
                ax.axhline(
                    float(csma[f"{name}_mean"].iloc[0]),
                    ls=":",
                    color="tab:red",
                    label="csma (shared channel)",
                )
            ax.set_xlabel("loss rate (%)")
            ax.set_ylabel(label)
            ax.legend(fontsize="small")
        crash = agg[agg["comms"] == "routed"].sort_values("crashed")
        crash = crash[(crash["loss_rate"] == 0.0)]
        axs[2].errorbar(
            crash["crashed"],
            crash["coverage_end_dbm_mean"],
            yerr=crash["coverage_end_dbm_std"].fillna(0.0),
            marker="s",
            capsize=3,
        )
        axs[2].set_xticks(crash["crashed"].tolist())
        axs[2].set_xlabel("robots crashed at mid-mission")
        axs[2].set_ylabel("coverage at the end (dBm)")
        fig.suptitle("communication: loss and failures (default scenario, mean ± std over seeds)")
        return fig

    def write(self, folder) -> list:
        """Write ``runs.csv``, ``aggregate.csv``, ``comms.png``, ``summary.json`` and the base
        ``config.toml`` into a :class:`~swarmgames.runfolder.RunFolder`."""
        files = [
            folder.write_csv("runs.csv", self.runs),
            folder.write_csv("aggregate.csv", self.aggregate()),
            folder.save_figure("comms.png", self.plot()),
        ]
        if self.config is not None:
            files.append(folder.write_text("config.toml", to_toml(self.config)))
        files.append(folder.write_json("summary.json", {"runs": self.summaries}))
        return files


def _variants(base: ScenarioConfig, loss_rates, crashes) -> list[tuple[str, dict]]:
    n = base.swarm.n_robots
    mid = base.sim.warmup_s + base.sim.duration_s / 2
    out = [("ideal", {"comms.model": "ideal"}), ("csma", {"comms.model": "csma"})]
    out += [
        (f"routed, {p:.0%} loss", {"comms.model": "routed", "comms.loss_rate": p})
        for p in loss_rates
    ]
    for k in crashes:
        if k >= n:
            raise ConfigError(f"crashes must be < swarm.n_robots = {n} (got {k})")
        crash = [[mid, robot] for robot in range(k)]
        out.append((f"routed, {k} crashed", {"comms.model": "routed", "faults.crash": crash}))
    return out


def reproduce_comms(
    *,
    base: ScenarioConfig | None = None,
    seeds: Sequence[int] = (0, 1, 2),
    loss_rates: Sequence[float] = DEFAULT_LOSS,
    crashes: Sequence[int] = DEFAULT_CRASHES,
    progress: bool = True,
) -> CommsResult:
    """Run the experiment (module notes).

    Parameters
    ----------
    base : ScenarioConfig, optional
        The scenario every run starts from (default: the default scenario); animations and
        the global regret's cost stay as it sets them.
    seeds : sequence of int
        Seeds of every variant.
    loss_rates : sequence of float
        Loss rates of the routed runs, in [0, 1].
    crashes : sequence of int
        Numbers of robots (0, 1, ...) that crash at the middle of the mission.
    progress : bool
        Show a progress bar over the runs.

    Raises
    ------
    ConfigError
        No seed, a loss rate outside [0, 1], or more crashes than robots.
    """
    from swarmgames.sim import run
    from swarmgames.sim.progress import ProgressBar

    base = ScenarioConfig() if base is None else base
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ConfigError("seeds must not be empty")
    jobs = [(v, o, s) for v, o in _variants(base, loss_rates, crashes) for s in seeds]
    rows, summaries = [], []
    with ProgressBar("communication runs", progress, total=len(jobs)) as tick:
        for done, (variant, overrides, seed) in enumerate(jobs, 1):
            cfg = base.with_overrides(
                {**overrides, "seed": seed, "sim.animation": False, "name": "comms"}
            )
            s = run(cfg, None, progress=False).summary
            summaries.append({"variant": variant, **s})
            rows.append(
                {
                    "variant": variant,
                    "comms": cfg.comms.model,
                    "loss_rate": cfg.comms.loss_rate,
                    "crashed": len(cfg.faults.crash),
                    "seed": seed,
                    **{k: np.nan if s.get(k) is None else s[k] for k in FIGURES},
                }
            )
            if tick is not None:
                tick(done)
    return CommsResult(pd.DataFrame(rows), base, summaries)
