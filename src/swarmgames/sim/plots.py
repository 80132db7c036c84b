"""Figures of a run: time series, and the swarm's paths over the mission's background.

Figures are built with :class:`matplotlib.figure.Figure` directly (no pyplot state), so they
can be made from threads and in headless runs. What belongs to a mission (its metrics, its
region or goal) comes from the mission's own columns and its optional ``draw(ax)`` hook.
"""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from swarmgames.labels import column_label
from swarmgames.missions.protocol import MissionHooks
from swarmgames.sim.result import NETWORK_COLUMNS

__all__ = [
    "DENSE_ROBOTS",
    "draw_background",
    "link_lines",
    "link_segments",
    "mission_columns",
    "plot_paths",
    "plot_timeseries",
    "steady_axis",
]

#: Above this many robots the figures draw thinner, fainter lines and smaller markers (and
#: the animation the swarm's density), so that a swarm stays readable instead of a blot.
DENSE_ROBOTS = 300


def _cycle(n: int) -> list:
    """Matplotlib's default colour cycle over ``n`` lines."""
    from matplotlib import rcParams

    colours = rcParams["axes.prop_cycle"].by_key()["color"]
    return [colours[i % len(colours)] for i in range(n)]


def link_segments(xy: np.ndarray, edges: np.ndarray, wide: bool = False):
    """The segments of the 1-hop links ``edges`` (E, 2) between the positions ``xy`` (N, 2);
    ``wide``: all of them one polyline broken by NaN (a segment each costs matplotlib a
    Python object: 60 ms for the 7 000 links of 1 000 UAVs). An array (E, 2, 2), or a list
    of one polyline (3 E, 2)."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    segments = xy[edges]
    if wide and len(segments):
        gaps = np.full((len(segments), 1, 2), np.nan)
        return [np.concatenate([segments, gaps], axis=1).reshape(-1, 2)]
    return segments


def link_lines(xy: np.ndarray, edges: np.ndarray, wide: bool = False) -> LineCollection:
    """The 1-hop links ``edges`` (E, 2) between the positions ``xy`` (N, 2) as one
    collection (:func:`link_segments`); ``wide`` (a swarm of more than
    :data:`DENSE_ROBOTS`): thin, faint lines."""
    return LineCollection(
        link_segments(xy, edges, wide),
        colors="0.5",
        linewidths=0.3 if wide else 0.7,
        alpha=0.35 if wide else 0.8,
    )


def mission_columns(result) -> list[str]:
    """The mission's own columns of ``swarm.csv``, in file order."""
    own = {"t", "mean_payoff", *NETWORK_COLUMNS}
    return [c for c in result.swarm.columns if c not in own]


def draw_background(ax, mission) -> None:
    """The mission's background (its ``draw`` hook), if it has one."""
    draw = MissionHooks.of(mission).draw
    if draw is not None:
        draw(ax)


def _moving(result) -> tuple[np.ndarray, np.ndarray]:
    tr = result.trajectory
    n = int(tr["robot"].max()) + 1
    xyz = tr[["x", "y", "z"]].to_numpy().reshape(-1, n, 3)
    moving = (np.linalg.norm(np.diff(xyz, axis=0), axis=-1) > 1e-6).sum(axis=1)
    return tr["t"].to_numpy()[::n][:-1], moving


def steady_axis(ax, values) -> None:
    """Plain tick labels on ``ax``'s y axis (no offset such as "1e-13 + 1e-1"), and a window
    of ±10 % (±1 around 0) around a series whose finite values are all equal up to float
    rounding, so that it is drawn as the flat line it is, not as float noise."""
    ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return
    lo, hi = float(v.min()), float(v.max())
    mid = 0.5 * (lo + hi)
    if hi - lo <= 1e-9 * max(1.0, abs(mid)):
        pad = 0.1 * abs(mid) if mid != 0 else 1.0
        ax.set_ylim(mid - pad, mid + pad)


def _legend_above(ax, handles=None, ncol: int = 3) -> None:
    """The panel's legend above it, outside the plotting area, so that it hides no line."""
    kwargs = {} if handles is None else {"handles": handles}
    ax.legend(
        loc="lower left",
        bbox_to_anchor=(0.0, 1.0),
        ncol=ncol,
        fontsize="small",
        frameon=False,
        borderaxespad=0.2,
        **kwargs,
    )


