"""The paper's Figure 1: neighbours and hop counts of 7 UAVs against their spacing.

Seven UAVs are placed in a line (spacing d between consecutive UAVs) or a hexagon (a centre
and a ring of six at radius d, so ring neighbours are also d apart). For each spacing the
network runs from empty tables until ``settle_s`` (30 s, as in the ns-3 measurements) with the
UAVs still, then every UAV's routing table is read:

* average number of direct neighbours = (1-hop entries) / 7;
* average hop count = mean over routed pairs (unreachable pairs left out).

With the ns-3 defaults the link range is R = 368.84 m, so the curves step at R / k for the line
(k = 1..6: 61.5, 73.8, 92.2, 122.9, 184.4, 368.8 m) and at R / 2, R / sqrt(3), R for the
hexagon (184.4, 212.9, 368.8 m): hence the default sweep in 1 m steps.

References
----------
.. [1] M. Fernando et al., ICRA 2022 workshop, Fig. 1.
.. [2] docs/reference.md section 4 (ns-3 3.44 values for the line and the hexagon).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from swarmgames.config import NetworkConfig
from swarmgames.network.propagation import max_range
from swarmgames.rng import as_generator
from swarmgames.sim.providers import provider_from_config

__all__ = ["Fig1Result", "break_points", "fig1_positions", "reproduce_fig1"]

LAYOUTS = ("line", "hexagon")


def fig1_positions(layout: str, spacing: float) -> np.ndarray:
    """Positions (7, 3) of the line or hexagon layout with spacing ``spacing`` metres.

    Examples
    --------
    >>> fig1_positions("line", 10.0)[:, 0].tolist()
    [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0]
    """
    if layout == "line":
        return np.c_[np.arange(7) * float(spacing), np.zeros(7), np.zeros(7)]
    if layout == "hexagon":
        a = np.arange(6) * np.pi / 3
        ring = np.c_[spacing * np.cos(a), spacing * np.sin(a), np.zeros(6)]
        return np.r_[np.zeros((1, 3)), ring]
    raise ValueError(f"layout must be one of {', '.join(LAYOUTS)} (got {layout!r})")


@dataclass(frozen=True, eq=False)
class Fig1Result:
    """Figure 1 data.

    Attributes
    ----------
    frame : DataFrame
        Columns ``layout, spacing_m, mean_neighbours, mean_hops, routes``; ``mean_hops`` is
        NaN where no UAV has a route.
    backend : str
        Provider used.
    """

    frame: pd.DataFrame
    backend: str

    def to_frame(self) -> pd.DataFrame:
        """The data as a DataFrame (a copy)."""
        return self.frame.copy()

    def steps(self) -> dict[str, list[tuple[float, float]]]:
        """Where the curves step, per layout: pairs ``(last spacing before, first after)`` at
        which the average number of direct neighbours changes.

        With the defaults the hexagon steps at (184, 185), (212, 213) and (368, 369) m.
        """
        out = {}
        for layout, f in self.frame.groupby("layout", sort=False):
            f = f.sort_values("spacing_m")
            d = f["spacing_m"].to_numpy()
            k = f["mean_neighbours"].to_numpy()
            change = np.flatnonzero(np.diff(k) != 0)
            out[str(layout)] = [(float(d[i]), float(d[i + 1])) for i in change]
        return out

    def plot(self):
        """Two panels (line, hexagon), neighbours on the left axis and hops on the right axis,
        as in the paper's Figure 1."""
        import matplotlib.pyplot as plt

        layouts = list(dict.fromkeys(self.frame["layout"]))
        fig, axes = plt.subplots(1, len(layouts), figsize=(5.5 * len(layouts), 4), squeeze=False)
        for ax, layout in zip(axes[0], layouts, strict=True):
            f = self.frame[self.frame["layout"] == layout]
            ax.plot(f["spacing_m"], f["mean_neighbours"], color="tab:blue", drawstyle="steps-mid")
            ax.set_xlabel("spacing (m)")
            ax.set_ylabel("average direct neighbours", color="tab:blue")
            ax2 = ax.twinx()
            ax2.plot(f["spacing_m"], f["mean_hops"], color="tab:red", drawstyle="steps-mid")
            ax2.set_ylabel("average hop count", color="tab:red")
            ax.set_title(f"7 UAVs, {layout} ({self.backend})")
            ax.grid(alpha=0.3)
        fig.tight_layout()
        return fig

    def write(self, run_folder) -> list[Path]:
        """Write ``fig1.csv`` and ``fig1.png`` into a RunFolder (or a folder path)."""

        from swarmgames.runfolder import RunFolder

        run = RunFolder.of(run_folder)
        paths = [run.write_csv("fig1.csv", self.frame)]
        paths.append(run.save_figure("fig1.png", self.plot()))
        return paths


