"""Figures of a run: time series, and the swarm's paths over the ROI.

Figures are built with :class:`matplotlib.figure.Figure` directly (no pyplot state), so they
can be made from threads and in headless runs.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Ellipse

__all__ = ["draw_roi", "plot_paths", "plot_timeseries"]


def draw_roi(ax, roi, cmap: str = "Greens") -> None:
    """Shade the ROI density on its grid and outline the concentration ellipse."""
    pts = roi.points
    dens = roi.weights / roi.cell_m**2
    ax.scatter(pts[:, 0], pts[:, 1], c=dens, s=2, marker="s", cmap=cmap, alpha=0.5, lw=0)
    lengths, _, angle = roi.semi_axes()
    ax.add_patch(
        Ellipse(
            tuple(roi.mean),
            2 * lengths[0],
            2 * lengths[1],
            angle=np.degrees(angle),
            fill=False,
            ls="--",
            color="tab:green",
            label=f"ROI ({roi.confidence:.0%})",
        )
    )


def plot_timeseries(result) -> Figure:
    """Mean payoff, coverage, local/global regret and the network against time."""
    sw, me = result.swarm, result.metrics
    fig = Figure(figsize=(10, 7), layout="constrained")
    axs = fig.subplots(2, 2, sharex=True)
    axs[0, 0].plot(sw["t"], sw["mean_payoff"], color="tab:blue")
    axs[0, 0].set_ylabel("mean payoff $M_i$ (eq. 1)")
    axs[0, 1].plot(sw["t"], sw["coverage"], color="tab:green")
    axs[0, 1].set_ylabel("coverage: E[best signal] (dBm)")
    grp = me.groupby("t")
    axs[1, 0].plot(
        grp["local_regret"].median().index, grp["local_regret"].median(), label="local, median"
    )
    axs[1, 0].plot(
        grp["local_regret"].max().index, grp["local_regret"].max(), label="local, max", alpha=0.6
    )
    axs[1, 0].plot(
        grp["global_regret"].median().index, grp["global_regret"].median(), label="global, median"
    )
    axs[1, 0].set_ylabel("regret")
    axs[1, 0].legend(fontsize="small")
    axs[1, 1].plot(sw["t"], sw["mean_hops"], label="mean hops")
    axs[1, 1].plot(sw["t"], sw["max_hops"], label="max hops")
    axs[1, 1].plot(sw["t"], sw["components"], label="components")
    tr = result.trajectory
    n = int(tr["robot"].max()) + 1
    xyz = tr[["x", "y", "z"]].to_numpy().reshape(-1, n, 3)
    moving = (np.linalg.norm(np.diff(xyz, axis=0), axis=-1) > 1e-6).sum(axis=1)
    axs[1, 1].plot(tr["t"].to_numpy()[::n][:-1], moving, label="moving robots", ls=":")
    axs[1, 1].set_ylabel("network / motion")
    axs[1, 1].legend(fontsize="small")
    for ax in axs[1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(
        f"{result.config.name}: {result.summary['n_robots']} robots, "
        f"{result.config.network.backend} network, {result.config.sim.controller} controller"
    )
    return fig


def plot_paths(result) -> Figure:
    """Every robot's path over the ROI, start and end marked, final 1-hop links drawn."""
    fig = Figure(figsize=(7, 6.5), layout="constrained")
    ax = fig.subplots()
    draw_roi(ax, result.roi)
    tr = result.trajectory
    n = int(tr["robot"].max()) + 1 if len(tr) else 0
    xy = tr[["x", "y"]].to_numpy().reshape(-1, n, 2) if n else np.zeros((0, 0, 2))
    for i in range(n):
        ax.plot(xy[:, i, 0], xy[:, i, 1], lw=0.8, alpha=0.8)
    if len(xy):
        ax.scatter(xy[0, :, 0], xy[0, :, 1], marker="x", color="k", s=15, label="start")
        ax.scatter(xy[-1, :, 0], xy[-1, :, 1], marker="o", color="tab:red", s=25, label="end")
        if result.links:
            for a, b in result.links[-1]:
                ax.plot(*xy[-1, [a, b]].T, color="tab:gray", lw=0.6, alpha=0.7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right", fontsize="small")
    ax.set_title("paths and final 1-hop links")
    return fig
