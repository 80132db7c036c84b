"""Shared plotting helpers: a headless-safe figure factory and the project's house style.

Plotting lives here and in the result objects' ``.plot()`` methods, never in solver code.
Matplotlib is imported lazily so that the numerical layers do not pay for it.
"""

from __future__ import annotations

import os
from typing import Any

__all__ = ["COLORS", "new_figure", "twin_axes"]

#: Colour cycle used across figures (Okabe-Ito, readable by colour-blind readers).
COLORS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000")


def _pyplot():
    import matplotlib

    if not os.environ.get("DISPLAY") and "MPLBACKEND" not in os.environ:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def new_figure(
    nrows: int = 1, ncols: int = 1, *, width: float = 6.4, height: float = 4.0, **kwargs: Any
):
    """Create a figure and axes with the house style (grid, colour cycle).

    Uses the non-interactive Agg backend when no display is available, so it is safe on
    servers and in CI.

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : Axes or ndarray of Axes
    """
    from cycler import cycler

    plt = _pyplot()
    fig, axes = plt.subplots(nrows, ncols, figsize=(width * ncols, height * nrows), **kwargs)
    for ax in fig.axes:
        ax.set_prop_cycle(cycler(color=COLORS))
        ax.grid(True, alpha=0.3)
    return fig, axes


def twin_axes(ax, left_label: str, right_label: str, colors: tuple[str, str] = COLORS[:2]):
    """Give ``ax`` a second y-axis on the right; colour each axis like its curve.

    Returns the right-hand axes (the paper's Figure 1 style: two quantities, one x-axis).
    """
    right = ax.twinx()
    ax.set_ylabel(left_label, color=colors[0])
    right.set_ylabel(right_label, color=colors[1])
    ax.tick_params(axis="y", colors=colors[0])
    right.tick_params(axis="y", colors=colors[1])
    return right
