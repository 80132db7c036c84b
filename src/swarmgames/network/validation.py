"""Boundary checks shared by the network providers: positions and times."""

from __future__ import annotations

import numpy as np

__all__ = ["check_positions", "check_time"]


def check_positions(positions: np.ndarray, n_robots: int | None = None) -> np.ndarray:
    """Return ``positions`` as a float array of shape (N, 3) (a (N, 2) input gets z = 0).

    Raises
    ------
    ValueError
        On a wrong shape, a wrong number of nodes, or NaN / infinite coordinates (the message
        names the first bad node).
    """
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 2 or pos.shape[1] not in (2, 3):
        raise ValueError(f"positions must have shape (N, 3) or (N, 2) (got {pos.shape})")
    if pos.shape[1] == 2:
        pos = np.c_[pos, np.zeros(pos.shape[0])]
    if n_robots is not None and pos.shape[0] != n_robots:
        raise ValueError(f"positions must have {n_robots} rows, one per node (got {pos.shape[0]})")
    bad = ~np.isfinite(pos).all(axis=1)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"positions must be finite (node {k} has {pos[k].tolist()})")
    return pos


def check_time(to_time: float, now: float) -> float:
    """Check that ``to_time`` is finite and not before ``now``."""
    t = float(to_time)
    if not np.isfinite(t):
        raise ValueError(f"to_time must be finite (got {to_time})")
    if t < now:
        raise ValueError(f"to_time must be >= the current time {now} (got {t})")
    return t
