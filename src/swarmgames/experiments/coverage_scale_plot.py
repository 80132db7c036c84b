"""The figure of the coverage-at-scale study (:mod:`swarmgames.experiments.coverage_scale`):
final coverage, components at the end, the share of take-off links lost and the component
splits during the run against the swarm size, one series per variant, the mean over the seeds
with its 95 % interval and every run as a dot, and the take-off value (the same for every
variant of a seed) as a dashed line."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

__all__ = ["PANELS", "plot_coverage_scale"]

#: ``(measure, axis label, the measure at take-off or None, counts)`` of each panel, left to
#: right. A panel of counts gets a log axis when they span a factor of 20 or more (linear up
#: to 1 where some are 0), and its intervals stop at 0.
PANELS = (
    ("coverage_end_dbm", "final coverage (dBm)", "coverage_start_dbm", False),
    ("components_end", "components at the end", "components_start", True),
    ("links_lost_share", "take-off links lost (share)", None, False),
    ("splits", "component splits in the run", None, True),
)
#: Colour and marker of each variant.
STYLES = {
    "game": ("tab:blue", "o"),
    "game-nolink": ("tab:orange", "s"),
    "lloyd": ("tab:green", "^"),
}


def plot_coverage_scale(aggregate: pd.DataFrame, runs: pd.DataFrame) -> Figure:
    """One panel per measure of :data:`PANELS` against N (log axis when N spans a factor of
    20 or more): per variant the mean over the seeds and its Student-t 95 % interval as
    error bars, every complete run as a faint dot; the variants sit side by side around each
    N so that their bars do not hide one another. A dashed grey line is the mean at take-off
    where the panel has one.

    Parameters
    ----------
    aggregate : DataFrame
        :meth:`~swarmgames.experiments.coverage_scale.CoverageScaleResult.aggregate`.
    runs : DataFrame
        The study's ``runs.csv``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    sizes = sorted(runs["n_robots"].unique())
    log = sizes[0] > 0 and sizes[-1] >= 20 * sizes[0]
    variants = [v for v in STYLES if v in set(runs["variant"])]
    done = runs[runs["status"] == "complete"]
    fig = Figure(figsize=(9.6, 2.9), layout="constrained")
    axes = fig.subplots(1, len(PANELS))
    for ax, (metric, label, start, counts) in zip(axes, PANELS, strict=True):
        if start is not None:
            first = aggregate[
                (aggregate["variant"] == variants[0]) & (aggregate["metric"] == start)
            ]
            first = first.sort_values("n_robots")
            ax.plot(
                first["n_robots"], first["mean"], color="0.45", ls="--", lw=1.0, label="take-off"
            )
        for k, variant in enumerate(variants):
            colour, marker = STYLES[variant]
            shift = (k - (len(variants) - 1) / 2) * 0.06
            rows = aggregate[(aggregate["variant"] == variant) & (aggregate["metric"] == metric)]
            rows = rows.sort_values("n_robots")
            xs = _shifted(rows["n_robots"].to_numpy(dtype=float), shift, log)
            mean = rows["mean"].to_numpy(dtype=float)
            low = rows["ci_low"].to_numpy(float)
            low = np.maximum(low, 0.0) if counts else low
            err = np.nan_to_num(np.vstack([mean - low, rows["ci_high"] - mean]), nan=0.0)
            ax.errorbar(
                xs,
                mean,
                yerr=err,
                color=colour,
                marker=marker,
                ms=4,
                lw=1.2,
                capsize=2.5,
                label=variant,
            )
            mine = done[done["variant"] == variant]
            ax.plot(
                _shifted(mine["n_robots"].to_numpy(dtype=float), shift, log),
                mine[metric].to_numpy(dtype=float),
                ls="none",
                marker=marker,
                ms=2.5,
                color=colour,
                alpha=0.35,
            )
        if log:
            ax.set_xscale("log")
            ax.minorticks_off()
        ax.set_xticks(sizes, [f"{n:,}" for n in sizes])
        values = done[metric].dropna()
        positive = values[values > 0]
        if counts and len(positive) and values.max() >= 20 * max(1.0, positive.min()):
            if values.min() >= 1:
                ax.set_yscale("log")
            else:
                ax.set_yscale("symlog", linthresh=1.0, linscale=0.5)
                ax.set_ylim(bottom=0.0)
            ax.yaxis.set_major_formatter("{x:g}")
        ax.set_xlabel("UAVs N")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, lw=0.5)
        ax.tick_params(labelsize="small")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(
        handles,
        labels,
        loc="outside lower center",
        ncols=len(labels),
        frameon=False,
        fontsize="small",
    )
    counted = aggregate.loc[aggregate["variant"].isin(variants), "n"]
    low, high = int(counted.min()), int(counted.max())
    seeds = f"{low}" if low == high else f"{low}\u2013{high}"
    fig.suptitle(
        f"coverage-large at constant density: mean and 95 % interval over {seeds} seeds "
        "per point, runs as dots",
        fontsize="small",
    )
    return fig


def _shifted(x: np.ndarray, shift: float, log: bool) -> np.ndarray:
    """``x`` moved by ``shift`` decades on a log axis, or by ``shift`` of its value."""
    return x * 10.0**shift if log else x * (1.0 + shift)
