"""The rendezvous mission: the swarm meets at a goal point and keeps its radio links.

The UAVs take off spread over a disc (a multi-hop network) and fly to a common goal. Flying
straight at the goal is not enough to keep the network: with a discrete set of headings two
neighbours whose bearings to the goal fall on either side of a heading boundary fly apart,
and robots that arrive early wait while the others are still far. The stage game therefore
pairs a goal term with a link-budget term on every radio link that exists now.

Potentials
----------
For the local game of robot ``i``, variable ``k`` (the owner, a neighbour or a virtual mean,
paper eq. 3) at state :math:`S_k` with next state :math:`S_k(x_k)` after action :math:`x_k`:

.. math::

    \\phi_u(k, x_k) &= -w_{goal}\\, \\lVert S_k(x_k)_{xy} - g \\rVert

    \\phi_p(k, x_k, l, x_l) &= -\\frac{w_{link}}{2 \\alpha_b}\\,
        [P(d_{kl}) \\ge P_{th}]\\;
        \\max\\bigl(0,\\; P_{th} + m - P(\\lVert S_k(x_k) - S_l(x_l) \\rVert)\\bigr)

where :math:`g` is the goal (x, y), :math:`d_{kl} = \\lVert S_k - S_l \\rVert` the 3-D
distance now, :math:`P(d)` the mean received power of the network's radio model
(:meth:`~swarmgames.network.propagation.PropagationModel.mean_rx_power`: Friis or
log-distance, ns-3's formulas, docs/reference.md section 2), :math:`P_{th}` the reception
threshold ``network.radio.rx_threshold_dbm`` and :math:`m` the margin ``link_margin_db``.
A pair that is not linked now gets 0: the term keeps links, it does not try to make new ones.

Weights. The engine multiplies the pairwise term by :math:`\\alpha_b` (``game.alpha_b``,
0.001 by default, the paper's) and sums it over *ordered* pairs (eq. 1), so the factor
:math:`1 / (2 \\alpha_b)` above makes the local game's payoff

.. math:: M_i(x) = -w_{goal} \\sum_k \\lVert S_k(x_k)_{xy} - g \\rVert
          - w_{link} \\sum_{k < l\\ \\mathrm{linked}} \\mathrm{shortfall}_{kl}(x_k, x_l)
          - c \\sum_k [x_k\\ \\mathrm{moves}],

whatever :math:`\\alpha_b` is: ``link_weight`` is what one dB of shortfall on one link costs,
in the same units as ``goal_weight`` times one metre. Without the division the default
:math:`\\alpha_b` would make a dB of shortfall worth a millimetre of progress and the link
term would never matter. The move cost :math:`c` (``move_cost``) is
:class:`~swarmgames.game.inertia.Inertia`'s switching cost.

The potentials plan on the mean received power (no shadowing or fading draw); the metrics use
the same mean power, so with a random channel they measure the geometry, not the draws.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), eqs. 1 and 3.
.. [2] docs/reference.md section 2: Friis / log-distance as ns-3 3.44 computes them, the -82 dBm
   reception threshold, the 368.84 m range.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from swarmgames.errors import ConfigError
from swarmgames.game.capabilities import PotentialCapabilities
from swarmgames.game.inertia import Inertia
from swarmgames.missions.geometry import link_components, link_pairs
from swarmgames.missions.motion import TakeOff, uav_actions
from swarmgames.missions.registry import MissionEntry
from swarmgames.network.parameters import RadioParameters
from swarmgames.network.propagation import PropagationModel, max_range
from swarmgames.section import Coordinate, Section

__all__ = ["ENTRY", "RendezvousConfig", "RendezvousMission", "RendezvousPotentials", "build"]


class RendezvousConfig(Section):
    """The [rendezvous] section: meet at a goal point while keeping every radio link.

    Defaults where nothing else decides: the goal 600 m from the default take-off disc; a 3 dB
    margin (under Friis a link is then kept at most 261 m long instead of 368.84 m, so it
    survives a step of both robots apart before it is lost); ``link_weight`` = 50 per dB, so
    that one dB of shortfall weighs as much as 50 m of goal distance and outweighs the 10 m a
    robot gains per move; ``move_cost`` = 5 (a move must gain more than half a 10 m step of goal
    distance; chosen by measurement, docs/rendezvous.md: over seeds 0-4 of the preset it had
    the least oscillation and no lost link, against 0, 1 and 3).
    """

    goal_m: tuple[Coordinate, Coordinate] = Field(
        (300.0, 0.0), description="Goal point where the swarm meets (x, y), metres."
    )
    gather_radius_m: float = Field(
        25.0,
        gt=0,
        description=(
            "The swarm has gathered when every robot is within this horizontal distance of "
            "the goal (summary's time_to_gather_s), metres."
        ),
    )
    link_margin_db: float = Field(
        3.0,
        ge=0,
        le=100,
        description=(
            "Margin above the reception threshold network.radio.rx_threshold_dbm that a link "
            "should keep; a linked pair is penalised for received power below threshold + "
            "margin, dB."
        ),
    )
    link_weight: float = Field(
        50.0,
        ge=0,
        description=(
            "Weight of the link-budget shortfall, payoff per dB per linked pair (in the units "
            "of goal_weight x 1 m; independent of game.alpha_b; 0 = off), 1/dB."
        ),
    )
    goal_weight: float = Field(
        1.0,
        ge=0,
        description="Weight of a robot's horizontal distance to the goal, payoff per metre, 1/m.",
    )
    move_cost: float = Field(
        5.0,
        ge=0,
        description=(
            "Cost of one move (Inertia's switching cost), payoff units (goal_weight x metres); "
            "a move must gain more than this; 0 = off."
        ),
    )

    def check_scenario(self, scenario) -> None:
        """The link term is weighted by ``game.alpha_b``, which must then be > 0."""
        if self.link_weight > 0 and scenario.game.alpha_b == 0:
            raise ValueError(
                "rendezvous: the link term needs game.alpha_b > 0 (got game.alpha_b = 0): set "
                "rendezvous.link_weight = 0 or game.alpha_b > 0"
            )


def _pair_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sqrt(np.sum((a - b) ** 2, axis=-1))


@dataclass(frozen=True, eq=False)
class RendezvousPotentials:
    """Goal distance (unary) and link-budget shortfall (pairwise) of the rendezvous mission.

    Parameters
    ----------
    goal_m : (float, float)
        The goal g, metres.
    radio : RadioParameters
        The network's radio: loss model, transmit power, reception threshold.
    link_margin_db : float, default 3.0
        m, dB (>= 0).
    link_weight : float, default 50.0
        :math:`w_{link}`, payoff per dB of shortfall per linked pair (>= 0).
    goal_weight : float, default 1.0
        :math:`w_{goal}`, payoff per metre (>= 0).
    alpha_b : float, default 0.001
        :math:`\\alpha_b` of eq. 1 (``game.alpha_b``); > 0 when ``link_weight`` > 0.

    Notes
    -----
    The equations are in the module docstring. ``unary`` is ``(B, K, A)``; ``pairwise`` is
    ``(B, K, K, A, A)`` and ``pair_table`` the same values already symmetrised in the
    solver's layout ``(B, K, A, K, A)``, half the memory. Padding holds finite values that the
    engine ignores.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> pot = RendezvousPotentials((100.0, 0.0), RadioParameters())
    >>> nxt = np.array([[[[0.0, 0, 30], [10.0, 0, 30]]]])  # one game, one robot, two actions
    >>> pot.unary(SimpleNamespace(next_states=nxt)).tolist()
    [[[-100.0, -90.0]]]
    """

    goal_m: tuple[float, float]
    radio: RadioParameters = field(default_factory=RadioParameters)
    link_margin_db: float = 3.0
    link_weight: float = 50.0
    goal_weight: float = 1.0
    alpha_b: float = 0.001

    #: The symmetrised table :meth:`pair_table`.
    capabilities: ClassVar[PotentialCapabilities] = PotentialCapabilities(pair_table=True)

    def __post_init__(self) -> None:
        for name in ("link_margin_db", "link_weight", "goal_weight", "alpha_b"):
            val = getattr(self, name)
            if not (np.isfinite(val) and val >= 0):
                raise ValueError(f"{name} must be >= 0 and finite (got {val})")
        if self.link_weight > 0 and self.alpha_b == 0:
            raise ValueError(
                "the link term needs a pairwise weight > 0 (got alpha_b = 0, i.e. "
                "game.alpha_b = 0): set rendezvous.link_weight = 0 or game.alpha_b > 0"
            )

    @property
    def model(self) -> PropagationModel:
        """The propagation model whose mean power the potentials use."""
        return PropagationModel(self.radio)

    def linked(self, distance: np.ndarray) -> np.ndarray:
        """Whether a pair at ``distance`` metres is linked: mean power >= the threshold."""
        return self.model.mean_rx_power(distance) >= self.radio.rx_threshold_dbm

    def shortfall_db(self, distance: np.ndarray) -> np.ndarray:
        """Link-budget shortfall :math:`\\max(0, P_{th} + m - P(d))` at ``distance``, dB."""
        floor = self.radio.rx_threshold_dbm + self.link_margin_db
        return np.maximum(0.0, floor - self.model.mean_rx_power(distance))

    def unary(self, batch) -> np.ndarray:
        """:math:`-w_{goal}` times every next position's horizontal distance to the goal,
        ``(B, K, A)``."""
        xy = np.asarray(batch.next_states, dtype=float)[..., :2]
        return -self.goal_weight * _pair_distances(xy, np.asarray(self.goal_m, dtype=float))

    def _table(self, batch, dtype) -> np.ndarray:
        """:math:`\\phi_p(k, a, l, c)` in the layout ``(B, K, A, K, A)``."""
        s = np.asarray(batch.states, dtype=float)[..., :3]
        nxt = np.asarray(batch.next_states, dtype=float)[..., :3]
        b, k, a = nxt.shape[:3]
        out = np.zeros((b, k, a, k, a), dtype=dtype)
        if self.link_weight == 0 or k < 2:
            return out
        now = self.linked(_pair_distances(s[:, :, None, :], s[:, None, :, :]))  # (B, K, K)
        now &= ~np.eye(k, dtype=bool)
        gb, gk, gl = np.nonzero(now)  # only linked pairs need the next distances
        if gb.size:
            d = _pair_distances(nxt[gb, gk][:, :, None, :], nxt[gb, gl][:, None, :, :])
            scale = -self.link_weight / (2.0 * self.alpha_b)
            out[gb, gk, :, gl, :] = scale * self.shortfall_db(d)
        return out

    def pairwise(self, batch) -> np.ndarray | None:
        """:math:`\\phi_p` for every ordered pair and both actions, ``(B, K, K, A, A)``; None
        when ``link_weight`` is 0."""
        if self.link_weight == 0:
            return None
        return self._table(batch, np.float64).transpose(0, 1, 3, 2, 4)

    def pair_table(self, batch, dtype=np.float64) -> np.ndarray:
        """The symmetrised table :math:`\\phi_p(k, a, l, c) + \\phi_p(l, c, k, a)
        = 2 \\phi_p(k, a, l, c)` (the shortfall is symmetric), ``(B, K, A, K, A)``, a new
        array."""
        out = self._table(batch, np.dtype(dtype))
        out *= 2
        return out


def _box(goal, gather_radius: float, center, radius: float, margin: float):
    """``(xmin, xmax, ymin, ymax)`` holding the gather circle and the take-off disc, plus
    ``margin``, metres."""
    gx, gy = goal
    cx, cy = center
    return (
        min(gx - gather_radius, cx - radius) - margin,
        max(gx + gather_radius, cx + radius) + margin,
        min(gy - gather_radius, cy - radius) - margin,
        max(gy + gather_radius, cy + radius) + margin,
    )


@dataclass(frozen=True, eq=False)
class RendezvousMission:
    """Rendezvous at ``goal_m`` of UAVs taking off from a disc, keeping their links.

    Parameters
    ----------
    potentials : Potentials
        ``RendezvousPotentials``, wrapped in ``Inertia`` when the move cost is > 0.
    action_model : HeadingActions or AccelerationActions
    goal_m : (float, float)
    gather_radius_m : float
    radio : RadioParameters
        The radio whose mean received power decides which pairs are linked.
    takeoff : TakeOff
        The take-off disc.
    """

    potentials: Any
    action_model: Any
    goal_m: tuple[float, float]
    gather_radius_m: float
    radio: RadioParameters
    takeoff: TakeOff
    name: str = "rendezvous"

    @property
    def state_dim(self) -> int:
        """D: 3 for heading moves, 5 for acceleration labels (velocities)."""
        return int(self.action_model.state_dim)

    @property
    def range_m(self) -> float:
        """Radio range of the mean received power (no shadowing or fading margin), metres."""
        return max_range(replace(self.radio, shadowing_sigma_db=0.0, nakagami_m=None))

    def initial_states(self, n_robots: int, rng: np.random.Generator) -> np.ndarray:
        """Uniform over the take-off disc at the flight altitude, at rest."""
        return self.takeoff.states(n_robots, rng, self.state_dim)

    def _goal_distances(self, states: np.ndarray) -> np.ndarray:
        xy = np.asarray(states, dtype=float)[:, :2]
        return _pair_distances(xy, np.asarray(self.goal_m, dtype=float))

    def _links(self, states: np.ndarray) -> set[tuple[int, int]]:
        """Pairs ``i < j`` whose mean received power is at least the threshold."""
        pos = np.asarray(states, dtype=float)[:, :3]
        cand = link_pairs(pos, self.range_m * (1 + 1e-9) + 1e-9)  # the KD-tree finds them
        d = _pair_distances(pos[cand[:, 0]], pos[cand[:, 1]])
        power = PropagationModel(self.radio).mean_rx_power(d)
        keep = cand[power >= self.radio.rx_threshold_dbm]
        return set(map(tuple, keep.tolist()))

    def swarm_metrics(
        self, states: np.ndarray, previous: np.ndarray | None, t: float
    ) -> dict[str, float]:
        """``goal_distance_m`` (mean) and ``max_goal_distance_m`` (horizontal, metres),
        ``links_lost`` (pairs linked at the previous stage and not now; 0 at the first) and
        ``link_components`` (components of the link graph by distance). The goal does not move:
        ``t`` is not read."""
        dist = self._goal_distances(states)
        lost = 0
        if previous is not None:
            lost = len(self._links(previous) - self._links(states))
        return {
            "goal_distance_m": float(dist.mean()) if dist.size else 0.0,
            "max_goal_distance_m": float(dist.max()) if dist.size else 0.0,
            "links_lost": float(lost),
            "link_components": float(link_components(states, self.range_m)),
        }

    def robot_metrics(self, states: np.ndarray, t: float) -> dict[str, np.ndarray]:
        """``goal_distance_m``: each robot's horizontal distance to the goal, metres."""
        return {"goal_distance_m": self._goal_distances(states)}

    def summary(self, times: np.ndarray, swarm: dict[str, np.ndarray]) -> dict[str, Any]:
        """``time_to_gather_s`` (first stage time, on ``swarm.csv``'s clock, at which every
        robot is within ``gather_radius_m``; None if never), ``total_links_lost`` and
        ``goal_distance_end_m`` (mean, at the last stage)."""
        far = np.asarray(swarm.get("max_goal_distance_m", np.zeros(0)), dtype=float)
        gathered = np.flatnonzero(far <= self.gather_radius_m)
        mean = np.asarray(swarm.get("goal_distance_m", np.zeros(0)), dtype=float)
        lost = np.asarray(swarm.get("links_lost", np.zeros(0)), dtype=float)
        return {
            "time_to_gather_s": float(times[gathered[0]]) if gathered.size else None,
            "total_links_lost": int(lost.sum()),
            "goal_distance_end_m": float(mean[-1]) if mean.size else None,
        }

    def draw(self, ax) -> None:
        """Mark the goal and outline the gather circle."""
        from matplotlib.patches import Circle

        ax.add_patch(
            Circle(
                self.goal_m,
                self.gather_radius_m,
                fill=False,
                ls="--",
                color="tab:green",
                label=f"gather radius ({self.gather_radius_m:g} m)",
            )
        )
        ax.scatter(*self.goal_m, marker="*", s=150, color="tab:green", zorder=3, label="goal")

    def extent(self) -> tuple[float, float, float, float]:
        """Box around the goal's gather circle and the take-off disc, metres."""
        return _box(
            self.goal_m, self.gather_radius_m, self.takeoff.center_m, self.takeoff.radius_m, 0
        )


