"""GIF animation of a run: the swarm over the mission's background with its links and one
neighbourhood.

Frames are drawn with matplotlib's Agg canvas and assembled with Pillow in memory, so the GIF
is written to the run folder atomically in one piece.
"""

from __future__ import annotations

import io

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from swarmgames.sim.plots import draw_background

__all__ = ["render_gif"]


def render_gif(result, max_frames: int = 60, fps: int = 8) -> bytes:
    """The animation as GIF bytes: robots, 1-hop links (grey) and robot 0's 2-hop
    neighbourhood (orange) at up to ``max_frames`` evenly spaced stages; a robot without a
    radio is grey, a crashed one a black cross."""
    from PIL import Image

    tr = result.trajectory
    n = int(tr["robot"].max()) + 1
    xy = tr[["x", "y"]].to_numpy().reshape(-1, n, 2)[:-1]  # positions at each stage
    times = tr["t"].to_numpy()[::n][:-1]
    s = len(xy)
    if s == 0:
        raise ValueError("cannot animate a run without stages")
    idx = np.unique(np.linspace(0, s - 1, min(max_frames, s)).round().astype(int))
    lo, hi = xy.reshape(-1, 2).min(axis=0), xy.reshape(-1, 2).max(axis=0)
    extent = getattr(result.mission, "extent", None)
    if extent is not None:  # keep the mission's area in view too
        box = np.asarray(extent(), dtype=float)
        lo, hi = np.minimum(lo, box[::2]), np.maximum(hi, box[1::2])
    pad = max(0.05 * float(np.max(hi - lo)), 1.0)  # metres around what the frames show
    alive, radio = _flags(result, "alive", s, n), _flags(result, "radio", s, n)
    fig = Figure(figsize=(5, 5), dpi=80)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    frames = []
    for k in idx:
        ax.clear()
        draw_background(ax, result.mission)
        edges = result.links[k]
        for a, b in edges:
            ax.plot(*xy[k, [a, b]].T, color="0.5", lw=0.7)
        near = _two_hop(edges, n, 0)
        ok = alive[k] & radio[k]
        ax.scatter(xy[k, ok, 0], xy[k, ok, 1], s=18, color="tab:blue", zorder=3)
        deaf = alive[k] & ~radio[k]
        ax.scatter(xy[k, deaf, 0], xy[k, deaf, 1], s=22, color="0.6", zorder=3)
        dead = ~alive[k]
        ax.scatter(xy[k, dead, 0], xy[k, dead, 1], s=40, marker="x", color="k", zorder=4)
        ax.scatter(xy[k, near, 0], xy[k, near, 1], s=30, color="tab:orange", zorder=4)
        ax.scatter(xy[k, 0, 0], xy[k, 0, 1], s=70, color="red", edgecolors="k", zorder=5)
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.set_title(f"t = {times[k]:.0f} s  (robot 0 red, its N(2) orange)", fontsize=9)
        canvas.draw()
        rgba = np.asarray(canvas.buffer_rgba())
        frames.append(Image.fromarray(rgba[..., :3].copy()).quantize(colors=128))
    buf = io.BytesIO()
    frames[0].save(
        buf,
        format="GIF",
        save_all=True,
        append_images=frames[1:],
        duration=int(1000 / fps),
        loop=0,
    )
    return buf.getvalue()


def _flags(result, name: str, s: int, n: int) -> np.ndarray:
    """A per-robot boolean column of metrics.csv as (S, N); all true when absent."""
    m = result.metrics
    if name not in m:
        return np.ones((s, n), dtype=bool)
    return m[name].to_numpy(dtype=bool).reshape(-1, n)[:s]


def _two_hop(edges: np.ndarray, n: int, i: int) -> np.ndarray:
    """Robots within 2 hops of ``i`` on the 1-hop link graph (excluding ``i``)."""
    if len(edges) == 0:
        return np.zeros(0, dtype=int)
    touch = (edges == i).any(axis=1)
    one = np.unique(edges[touch])
    two = np.unique(edges[np.isin(edges, one).any(axis=1)])
    return two[(two != i) & (two < n)]
