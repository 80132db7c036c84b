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

from swarmgames.sim.plots import DENSE_ROBOTS, draw_background, link_lines

__all__ = ["draw_frame", "render_gif"]


def render_gif(result, max_frames: int = 60, fps: int = 8, max_bytes: int = 8_000_000) -> bytes:
    """The animation as GIF bytes, at most ``max_frames`` evenly spaced stages and (about)
    ``max_bytes``.

    Every frame shows the mission's background, the 1-hop links (grey), robot 0 (red) and its
    2-hop neighbourhood (orange), robots without a radio (grey) and crashed robots (black
    crosses). Up to :data:`~swarmgames.sim.plots.DENSE_ROBOTS` robots each robot is a dot;
    above, the swarm is drawn as its density (robots per cell of a 60 x 60 grid over the
    frame, blue), with the links faint, so that a large swarm reads as where it is thick and
    where it is thin, not as a blot. A GIF larger than ``max_bytes`` is drawn again with
    half the frames (down to 2).

    Raises
    ------
    ValueError
        The run has no stage.
    """
    tr = result.trajectory
    n = int(tr["robot"].max()) + 1
    xy = tr[["x", "y"]].to_numpy().reshape(-1, n, 2)
    s = len(result.swarm)
    if s == 0:
        raise ValueError("cannot animate a run without stages")
    xy, times = xy[:s], tr["t"].to_numpy()[::n][:s]  # positions at each stage
    frames = max(2, int(max_frames))
    while True:
        idx = np.unique(np.linspace(0, s - 1, min(frames, s)).round().astype(int))
        data = _gif(result, xy, times, idx, fps)
        if len(data) <= max_bytes or len(idx) <= 2:
            return data
        frames = len(idx) // 2


def _bounds(mission, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What the frames show: every position of ``xy`` (..., 2) and the mission's area, with a
    margin."""
    pts = np.asarray(xy, dtype=float).reshape(-1, 2)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    extent = getattr(mission, "extent", None)
    if extent is not None:  # keep the mission's area in view too
        box = np.asarray(extent(), dtype=float)
        lo, hi = np.minimum(lo, box[::2]), np.maximum(hi, box[1::2])
    pad = max(0.05 * float(np.max(hi - lo)), 1.0)  # metres around what the frames show
    return lo - pad, hi + pad


def _draw(ax, mission, xy, edges, alive, radio, t: float, lo, hi) -> None:
    """One frame on ``ax`` (see :func:`render_gif`)."""
    ax.clear()
    _draw_background(ax, mission, lo, hi)
    _draw_swarm(ax, xy, edges, alive, radio, t, lo, hi)


def _draw_background(ax, mission, lo, hi) -> None:
    """What every frame shares: the mission's background and the view."""
    draw_background(ax, mission)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")


def _draw_swarm(ax, xy, edges, alive, radio, t: float, lo, hi) -> list:
    """What changes from frame to frame; returns its artists."""
    n = xy.shape[0]
    wide = n > DENSE_ROBOTS
    artists = [ax.add_collection(link_lines(xy, edges, wide), autolim=False)]
    near = _two_hop(edges, n, 0)
    ok = alive & radio
    if wide:
        counts, ex, ey = np.histogram2d(
            xy[ok, 0], xy[ok, 1], bins=60, range=[[lo[0], hi[0]], [lo[1], hi[1]]]
        )
        artists.append(
            ax.imshow(
                np.ma.masked_equal(counts.T, 0),
                origin="lower",
                extent=(ex[0], ex[-1], ey[0], ey[-1]),
                cmap="Blues",
                vmin=0,
                aspect="auto",
                zorder=2,
                interpolation="nearest",
            )
        )
    else:
        artists.append(ax.scatter(xy[ok, 0], xy[ok, 1], s=18, color="tab:blue", zorder=3))
    deaf = alive & ~radio
    dead = ~alive
    artists += [
        ax.scatter(xy[deaf, 0], xy[deaf, 1], s=8 if wide else 22, color="0.6", zorder=3),
        ax.scatter(xy[dead, 0], xy[dead, 1], s=12 if wide else 40, marker="x", color="k", zorder=4),
        ax.scatter(xy[near, 0], xy[near, 1], s=8 if wide else 30, color="tab:orange", zorder=4),
        ax.scatter(xy[0, 0], xy[0, 1], s=70, color="red", edgecolors="k", zorder=5),
    ]
    # imshow and scatter may have widened the view: every frame shows the same one.
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    what = f"{n} robots, density" if wide else "robot 0 red, its N(2) orange"
    ax.set_title(f"t = {t:.0f} s  ({what}; crashed x)", fontsize=9)
    return artists


def _canvas():
    fig = Figure(figsize=(5, 5), dpi=80)
    return FigureCanvasAgg(fig), fig.add_subplot()


def draw_frame(mission, xy, edges, alive, radio, t: float) -> np.ndarray:
    """One frame of the animation as an RGB array (H, W, 3) of uint8: positions ``xy``
    (N, 2), 1-hop ``edges`` (E, 2), the ``alive`` and ``radio`` flags (N,), at time ``t``."""
    xy = np.asarray(xy, dtype=float)
    canvas, ax = _canvas()
    lo, hi = _bounds(mission, xy)
    _draw(ax, mission, xy, np.asarray(edges), np.asarray(alive), np.asarray(radio), t, lo, hi)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def _gif(result, xy: np.ndarray, times: np.ndarray, idx: np.ndarray, fps: int) -> bytes:
    from PIL import Image

    s, n = xy.shape[:2]
    lo, hi = _bounds(result.mission, xy)
    alive, radio = _flags(result, "alive", s, n), _flags(result, "radio", s, n)
    canvas, ax = _canvas()
    _draw_background(ax, result.mission, lo, hi)  # once: each frame replaces only the swarm
    images = []
    for k in idx:
        edges = result.links[k] if k < len(result.links) else np.zeros((0, 2), dtype=int)
        artists = _draw_swarm(ax, xy[k], edges, alive[k], radio[k], times[k], lo, hi)
        canvas.draw()
        rgba = np.asarray(canvas.buffer_rgba())
        images.append(Image.fromarray(rgba[..., :3].copy()).quantize(colors=128))
        for artist in artists:
            artist.remove()
    buf = io.BytesIO()
    images[0].save(
        buf,
        format="GIF",
        save_all=True,
        append_images=images[1:],
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
