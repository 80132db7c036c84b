"""Controllers of the stage loop: the graphical game (the paper's method) and mission baselines.

Both are thin: they turn an observed stage and the configuration into a
:class:`~swarmgames.game.problem.StageProblem` (:meth:`~Controller.problem`), solve it with
the game layer's one stage pipeline (:func:`~swarmgames.game.stage.solve`) or measure given
actions on it (:func:`~swarmgames.game.stage.measure_stage`), and return its
:class:`~swarmgames.game.stage.StageSolution`, so every controller is measured the same way:

* ``payoff`` — :math:`M_i` (eq. 1) of robot i's local game at the profile robot i settles on;
  for the baseline and centralised controllers, which have no local games of their own, robot
  i's true local game (actual neighbours' states, no virtual means) at the actual actions;
* ``local_regret`` — the largest gain any variable of that local game gets by deviating alone
  from that profile (0 = a pure Nash equilibrium of the local game);
* ``global_regret`` — what robot i could gain by deviating alone in its *true* local game;
* ``expost_regret`` — what robot i could have gained, given the states its neighbours
  actually reached (:mod:`swarmgames.game.expost`; measured with the global regret);
* ``iterations``, ``converged`` — of the solver; the solve and payoff-integration times.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, eq. 1, Algorithm 1, Fig. 2.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Protocol

import numpy as np

from swarmgames.errors import ConfigError
from swarmgames.game import Solver, capabilities_of, make_solver
from swarmgames.game.kept import RowTables
from swarmgames.game.problem import StageProblem
from swarmgames.game.stage import StageSolution, measure_expost, measure_stage, solve
from swarmgames.missions.protocol import MissionHooks
from swarmgames.names import CONTROLLERS

__all__ = [
    "BaselineController",
    "Controller",
    "GameController",
    "make_controller",
    "solver_from_config",
]


def solver_from_config(game) -> Solver:
    """The solver a :class:`~swarmgames.config.GameConfig` names (``centralised`` is the
    mean-field solver on one swarm-wide game)."""
    name = "mean_field" if game.solver == "centralised" else game.solver
    params = {
        "alpha_a": game.alpha_a,
        "alpha_b": game.alpha_b,
        "dtype": game.dtype,
        "pair_weighting": game.pair_weighting,
    }
    if name == "mean_field":
        params.update(
            beta=game.beta,
            delta=game.delta,
            max_iter=game.max_iter,
            action_choice=game.action_choice,
            engine=game.engine,
        )
    elif name == "exact":
        params["max_profiles"] = game.max_profiles
    elif name == "best_response":
        params["max_iter"] = game.max_iter
    return make_solver(name, **params)


class Controller(Protocol):
    """What the stage loop (:class:`~swarmgames.sim.loop.StageLoop`) asks of a controller.

    Attributes
    ----------
    hops : int
        h, the neighbourhood radius of its stage problems.
    """

    hops: int

    def plan(self, loop) -> None:
        """Before the stage's messages are exchanged: look ahead on ``loop`` (restored to
        where it was afterwards), or nothing."""
        ...

    def problem(self, t: float, snapshot, states, messages, **options) -> StageProblem:
        """The stage problem at time ``t`` with the routing tables ``snapshot``, the true
        ``states`` and the ``messages`` every robot holds; ``options`` replace the
        controller's values of the problem's other fields."""
        ...

    def decide(self, problem: StageProblem, rng: np.random.Generator) -> StageSolution:
        """Every robot's action and its measures."""
        ...

    def measure(self, problem: StageProblem, actions, *, expost: bool | None = None):
        """Given actions with the measures the controller takes of its own decisions."""
        ...

    def expost_regret(self, problem: StageProblem, actions, next_states) -> np.ndarray:
        """Every robot's ex-post regret against the states the robots reached, (N,)."""
        ...


