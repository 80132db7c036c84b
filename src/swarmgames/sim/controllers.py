"""Controllers of the stage loop: the graphical game (the paper's method) and the Lloyd baseline.

Both are thin: they turn the configuration into the parameters of the game layer's one stage
pipeline (:func:`~swarmgames.game.stage.solve_stage`, :func:`~swarmgames.game.stage.
measure_stage`) and return its :class:`~swarmgames.game.stage.StageSolution`, so every
controller is measured the same way:

* ``payoff`` — :math:`M_i` (eq. 1) of robot i's local game at the profile robot i settles on;
  for the Lloyd and centralised controllers, which have no local games of their own, robot
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

import numpy as np

from swarmgames.errors import ConfigError
from swarmgames.game import Solver, capabilities_of, make_solver
from swarmgames.game.stage import StageSolution, measure_expost, measure_stage, solve_stage
from swarmgames.missions.coverage.lloyd import lloyd_actions

__all__ = ["GameController", "LloydController", "make_controller", "solver_from_config"]


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


class _Controller:
    """What both controllers share: the solver that measures, the stage's parameters."""

    def __init__(self, config, mission) -> None:
        self.mission = mission
        capabilities_of(mission.potentials)  # a plug-in must declare its optional forms
        self.hops = int(config.network.hops)
        self.buckets = int(config.game.buckets)
        self.solver_name = config.game.solver
        self.solver = solver_from_config(config.game)
        self.global_regret = bool(config.sim.global_regret)

    def measure(self, snapshot, states, actions, *, expost: bool | None = None) -> StageSolution:
        """Given ``actions`` with the measures :func:`~swarmgames.game.stage.solve_stage`
        takes of its own (payoff, local and global regret on the true local games, and the
        ex-post regret when ``expost``; default: with ``sim.global_regret``)."""
        m = self.mission
        return measure_stage(
            self.solver,
            snapshot,
            self.hops,
            states,
            m.action_model,
            m.potentials,
            actions,
            buckets=self.buckets,
            expost=self.global_regret if expost is None else bool(expost),
        )

    def expost_regret(self, snapshot, states, actions, next_states) -> np.ndarray:
        """Every robot's ex-post regret against the states ``next_states`` the robots
        reached (:func:`~swarmgames.game.stage.measure_expost`), (N,)."""
        m = self.mission
        return measure_expost(
            self.solver,
            snapshot,
            self.hops,
            states,
            next_states,
            actions,
            m.action_model,
            m.potentials,
            buckets=self.buckets,
        )


class GameController(_Controller):
    """Every robot builds and solves its local game (all games batched) and acts on its own
    marginal (``game.virtual_mean``: how the members reaching outside N_i stand in for it);
    ``game.solver = "centralised"`` solves the swarm as one game instead.

    Parameters
    ----------
    config : ScenarioConfig
    mission : Mission
    """

    def __init__(self, config, mission) -> None:
        super().__init__(config, mission)
        self.virtual_mean = config.game.virtual_mean  # normalised by the schema: "eq3", ...
        self.centralised = config.game.solver == "centralised"
        self.refine = config.game.refine

    def decide(self, snapshot, states, rng, inbox=None, keep_games=False) -> StageSolution:
        """Every robot's action at ``states`` with the tables of ``snapshot``, each local game
        built from ``inbox`` (what the robots know; default: exact, instant delivery);
        ``keep_games``: the solved games and marginals are kept in the solution."""
        m = self.mission
        try:
            return solve_stage(
                self.solver,
                snapshot,
                self.hops,
                states,
                m.action_model,
                m.potentials,
                rng,
                virtual_mean=self.virtual_mean,
                centralised=self.centralised,
                buckets=self.buckets,
                global_regret=self.global_regret,
                inbox=inbox,
                keep_games=keep_games,
                refine=self.refine,
            )
        except ValueError as exc:
            if self.solver_name != "exact":
                raise
            raise ConfigError(
                f"game.solver = 'exact' cannot solve this stage: {exc}; raise "
                "game.max_profiles, use fewer robots or another solver"
            ) from None


class LloydController(_Controller):
    """Lloyd/Voronoi baseline (:mod:`swarmgames.missions.coverage.lloyd`) over the mission's
    ``density``, measured on the true local games at its actions.

    Raises
    ------
    ConfigError
        The mission has no ``density`` (Lloyd's algorithm covers a density).
    """

    def __init__(self, config, mission) -> None:
        super().__init__(config, mission)
        if getattr(mission, "density", None) is None:
            raise ConfigError(
                f"sim.controller = 'lloyd' needs a mission with a density to cover; mission "
                f"{getattr(mission, 'name', config.scenario)!r} has none"
            )

    def decide(self, snapshot, states, rng, inbox=None) -> StageSolution:
        """Each robot's move toward its Voronoi centroid (from every true position: the
        baseline is centralised, ``inbox`` is unused), and its measures."""
        m = self.mission
        n = states.shape[0]
        t0 = time.perf_counter()
        actions = lloyd_actions(states, m.density, m.action_model)
        solve_s = time.perf_counter() - t0
        stage = self.measure(snapshot, states, actions)
        return replace(
            stage,
            iterations=np.ones(n, dtype=np.int64),
            converged=np.ones(n, dtype=bool),
            solve_s=solve_s,
        )


def make_controller(config, mission):
    """The controller ``sim.controller`` names: the game controller, Lloyd's baseline or the
    receding-horizon controller (:mod:`swarmgames.sim.mpc`)."""
    if config.sim.controller == "lloyd":
        return LloydController(config, mission)
    if config.sim.controller == "mpc":
        from swarmgames.sim.mpc import MpcController

        return MpcController(config, mission)
    return GameController(config, mission)