def plot_timeseries(result) -> Figure:
    """Mean payoff, the mission's metrics, local, global and ex-post regret and the network
    against time; with routed communication, a last row for information age, freshness and bytes.

    One panel per mission metric: the first beside the payoff, the others in further rows.
    Every axis is labelled with its unit (:mod:`swarmgames.labels`); legends stand above their
    panels; a constant series is drawn flat (:func:`steady_axis`).
    """
    sw, me = result.swarm, result.metrics
    own = mission_columns(result)
    extra = own[1:]
    routed = getattr(getattr(result.config, "comms", None), "model", "ideal") != "ideal"
    rows = 2 + -(-len(extra) // 2) + int(routed)
    fig = Figure(figsize=(10, 3.5 * rows), layout="constrained")
    grid = axs = fig.subplots(rows, 2, sharex=True, squeeze=False)
    if routed:
        _comms_row(axs[-1], sw, me)
        axs = axs[:-1]
    axs[0, 0].plot(sw["t"], sw["mean_payoff"], color="tab:blue")
    axs[0, 0].set_ylabel("mean payoff $M_i$ (eq. 1)")
    steady_axis(axs[0, 0], sw["mean_payoff"])
    panels = [axs[0, 1], *axs[2:].ravel()]
    for ax, name in zip(panels, own, strict=False):
        ax.plot(sw["t"], sw[name], color="tab:green")
        ax.set_ylabel(column_label(name))
        steady_axis(ax, sw[name])
    for ax in panels[len(own) :]:
        ax.set_visible(False)
    grp = me.groupby("t")
    reg = axs[1, 0]
    series = [
        (grp["local_regret"].median(), {"label": "local, median"}),
        (grp["local_regret"].max(), {"label": "local, max", "alpha": 0.6}),
        (grp["global_regret"].median(), {"label": "global, median"}),
    ]
    if "expost_regret" in me:
        series.append((grp["expost_regret"].median(), {"label": "ex-post, median", "ls": "--"}))
    for values, style in series:
        reg.plot(values.index, values, **style)
    reg.set_ylabel("regret (payoff units)")
    steady_axis(reg, np.concatenate([v.to_numpy(dtype=float) for v, _ in series]))
    _legend_above(reg, ncol=2)
    net = axs[1, 1]
    net.plot(sw["t"], sw["mean_hops"], label="mean hops")
    net.plot(sw["t"], sw["max_hops"], label="max hops")
    net.plot(sw["t"], sw["components"], label="components")
    t, moving = _moving(result)
    net.plot(t, moving, label="moving robots", ls=":")
    if "alive_robots" in sw and (sw["alive_robots"] < result.summary["n_robots"]).any():
        net.plot(sw["t"], sw["alive_robots"], label="alive robots", ls="-.")
    if "oscillation" in sw:
        n = result.summary["n_robots"]
        net.plot(sw["t"], n * sw["oscillation"], label="oscillating robots", ls="--")
    net.set_ylabel("hops, components, robots")
    net.ticklabel_format(axis="y", useOffset=False, style="plain")
    _legend_above(net)
    for col in range(2):  # the lowest visible panel of each column carries the time axis
        ax = [a for a in grid[:, col] if a.get_visible()][-1]
        ax.set_xlabel("time (s)")
        ax.tick_params(labelbottom=True)
    cfg = result.config
    mission = result.summary.get("mission", cfg.scenario)
    name = cfg.name if mission == cfg.name else f"{cfg.name} ({mission})"
    fig.suptitle(
        f"{name}: {result.summary['n_robots']} robots, {cfg.network.backend} network, "
        f"{cfg.sim.controller} controller"
    )
    return fig


def _comms_row(axs, sw, me) -> None:
    """Information age and freshness (left), bytes per robot and stage (right)."""
    age, fresh = axs
    (line,) = age.plot(
        sw["t"], sw["mean_info_age_s"], color="tab:purple", label="mean information age"
    )
    age.set_ylabel("information age (s)")
    steady_axis(age, sw["mean_info_age_s"])
    share = me.groupby("t")["fresh_fraction"].mean()
    twin = age.twinx()
    (dots,) = twin.plot(share.index, share, color="tab:gray", ls=":", label="fresh share")
    twin.set_ylabel("fresh share of $N_i(h)$")
    twin.set_ylim(0, 1.05)
    _legend_above(age, handles=[line, dots], ncol=2)
    fresh.plot(sw["t"], sw["bytes_per_robot"], color="tab:brown")
    fresh.set_ylabel("state-message bytes per robot and stage\n(sent + relayed)")
    steady_axis(fresh, sw["bytes_per_robot"])


def plot_paths(result) -> Figure:
    """Every robot's path over the mission's background, start and end marked, final 1-hop
    links drawn."""
    fig = Figure(figsize=(7, 6.5), layout="constrained")
    ax = fig.subplots()
    draw_background(ax, result.mission)
    tr = result.trajectory
    n = int(tr["robot"].max()) + 1 if len(tr) else 0
    xy = tr[["x", "y"]].to_numpy().reshape(-1, n, 2) if n else np.zeros((0, 0, 2))
    if len(xy):
        # One collection for all paths and one for the links: drawing stays fast at 10 000.
        wide = n > DENSE_ROBOTS
        paths = LineCollection(
            np.swapaxes(xy, 0, 1),
            linewidths=0.3 if wide else 0.8,
            alpha=0.3 if wide else 0.8,
            colors=None if wide else _cycle(n),
        )
        ax.add_collection(paths)
        size = 2 if wide else 15
        ax.scatter(xy[0, :, 0], xy[0, :, 1], marker="x", color="k", s=size, label="start")
        ax.scatter(
            xy[-1, :, 0], xy[-1, :, 1], marker="o", color="tab:red", s=size + 10, label="end"
        )
        if result.links:
            ax.add_collection(link_lines(xy[-1], result.links[-1], wide))
        ax.autoscale_view()
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right", fontsize="small")
    ax.set_title("paths and final 1-hop links")
    return fig
