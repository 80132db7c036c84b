"""Channel load: the airtime a robot's neighbourhood offers the channel in a decision window.

A robot shares the channel with every robot it can hear. The load at robot v is the airtime
of every frame transmitted in the stage by v or by a robot that v hears, over the window the
robots have to exchange their messages (``decide_after_s``):

    load_v = (a_v + Σ_{u → v} a_u) / decide_after_s,

with a_u the seconds robot u transmitted. A load above 1 cannot be carried by the decision:
no channel access scheme fits more than the window's airtime into it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["offered_load"]


def offered_load(
    tx: np.ndarray, rx: np.ndarray, airtime_s: np.ndarray, window_s: float
) -> np.ndarray:
    """Each robot's offered channel load over ``window_s`` (module docstring).

    Parameters
    ----------
    tx, rx : ndarray of int, shape (E,)
        The pairs (u, v) where v hears u.
    airtime_s : ndarray of float, shape (N,)
        Seconds each robot transmitted.
    window_s : float
        The decision window, seconds (> 0).

    Returns
    -------
    ndarray of float64, shape (N,)

    Examples
    --------
    >>> offered_load(np.array([0, 1]), np.array([1, 0]), np.array([0.02, 0.03, 0.05]), 0.1)
    array([0.5, 0.5, 0.5])
    """
    air = np.asarray(airtime_s, dtype=float)
    heard = np.bincount(
        np.asarray(rx, np.int64), weights=air[np.asarray(tx, np.int64)], minlength=air.size
    )
    return (air + heard) / float(window_s)