class _Controller:
    """What every controller shares: the solver that measures, the stage's parameters."""

    def __init__(self, config, mission) -> None:
        self.mission = mission
        try:  # a plug-in's potentials must declare their optional forms
            capabilities_of(mission.potentials)
        except TypeError as exc:
            raise ConfigError(f"mission {mission.name!r}: {exc}") from None
        self.hops = int(config.network.hops)
        self.buckets = int(config.game.buckets)
        self.solver_name = config.game.solver
        self.solver = solver_from_config(config.game)
        self.global_regret = bool(config.sim.global_regret)
        self.virtual_mean = config.game.virtual_mean  # normalised by the schema: "eq3", ...
        self.centralised = config.game.solver == "centralised"
        self.refine = config.game.refine
        #: The per-row values this run's stages keep for the next (results do not depend on it).
        self.kept = RowTables()

    def plan(self, loop) -> None:
        """Nothing: the controller decides from the stage alone."""

    def problem(self, t: float, snapshot, states, messages, **options) -> StageProblem:
        """The stage problem at time ``t`` (s) with the routing tables ``snapshot``, the true
        ``states`` (N, D) and the ``messages`` every robot holds, with this controller's
        mission, solver and options; ``options``: other values of the problem's fields
        (``keep_games=True``: the solved games and marginals are kept in the solution;
        ``swarms``, ``global_regret``, ``kept``)."""
        m = self.mission
        fields = {
            "h": self.hops,
            "action_model": m.action_model,
            "potentials": m.potentials,
            "solver": self.solver,
            "virtual_mean": self.virtual_mean,
            "centralised": self.centralised,
            "buckets": self.buckets,
            "global_regret": self.global_regret,
            "refine": self.refine,
            "kept": self.kept,
        }
        return StageProblem(
            t=t, snapshot=snapshot, states=states, messages=messages, **{**fields, **options}
        )

    def measure(self, problem: StageProblem, actions, *, expost: bool | None = None):
        """Given ``actions`` with the measures :func:`~swarmgames.game.stage.solve` takes of
        its own (payoff, local and global regret on the true local games, and the ex-post
        regret when ``expost``; default: with ``sim.global_regret``)."""
        expost = self.global_regret if expost is None else bool(expost)
        return measure_stage(problem, actions, expost=expost)

    def expost_regret(self, problem: StageProblem, actions, next_states) -> np.ndarray:
        """Every robot's ex-post regret against the states ``next_states`` the robots
        reached (:func:`~swarmgames.game.stage.measure_expost`), (N,)."""
        return measure_expost(problem, actions, next_states)


class GameController(_Controller):
    """Every robot builds and solves its local game (all games batched) and acts on its own
    marginal (``game.virtual_mean``: how the members reaching outside N_i stand in for it);
    ``game.solver = "centralised"`` solves the swarm as one game instead.

    Parameters
    ----------
    config : ScenarioConfig
    mission : Mission
    """

    def decide(self, problem: StageProblem, rng) -> StageSolution:
        """Every robot's action in ``problem`` (:func:`~swarmgames.game.stage.solve`)."""
        try:
            return solve(problem, rng)
        except ValueError as exc:
            if self.solver_name != "exact":
                raise
            raise ConfigError(
                f"game.solver = 'exact' cannot solve this stage: {exc}; raise "
                "game.max_profiles, use fewer robots or another solver"
            ) from None


class BaselineController(_Controller):
    """A baseline the mission offers (its ``baselines`` hook, :mod:`swarmgames.missions.
    protocol`), measured on the true local games at its actions.

    Parameters
    ----------
    config : ScenarioConfig
    mission : Mission
    name : str
        The baseline's name among the mission's ``baselines`` (``sim.controller``).

    Raises
    ------
    ConfigError
        The mission offers no baseline ``name``; the message lists those it offers.
    """

    def __init__(self, config, mission, name: str) -> None:
        super().__init__(config, mission)
        offered = MissionHooks.of(mission).baselines
        if name not in offered:
            have = ", ".join(map(repr, offered)) or "none"
            raise ConfigError(
                f"sim.controller must be {', '.join(map(repr, CONTROLLERS))} or a baseline "
                f"of mission {mission.name!r} (it offers: {have}) (got {name!r})"
            )
        self.name = name
        self.baseline = offered[name]

    def decide(self, problem: StageProblem, rng) -> StageSolution:
        """Every robot's action from the baseline (from every true state: a baseline is
        centralised, the messages are unused), and its measures."""
        states = problem.states
        n = states.shape[0]
        t0 = time.perf_counter()
        actions = np.asarray(self.baseline(states), dtype=np.int64)
        solve_s = time.perf_counter() - t0
        stage = self.measure(problem, actions)
        return replace(
            stage,
            iterations=np.ones(n, dtype=np.int64),
            converged=np.ones(n, dtype=bool),
            solve_s=solve_s,
        )


def make_controller(config, mission):
    """The controller ``sim.controller`` names: the game controller, the receding-horizon
    controller (:mod:`swarmgames.sim.mpc`) or one of the mission's baselines.

    Raises
    ------
    ConfigError
        ``sim.controller`` names a baseline the mission does not offer.
    """
    if config.sim.controller == "game":
        return GameController(config, mission)
    if config.sim.controller == "mpc":
        from swarmgames.sim.mpc import MpcController

        return MpcController(config, mission)
    return BaselineController(config, mission, config.sim.controller)
