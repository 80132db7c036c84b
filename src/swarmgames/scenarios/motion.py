"""UAV motion: a discrete action set of "stay" plus moves along evenly spaced headings.

Action 0 keeps the UAV where it is; action ``m`` (1 <= m <= n_headings) flies ``step_m`` metres
at constant altitude along heading :math:`\\theta_m = 2\\pi (m - 1) / n_{headings}`
(counter-clockwise from +x) during one control period. The speed is therefore
``step_m / control_period_s``; the configuration rejects a step faster than the UAV's speed
limit. A move is *valid* when it ends inside the arena (an axis-aligned box around the take-off
area and the ROI) or, for a UAV already outside, when it does not take it farther from the
arena; "stay" is always valid, so every robot has at least one action.

The model implements the engine's ``ActionModel`` protocol: ``n_actions``, ``apply(states)``
and ``valid(states)`` over states of shape ``(..., 3)`` = (x, y, z) in metres.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), section II.B: discrete
   action sets :math:`\\mathcal{A}_i`, one decision per robot per stage (1 Hz in ROSNS3).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["HeadingActions", "arena_for"]

STAY = 0


@dataclass(frozen=True, eq=False)
class HeadingActions:
    """Stay + ``n_headings`` moves of ``step_m`` metres, kept inside ``bounds``.

    Parameters
    ----------
    step_m : float
        Distance of one move, metres (> 0).
    n_headings : int
        Number of evenly spaced headings (>= 1).
    bounds : tuple of 4 floats, optional
        Arena ``(xmin, xmax, ymin, ymax)``, metres; ``None`` = unbounded.

    Examples
    --------
    >>> m = HeadingActions(10.0, 4)
    >>> m.apply(np.array([0.0, 0.0, 30.0])).round(6).tolist()[:3]
    [[0.0, 0.0, 30.0], [10.0, 0.0, 30.0], [0.0, 10.0, 30.0]]
    """

    step_m: float
    n_headings: int = 8
    bounds: tuple[float, float, float, float] | None = None
    offsets: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.step_m > 0:
            raise ValueError(f"step_m must be > 0 (got {self.step_m})")
        if int(self.n_headings) != self.n_headings or self.n_headings < 1:
            raise ValueError(f"n_headings must be an integer >= 1 (got {self.n_headings})")
        if self.bounds is not None:
            xmin, xmax, ymin, ymax = self.bounds
            if not (xmin < xmax and ymin < ymax):
                raise ValueError(
                    f"bounds must have xmin < xmax and ymin < ymax (got {self.bounds})"
                )
        theta = 2.0 * np.pi * np.arange(self.n_headings) / self.n_headings
        off = np.zeros((self.n_actions, 3))
        off[1:, 0] = self.step_m * np.cos(theta)
        off[1:, 1] = self.step_m * np.sin(theta)
        off[np.abs(off) < 1e-12] = 0.0  # exact zeros for axis-aligned headings
        off.setflags(write=False)
        object.__setattr__(self, "offsets", off)

    @property
    def n_actions(self) -> int:
        """Number of actions A = 1 + n_headings."""
        return 1 + int(self.n_headings)

    def labels(self) -> list[str]:
        """Human-readable action names: ``stay``, then headings in degrees."""
        deg = 360.0 * np.arange(self.n_headings) / self.n_headings
        return ["stay", *(f"{d:g}deg" for d in deg)]

    def apply(self, states: np.ndarray) -> np.ndarray:
        """Next states, shape ``(..., A, 3)``, for states of shape ``(..., 3)``."""
        s = np.asarray(states, dtype=float)
        return s[..., None, :] + self.offsets

    def _outside(self, xy: np.ndarray) -> np.ndarray:
        xmin, xmax, ymin, ymax = self.bounds  # type: ignore[misc]
        dx = np.maximum(np.maximum(xmin - xy[..., 0], xy[..., 0] - xmax), 0.0)
        dy = np.maximum(np.maximum(ymin - xy[..., 1], xy[..., 1] - ymax), 0.0)
        return np.hypot(dx, dy)

    def valid(self, states: np.ndarray) -> np.ndarray:
        """Valid actions, shape ``(..., A)`` bool: moves that end inside the arena, or do not
        take a UAV already outside it farther away; "stay" always."""
        s = np.asarray(states, dtype=float)
        shape = (*s.shape[:-1], self.n_actions)
        if self.bounds is None:
            return np.ones(shape, dtype=bool)
        now = self._outside(s)[..., None]
        nxt = self._outside(self.apply(s))
        ok = nxt <= now + 1e-9
        ok[..., STAY] = True
        return ok

    @classmethod
    def from_config(cls, swarm, bounds=None) -> HeadingActions:
        """Build from a :class:`~swarmgames.config.SwarmConfig` and an arena."""
        return cls(swarm.step_m, swarm.n_headings, bounds)


def arena_for(roi, start_center_m, start_radius_m: float, margin_m: float):
    """Arena box holding the ROI's bounding box and the take-off disc, plus a margin.

    Returns ``(xmin, xmax, ymin, ymax)`` in metres.
    """
    xmin, xmax, ymin, ymax = roi.bounding_box()
    cx, cy = start_center_m
    r = start_radius_m
    return (
        min(xmin, cx - r) - margin_m,
        max(xmax, cx + r) + margin_m,
        min(ymin, cy - r) - margin_m,
        max(ymax, cy + r) + margin_m,
    )
