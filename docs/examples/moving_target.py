"""A moving target: the UAVs track a target that circles on a known path, keeping apart.

A complete swarmgames mission in one file. The state is the position alone (x, y, z; no
clock): time comes from the simulation, as ``batch.t`` in the potentials and as ``t`` in the
metrics hooks, both the stage time in seconds (warm-up plus stage number times the control
period, the ``t`` column of ``swarm.csv``).

Register it by entry point (``moving_target = "moving_target:ENTRY"`` in the group
``swarmgames.missions``) or from Python with ``register_mission(ENTRY)``; a scenario then
names it with ``scenario = "moving_target"`` and configures it in ``[moving_target]``.
"""

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from swarmgames.game import PotentialCapabilities
from swarmgames.missions import HeadingActions, MissionEntry, TakeOff
from swarmgames.section import Coordinate, Section


class MovingTargetConfig(Section):
    """The [moving_target] section: the target's circle and the robots' spacing."""

    centre_m: tuple[Coordinate, Coordinate] = Field(
        (-200.0, 0.0), description="Centre of the target's circle (x, y), metres."
    )
    radius_m: float = Field(100.0, gt=0, le=1e5, description="Radius of the circle, metres.")
    angular_speed_rad_s: float = Field(
        0.05, ge=-1.0, le=1.0, description="Target's angular speed (> 0 anticlockwise), rad/s."
    )
    separation_m: float = Field(
        30.0, ge=0, description="Distance below which two UAVs crowd (0 = off), metres."
    )
    separation_weight: float = Field(
        50.0, ge=0, description="Crowding cost of two UAVs at the same point, metres."
    )


@dataclass(frozen=True)
class CirclePath:
    """p(t) = centre + radius (cos ωt, sin ωt): where the target is at time t (seconds)."""

    centre_m: tuple[float, float]
    radius_m: float
    angular_speed_rad_s: float

    def at(self, t: float) -> np.ndarray:
        """The target's position (x, y) at time ``t``, metres."""
        angle = self.angular_speed_rad_s * t
        return np.asarray(self.centre_m) + self.radius_m * np.array([np.cos(angle), np.sin(angle)])


@dataclass(frozen=True)
class MovingTargetPotentials:
    """phi_u = -|S_k(x_k) - p(t + lead)|, the horizontal distance of the next position to
    where the target will be when the robot gets there (lead = the control period);
    phi_p = -w max(0, 1 - |S_k(x_k) - S_l(x_l)| / separation)^2 / alpha_b (crowding)."""

    capabilities = PotentialCapabilities()  # unary and pairwise only: no optional forms

    path: CirclePath
    lead_s: float
    separation_m: float
    separation_weight: float
    alpha_b: float

    def unary(self, batch):
        target = self.path.at(batch.t + self.lead_s)
        return -np.linalg.norm(batch.next_states[..., :2] - target, axis=-1)  # (B, K, A)

    def pairwise(self, batch):
        if 0 in (self.separation_m, self.separation_weight, self.alpha_b):  # no crowding term
            return None
        p = batch.next_states[..., :2]
        gap = np.linalg.norm(p[:, :, None, :, None] - p[:, None, :, None, :], axis=-1)
        crowd = np.maximum(0.0, 1.0 - gap / self.separation_m) ** 2  # (B, K, K, A, A)
        return -self.separation_weight * crowd / self.alpha_b


@dataclass(frozen=True, eq=False)
class MovingTargetMission:
    """Track the target of ``path`` from the take-off disc ``takeoff``."""

    potentials: MovingTargetPotentials
    action_model: HeadingActions
    path: CirclePath
    takeoff: TakeOff
    name: str = "moving_target"
    state_dim: int = 3

    def initial_states(self, n_robots, rng):
        return self.takeoff.states(n_robots, rng)

    def robot_metrics(self, states, t):
        return {"target_distance_m": np.linalg.norm(states[:, :2] - self.path.at(t), axis=1)}

    def swarm_metrics(self, states, previous, t):
        return {
            "target_distance_m": float(self.robot_metrics(states, t)["target_distance_m"].mean())
        }

    def summary(self, times, swarm):
        return {"target_distance_end_m": float(swarm["target_distance_m"][-1])}

    def draw(self, ax):
        from matplotlib.patches import Circle

        ax.add_patch(Circle(self.path.centre_m, self.path.radius_m, fill=False, ls="--"))

    def extent(self):
        (cx, cy), r = self.path.centre_m, self.path.radius_m
        (tx, ty), tr = self.takeoff.center_m, self.takeoff.radius_m
        return (
            min(cx - r, tx - tr),
            max(cx + r, tx + tr),
            min(cy - r, ty - tr),
            max(cy + r, ty + tr),
        )


def build(config):
    """The mission of a validated scenario (its own section is ``config.mission``)."""
    cfg, swarm = config.mission, config.swarm
    path = CirclePath(tuple(cfg.centre_m), cfg.radius_m, cfg.angular_speed_rad_s)
    potentials = MovingTargetPotentials(
        path,
        lead_s=config.sim.control_period_s,
        separation_m=cfg.separation_m,
        separation_weight=cfg.separation_weight,
        alpha_b=config.game.alpha_b,
    )
    actions = HeadingActions(swarm.step_m, swarm.n_headings)
    return MovingTargetMission(potentials, actions, path, TakeOff.of(swarm))


ENTRY = MissionEntry("moving_target", MovingTargetConfig, build, "track a target on a circle")