def build(config) -> RendezvousMission:
    """The rendezvous mission of a :class:`~swarmgames.config.ScenarioConfig`.

    Raises
    ------
    ConfigError
        A link term with ``game.alpha_b = 0`` (the message names both fields).
    """
    rv: RendezvousConfig = config.mission
    radio = RadioParameters(**config.network.radio.model_dump())
    try:
        base = RendezvousPotentials(
            tuple(rv.goal_m),
            radio,
            link_margin_db=rv.link_margin_db,
            link_weight=rv.link_weight,
            goal_weight=rv.goal_weight,
            alpha_b=config.game.alpha_b,
        )
    except ValueError as exc:
        raise ConfigError(f"rendezvous: {exc}") from None
    potentials = Inertia(base, rv.move_cost) if rv.move_cost else base
    sw = config.swarm
    takeoff = TakeOff.of(sw)
    bounds = _box(
        rv.goal_m, rv.gather_radius_m, takeoff.center_m, takeoff.radius_m, sw.arena_margin_m
    )
    return RendezvousMission(
        potentials=potentials,
        action_model=uav_actions(sw, config.sim.control_period_s, bounds),
        goal_m=tuple(rv.goal_m),
        gather_radius_m=rv.gather_radius_m,
        radio=radio,
        takeoff=takeoff,
    )


#: The registry entry of the built-in ``rendezvous`` mission.
ENTRY = MissionEntry(
    name="rendezvous",
    config=RendezvousConfig,
    build=build,
    description="meet at a goal point while keeping every radio link above a power margin",
)
