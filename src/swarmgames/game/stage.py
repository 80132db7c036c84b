"""One stage of the graphical game: every robot's action for one control period.

:func:`solve_stage` chains the layers a simulation loop needs once per control period:
routing tables → local games (:mod:`swarmgames.game.local`, with or without virtual means) →
potentials → the configured solver (:mod:`swarmgames.game.solvers`) → one action per robot.
:func:`stage_regret` measures the result against the stage game (global regret).

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.B-C and Algorithm 1.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from swarmgames.game.actions import ActionModel
from swarmgames.game.batch import LocalGameBatch, _freeze_arrays
from swarmgames.game.equilibrium import global_regret
from swarmgames.game.local import (
    broadcast,
    build_local_games,
    centralised_game,
    gather_views,
    local_games,
)
from swarmgames.game.potentials import Potentials, evaluate_payoffs
from swarmgames.game.solvers import GameSolution, Solver, normalise_rng, sample_actions
from swarmgames.topology import TopologySnapshot

__all__ = ["StageSolution", "size_groups", "solve_stage", "stage_regret"]


@dataclass(frozen=True, eq=False)
class StageSolution:
    """One stage: every robot's action, plus the games and solution behind it.

    Parameters
    ----------
    actions : ndarray of int, shape (N,)
        Action index of every robot.
    next_states : ndarray, shape (N, D)
        Every robot's state after its action (from the action model, actual states).
    batch : LocalGameBatch
        The games solved (B = N local games, or one swarm-wide game for ``centralised``).
    solution : GameSolution
    build_time_s : float
        Wall time of building the games, seconds.
    """

    actions: np.ndarray
    next_states: np.ndarray
    batch: LocalGameBatch
    solution: GameSolution
    build_time_s: float = field(default=0.0)

    def __post_init__(self) -> None:
        _freeze_arrays(self)


#: Largest pairwise table one batch of a stage may hold, entries (B K² A²): 200 MB in float64.
MAX_PAIR_ELEMS = 25_000_000


def size_groups(
    sizes: np.ndarray, buckets: int, n_actions: int, max_elems: int = MAX_PAIR_ELEMS
) -> list[np.ndarray]:
    """Robots split into batches of similar neighbourhood size |N_i|.

    Robots are sorted by size (stable) and split into ``buckets`` equal-count groups
    (0 = automatic: one per 128 robots, at most 8); a group whose pairwise table
    (``count × K_max² × A²`` entries) would exceed ``max_elems`` is split further, so the
    memory of a stage stays bounded however large the swarm.

    Returns
    -------
    list of ndarray of int
        Robot indices of each group, in order of increasing size.
    """
    sizes = np.asarray(sizes)
    n = sizes.size
    if buckets == 0:
        buckets = int(np.clip(n // 128, 1, 8))
    if buckets == 1 and n * int(sizes.max(initial=1)) ** 2 * n_actions**2 <= max_elems:
        return [np.arange(n)]
    order = np.argsort(sizes, kind="stable")
    out = []
    for g in np.array_split(order, min(int(buckets), max(n, 1))):
        if not g.size:
            continue
        per = max(1, int(max_elems // max(1, int(sizes[g[-1]]) ** 2 * n_actions**2)))
        out.extend(np.array_split(g, -(-g.size // per)))
    return out


def solve_stage(
    solver: Solver,
    snapshot: TopologySnapshot,
    h: int,
    states: np.ndarray,
    action_model: ActionModel,
    potentials: Potentials,
    rng: int | np.random.Generator | None = None,
    *,
    buckets: int | None = None,
) -> StageSolution:
    """Decide every robot's action for one control period.

    Builds each robot's local game from the routing tables (:func:`local_games`, with the
    solver's ``virtual_mean``), or the swarm-wide game for the centralised solver, solves them
    and returns one action per robot.

    Parameters
    ----------
    solver : a solver from :func:`make_solver`
    snapshot : TopologySnapshot
    h : int
        Neighbourhood radius in hops (paper: 2).
    states : ndarray, shape (N, D)
    action_model : ActionModel
    potentials : Potentials
    rng : int, Generator or None
        Randomness of ``action_choice="sample"`` and of the random solver.
    buckets : int, optional
        Solve the local games in this many batches of similar size |N_i| (robots sorted by
        |N_i|, equal counts; see :func:`size_groups`, which also splits a batch whose
        pairwise table would exceed ``MAX_PAIR_ELEMS``). 0 = automatic: one batch per 128
        robots, at most 8. Default:
        the solver's ``buckets`` (``GameConfig.buckets``). A batch is padded to its largest
        game and the pairwise table grows with K², so buckets save work and memory when
        neighbourhood sizes are uneven.
        Results do not depend on it, except through the draws of ``rng``, and up to rounding
        with ``engine="blas"`` (see :mod:`swarmgames.game.meanfield`).

    Returns
    -------
    StageSolution
        ``batch`` and ``solution`` hold the games in robot order (padded to the widest game).
    """
    if buckets is None:
        buckets = getattr(solver, "buckets", 0)
    if isinstance(buckets, bool) or not isinstance(buckets, (int, np.integer)) or buckets < 0:
        raise ValueError(f"buckets must be an integer >= 0 (got {buckets})")
    gen = normalise_rng(rng)
    t0 = time.perf_counter()
    states = np.asarray(states, dtype=float)
    centralised = getattr(solver, "centralised", False)
    if centralised:
        batch = centralised_game(snapshot, h, states, action_model)
        t_build = time.perf_counter() - t0
        sol = solver.solve(batch, potentials, gen)
        actions = sol.profile[0].copy()
        if getattr(solver, "action_choice", "argmax") == "sample":
            actions = sample_actions(sol.marginals[0], batch.action_mask[0], actions, gen)
    else:
        messages = broadcast(snapshot, h, states)
        sizes = np.diff(messages.indptr)
        groups = size_groups(sizes, int(buckets), int(action_model.n_actions))
        batches, sols = [], []
        t_build = time.perf_counter() - t0
        for owners in groups:
            t1 = time.perf_counter()
            part = build_local_games(
                gather_views(messages, owners),
                action_model,
                virtual_mean=bool(solver.virtual_mean),
            )
            t_build += time.perf_counter() - t1
            batches.append(part)
            sols.append(solver.solve(part, potentials, gen))
        inverse = np.argsort(np.concatenate(groups))
        batch = batches[0] if len(batches) == 1 else LocalGameBatch.concat(batches)
        sol = sols[0] if len(sols) == 1 else GameSolution.concat(sols)
        if len(groups) > 1:
            batch, sol = batch.select(inverse), sol.select(inverse)
        actions = sol.actions
    nxt = np.asarray(action_model.apply(states))[np.arange(states.shape[0]), actions]
    return StageSolution(actions, nxt, batch, sol, t_build)


def stage_regret(
    snapshot: TopologySnapshot,
    h: int,
    states: np.ndarray,
    action_model: ActionModel,
    potentials: Potentials,
    joint_actions,
    alpha_a: float = 1.0,
    alpha_b: float = 0.001,
) -> np.ndarray:
    """Global (stage-game) regret of every robot at the realised joint action.

    Robot i's payoff is eq. 1 over its neighbourhood N_i(h) in ``snapshot`` with the actual
    ``states`` (no virtual means); its regret is the most it could gain by changing only its
    own action, every other robot keeping its realised action. Pass the snapshot taken as the
    truth (for example instantaneous BFS on the geometry rather than lagging routing tables).

    Returns
    -------
    ndarray, shape (N,)
        >= 0; 0 for every robot iff the joint action is a pure NE of the stage game.
    """
    batch = local_games(snapshot, h, states, action_model, virtual_mean=False)
    payoffs = evaluate_payoffs(batch, potentials, alpha_a, alpha_b)
    return global_regret(payoffs, joint_actions)
