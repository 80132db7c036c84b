"""The mean-field flocking mission: cohesion, alignment, separation and a goal velocity.

The setting of the authors' mean-field flocking controller (docs/reference.md section 5): every UAV
picks one of 25 horizontal acceleration labels on a ±0.5 m/s² grid in steps of 0.25, rolled
forward over a 1 s control period with a speed limit of 1 m/s
(:class:`~swarmgames.missions.motion.AccelerationActions`, states ``(x, y, z, v_x, v_y)``), and
the stage game rewards a flock: each robot near the centroid of the others (cohesion), at
their mean velocity (alignment) and at a common goal velocity, and apart from every other
robot by at least a separation distance (a pairwise potential on both robots' next
positions). :class:`FlockingPotentials` holds the equations; :class:`FlockingMission` the
metrics (``polarisation``, ``cohesion_radius_m``, ``near_collisions``, ``link_components``,
``mean_speed_m_s``).

References
----------
.. [1] docs/reference.md section 5: the authors' mean-field flocking controller (25 acceleration
   labels, ±0.5 m/s², |v| < 1 m/s, one decision per robot per period).
.. [2] C. W. Reynolds, "Flocks, herds and schools: a distributed behavioral model",
   SIGGRAPH 1987 (cohesion, alignment, separation).
.. [3] T. Vicsek et al., "Novel type of phase transition in a system of self-driven
   particles", Phys. Rev. Lett. 75, 1995 (the polarisation order parameter).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from swarmgames.game.capabilities import PotentialCapabilities
from swarmgames.missions.geometry import close_pairs, crowding_blocks, link_components
from swarmgames.missions.motion import TakeOff, uav_actions
from swarmgames.missions.registry import MissionEntry
from swarmgames.section import Section

__all__ = [
    "ENTRY",
    "FlockingConfig",
    "FlockingMission",
    "FlockingPotentials",
    "build",
    "polarisation",
]

#: Polarisation from which the flock counts as aligned (``time_to_polarisation_s``).
POLARISED = 0.9


class FlockingConfig(Section):
    """The [flocking] table: weights of the flocking potentials and the metrics' distances.

    Defaults where the authors' controller is silent: a goal velocity of 0.5 m/s along +x
    (half the 1 m/s speed limit, so a robot can still speed up or slow down to rejoin the
    flock). The terms are norms, so a robot trades them linearly: one acceleration step of
    0.25 m/s² moves its next position 0.125 m and its next velocity 0.25 m/s, and cohesion acts
    only while ``cohesion_weight / 2`` exceeds ``alignment_weight + goal_weight`` (1.0 / 2 >
    0.4: far robots close in, then the velocity terms align the flock); a separation of 4 m at
    weight 10 keeps robots apart at 1 m/s closing speeds (``docs/flocking.md``).
    """

    goal_velocity_m_s: tuple[float, float] = Field(
        (0.5, 0.0), description="Velocity the flock is asked to fly at (v_x, v_y), m/s."
    )
    cohesion_weight: float = Field(
        1.0,
        ge=0,
        description="Weight of the distance of a robot's next position to the centroid of the "
        "other members of its game, payoff per metre.",
    )
    alignment_weight: float = Field(
        0.2,
        ge=0,
        description="Weight of the gap between a robot's next velocity and the others' mean "
        "current velocity, payoff per m/s.",
    )
    goal_weight: float = Field(
        0.2,
        ge=0,
        description="Weight of the gap between a robot's next velocity and the goal velocity, "
        "payoff per m/s.",
    )
    separation_m: float = Field(
        4.0,
        ge=0,
        description="Distance below which two robots' next positions are penalised "
        "(0 = no separation term), metres.",
    )
    separation_weight: float = Field(
        10.0,
        ge=0,
        description="Penalty of a pair of robots at the same next position; it falls as "
        "(1 - d / separation_m)^2 to 0 at separation_m (0 = no separation term), payoff.",
    )
    accel_cost: float = Field(
        0.0,
        ge=0,
        description="Cost of a change of velocity, payoff per m/s (0 = none); damps the "
        "flock's corrections.",
    )
    collision_m: float = Field(
        1.0,
        gt=0,
        description="Distance below which a pair of robots counts as a near-collision "
        "(metric only), metres.",
    )
    initial_speed_m_s: float = Field(
        0.5,
        ge=0,
        description="Largest speed of the robots' random initial velocities: speed uniform "
        "in [0, initial_speed_m_s], heading uniform (0 = at rest), m/s.",
    )

    def check_scenario(self, scenario) -> None:
        """The flock's state holds velocities (``swarm.action_set = 'acceleration'``), its
        speeds stay within ``swarm.max_speed_m_s``, and the separation term is weighted by
        ``game.alpha_b > 0``."""
        sw = scenario.swarm
        if sw.action_set != "acceleration":
            raise ValueError(
                "flocking: swarm.action_set must be 'acceleration' (velocities are the flock's "
                f"state) (got {sw.action_set!r})"
            )
        goal_speed = math.hypot(*self.goal_velocity_m_s)
        if goal_speed > sw.max_speed_m_s:
            raise ValueError(
                "flocking: |flocking.goal_velocity_m_s| must be <= swarm.max_speed_m_s "
                f"(got {goal_speed:g} > {sw.max_speed_m_s:g} m/s)"
            )
        if self.initial_speed_m_s > sw.max_speed_m_s:
            raise ValueError(
                "flocking: flocking.initial_speed_m_s must be <= swarm.max_speed_m_s "
                f"(got {self.initial_speed_m_s:g} > {sw.max_speed_m_s:g} m/s)"
            )
        if self.separation_m > 0 and self.separation_weight > 0 and scenario.game.alpha_b == 0:
            raise ValueError(
                "flocking: the separation term needs game.alpha_b > 0 (got game.alpha_b = 0); "
                "set flocking.separation_weight = 0 to turn it off"
            )


@dataclass(frozen=True, eq=False)
class FlockingPotentials:
    """Cohesion, alignment and goal unary; separation pairwise (the engine's ``Potentials``).

    Parameters
    ----------
    goal_velocity : (float, float)
        g, m/s.
    cohesion_weight, alignment_weight, goal_weight : float
        :math:`w_c` (per metre), :math:`w_a`, :math:`w_g` (per m/s), >= 0.
    separation_m : float, default 0
        :math:`d_s`, metres (0 = no pairwise term).
    separation_weight : float, default 0
        :math:`w_s` (0 = no pairwise term).
    accel_cost : float, default 0
        :math:`w_v`, per m/s of velocity change.
    alpha_b : float, default 0.001
        The engine's pairwise weight ``game.alpha_b``; the pairwise potential is divided by
        :math:`2 \\alpha_b` so that :math:`w_s` is the payoff of one pair (Notes).

    Notes
    -----
    For variable k of a local game with valid members :math:`\\mathcal{M}` and action
    :math:`x_k`, with next position :math:`p_k(x_k)` (x, y, z) and next velocity
    :math:`v_k(x_k)`, and the others' current centroid and mean velocity
    :math:`\\bar p_{-k} = \\frac{1}{|\\mathcal{M}| - 1} \\sum_{l \\ne k} p_l`,
    :math:`\\bar v_{-k}` likewise:

    .. math::

        \\phi_u(k, x_k) = -\\big( w_c \\lVert p_k(x_k) - \\bar p_{-k} \\rVert
                        + w_a \\lVert v_k(x_k) - \\bar v_{-k} \\rVert
                        + w_g \\lVert v_k(x_k) - g \\rVert
                        + w_v \\lVert v_k(x_k) - v_k \\rVert \\big)

    (an isolated robot, :math:`|\\mathcal{M}| = 1`, keeps only the goal and the velocity-change
    terms), and

    .. math::

        \\phi_p(k, x_k, l, x_l) = -\\frac{w_s}{2 \\alpha_b}
            \\max\\big(0,\\ 1 - \\lVert p_k(x_k) - p_l(x_l) \\rVert / d_s\\big)^2 .

    The engine's payoff (eq. 1) sums :math:`\\alpha_b \\phi_p` over ordered pairs, so a local
    game's payoff is :math:`\\alpha_a \\sum_k \\phi_u - w_s \\sum_{k<l} \\max(0, 1 - d_{kl} /
    d_s)^2`: each pair of robots at distance :math:`d` costs
    :math:`w_s (1 - d/d_s)^2`, whatever :math:`\\alpha_b`. Virtual means (eq. 3) are members like
    any other. Entries of padded variables and invalid actions are 0.

    Examples
    --------
    >>> pot = FlockingPotentials((0.5, 0.0), 0.2, 0.5, 0.5)
    >>> pot.pairwise(None) is None
    True
    """

    goal_velocity: tuple[float, float]
    cohesion_weight: float
    alignment_weight: float
    goal_weight: float
    separation_m: float = 0.0
    separation_weight: float = 0.0
    accel_cost: float = 0.0
    alpha_b: float = 0.001

    #: The symmetrised table :meth:`pair_table`.
    capabilities: ClassVar[PotentialCapabilities] = PotentialCapabilities(pair_table=True)

    def __post_init__(self) -> None:
        for name in (
            "cohesion_weight",
            "alignment_weight",
            "goal_weight",
            "separation_m",
            "separation_weight",
            "accel_cost",
            "alpha_b",
        ):
            val = getattr(self, name)
            if not (np.isfinite(val) and val >= 0):
                raise ValueError(f"{name} must be >= 0 and finite (got {val})")
        if self.separating and self.alpha_b == 0:
            raise ValueError(
                "the pairwise separation term needs a pairwise weight > 0 (got alpha_b = 0): "
                "set separation_weight = 0 or alpha_b > 0"
            )

    @property
    def separating(self) -> bool:
        """Whether the pairwise separation term is on."""
        return self.separation_m > 0 and self.separation_weight > 0

    def unary(self, batch) -> np.ndarray:
        """:math:`\\phi_u(k, x_k)` for every game, variable and action, ``(B, K, A)``."""
        mask = np.asarray(batch.mask, dtype=bool)
        amask = np.asarray(batch.action_mask, dtype=bool) & mask[..., None]
        states = np.where(mask[..., None], np.asarray(batch.states, dtype=float), 0.0)
        nxt = np.asarray(batch.next_states, dtype=float)
        m = mask.astype(float)
        # The others' centroid and mean velocity: the game's sums minus the variable's own.
        others = m.sum(axis=1, keepdims=True) - m  # (B, K)
        share = 1.0 / np.maximum(others, 1.0)
        total = states.sum(axis=1, keepdims=True)  # (B, 1, D)
        mean = (total - states) * share[..., None]  # (B, K, D)
        vel = nxt[..., 3:5]
        cost = self.goal_weight * np.linalg.norm(vel - np.asarray(self.goal_velocity), axis=-1)
        if self.accel_cost:
            cost += self.accel_cost * np.linalg.norm(vel - states[:, :, None, 3:5], axis=-1)
        flock = self.cohesion_weight * np.linalg.norm(
            nxt[..., :3] - mean[:, :, None, :3], axis=-1
        ) + self.alignment_weight * np.linalg.norm(vel - mean[:, :, None, 3:5], axis=-1)
        cost += np.where((others > 0)[..., None], flock, 0.0)
        return np.where(amask, -cost, 0.0)

    def pairwise(self, batch) -> np.ndarray | None:
        """:math:`\\phi_p(k, x_k, l, x_l)`, ``(B, K, K, A, A)``; ``None`` when the separation
        term is off."""
        if not self.separating:
            return None
        mask = np.asarray(batch.mask, dtype=bool)
        amask = np.asarray(batch.action_mask, dtype=bool) & mask[..., None]
        pos = np.where(amask[..., None], np.asarray(batch.next_states, dtype=float)[..., :3], 0.0)
        k = mask.shape[1]
        d = np.linalg.norm(pos[:, :, None, :, None, :] - pos[:, None, :, None, :, :], axis=-1)
        pen = np.maximum(0.0, 1.0 - d / self.separation_m) ** 2
        ok = (
            amask[:, :, None, :, None]
            & amask[:, None, :, None, :]
            & ~np.eye(k, dtype=bool)[None, :, :, None, None]
        )
        return np.where(ok, (-self.separation_weight / (2.0 * self.alpha_b)) * pen, 0.0)

    def pair_table(self, batch, dtype=np.float64) -> np.ndarray | None:
        """The separation term symmetrised in the engine's layout, ``(B, K, A, K, A)``:
        :math:`\\phi_p(k, a, l, c) + \\phi_p(l, c, k, a) = 2 \\phi_p(k, a, l, c)` (the
        engine's cheaper form of :meth:`pairwise`; a new array). Only the pairs of variables
        that can come within ``separation_m`` are computed
        (:func:`~swarmgames.missions.geometry.crowding_blocks`); in float64 the values equal
        :meth:`pairwise`'s, doubled, bit for bit; ``None`` when the separation term is
        off."""
        if not self.separating:
            return None
        b, k, a = np.asarray(batch.action_mask).shape
        out = np.zeros((b, k, a, k, a), dtype=dtype)
        for gb, gk, gl, pen in crowding_blocks(batch, self.separation_m):
            phi = (-self.separation_weight / (2.0 * self.alpha_b)) * pen
            out[gb, gk, :, gl, :] = (2.0 * phi).astype(dtype, copy=False)
        return out


def polarisation(velocities: np.ndarray) -> float:
    """The flock's order parameter :math:`|\\sum_i v_i| / \\sum_i |v_i|`: 1 when every robot
    flies the same way, near 0 for random headings; 0 when no robot moves.

    Examples
    --------
    >>> polarisation(np.array([[1.0, 0.0], [0.5, 0.0]]))
    1.0
    >>> polarisation(np.array([[1.0, 0.0], [-1.0, 0.0]]))
    0.0
    """
    v = np.asarray(velocities, dtype=float)
    total = float(np.linalg.norm(v, axis=-1).sum())
    if total <= 1e-12:
        return 0.0
    return float(np.linalg.norm(v.sum(axis=0)) / total)


@dataclass(frozen=True, eq=False)
class FlockingMission:
    """A flock taking off from a disc and flying at a goal velocity.

    Parameters
    ----------
    potentials : FlockingPotentials
    action_model : AccelerationActions
    takeoff : TakeOff
        The take-off disc.
    initial_speed_m_s : float
        Largest initial speed, m/s (0 = at rest).
    collision_m : float
        Near-collision distance of the ``near_collisions`` metric, metres.
    radio_range_m : float
        Link distance of the ``link_components`` metric, metres.
    horizon_s : float
        How long the goal arrow of :meth:`draw` flies the goal velocity (the mission time).
    """

    potentials: FlockingPotentials
    action_model: Any
    takeoff: TakeOff
    initial_speed_m_s: float
    collision_m: float
    radio_range_m: float
    horizon_s: float = 60.0
    name: str = "flocking"

    @property
    def state_dim(self) -> int:
        """D = 5: (x, y, z, v_x, v_y)."""
        return int(self.action_model.state_dim)

    def initial_states(self, n_robots: int, rng: np.random.Generator) -> np.ndarray:
        """Uniform over the take-off disc at the flight altitude, then one random velocity per
        robot: speed uniform in ``[0, initial_speed_m_s]``, heading uniform (drawn after the
        positions, so the positions do not depend on ``initial_speed_m_s``)."""
        out = self.takeoff.states(n_robots, rng, 5)
        speed = self.initial_speed_m_s * rng.random(n_robots)
        heading = 2.0 * np.pi * rng.random(n_robots)
        out[:, 3] = speed * np.cos(heading)
        out[:, 4] = speed * np.sin(heading)
        return out

    def swarm_metrics(
        self, states: np.ndarray, previous: np.ndarray | None, t: float
    ) -> dict[str, float]:
        """``polarisation``, ``cohesion_radius_m`` (largest distance to the swarm's centroid),
        ``near_collisions`` (pairs closer than ``collision_m``), ``link_components`` (of the
        graph of robots within radio range) and ``mean_speed_m_s``; ``t`` is not read."""
        s = np.asarray(states, dtype=float)
        pos, vel = s[:, :3], s[:, 3:5]
        radius = np.linalg.norm(pos - pos.mean(axis=0), axis=1).max() if len(s) else 0.0
        return {
            "polarisation": polarisation(vel),
            "cohesion_radius_m": float(radius),
            "near_collisions": float(close_pairs(pos, self.collision_m)),
            "link_components": float(link_components(pos, self.radio_range_m)),
            "mean_speed_m_s": float(np.linalg.norm(vel, axis=1).mean()) if len(s) else 0.0,
        }

    def robot_metrics(self, states: np.ndarray, t: float) -> dict[str, np.ndarray]:
        """``speed_m_s`` of every robot."""
        return {"speed_m_s": np.linalg.norm(np.asarray(states, dtype=float)[:, 3:5], axis=1)}

    def summary(self, times: np.ndarray, swarm: dict[str, np.ndarray]) -> dict[str, Any]:
        """Polarisation and cohesion radius at the last stage, near-collisions summed over the
        stages, and the time from the first stage to the first with polarisation >= 0.9
        (``None`` if never)."""
        pol = np.asarray(swarm.get("polarisation", np.zeros(0)), dtype=float)
        rad = np.asarray(swarm.get("cohesion_radius_m", np.zeros(0)), dtype=float)
        near = np.asarray(swarm.get("near_collisions", np.zeros(0)), dtype=float)
        reached = np.flatnonzero(pol >= POLARISED)
        t = np.asarray(times, dtype=float)
        return {
            "polarisation_start": float(pol[0]) if len(pol) else None,
            "polarisation_end": float(pol[-1]) if len(pol) else None,
            "time_to_polarisation_s": float(t[reached[0]] - t[0]) if len(reached) else None,
            "cohesion_radius_end_m": float(rad[-1]) if len(rad) else None,
            "near_collisions_total": int(near.sum()),
        }

    def draw(self, ax) -> None:
        """An arrow from the take-off centre along the goal velocity, as far as the goal
        velocity flies in the mission time."""
        cx, cy = self.takeoff.center_m
        gx, gy = (self.horizon_s * np.asarray(self.potentials.goal_velocity)).tolist()
        if gx == 0 and gy == 0:
            ax.plot([cx], [cy], marker="+", color="tab:green", ms=12, label="goal: hover")
            return
        ax.annotate(
            "",
            xy=(cx + gx, cy + gy),
            xytext=(cx, cy),
            arrowprops={"arrowstyle": "->", "color": "tab:green", "lw": 1.5, "alpha": 0.7},
        )
        ax.plot([], [], color="tab:green", label="goal velocity x mission time")


def build(config) -> FlockingMission:
    """The flocking mission of a :class:`~swarmgames.config.ScenarioConfig`.

    The rules that span sections (action set, speeds, ``game.alpha_b``) are
    :meth:`FlockingConfig.check_scenario`'s, checked when the configuration is validated.
    """
    from swarmgames.network.parameters import RadioParameters
    from swarmgames.network.propagation import max_range

    fl: FlockingConfig = config.mission
    sw = config.swarm
    potentials = FlockingPotentials(
        goal_velocity=tuple(fl.goal_velocity_m_s),
        cohesion_weight=fl.cohesion_weight,
        alignment_weight=fl.alignment_weight,
        goal_weight=fl.goal_weight,
        separation_m=fl.separation_m,
        separation_weight=fl.separation_weight,
        accel_cost=fl.accel_cost,
        alpha_b=config.game.alpha_b,
    )
    radio = RadioParameters(**config.network.radio.model_dump())
    return FlockingMission(
        potentials=potentials,
        # Unbounded: the flock travels at the goal velocity, out of any fixed arena.
        action_model=uav_actions(sw, config.sim.control_period_s, None),
        takeoff=TakeOff.of(sw),
        initial_speed_m_s=fl.initial_speed_m_s,
        collision_m=fl.collision_m,
        radio_range_m=max_range(radio),
        horizon_s=config.sim.duration_s,
    )


#: The registry entry of the built-in ``flocking`` mission.
ENTRY = MissionEntry(
    name="flocking",
    config=FlockingConfig,
    build=build,
    description="mean-field flocking on acceleration labels: cohesion, alignment, separation, "
    "goal velocity",
)
