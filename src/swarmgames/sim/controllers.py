"""Controllers of the stage loop: the graphical game (the paper's method) and the Lloyd baseline.

Both return a :class:`Decision` holding every robot's action and the per-robot measurements
the run records. Both are measured the same way, on the local games of the stage:

* ``payoff`` — :math:`M_i` (eq. 1) of robot i's local game at the profile robot i settles on
  (the solver's profile of its own game: the argmax of every marginal for mean-field); for the
  Lloyd and centralised controllers, which have no local games of their own, robot i's true
  local game (actual neighbours' states, no virtual means) at the robots' actual actions;
* ``local_regret`` — the largest gain any variable of that local game gets by deviating
  alone from that profile (0 = a pure Nash equilibrium of the local game);
* ``global_regret`` — what robot i could gain by deviating alone in the *true* stage game
  (its payoff over :math:`N_i(h)` with the neighbours' actual states and actual actions);
* ``iterations``, ``converged`` — of the solver; ``solve_ms``, ``integrate_ms`` — the batch's
  solve time and payoff-integration time divided by the number of local games (amortised).

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, eq. 1, Algorithm 1, Fig. 2.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from swarmgames.errors import ConfigError
from swarmgames.game import (
    centralised_game,
    global_regret,
    local_games,
    local_regret,
    make_solver,
    profile_payoff,
)
from swarmgames.game.local import broadcast, build_local_games, gather_views
from swarmgames.game.solvers import sample_actions
from swarmgames.game.stage import size_groups
from swarmgames.sim.lloyd import lloyd_actions

__all__ = ["Decision", "GameController", "LloydController"]


@dataclass(frozen=True, eq=False)
class Decision:
    """Every robot's action and the measurements of one stage (arrays of shape (N,))."""

    actions: np.ndarray
    payoff: np.ndarray
    neighbours: np.ndarray
    local_regret: np.ndarray
    global_regret: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    solve_ms: np.ndarray
    integrate_ms: np.ndarray

    def per_robot(self) -> dict[str, np.ndarray]:
        """The per-robot columns of ``metrics.csv``."""
        return {
            "payoff": self.payoff,
            "neighbours": self.neighbours,
            "local_regret": self.local_regret,
            "global_regret": self.global_regret,
            "iterations": self.iterations,
            "converged": self.converged,
            "solve_ms": self.solve_ms,
            "integrate_ms": self.integrate_ms,
        }


class _Measured:
    """Shared construction and measurement of the local games of a stage."""

    def __init__(self, config, potentials, action_model) -> None:
        self.cfg = config
        self.potentials = potentials
        self.model = action_model
        try:
            self.solver = make_solver(config.game)
        except ValueError as exc:
            raise ConfigError(f"game: {exc}") from None

    def _games(self, snapshot, positions, virtual_mean: bool):
        batch = local_games(
            snapshot, self.cfg.network.hops, positions, self.model, virtual_mean=virtual_mean
        )
        t0 = time.perf_counter()
        pay = self.solver.evaluate(batch, self.potentials)
        return batch, pay, time.perf_counter() - t0

    def _game_groups(self, snapshot, positions, virtual_mean: bool):
        """The local games of the stage in batches of similar size
        (:func:`~swarmgames.game.stage.size_groups`), each evaluated: yields
        ``(batch, payoffs, integrate_s)``. One batch for small swarms."""
        messages = broadcast(snapshot, self.cfg.network.hops, positions)
        sizes = np.diff(messages.indptr)
        groups = size_groups(sizes, int(self.solver.buckets), int(self.model.n_actions))
        for owners in groups:
            batch = build_local_games(
                gather_views(messages, owners), self.model, virtual_mean=virtual_mean
            )
            t0 = time.perf_counter()
            pay = self.solver.evaluate(batch, self.potentials)
            yield batch, pay, time.perf_counter() - t0

    def _solve(self, pay, rng):
        try:
            return self.solver.solve_payoffs(pay, rng)
        except ValueError as exc:
            if self.cfg.game.solver != "exact":
                raise
            raise ConfigError(
                f"game.solver = 'exact' cannot solve this stage: {exc}; raise "
                "game.exact_max_profiles, use fewer robots or another solver"
            ) from None

    def _true_measures(self, snapshot, positions, actions, pay_true=None):
        """Payoff, local and global regret of every robot's true local game (actual states,
        no virtual means) at the robots' actual actions."""
        n = positions.shape[0]
        out = (np.zeros(n), np.zeros(n), np.zeros(n))
        if pay_true is None:
            parts = (p for _, p, _ in self._game_groups(snapshot, positions, False))
        else:
            parts = [pay_true]
        for pay in parts:
            members = np.asarray(pay.members)
            profile = np.where(pay.mask, actions[np.maximum(members, 0)], 0)
            owners = np.asarray(pay.owner)
            out[0][owners] = profile_payoff(pay, profile)
            out[1][owners] = local_regret(pay, profile)
            out[2][owners] = global_regret(pay, actions)
        return out