def reproduce_fig1(
    backend: str = "olsr",
    spacings: np.ndarray | None = None,
    layouts: tuple[str, ...] = LAYOUTS,
    settle_s: float = 30.0,
    seed: int | np.random.Generator | None = 0,
    config: NetworkConfig | None = None,
    out=None,
    progress: Callable[[int, int], None] | None = None,
) -> Fig1Result:
    """Sweep the spacing of 7 UAVs and read neighbours and hop counts after settling.

    Parameters
    ----------
    backend : str, default "olsr"
        Provider name (``olsr``, ``oracle``, ``ns3``, ...).
    spacings : array_like, optional
        Spacings in metres (> 0). Default: every metre from 10 to 400 m, which shows every
        break point (184/185, 212/213, 368/369 m with the defaults).
    layouts : tuple of str
        Any of ``"line"`` and ``"hexagon"``.
    settle_s : float, default 30
        Time at which the tables are read, seconds (> 0).
    seed : int, Generator or None
        Seed of the OLSR jitter.
    config : NetworkConfig, optional
        Radio and OLSR parameters (``backend`` overrides its backend).
    out : RunFolder, str or Path, optional
        If given, write ``fig1.csv`` and ``fig1.png`` there.
    progress : callable, optional
        Called as ``progress(done, total)`` after each spacing (for a progress bar).

    Returns
    -------
    Fig1Result

    Examples
    --------
    >>> r = reproduce_fig1("oracle", spacings=[100.0], layouts=("line",))
    >>> r.to_frame()[["mean_neighbours", "mean_hops"]].round(3).values.tolist()
    [[4.286, 1.286]]
    """
    if not np.isfinite(settle_s) or settle_s <= 0:
        raise ValueError(f"settle_s must be > 0 (got {settle_s})")
    for layout in layouts:
        if layout not in LAYOUTS:
            raise ValueError(f"layout must be one of {', '.join(LAYOUTS)} (got {layout!r})")
    spacings = np.arange(10.0, 401.0, 1.0) if spacings is None else np.asarray(spacings, float)
    if (
        spacings.ndim != 1
        or spacings.size == 0
        or not (np.isfinite(spacings) & (spacings > 0)).all()
    ):
        raise ValueError(f"spacings must be a non-empty 1-d array of values > 0 (got {spacings})")
    cfg = (config or NetworkConfig()).model_copy(update={"backend": backend})
    rng = as_generator(seed)
    rows = []
    total = len(layouts) * spacings.size
    for layout in layouts:
        for d in spacings:
            pos = fig1_positions(layout, d)
            provider = provider_from_config(cfg, 7, rng, full_tables=True)
            provider.reset(pos, 0.0)
            snap = provider.advance(settle_s, pos)
            rows.append(
                {
                    "layout": layout,
                    "spacing_m": float(d),
                    "mean_neighbours": float((snap.hops == 1).sum()) / 7,
                    "mean_hops": float(snap.hops.mean()) if snap.n_entries else float("nan"),
                    "routes": snap.n_entries,
                }
            )
            if progress is not None:
                progress(len(rows), total)
    result = Fig1Result(pd.DataFrame(rows), backend)
    if out is not None:
        result.write(out)
    return result


def break_points(config: NetworkConfig | None = None) -> dict[str, list[float]]:
    """Spacings (m) at which the Figure 1 curves step, from the link range R.

    Examples
    --------
    >>> [round(x, 1) for x in break_points()["hexagon"]]
    [184.4, 212.9, 368.8]
    """
    r = max_range((config or NetworkConfig()).radio)
    return {
        "line": [r / k for k in range(6, 0, -1)],
        "hexagon": [r / 2, r / float(np.sqrt(3)), r],
    }
