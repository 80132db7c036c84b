"""The mission protocol: what the simulation needs from a mission, and nothing more.

A mission is data plus potentials. It never drives the stage loop; the loop
(:mod:`swarmgames.sim.loop`) asks it only for what :class:`Mission` declares:

* ``potentials`` and ``action_model``: the stage game's payoff (paper eq. 1, see
  :class:`~swarmgames.game.potentials.Potentials`) and its discrete action set
  (:class:`~swarmgames.game.actions.ActionModel`);
* ``state_dim`` and ``initial_states(n_robots, rng)``: the robots' states, D columns whose
  first three are the position (x, y, z) in metres (the network sees only those);
* ``swarm_metrics(states, previous, t)``: the mission's per-stage figures, name → float (the
  columns that follow ``mean_payoff`` in ``swarm.csv``, e.g. ``coverage`` in dBm).

Time is the simulation's, never a state column: the stage time ``t`` in seconds (the warm-up
plus the stage number times the control period, the ``t`` column of ``swarm.csv``) reaches
the potentials as ``batch.t`` (:class:`~swarmgames.game.batch.LocalGameBatch`) and the metrics
hooks as their ``t`` argument, so a mission with time-varying data (a moving target) keeps its
states to what the robots are.

Optional hooks, used when present (:func:`~swarmgames.missions.conformance.check_mission`
checks them too):

* ``robot_metrics(states, t) -> {name: (N,) array}``: extra columns of ``metrics.csv``;
* ``summary(times, swarm) -> {name: value}``: headline figures for ``summary.json`` from the
  per-stage metrics (``swarm`` maps every ``swarm.csv`` column to an ``(S,)`` array);
* ``draw(ax)``: draw the mission's background (a region, a goal) on a matplotlib Axes, under
  the robots of ``paths.png`` and of every animation frame;
* ``extent() -> (xmin, xmax, ymin, ymax)``: the area plots keep in view, metres;
* ``moves_undone(states, previous, t) -> (N,) array or None``: the first of
  ``swarm_metrics``' values with each robot's move undone in turn (robot i at
  ``previous[i]``, the others at ``states``), equal to calling ``swarm_metrics`` N times:
  the learning environment's difference reward (:mod:`swarmgames.env.vector`) asks for it
  once a step instead; None where the mission computes it no faster;
* ``baselines``: the mission's own reference controllers, a mapping of name to a
  :data:`Baseline`, a callable that returns every robot's action index ``(N,)`` from the
  robots' true states ``(N, D)`` (e.g. the coverage mission's ``"lloyd"``, Lloyd/Voronoi
  coverage). ``sim.controller = name`` runs one in place of the game; the simulation measures
  its actions as it measures the game's (:class:`~swarmgames.sim.controllers.
  BaselineController`).

A mission registered by name (:mod:`swarmgames.missions.registry`) also brings its own
configuration section, the ``[name]`` table of a scenario file, and declares the names of its
baselines (:attr:`~swarmgames.missions.registry.MissionEntry.baselines`), so that a
configuration is checked without building the mission.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable

import numpy as np

from swarmgames.game.actions import ActionModel
from swarmgames.game.potentials import Potentials

__all__ = [
    "COMMS_COLUMNS",
    "METRICS_COLUMNS",
    "NETWORK_COLUMNS",
    "OPTIONAL_HOOKS",
    "RESERVED_COLUMNS",
    "SWARM_HEAD",
    "TRAJECTORY_COLUMNS",
    "Baseline",
    "Mission",
    "MissionHooks",
]

#: Columns the simulation writes itself, in file order: trajectory.csv; metrics.csv (a
#: mission's robot metrics follow); swarm.csv starts with SWARM_HEAD, then the mission's
#: metrics, then NETWORK_COLUMNS. No mission metric may take one of these names.
TRAJECTORY_COLUMNS = ["t", "robot", "x", "y", "z", "action"]
METRICS_COLUMNS = [
    "t",
    "robot",
    "payoff",
    "neighbours",
    "local_regret",
    "global_regret",
    "expost_regret",
    "iterations",
    "converged",
    "solve_ms",
    "integrate_ms",
    "refine_sweeps",
    "refine_moves",
    "refine_ms",
]
SWARM_HEAD = ["t", "mean_payoff"]
NETWORK_COLUMNS = [
    "mean_hops",
    "max_hops",
    "components",
    "oscillation",
    "mean_info_age_s",
    "bytes_per_robot",
    "alive_robots",
    "olsr_bytes_per_robot",
    "channel_load",
]
#: Per-robot columns of the communication layer and the faults (metrics.csv, after
#: METRICS_COLUMNS).
COMMS_COLUMNS = [
    "info_age_s",
    "fresh_fraction",
    "messages_sent",
    "messages_forwarded",
    "messages_received",
    "bytes_sent",
    "bytes_forwarded",
    "bytes_received",
    "channel_load",
    "alive",
    "radio",
    "olsr_messages",
    "olsr_bytes",
]
RESERVED_COLUMNS = frozenset(
    [*TRAJECTORY_COLUMNS, *METRICS_COLUMNS, *COMMS_COLUMNS, *SWARM_HEAD, *NETWORK_COLUMNS]
)

#: Optional methods and attributes of a mission (see the module docstring).
OPTIONAL_HOOKS = ("robot_metrics", "summary", "draw", "extent", "moves_undone", "baselines")

#: A mission's baseline controller (the ``baselines`` hook): the robots' true states
#: ``(N, D)`` to every robot's action index ``(N,)``, an integer array of valid actions of the
#: mission's ``action_model``. It sees every robot's state: a centralised reference.
Baseline = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class MissionHooks:
    """The optional hooks a mission offers (:data:`OPTIONAL_HOOKS`), read once.

    Each field is the mission's own hook, or None where it has none (``baselines``: an empty
    mapping). :meth:`of` is the one place the simulation reads a mission's optional hooks;
    :func:`~swarmgames.missions.conformance.check_mission` checks what they return.

    Attributes
    ----------
    robot_metrics : callable ``(states (N, D), t) -> {name: (N,) array}`` or None
    summary : callable ``(times (S,), swarm {name: (S,) array}) -> {name: value}`` or None
    draw : callable ``(ax) -> None`` or None
    extent : callable ``() -> (xmin, xmax, ymin, ymax)`` or None
    moves_undone : callable ``(states (N, D), previous (N, D), t) -> (N,) array or None``,
        or None
    baselines : mapping of str to Baseline (read-only)
    """

    robot_metrics: Callable[..., Mapping[str, np.ndarray]] | None = None
    summary: Callable[..., Mapping[str, Any]] | None = None
    draw: Callable[[Any], None] | None = None
    extent: Callable[[], tuple[float, float, float, float]] | None = None
    moves_undone: Callable[..., np.ndarray | None] | None = None
    baselines: Mapping[str, Baseline] = field(default_factory=lambda: MappingProxyType({}))

    @classmethod
    def of(cls, mission: Any) -> MissionHooks:
        """The hooks ``mission`` offers.

        Examples
        --------
        >>> from swarmgames.missions import get_mission
        >>> from swarmgames.config import ScenarioConfig
        >>> hooks = MissionHooks.of(get_mission("coverage").build(ScenarioConfig()))
        >>> sorted(hooks.baselines), hooks.draw is not None
        (['lloyd'], True)
        """
        found = {name: getattr(mission, name, None) for name in OPTIONAL_HOOKS}
        baselines = MappingProxyType(dict(found.pop("baselines") or {}))
        return cls(**found, baselines=baselines)


@runtime_checkable
class Mission(Protocol):
    """What a mission offers the simulation.

    Attributes
    ----------
    name : str
        The mission's name (in plots and ``summary.json``).
    potentials : Potentials
        Unary and pairwise potentials of eq. 1, vectorised over a batch of local games.
    action_model : ActionModel
        The robots' discrete action set; ``apply`` maps ``(..., D)`` states to
        ``(..., A, D)`` next states.
    state_dim : int
        D, the number of state columns (>= 3; the first three are x, y, z in metres).

    Examples
    --------
    >>> from swarmgames.missions import get_mission
    >>> from swarmgames.config import ScenarioConfig
    >>> mission = get_mission("coverage").build(ScenarioConfig())
    >>> isinstance(mission, Mission), mission.state_dim
    (True, 3)
    """

    name: str
    potentials: Potentials
    action_model: ActionModel
    state_dim: int

    def initial_states(self, n_robots: int, rng: np.random.Generator) -> np.ndarray:
        """States of ``n_robots`` robots at the start, shape ``(n_robots, state_dim)``; every
        random draw from ``rng``."""
        ...

    def swarm_metrics(
        self, states: np.ndarray, previous: np.ndarray | None, t: float
    ) -> dict[str, float]:
        """The mission's figures at one stage, from the states ``(N, D)`` at the stage, those
        of the stage before (``None`` at the first stage) and the stage time ``t`` in seconds."""
        ...
