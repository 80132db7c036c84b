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

from swarmgames.game.actions import DisplacementActions

__all__ = [
    "AccelerationActions",
    "HeadingActions",
    "TakeOff",
    "arena_for",
    "disc_states",
    "takeoff_radius",
    "uav_actions",
]

STAY = 0


def outside_distance(xy: np.ndarray, bounds) -> np.ndarray:
    """Distance of points ``(..., 2)`` (x, y) from the box ``(xmin, xmax, ymin, ymax)``, 0
    inside, metres."""
    xmin, xmax, ymin, ymax = bounds
    dx = np.maximum(np.maximum(xmin - xy[..., 0], xy[..., 0] - xmax), 0.0)
    dy = np.maximum(np.maximum(ymin - xy[..., 1], xy[..., 1] - ymax), 0.0)
    return np.hypot(dx, dy)


@dataclass(frozen=True, eq=False)
class HeadingActions:
    """Stay + ``n_headings`` moves of ``step_m`` metres, kept inside ``bounds``.

    The moves are :meth:`swarmgames.game.actions.DisplacementActions.headings` in 3-D; this
    class adds the arena rule of the module docstring and action labels.

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
        moves = DisplacementActions.headings(self.step_m, int(self.n_headings), dim=3)
        object.__setattr__(self, "offsets", moves.displacements)

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
        return outside_distance(xy, self.bounds)

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

    state_dim = 3


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


@dataclass(frozen=True, eq=False)
class AccelerationActions:
    """Acceleration labels on a square grid, rolled forward over one control period.

    The alternative action set of the authors' mean-field flocking controller: each action is
    a horizontal acceleration :math:`a = (a_x, a_y)` from the grid
    :math:`\\{-m s, \\dots, 0, \\dots, m s\\}^2` (``s = accel_step``, ``m = n_levels``; the
    authors used ±0.5 m/s² in steps of 0.25, 25 labels), applied for ``dt`` seconds:

    .. math:: v' = \\mathrm{clip}(v + a\\, dt), \\qquad p' = p + \\tfrac12 (v + v')\\, dt,

    where clip scales the velocity down to ``max_speed`` when it is faster. States are
    ``(x, y, z, v_x, v_y)`` (metres, m/s). Validity follows :class:`HeadingActions`: the new
    position must stay in the arena or, outside it, not get farther away; the action that
    ends nearest the arena is always valid, so no robot is left without an action.

    Parameters
    ----------
    accel_step : float
        Grid step s of the accelerations, m/s² (> 0).
    n_levels : int
        Levels m on each side of zero (>= 1): (2 m + 1)² actions.
    max_speed : float
        Speed limit, m/s (> 0).
    dt : float
        Control period, s (> 0).
    bounds : tuple of 4 floats, optional
        Arena ``(xmin, xmax, ymin, ymax)``, metres.

    References
    ----------
    .. [1] docs/reference.md section 5: the authors' flocking controller, 25 acceleration labels on
       a ±0.5 m/s² grid (step 0.25) rolled forward over 1 s with |v| < 1 m/s.

    Examples
    --------
    >>> m = AccelerationActions(0.25, 2, 1.0, 1.0)
    >>> m.n_actions
    25
    >>> m.apply(np.zeros(5))[0].tolist()
    [0.0, 0.0, 0.0, 0.0, 0.0]
    """

    accel_step: float
    n_levels: int = 2
    max_speed: float = 1.0
    dt: float = 1.0
    bounds: tuple[float, float, float, float] | None = None
    accels: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("accel_step", "max_speed", "dt"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 (got {getattr(self, name)})")
        if int(self.n_levels) != self.n_levels or self.n_levels < 1:
            raise ValueError(f"n_levels must be an integer >= 1 (got {self.n_levels})")
        levels = self.accel_step * np.arange(-self.n_levels, self.n_levels + 1)
        ax, ay = np.meshgrid(levels, levels, indexing="ij")
        acc = np.column_stack([ax.ravel(), ay.ravel()])
        zero = int(np.flatnonzero((acc == 0).all(axis=1))[0])
        acc = np.vstack([acc[zero : zero + 1], np.delete(acc, zero, axis=0)])  # 0 = coast
        acc.setflags(write=False)
        object.__setattr__(self, "accels", acc)
        if self.bounds is not None:
            HeadingActions(1.0, 1, self.bounds)  # same bounds check

    state_dim = 5

    @property
    def n_actions(self) -> int:
        """Number of actions A = (2 n_levels + 1)²."""
        return int(self.accels.shape[0])

    def apply(self, states: np.ndarray) -> np.ndarray:
        """Next states ``(..., A, 5)`` for states ``(..., 5)`` = (x, y, z, v_x, v_y)."""
        s = np.asarray(states, dtype=float)
        if s.shape[-1] != 5:
            raise ValueError(f"states must have 5 columns (x, y, z, vx, vy) (got {s.shape[-1]})")
        v = s[..., None, 3:5]
        v_new = v + self.accels * self.dt
        speed = np.linalg.norm(v_new, axis=-1, keepdims=True)
        v_new = v_new * np.minimum(1.0, self.max_speed / np.maximum(speed, 1e-300))
        out = np.broadcast_to(s[..., None, :], (*s.shape[:-1], self.n_actions, 5)).copy()
        out[..., 0:2] += 0.5 * (v + v_new) * self.dt
        out[..., 3:5] = v_new
        return out

    def valid(self, states: np.ndarray) -> np.ndarray:
        """Valid actions ``(..., A)``: see the class docstring."""
        s = np.asarray(states, dtype=float)
        shape = (*s.shape[:-1], self.n_actions)
        if self.bounds is None:
            return np.ones(shape, dtype=bool)
        now = outside_distance(s[..., :2], self.bounds)[..., None]
        nxt = outside_distance(self.apply(s)[..., :2], self.bounds)
        ok = nxt <= now + 1e-9
        np.put_along_axis(ok, np.argmin(nxt, axis=-1)[..., None], True, axis=-1)
        return ok


def disc_states(
    n: int, center, radius: float, altitude: float, rng: np.random.Generator, state_dim: int = 3
) -> np.ndarray:
    """``n`` UAVs drawn uniformly over a take-off disc at ``altitude``, at rest.

    Parameters
    ----------
    n : int
        Number of UAVs.
    center : (float, float)
        Centre of the disc (x, y), metres.
    radius : float
        Radius of the disc, metres.
    altitude : float
        z of every UAV, metres.
    rng : numpy.random.Generator
        Two draws per UAV: all radii (``sqrt`` of a uniform, so the density is uniform over
        the disc), then all angles.
    state_dim : int
        D >= 3; columns after (x, y, z) (velocities) are 0.

    Returns
    -------
    ndarray, shape (n, state_dim)
    """
    r = radius * np.sqrt(rng.random(n))
    theta = 2.0 * np.pi * rng.random(n)
    out = np.zeros((n, max(3, int(state_dim))))
    out[:, 0] = center[0] + r * np.cos(theta)
    out[:, 1] = center[1] + r * np.sin(theta)
    out[:, 2] = altitude
    return out


def uav_actions(swarm, period_s: float, bounds=None) -> HeadingActions | AccelerationActions:
    """The action set a swarm section names (``swarm.action_set``), kept inside ``bounds``.

    Parameters
    ----------
    swarm : SwarmConfig
        Uses ``action_set``, ``step_m``, ``n_headings``, ``accel_step_m_s2``,
        ``accel_levels`` and ``max_speed_m_s``.
    period_s : float
        The control period (``sim.control_period_s``), seconds.
    bounds : tuple of 4 floats, optional
        Arena ``(xmin, xmax, ymin, ymax)``, metres.
    """
    if swarm.action_set == "acceleration":
        return AccelerationActions(
            swarm.accel_step_m_s2, swarm.accel_levels, swarm.max_speed_m_s, period_s, bounds
        )
    return HeadingActions(swarm.step_m, swarm.n_headings, bounds)


def takeoff_radius(n_robots: int, radius_m: float, max_neighbours: int, range_m: float) -> float:
    """Radius of the take-off disc of ``n_robots`` UAVs: ``radius_m``, grown for a large
    swarm so that a UAV has on average at most ``max_neighbours`` others within
    ``range_m``.

    .. math:: R(N) = \\begin{cases} R_0 & N - 1 \\le M \\\\
              \\max\\bigl(R_0,\\ r \\sqrt{(N - 1) / M}\\bigr) & N - 1 > M \\end{cases}

    In a uniform disc of radius :math:`R \\ge r` a UAV has about :math:`(N - 1) r^2 / R^2`
    others within r (fewer near the edge), so the disc holds at most M per radio range
    however large N; a swarm of at most M + 1 UAVs keeps ``radius_m`` (it is one clique
    anyway: every UAV within range of every other).

    Parameters
    ----------
    n_robots : int
        N.
    radius_m : float
        :math:`R_0`, ``swarm.start_radius_m``, metres.
    max_neighbours : int
        M, ``swarm.start_max_neighbours``; 0 keeps ``radius_m`` whatever N.
    range_m : float
        r, ``swarm.start_neighbour_range_m`` (the default radio range), metres.

    Examples
    --------
    >>> takeoff_radius(7, 25.0, 20, 368.84)
    25.0
    >>> round(takeoff_radius(1000, 25.0, 20, 368.84))
    2607
    """
    if max_neighbours <= 0 or n_robots - 1 <= max_neighbours:
        return float(radius_m)
    return max(float(radius_m), float(range_m) * float(np.sqrt((n_robots - 1) / max_neighbours)))


@dataclass(frozen=True)
class TakeOff:
    """The common take-off disc of a swarm (``swarm.start_center_m``, ``altitude_m`` and the
    radius :func:`takeoff_radius` gives ``swarm.n_robots``), shared by every built-in
    mission.

    Examples
    --------
    >>> disc = TakeOff((0.0, 0.0), 25.0, 30.0)
    >>> disc.states(4, np.random.default_rng(0), state_dim=5).shape
    (4, 5)
    """

    center_m: tuple[float, float]
    radius_m: float
    altitude_m: float

    @classmethod
    def of(cls, swarm) -> TakeOff:
        """The take-off disc of a :class:`~swarmgames.config.SwarmConfig` (its radius grown
        for ``n_robots`` by :func:`takeoff_radius`)."""
        radius = takeoff_radius(
            swarm.n_robots,
            swarm.start_radius_m,
            swarm.start_max_neighbours,
            swarm.start_neighbour_range_m,
        )
        return cls(tuple(swarm.start_center_m), radius, swarm.altitude_m)

    def states(self, n: int, rng: np.random.Generator, state_dim: int = 3) -> np.ndarray:
        """``n`` UAVs uniform over the disc, at rest (:func:`disc_states`)."""
        return disc_states(n, self.center_m, self.radius_m, self.altitude_m, rng, state_dim)
