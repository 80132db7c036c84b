"""Model-predictive control over stage games: ``sim.controller = "mpc"``.

The myopic game controller solves each stage's local games and acts. The MPC controller
looks ``H = sim.mpc_horizon`` stages ahead before it acts: from the current stage it tries a
few candidate joint actions, plays each forward on the run's own models — the network
provider restored from its snapshot (:meth:`~swarmgames.sim.loop.StageLoop.state`), the
messages exchanged by the communication layer, the faults — with the myopic controller for
the H − 1 stages after it, and executes the candidate whose predicted stages score best; at
the next stage it plans again (a receding horizon). The score of a candidate is

.. math:: J = \\sum_{s=0}^{H-1} \\frac{1}{|A_s|} \\sum_{i \\in A_s} M_i\\bigl(x^{(s)}\\bigr),

the robots' payoffs in their true local games (actual states, no virtual means) at the joint
actions of each predicted stage, averaged over the robots alive. Candidates:

1. the myopic decision (the game controller's, as ``sim.controller = "game"`` takes it);
2. every robot that the myopic decision sends back to where it was one stage before holds
   its position instead (the two-stage cycle a myopic game can fall into);
3. ``sim.mpc_samples`` profiles drawn from the robots' mean-field marginals (seeded).

A candidate in which every robot holds its position is not among them: over a short horizon
it often scores best (no move costs, no link put at risk) and, chosen again at every stage,
freezes the swarm short of its goal.

A tie goes to the earlier candidate, so the myopic decision wins unless another is strictly
better. With ``H = 1`` nothing is predicted and the controller is the myopic one, bit for
bit. The planner uses the simulator's models of the future, so it is a centralised
reference, not a decentralised controller: it shows what looking ahead is worth. Its cost is
about ``candidates × H`` stages per stage. ns-3 cannot snapshot its simulator, so MPC does
not run on it (a configuration error says so).

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section IV (MPC as future work).
.. [2] J. B. Rawlings, D. Q. Mayne, M. M. Diehl, *Model Predictive Control: Theory,
   Computation, and Design*, 2nd ed., 2017, chapter 1 (receding horizon).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from swarmgames.game.actions import action_mask_of
from swarmgames.game.problem import StageProblem
from swarmgames.game.stage import StageSolution
from swarmgames.sim.controllers import GameController

__all__ = ["MpcController"]

#: Position change below which a robot is where it was, metres (as ``loop.oscillation``).
SAME_PLACE_M = 1e-6


class MpcController:
    """The receding-horizon controller (see the module docstring).

    Parameters
    ----------
    config : ScenarioConfig
        Uses ``sim.mpc_horizon``, ``sim.mpc_samples`` and ``seed``, and the game controller's
        settings.
    mission : Mission
    """

    def __init__(self, config, mission) -> None:
        self.inner = GameController(config, mission)
        self.mission = mission
        self.hops = self.inner.hops
        self.horizon = int(config.sim.mpc_horizon)
        self.samples = int(config.sim.mpc_samples)
        self._seed = np.random.SeedSequence(config.seed).spawn(7)[6]
        self._plan: np.ndarray | None = None  # the chosen actions, when not the myopic ones
        self._plan_s = 0.0
        self.last_scores: np.ndarray = np.zeros(0)

    # ------------------------------------------------------------------ the loop's hooks
    def plan(self, loop) -> None:
        """Before the stage's messages: predict every candidate H stages ahead on ``loop``
        (restored to where it was afterwards) and keep the best."""
        if self.horizon <= 1:
            self._plan, self._plan_s = None, 0.0
            return
        t0 = time.perf_counter()
        saved = loop.state()
        try:
            view = loop.observe()
            problem = self.inner.problem(*view.problem_fields, keep_games=True)
            myopic = self.inner.decide(problem, loop.rng)
            candidates = self._candidates(loop, view, myopic)
            scores = np.array([self._score(loop, saved, c) for c in candidates])
        finally:
            loop.restore(saved)
        best = int(np.argmax(scores))  # the first of the best: the myopic one on a tie
        self.last_scores = scores
        self._plan = None if best == 0 else candidates[best]
        self._plan_s = time.perf_counter() - t0

    def problem(self, t: float, snapshot, states, messages, **options) -> StageProblem:
        """The stage problem (the game controller's)."""
        return self.inner.problem(t, snapshot, states, messages, **options)

    def decide(self, problem: StageProblem, rng) -> StageSolution:
        """The planned first action of this stage (the myopic decision when it is the best,
        or without a plan)."""
        chosen, planning = self._plan, self._plan_s
        self._plan, self._plan_s = None, 0.0
        if chosen is None:
            dec = self.inner.decide(problem, rng)
            return replace(dec, solve_s=dec.solve_s + planning) if planning else dec
        t0 = time.perf_counter()
        dec = self.measure(problem, chosen)
        return replace(dec, solve_s=planning + time.perf_counter() - t0)

    def measure(self, problem: StageProblem, actions, *, expost=None) -> StageSolution:
        """Given ``actions`` with their measures on the true local games (as the game
        controller's :meth:`~swarmgames.sim.controllers.GameController.measure`)."""
        return self.inner.measure(problem, actions, expost=expost)

    def expost_regret(self, problem: StageProblem, actions, next_states) -> np.ndarray:
        """Every robot's ex-post regret against the states the robots reached (the game
        controller's :meth:`~swarmgames.sim.controllers.GameController.expost_regret`)."""
        return self.inner.expost_regret(problem, actions, next_states)

    # ------------------------------------------------------------------ planning
    def _candidates(self, loop, view, myopic) -> list[np.ndarray]:
        states = view.states
        n = states.shape[0]
        mask = action_mask_of(self.mission.action_model, states)
        first = np.asarray(myopic.actions, dtype=np.int64)
        out = [first]
        nxt = np.asarray(myopic.next_states)
        prev = loop.previous
        stay = _stay_actions(self.mission.action_model, states, mask)
        if prev is not None and stay is not None:
            back = np.linalg.norm(nxt[:, :3] - prev[:, :3], axis=1) <= SAME_PLACE_M
            moved = np.linalg.norm(states[:, :3] - prev[:, :3], axis=1) > SAME_PLACE_M
            cycling = back & moved
            if cycling.any():
                out.append(np.where(cycling, stay, first))
        if self.samples and myopic.solution is not None:
            rng = np.random.default_rng([*self._seed.generate_state(2), loop.stage])
            own = np.asarray(myopic.solution.marginals)[:, 0, :]  # each robot's own marginal
            own = np.where(mask, np.clip(own, 0.0, None), 0.0)
            own = own / np.maximum(own.sum(axis=1, keepdims=True), 1e-300)
            for _ in range(self.samples):
                u = rng.random((n, 1))
                pick = (np.cumsum(own, axis=1) < u).sum(axis=1)
                out.append(np.minimum(pick, mask.shape[1] - 1).astype(np.int64))
        return out

    def _score(self, loop, saved, actions: np.ndarray) -> float:
        """J of playing ``actions`` now and the myopic decisions after (see the module
        docstring), predicted on ``loop`` from ``saved``."""
        loop.restore(saved)
        total = 0.0
        for step in range(self.horizon):
            problem = self.inner.problem(*loop.observe().problem_fields)
            if step:
                actions = self.inner.decide(problem, loop.rng).actions
            # A predicted stage is scored by its payoff: its ex-post regret is not needed.
            record = loop.act(self.measure(problem, actions, expost=False))
            pay = np.where(record.robot["alive"], record.robot["payoff"], np.nan)
            total += float(np.nanmean(pay)) if np.isfinite(pay).any() else 0.0
        return total


def _stay_actions(action_model, states, mask) -> np.ndarray | None:
    """For every robot, an allowed action that keeps its position, or None if some robot
    has none (then no candidate holds positions)."""
    nxt = np.asarray(action_model.apply(states))  # (N, A, D)
    still = np.linalg.norm(nxt[..., :3] - states[:, None, :3], axis=-1) <= SAME_PLACE_M
    still &= mask
    if not still.any(axis=1).all():
        return None
    return np.argmax(still, axis=1).astype(np.int64)