class GameController(_Measured):
    """Every robot builds and solves its local game (all games in one batch) and acts on its
    own marginal; ``game.solver`` selects the solver (``centralised``: one swarm-wide game).

    Parameters
    ----------
    config : ScenarioConfig
    potentials : Potentials
    action_model : ActionModel
    """

    def decide(self, snapshot, positions, rng) -> Decision:
        n = positions.shape[0]
        h = self.cfg.network.hops
        if getattr(self.solver, "centralised", False):
            batch = centralised_game(snapshot, h, positions, self.model)
            t0 = time.perf_counter()
            pay = self.solver.evaluate(batch, self.potentials)
            integ_s = time.perf_counter() - t0
            sol = self._solve(pay, rng)
            actions = np.asarray(sol.profile[0], dtype=np.int64)
            if self.cfg.game.action_choice == "sample":
                actions = sample_actions(sol.marginals[0], batch.action_mask[0], actions, rng)
            _, pay_true, _ = self._games(snapshot, positions, virtual_mean=False)
            payoff, lreg, greg = self._true_measures(snapshot, positions, actions, pay_true)
            neigh = _scatter(pay_true.owner, np.asarray(pay_true.mask).sum(axis=1) - 1, n)
            iters = np.full(n, int(sol.iterations[0]))
            conv = np.full(n, bool(sol.converged[0]))
            per_game = 1.0 / n
        else:
            vm = bool(self.cfg.game.virtual_mean) and bool(self.solver.virtual_mean)
            actions = np.zeros(n, dtype=np.int64)
            payoff, lreg = np.zeros(n), np.zeros(n)
            neigh, iters = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
            conv = np.zeros(n, dtype=bool)
            integ_s = solve_s = 0.0
            n_games = 0
            pays = []
            for batch, pay, t_int in self._game_groups(snapshot, positions, vm):
                sol = self._solve(pay, rng)
                owners = np.asarray(batch.owner)
                actions[owners] = sol.actions
                # The robot's own view: its local game at the profile it settled on.
                payoff[owners] = profile_payoff(pay, sol.profile)
                lreg[owners] = local_regret(pay, sol.profile)
                neigh[owners] = np.asarray(batch.mask).sum(axis=1) - 1
                iters[owners] = sol.iterations
                conv[owners] = sol.converged
                integ_s += t_int
                solve_s += sol.solve_time_s
                n_games += batch.n_games
                pays.append(pay)
            if self.cfg.sim.global_regret:
                if vm:
                    greg = self._true_measures(snapshot, positions, actions)[2]
                else:
                    greg = np.zeros(n)
                    for pay in pays:
                        greg[np.asarray(pay.owner)] = global_regret(pay, actions)
            else:
                greg = np.full(n, np.nan)
            del pays
            per_game = 1.0 / max(1, n_games)
            sol = _Timing(solve_s)
        return Decision(
            actions=actions,
            payoff=payoff,
            neighbours=neigh.astype(int),
            local_regret=lreg,
            global_regret=greg,
            iterations=iters.astype(int),
            converged=conv.astype(bool),
            solve_ms=np.full(n, 1e3 * sol.solve_time_s * per_game),
            integrate_ms=np.full(n, 1e3 * integ_s * per_game),
        )


class LloydController(_Measured):
    """Lloyd/Voronoi baseline (:mod:`swarmgames.sim.lloyd`), measured on the true local games
    at its actions."""

    def decide(self, snapshot, positions, rng) -> Decision:
        n = positions.shape[0]
        t0 = time.perf_counter()
        actions = lloyd_actions(positions, self.potentials.roi, self.model)
        solve_s = time.perf_counter() - t0
        batch, pay, integ_s = self._games(snapshot, positions, virtual_mean=False)
        payoff, lreg, greg = self._true_measures(snapshot, positions, actions, pay)
        neigh = _scatter(np.asarray(batch.owner), np.asarray(batch.mask).sum(axis=1) - 1, n)
        return Decision(
            actions=actions,
            payoff=payoff,
            neighbours=neigh.astype(int),
            local_regret=lreg,
            global_regret=greg,
            iterations=np.ones(n, dtype=int),
            converged=np.ones(n, dtype=bool),
            solve_ms=np.full(n, 1e3 * solve_s / n),
            integrate_ms=np.full(n, 1e3 * integ_s / n),
        )


@dataclass(frozen=True)
class _Timing:
    solve_time_s: float


def _scatter(owners: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    out = np.zeros(n, dtype=np.asarray(values).dtype)
    out[np.asarray(owners)] = values
    return out
