"""The paper's Figure 2: payoff against time for several swarm sizes, and compute cost.

Figure 2a plots the average payoff of a robot against time for swarms of several sizes, with
and without virtual mean neighbours (eq. 3); Figure 2b the time of the local-game
optimisation and of the payoff integration against swarm size. Both come from full coverage
runs (:func:`swarmgames.run`) of the same scenario that differ only in ``swarm.n_robots`` and
``game.virtual_mean`` (``"eq3"``, the paper's virtual means, against ``"off"``; the other
variants of :data:`~swarmgames.names.VIRTUAL_MEANS` can be added).

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section III and Fig. 2.
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

__all__ = ["Fig2Result", "reproduce_fig2"]

#: Swarm sizes of the reproduction (the paper shows swarms up to 7; 10 and 20 extend it).
DEFAULT_SIZES = (3, 5, 7, 10, 20)


@dataclass(eq=False)
class Fig2Result:
    """Data of Figure 2.

    Attributes
    ----------
    payoff : DataFrame
        Figure 2a, one row per (n_robots, virtual_mean, t): ``mean_payoff`` (average payoff
        of a robot, eq. 1), ``coverage`` (dBm).
    timing : DataFrame
        Figure 2b, one row per (n_robots, virtual_mean): median and 90th percentile of the
        per-local-game solve time and payoff-integration time (ms), and the median stage
        time (ms) of the whole swarm.
    summaries : list of dict
        ``summary.json`` of every run.
    config : ScenarioConfig
        The base scenario.
    """

    payoff: pd.DataFrame
    timing: pd.DataFrame
    summaries: list = field(default_factory=list)
    config: Any = None

    def plot(self) -> Figure:
        """Both panels of Figure 2 as one matplotlib Figure."""
        fig = Figure(figsize=(11, 4.2), layout="constrained")
        ax_a, ax_b = fig.subplots(1, 2)
        sizes = sorted(self.payoff["n_robots"].unique())
        colours = {n: f"C{i}" for i, n in enumerate(sizes)}
        for (n, vm), grp in self.payoff.groupby(["n_robots", "virtual_mean"]):
            ax_a.plot(
                grp["t"],
                grp["mean_payoff"],
                color=colours[n],
                ls=_LINES.get(vm, ":"),
                label=f"N = {n}" + ("" if vm == "eq3" else f", virtual_mean = {vm}"),
            )
        ax_a.set_xlabel("time (s)")
        ax_a.set_ylabel("average payoff of a robot (eq. 1)")
        ax_a.set_title("(a) payoff against time")
        ax_a.legend(fontsize="x-small", ncol=2)
        shown = "eq3" if (self.timing["virtual_mean"] == "eq3").any() else None
        tm = self.timing
        if shown is not None:
            tm = tm[tm["virtual_mean"] == shown]
        ax_b.plot(tm["n_robots"], tm["solve_ms_median"], "o-", color="tab:blue", label="solve")
        ax_b.plot(
            tm["n_robots"], tm["integrate_ms_median"], "s-", color="tab:red", label="integration"
        )
        ax_b.fill_between(tm["n_robots"], tm["solve_ms_median"], tm["solve_ms_p90"], alpha=0.2)
        ax_b.fill_between(
            tm["n_robots"],
            tm["integrate_ms_median"],
            tm["integrate_ms_p90"],
            alpha=0.2,
            color="tab:red",
        )
        ax_b.set_xlabel("swarm size N")
        ax_b.set_ylabel("time per local game (ms), median to p90")
        ax_b.set_title("(b) local-game optimisation and payoff integration")
        ax_b.legend()
        return fig

    def write(self, folder) -> list:
        """Write ``fig2a.csv``, ``fig2b.csv``, ``fig2.png``, ``summary.json`` and the base
        ``config.toml`` into a :class:`~swarmgames.runfolder.RunFolder`."""
        files = [
            folder.write_csv("fig2a.csv", self.payoff),
            folder.write_csv("fig2b.csv", self.timing),
            folder.save_figure("fig2.png", self.plot()),
        ]
        if self.config is not None:
            files.append(folder.write_text("config.toml", to_toml(self.config)))
        files.append(folder.write_json("summary.json", {"runs": self.summaries}))
        return files


#: Line style of each variant in Figure 2a.
_LINES = {"eq3": "-", "off": "--", "outside": "-.", "exact": (0, (1, 1))}

#: Run names of the paper's two variants in Figure 2 (``vm``: eq. 3's virtual means, ``novm``:
#: none).
_NAMES = {"eq3": "vm", "off": "novm"}


def _variant(base: ScenarioConfig, n: int, virtual_mean: str, seed: int) -> ScenarioConfig:
    return base.with_overrides(
        {
            "swarm.n_robots": n,
            "game.virtual_mean": virtual_mean,
            "sim.animation": False,
            "seed": seed,
            "name": f"fig2-n{n}-{_NAMES.get(virtual_mean, virtual_mean)}",
        }
    )


def reproduce_fig2(
    sizes: Sequence[int] = DEFAULT_SIZES,
    *,
    base: ScenarioConfig | None = None,
    seed: int = 0,
    duration_s: float | None = None,
    virtual_mean: Sequence[str | bool] = ("eq3", "off"),
    progress: bool = True,
) -> Fig2Result:
    """Run the coverage mission for every swarm size, with and without virtual means.

    Parameters
    ----------
    sizes : sequence of int
        Swarm sizes (default 3, 5, 7, 10, 20).
    base : ScenarioConfig, optional
        Scenario the runs share (default: the default scenario with ``comms.model =
        "ideal"``: the paper's runs gave every robot its neighbours' exact states, and with
        routed messages the virtual means differ, each S̄_j being the mean of what robot j
        has heard).
    seed : int
        Seed of every run (same take-off draw for both virtual-mean settings).
    duration_s : float, optional
        Override ``sim.duration_s``.
    virtual_mean : sequence of str or bool
        Settings of ``game.virtual_mean`` to compare (default ``("eq3", "off")``, the paper's
        with and without eq. 3; True and False name the same two).
    progress : bool
        Show a progress bar over the runs.

    Returns
    -------
    Fig2Result

    Raises
    ------
    ConfigError
        Empty or non-positive ``sizes``, or an invalid ``duration_s``.
    """
    from swarmgames.sim import run
    from swarmgames.sim.progress import ProgressBar

    if base is None:
        base = ScenarioConfig().with_overrides({"comms.model": "ideal"})
    sizes = [int(n) for n in sizes]
    if not sizes or min(sizes) < 1:
        raise ConfigError(f"sizes must be a non-empty list of integers >= 1 (got {sizes})")
    if duration_s is not None:
        if not duration_s > 0:
            raise ConfigError(f"duration_s must be > 0 (got {duration_s})")
        base = base.with_overrides({"sim.duration_s": float(duration_s)})
    from swarmgames.game.virtual import virtual_mode

    try:
        modes = [virtual_mode(vm) for vm in virtual_mean]
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    jobs = [(n, vm) for n in sizes for vm in modes]
    rows, timing, summaries = [], [], []
    with ProgressBar("Figure 2 runs", progress, total=len(jobs)) as tick:
        for done, (n, vm) in enumerate(jobs, 1):
            res = run(_variant(base, n, vm, seed), None, progress=False)
            sw = res.to_frame()
            rows.append(
                pd.DataFrame(
                    {
                        "n_robots": n,
                        "virtual_mean": vm,
                        "t": sw["t"],
                        "mean_payoff": sw["mean_payoff"],
                        "coverage": sw["coverage"],
                    }
                )
            )
            me = res.to_frame("metrics").groupby("t")[["solve_ms", "integrate_ms"]].first()
            timing.append(
                {
                    "n_robots": n,
                    "virtual_mean": vm,
                    "solve_ms_median": float(np.median(me["solve_ms"])),
                    "solve_ms_p90": float(np.percentile(me["solve_ms"], 90)),
                    "integrate_ms_median": float(np.median(me["integrate_ms"])),
                    "integrate_ms_p90": float(np.percentile(me["integrate_ms"], 90)),
                    "stage_ms_median": res.summary["median_stage_ms"],
                    "final_coverage_dbm": res.summary["coverage_end_dbm"],
                }
            )
            summaries.append(res.summary)
            if tick is not None:
                tick(done)
    return Fig2Result(
        payoff=pd.concat(rows, ignore_index=True),
        timing=pd.DataFrame(timing),
        summaries=summaries,
        config=base,
    )
