"""One stage of the graphical game, built, evaluated, solved and measured in one place.

:func:`solve` is the stage pipeline that the simulation's controllers, the benchmarks, the
environment, the MPC controller and the public API all call once per control period, on a
:class:`~swarmgames.game.problem.StageProblem`:

1. the messages every robot holds (the problem's; exact ones are also the truth the
   measurements need, otherwise N_i(h) is built from the routing tables once), robots split
   into batches of similar neighbourhood size (:func:`size_groups`);
2. per batch: the local games (with virtual means, eq. 3, or one of the other variants of
   :data:`~swarmgames.names.VIRTUAL_MEANS`), their payoff tables (the potentials, eq. 1) and
   their solution (the configured solver, Algorithm 1); with ``refine="best_response"``
   each game's profile is then refined by best-response sweeps from the solver's profile to
   a pure Nash equilibrium (:mod:`swarmgames.game.refine`), and the owner plays its action
   of the refined profile;
3. robots whose states coincide build the same game and would take the same action for
   ever: they get distinct actions, the order among them drawn from the stage's Generator
   (:func:`~swarmgames.game.colocated.separate_colocated`; nothing changes, and nothing is
   drawn, when no two robots coincide);
4. the measurements from the tables already computed: every robot's payoff :math:`M_i` and
   local regret at the profile it settled on, and its global (stage-game) regret at the
   realised joint action. The global regret needs robot i's *true* local game (actual states,
   no virtual means, no context): it is the solved game itself whenever no member of N_i was
   replaced by a virtual mean and no context joined it, and only the other games are built
   and evaluated a second time. The ex-post regret (:mod:`swarmgames.game.expost`) scores
   robot i's actions against the states its neighbours reached: its games are built and
   evaluated once more.

``centralised=True`` solves the swarm as one game instead (the centralised baseline) and
measures every robot on its true local game. :func:`measure_stage` measures given actions the
same way (for controllers that are not games, such as a mission's baseline);
:func:`stage_regret` measures a joint action against any snapshot taken as the truth.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.B-C and Algorithm 1.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from swarmgames.arrays import freeze_fields, sorted_unique
from swarmgames.game.actions import ActionModel
from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.colocated import separate_colocated
from swarmgames.game.equilibrium import (
    OwnerPayoffs,
    global_regret,
    owner_deviations,
    profile_measures,
)
from swarmgames.game.expost import expost_games, expost_regret
from swarmgames.game.local import (
    Inbox,
    Messages,
    broadcast,
    build_local_games,
    centralised_game,
    local_games,
)
from swarmgames.game.potentials import GamePayoffs, Potentials, evaluate_payoffs
from swarmgames.game.problem import StageProblem
from swarmgames.game.refine import refine_profiles
from swarmgames.game.rows import StageRows
from swarmgames.game.solvers import GameSolution, sample_actions
from swarmgames.game.virtual import virtual_mode
from swarmgames.rng import as_generator
from swarmgames.topology import TopologySnapshot

__all__ = [
    "StageSolution",
    "evaluate_games",
    "measure_expost",
    "measure_stage",
    "plan_stage",
    "profile_payoffs",
    "sharing_games",
    "size_groups",
    "solve",
    "stage_regret",
]


@dataclass(frozen=True, eq=False)
class StageSolution:
    """One stage: every robot's action and what the run measures of it.

    Parameters
    ----------
    actions : ndarray of int64, shape (N,)
        Action index of every robot.
    next_states : ndarray, shape (N, D)
        Every robot's state after its action (from the action model).
    payoff : ndarray, shape (N,)
        :math:`M_i` (eq. 1) of robot i's local game at the profile robot i settled on (the
        solver's profile of its own game); for centralised or given actions, robot i's true
        local game at the realised actions.
    local_regret : ndarray, shape (N,)
        Largest gain of any variable of that game deviating alone from that profile
        (0: a pure Nash equilibrium of the local game).
    global_regret : ndarray, shape (N,)
        What robot i could gain by deviating alone in its true local game, every other robot
        at its realised action; NaN when not measured.
    neighbours : ndarray of int64, shape (N,)
        :math:`|N_i| - 1`.
    iterations : ndarray of int64, shape (N,)
        Solver iterations of robot i's game (of the swarm's game when centralised).
    converged : ndarray of bool, shape (N,)
    integrate_s, solve_s, build_s : float
        Wall time of evaluating the potentials, of solving and of building the games of the
        solve, seconds (measurement-only work is not counted).
    n_games : int
        Number of games solved (N, or 1 when centralised).
    batch : LocalGameBatch or None
        The games solved, in robot order (only with ``keep_games=True``).
    solution : GameSolution or None
        Their solution (only with ``keep_games=True``; with a refinement, its ``profile``
        and ``actions`` are the refined ones).
    expost_regret : ndarray, shape (N,)
        What robot i could have gained, given the states its neighbours actually reached
        (:mod:`swarmgames.game.expost`); NaN when not measured (the default).
    refine_sweeps, refine_moves : ndarray of int64, shape (N,)
        Best-response sweeps and variable switches of the refinement of robot i's game
        (:func:`~swarmgames.game.refine.refine_profiles`: 1 and 0 for a profile that was
        already a pure NE); 0 and 0 without a refinement (the default).
    refine_s : float
        Wall time of the refinements, seconds (not part of ``solve_s``).
    expost_s : float
        Wall time of the ex-post regret measurement, seconds.
    """

    actions: np.ndarray
    next_states: np.ndarray
    payoff: np.ndarray
    local_regret: np.ndarray
    global_regret: np.ndarray
    neighbours: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    integrate_s: float = 0.0
    solve_s: float = 0.0
    build_s: float = 0.0
    n_games: int = 0
    batch: LocalGameBatch | None = field(default=None, repr=False)
    solution: GameSolution | None = field(default=None, repr=False)
    expost_regret: np.ndarray | None = None
    refine_sweeps: np.ndarray | None = None
    refine_moves: np.ndarray | None = None
    refine_s: float = 0.0
    expost_s: float = 0.0

    def __post_init__(self) -> None:
        n = np.shape(self.actions)[0]
        if self.expost_regret is None:
            object.__setattr__(self, "expost_regret", np.full(n, np.nan))
        for name in ("refine_sweeps", "refine_moves"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, np.zeros(n, dtype=np.int64))
        freeze_fields(self)

    @property
    def n_robots(self) -> int:
        """N."""
        return int(self.actions.size)


#: Largest pairwise table one batch of a stage may hold, entries (B K² A²): 200 MB in float64.
MAX_PAIR_ELEMS = 25_000_000


def size_groups(
    sizes: np.ndarray,
    buckets: int,
    n_actions: int,
    max_elems: int = MAX_PAIR_ELEMS,
    *,
    on_demand: bool = False,
    shared: np.ndarray | None = None,
) -> list[np.ndarray]:
    """Robots split into batches of similar neighbourhood size |N_i|.

    Robots are sorted by size (stable) and split into ``buckets`` equal-count groups
    (0 = automatic: one per 128 robots, at most 8); a group whose pairwise table
    (``count × K_max² × A²`` entries) would exceed ``max_elems`` is split further, so the
    memory of a stage stays bounded however large the swarm. With ``on_demand`` (the solver
    computes the tables per chunk of games: ``pairs_on_demand`` of its
    :class:`~swarmgames.game.capabilities.SolverCapabilities`) a batch holds no table,
    only the measurements' rows of it at a profile, ``count × K_max² × A`` entries.

    ``shared`` (N,) int, optional: a label per robot whose equal labels mark games that hold
    one pairwise table between them (:func:`held_sharing`; -1: a table of its own). A group
    whose games all have labels, ``d`` distinct ones, holds at most ``min(d, count)`` tables
    and the rows of every game at a profile: it is split into batches of the most games
    ``c`` with ``min(d, c) K_max² A² + c K_max² A <= max_elems`` (a dense swarm's batches
    then hold 21 games of K = 300, where a table per game would allow 3).

    Returns
    -------
    list of ndarray of int
        Robot indices of each group, in order of increasing size.
    """
    sizes = np.asarray(sizes)
    n = sizes.size
    per_var = n_actions if on_demand else n_actions**2
    if buckets == 0:
        buckets = int(np.clip(n // 128, 1, 8))
    if buckets == 1 and n * int(sizes.max(initial=1)) ** 2 * per_var <= max_elems:
        return [np.arange(n)]
    order = np.argsort(sizes, kind="stable")
    out = []
    for g in np.array_split(order, min(int(buckets), max(n, 1))):
        if not g.size:
            continue
        k2 = int(sizes[g[-1]]) ** 2
        per = max(1, int(max_elems // max(1, k2 * per_var)))
        if shared is not None and not on_demand and np.all(shared[g] >= 0):
            per = max(per, sharing_games(sorted_unique(shared[g]).size, k2, n_actions, max_elems))
        out.extend(np.array_split(g, -(-g.size // per)))
    return out


def sharing_games(d: int, k2: int, n_actions: int, max_elems: int) -> int:
    """The most games ``c`` of a batch with ``min(d, c)`` tables of ``k2 A²`` entries and
    ``c`` rows of ``k2 A`` within ``max_elems``."""
    table, rows = k2 * n_actions**2, k2 * n_actions
    if d * table + d * rows <= max_elems:  # more games than tables
        return max(d, int((max_elems - d * table) // rows))
    return max(1, int(max_elems // (table + rows)))


def sharing_labels(messages: Messages, n_actions: int, min_entries: int) -> np.ndarray:
    """A label per robot, equal for robots whose local games (from exact ``messages``) hold
    the same robots, and -1 for games of fewer than ``min_entries`` valid entries: the
    ``shared`` of :func:`size_groups`. Each neighbourhood is labelled by its size and a
    64-bit hash of its sorted members (a collision only merges two labels in the budget)."""
    sizes = messages.sizes.astype(np.int64)
    n = sizes.size
    big = sizes * n_actions >= min_entries
    if not big.any():
        return np.full(n, -1, dtype=np.int64)
    members = np.asarray(messages.indices, dtype=np.uint64)
    pos = np.arange(members.size, dtype=np.uint64) - np.repeat(
        np.asarray(messages.indptr[:-1], dtype=np.uint64), sizes
    )
    with np.errstate(over="ignore"):
        mixed = (members + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15) ^ (
            pos * np.uint64(0xC2B2AE3D27D4EB4F)
        )
        mixed *= np.uint64(0xFF51AFD7ED558CCD)
    h = np.zeros(n, dtype=np.uint64)
    nz = sizes > 0
    h[nz] = np.bitwise_xor.reduceat(mixed, np.asarray(messages.indptr[:-1])[nz])
    key = h ^ (sizes.astype(np.uint64) << np.uint64(48))
    _, label = np.unique(key, return_inverse=True)
    return np.where(big, label.reshape(-1), -1)


class _Record:
    """The per-robot arrays of a stage, filled game batch by game batch."""

    def __init__(self, problem: StageProblem, n_actions: int = 0) -> None:
        n = problem.n_robots
        #: The stage's distinct rows, shared by every batch the stage builds.
        self.rows = StageRows(kept=problem.kept)
        self.actions = np.zeros(n, dtype=np.int64)
        self.marginal = np.zeros((n, n_actions))
        self.action_mask = np.zeros((n, n_actions), dtype=bool)
        self.payoff = np.zeros(n)
        self.local_regret = np.zeros(n)
        self.global_regret = np.full(n, np.nan)
        self.expost_regret = np.full(n, np.nan)
        self.refine_sweeps = np.zeros(n, dtype=np.int64)
        self.refine_moves = np.zeros(n, dtype=np.int64)
        self.neighbours = np.zeros(n, dtype=np.int64)
        self.iterations = np.zeros(n, dtype=np.int64)
        self.converged = np.zeros(n, dtype=bool)

    def measure(self, owners, batch, pay, profile) -> None:
        """Payoff, local regret and neighbour count of the games of ``owners`` (context
        variables, which decide nothing, are not counted as neighbours)."""
        players = None if batch.is_context is None else batch.players
        self.payoff[owners], self.local_regret[owners] = profile_measures(pay, profile, players)
        self.neighbours[owners] = np.asarray(batch.players).sum(axis=1) - 1

    def next_states(self, states, action_model) -> np.ndarray:
        """Every robot's state after its action, (N, D)."""
        return np.asarray(action_model.apply(states))[np.arange(states.shape[0]), self.actions]

    def solution(self, states, action_model, nxt=None, **extra) -> StageSolution:
        if nxt is None:
            nxt = self.next_states(states, action_model)
        return StageSolution(
            actions=self.actions,
            next_states=nxt,
            payoff=self.payoff,
            local_regret=self.local_regret,
            global_regret=self.global_regret,
            neighbours=self.neighbours,
            iterations=self.iterations,
            converged=self.converged,
            expost_regret=self.expost_regret,
            refine_sweeps=self.refine_sweeps,
            refine_moves=self.refine_moves,
            **extra,
        )


def evaluate_games(
    problem: StageProblem,
    inbox: Inbox,
    owners,
    *,
    virtual_mean: bool | str,
    stage: StageRows | None = None,
) -> tuple[LocalGameBatch, GamePayoffs, float, float]:
    """The second step, for one batch: the local games of ``owners`` built from their inboxes
    (``inbox.views(owners)``, with ``context=True`` for ``virtual_mean = "exact"``:
    :class:`~swarmgames.game.local.Messages` for exact, instant delivery, or what a
    communication model delivered) at the problem's time, with its action model, and their
    payoff tables (its potentials under its solver's weights); with the build and the
    evaluation (payoff integration) times, seconds. ``stage``: the distinct rows of the
    stage the batch belongs to (default: a batch of its own, with the problem's kept
    tables)."""
    t0 = time.perf_counter()
    mode = virtual_mode(virtual_mean)
    views = inbox.views(owners, context=True) if mode == "exact" else inbox.views(owners)
    batch = build_local_games(views, problem.action_model, virtual_mean=mode, t=problem.t)
    batch = batch.on(StageRows(kept=problem.kept) if stage is None else stage)
    t1 = time.perf_counter()
    pay = problem.solver.evaluate(batch, problem.potentials)
    return batch, pay, t1 - t0, time.perf_counter() - t1


def _true_measures(rec: _Record, problem: StageProblem, messages, groups) -> float:
    """Payoff, local and global regret of every robot's true local game (actual states, no
    virtual means) at the realised actions ``rec.actions``; returns the evaluation time."""
    integrate_s = 0.0
    for owners in groups:
        batch, pay, _, t_int = evaluate_games(
            problem, messages, owners, virtual_mean="off", stage=rec.rows
        )
        members = np.asarray(pay.members)
        profile = np.where(pay.mask, rec.actions[np.maximum(members, 0)], 0)
        rec.measure(owners, batch, pay, profile)
        rec.global_regret[owners] = global_regret(pay, rec.actions)
        integrate_s += t_int
        del batch, pay  # this batch's table is freed before the next one is built
    return integrate_s


def _owner_rows(solver, batch: LocalGameBatch, potentials: Potentials) -> OwnerPayoffs:
    """The owners' rows of ``solver.evaluate(batch, potentials)``, bit for bit
    (``solver.evaluate_owners``)."""
    return solver.evaluate_owners(batch, potentials)


def _expost(rec: _Record, problem: StageProblem, messages, groups, next_states) -> float:
    """Ex-post regret of every robot (:mod:`swarmgames.game.expost`) at the realised actions
    ``rec.actions``, the others at ``next_states``, one batch's tables at a time; returns the
    wall time, seconds."""
    t0 = time.perf_counter()
    for owners in groups:
        views = messages.views(owners)
        batch = expost_games(views, next_states, problem.action_model, t=problem.t).on(rec.rows)
        rows = _owner_rows(problem.solver, batch, problem.potentials)
        rec.expost_regret[owners] = expost_regret(rows, rec.actions)
        del batch, rows
    return time.perf_counter() - t0


def _refined(sol: GameSolution, pay: GamePayoffs, refine: str):
    """``sol`` with the refinement ``refine`` applied to its profile (its owners playing
    their refined actions), and the refinement (None for ``"none"``)."""
    if refine == "none":
        return sol, None
    ref = refine_profiles(pay, sol.profile)
    profile = ref.profile
    return GameSolution(**{**sol.__dict__, "profile": profile, "actions": profile[:, 0]}), ref


def _preferring(marginal: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """``marginal`` (M, A) with each row's ``actions`` ranked first (co-located robots keep
    the refined action as their group's preferred one), the rest in marginal order."""
    out = np.array(marginal, dtype=float)
    out[np.arange(out.shape[0]), actions] = 2.0  # above any probability
    return out


def solve(problem: StageProblem, rng: int | np.random.Generator | None = None) -> StageSolution:
    """Decide and measure every robot's action for one control period.

    Parameters
    ----------
    problem : StageProblem
        The stage: network, states, messages, action model, potentials, solver and options.
    rng : int, Generator, None, or sequence of Generator
        Randomness of ``action_choice="sample"``, of the random solver and of the order among
        co-located robots; for a problem of several swarms (``problem.swarms``), one
        Generator per swarm (an int or None seeds them all, a Generator spawns them), so
        that each swarm's draws do not depend on the others.

    Returns
    -------
    StageSolution

    Examples
    --------
    >>> import numpy as np
    >>> from swarmgames.game import (DisplacementActions, FunctionPotentials, MeanFieldSolver,
    ...                              StageProblem)
    >>> from swarmgames.network import TopologySnapshot
    >>> snap = TopologySnapshot.from_hop_matrix(0.0, np.array([[0, 1], [1, 0]]))
    >>> goal = FunctionPotentials(lambda s: -np.linalg.norm(s - [5.0, 0.0], axis=-1))
    >>> problem = StageProblem.ideal(snap, 1, np.array([[0.0, 0.0], [0.0, 2.0]]),
    ...                              DisplacementActions.headings(1.0, 4), goal,
    ...                              MeanFieldSolver())
    >>> stage = solve(problem)
    >>> stage.actions.tolist(), stage.local_regret.tolist()
    ([1, 1], [0.0, 0.0])
    """
    gens = swarm_generators(rng, problem.swarms)
    gen = gens[0]
    if problem.centralised:
        return _solve_centralised(problem, gen)
    solver, potentials, action_model = problem.solver, problem.potentials, problem.action_model
    states, mode, source = problem.states, problem.virtual_mean, problem.messages
    n = problem.n_robots
    t0 = time.perf_counter()
    messages = _truth(problem)
    sizes = source.sizes
    if mode == "exact":  # the games hold the context too
        sizes = sizes + source.context_sizes
    caps = solver.capabilities(potentials)  # read once a stage
    on_demand = caps.pairs_on_demand
    n_act = problem.n_actions
    share_min = None if not problem.exact or mode == "exact" else caps.held_sharing_min
    shared = None if share_min is None else sharing_labels(messages, n_act, share_min)
    split = problem.swarms > 1 and caps.draws  # a drawing solver: each swarm on its own
    if split:
        size = n // problem.swarms
        groups = [
            g + e * size
            for e in range(problem.swarms)
            for g in size_groups(
                sizes[e * size : (e + 1) * size],
                problem.buckets,
                n_act,
                on_demand=on_demand,
                shared=None if shared is None else shared[e * size : (e + 1) * size],
            )
        ]
    else:
        groups = size_groups(sizes, problem.buckets, n_act, on_demand=on_demand, shared=shared)
    build_s = time.perf_counter() - t0
    rec = _Record(problem, n_act)
    integrate_s = solve_s = refine_s = 0.0
    batches, sols = [], []
    for owners in groups:
        batch, pay, t_build, t_int = evaluate_games(
            problem, source, owners, virtual_mean=mode, stage=rec.rows
        )
        draw = gens[int(owners[0]) // (n // problem.swarms)] if split else gen
        sol, ref = _refined(solver.solve_payoffs(pay, draw), pay, problem.refine)
        rec.actions[owners] = sol.actions
        rec.marginal[owners] = sol.marginals[:, 0]
        if ref is not None:
            rec.marginal[owners] = _preferring(sol.marginals[:, 0], sol.actions)
            rec.refine_sweeps[owners] = ref.sweeps
            rec.refine_moves[owners] = ref.moves
            refine_s += ref.time_s
        rec.action_mask[owners] = pay.action_mask[:, 0]
        rec.iterations[owners] = sol.iterations
        rec.converged[owners] = sol.converged
        # The robot's own view: its local game at the profile it settled on.
        rec.measure(owners, batch, pay, sol.profile)
        build_s += t_build
        integrate_s += t_int
        solve_s += sol.solve_time_s
        if problem.global_regret:
            # Only the owners' rows wait for the joint action, not the whole tables.
            redo = np.asarray(batch.is_virtual).any(axis=1)
            if batch.is_context is not None:
                redo |= np.asarray(batch.is_context).any(axis=1)
            if not problem.exact:
                redo |= ~_knows_the_truth(batch, messages.views(owners))
            rows = None if redo.all() else OwnerPayoffs.of(pay)
            if rows is not None and redo.any():  # the others' rows may hold context robots
                rows = rows.select(~redo)
            batches.append((owners, redo, rows))
        if problem.keep_games:
            sols.append((batch, sol))
        del pay  # this batch's table is freed before the next one is built
    swarm = problem.swarm if problem.swarms > 1 else None
    rec.actions[:] = separate_colocated(
        states, rec.actions, rec.marginal, rec.action_mask, gens if swarm is not None else gen,
        swarm=swarm,
    )  # fmt: skip
    nxt = rec.next_states(states, action_model)
    expost_s = 0.0
    if problem.global_regret:
        _global_regret(rec, problem, messages, batches)
        true_groups = groups
        if not problem.exact or shared is not None:
            # The true neighbourhoods may be sized otherwise, and the ex-post games (each
            # owner deviating alone) are never equal: a table each.
            true_groups = size_groups(messages.sizes, problem.buckets, n_act, on_demand=on_demand)
        expost_s = _expost(rec, problem, messages, true_groups, nxt)
    extra = {}
    if problem.keep_games:
        extra = _in_robot_order(groups, sols)
    return rec.solution(
        states,
        action_model,
        nxt,
        integrate_s=integrate_s,
        solve_s=solve_s,
        build_s=build_s,
        n_games=n,
        refine_s=refine_s,
        expost_s=expost_s,
        **extra,
    )


def swarm_generators(rng, swarms: int) -> list[np.random.Generator]:
    """One Generator per swarm from ``solve``'s ``rng``: a sequence of ``swarms`` of them as
    given; else, for one swarm, ``as_generator(rng)``; for several, children of it (an int
    or None seeds a SeedSequence, a Generator spawns)."""
    if isinstance(rng, (list, tuple)):
        if len(rng) != swarms:
            raise ValueError(f"rng must hold one Generator per swarm, {swarms} (got {len(rng)})")
        return [as_generator(g) for g in rng]
    if swarms == 1:
        return [as_generator(rng)]
    if isinstance(rng, np.random.Generator):
        return list(rng.spawn(swarms))
    return [np.random.default_rng(s) for s in np.random.SeedSequence(rng).spawn(swarms)]


def _truth(problem: StageProblem) -> Messages:
    """Every robot's true neighbourhood and its members' actual states: the problem's
    messages when they are exact, else built from the routing tables once."""
    if problem.exact:
        return problem.messages
    return broadcast(problem.snapshot, problem.h, problem.states)


def _global_regret(rec: _Record, problem: StageProblem, messages, batches) -> None:
    """Global regret from the solved games' owner rows where they are the true games (no
    virtual mean, no context, and the members and states the robot knew are the actual ones:
    always with exact delivery, and with routed delivery wherever every message arrived
    unchanged); the other games are rebuilt with actual states and true neighbourhoods,
    every neighbour held at its realised action, and only their owners' rows evaluated, one
    batch at a time."""

    def again(owners) -> np.ndarray:
        views = messages.views(owners)
        batch = build_local_games(views, problem.action_model, virtual_mean="off", t=problem.t)
        batch = batch.on(rec.rows)
        # Only the owner's row is read: the others are held at their realised actions.
        batch = owner_deviations(batch, rec.actions)
        return global_regret(_owner_rows(problem.solver, batch, problem.potentials), rec.actions)

    n_act = problem.n_actions
    for owners, redo, rows in batches:
        if rows is not None:
            rec.global_regret[owners[~redo]] = global_regret(rows, rec.actions)
        if redo.any():
            # Each rebuilt game (its owner deviating alone) has a table of its own, so a
            # batch of games that shared one is rebuilt within the tables' budget.
            todo = owners[redo]
            for part in size_groups(messages.sizes[todo], 1, n_act):
                rec.global_regret[todo[part]] = again(todo[part])


def _knows_the_truth(batch: LocalGameBatch, truth) -> np.ndarray:
    """Whether each game of ``batch`` has exactly the members and states of the true views
    ``truth`` (then, without virtual means, it is the true local game), shape (B,)."""
    k = max(batch.members.shape[1], truth.members.shape[1])

    def pad(a, fill):
        width = [(0, 0)] * a.ndim
        width[1] = (0, k - a.shape[1])
        return np.pad(a, width, constant_values=fill)

    same = (pad(batch.members, -1) == pad(truth.members, -1)).all(axis=1)
    same &= (pad(batch.states, 0.0) == pad(truth.states, 0.0)).all(axis=(1, 2))
    return same


def _in_robot_order(groups, sols) -> dict:
    """The games and solutions of every group, concatenated in robot order."""
    batches = [b for b, _ in sols]
    solutions = [s for _, s in sols]
    batch = batches[0] if len(batches) == 1 else LocalGameBatch.concat(batches)
    sol = solutions[0] if len(solutions) == 1 else GameSolution.concat(solutions)
    if len(groups) > 1:
        inverse = np.argsort(np.concatenate(groups))
        batch, sol = batch.select(inverse), sol.select(inverse)
    return {"batch": batch, "solution": sol}


def _solve_centralised(problem: StageProblem, gen: np.random.Generator) -> StageSolution:
    """The swarm as one game (refined to a pure NE of that game with ``refine``); every robot
    measured on its true local game."""
    solver, potentials, action_model = problem.solver, problem.potentials, problem.action_model
    states = problem.states
    t0 = time.perf_counter()
    rec = _Record(problem)
    batch = centralised_game(problem.snapshot, problem.h, states, action_model, t=problem.t)
    batch = batch.on(rec.rows)
    t1 = time.perf_counter()
    pay = solver.evaluate(batch, potentials)
    t2 = time.perf_counter()
    sol, ref = _refined(solver.solve_payoffs(pay, gen), pay, problem.refine)
    actions = np.asarray(sol.profile[0], dtype=np.int64)
    marginal = sol.marginals[0]
    if ref is not None:
        marginal = _preferring(marginal, actions)
    elif solver.capabilities(potentials).samples_actions:
        actions = sample_actions(sol.marginals[0], batch.action_mask[0], actions, gen)
    rec.actions[:] = separate_colocated(states, actions, marginal, batch.action_mask[0], gen)
    messages, groups = plan_stage(problem)
    _true_measures(rec, problem, messages, groups)
    nxt = rec.next_states(states, action_model)
    expost_s = 0.0
    if problem.global_regret:
        expost_s = _expost(rec, problem, messages, groups, nxt)
    rec.iterations[:] = int(sol.iterations[0])
    rec.converged[:] = bool(sol.converged[0])
    if ref is not None:
        rec.refine_sweeps[:] = int(ref.sweeps[0])
        rec.refine_moves[:] = int(ref.moves[0])
    extra = {"batch": batch, "solution": sol} if problem.keep_games else {}
    return rec.solution(
        states,
        action_model,
        nxt,
        integrate_s=t2 - t1,
        solve_s=sol.solve_time_s,
        build_s=t1 - t0,
        n_games=1,
        refine_s=0.0 if ref is None else ref.time_s,
        expost_s=expost_s,
        **extra,
    )


def plan_stage(problem: StageProblem) -> tuple[Messages, list[np.ndarray]]:
    """The first step of a stage's measurements: every robot's true neighbourhood with its
    members' actual states (the problem's messages when they are exact, else
    :func:`~swarmgames.game.local.broadcast` of the routing tables) and the robots split into
    batches of similar neighbourhood size (:func:`size_groups`)."""
    messages = _truth(problem)
    return messages, size_groups(messages.sizes, problem.buckets, problem.n_actions)


def _given_actions(problem: StageProblem, actions) -> _Record:
    """A record holding the given joint action, checked against the problem's N robots."""
    actions = np.asarray(actions, dtype=np.int64)
    n = problem.n_robots
    if actions.shape != (n,):
        raise ValueError(f"actions must have shape ({n},) (got {actions.shape})")
    rec = _Record(problem)
    rec.actions[:] = actions
    return rec


def measure_stage(problem: StageProblem, actions, *, expost: bool = True) -> StageSolution:
    """Measure given actions as :func:`solve` measures its own: every robot's payoff, local
    and global regret in its true local game (actual states, no virtual means) at the
    realised joint action, and (``expost``) its ex-post regret against the states the
    others' actions reach.

    For controllers that are not games (a mission's baseline such as Lloyd's, the MPC's
    chosen actions, a learned policy). The problem's messages and options other than
    ``buckets`` are not used. ``iterations`` and ``converged`` are 0 and false, ``solve_s``
    is 0 and ``integrate_s`` is the evaluation of the true games; ``n_games`` is N.
    """
    rec = _given_actions(problem, actions)
    messages, groups = plan_stage(problem)
    integrate_s = _true_measures(rec, problem, messages, groups)
    nxt = rec.next_states(problem.states, problem.action_model)
    expost_s = 0.0
    if expost:
        expost_s = _expost(rec, problem, messages, groups, nxt)
    return rec.solution(
        problem.states,
        problem.action_model,
        nxt,
        integrate_s=integrate_s,
        n_games=problem.n_robots,
        expost_s=expost_s,
    )


def profile_payoffs(problem: StageProblem, actions) -> np.ndarray:
    """Every robot's payoff M_i (eq. 1) in its true local game (actual states, N_i(h) from
    the routing tables, no virtual means) at the joint action ``actions`` (N,): the
    ``payoff`` of :func:`measure_stage`, evaluated on games of one action each
    (:meth:`~swarmgames.game.batch.LocalGameBatch.at`) instead of whole tables, so the
    unary term costs 1/A of it and the pairwise 1/A². Nothing else is measured.

    Returns
    -------
    ndarray, shape (N,)
    """
    rec = _given_actions(problem, actions)
    messages = _truth(problem)
    for owners in size_groups(messages.sizes, problem.buckets, 1):
        views = messages.views(owners)
        batch = build_local_games(views, problem.action_model, virtual_mean="off", t=problem.t)
        pay = problem.solver.evaluate(batch.at(rec.actions), problem.potentials)
        rec.payoff[owners] = profile_measures(pay, np.zeros(batch.mask.shape, np.int64))[0]
    return rec.payoff


def measure_expost(problem: StageProblem, actions, next_states: np.ndarray) -> np.ndarray:
    """Ex-post regret of every robot (:mod:`swarmgames.game.expost`): robot i's true local
    game (actual states, N_i(h), no virtual means) with every other member at the state it
    reached, ``next_states`` (N, D), scored under the problem's solver weights at robot i's
    action ``actions[i]``.

    For a loop whose robots do not all reach the states their actions lead to (a crashed
    robot stays where it is); :func:`solve` and :func:`measure_stage` measure it from the
    action model's next states.

    Returns
    -------
    ndarray, shape (N,)
        >= 0; equal to the global regret where every neighbour stands still.
    """
    rec = _given_actions(problem, actions)
    nxt = np.asarray(next_states, dtype=float)
    if nxt.shape != problem.states.shape:
        raise ValueError(f"next_states must have shape {problem.states.shape} (got {nxt.shape})")
    messages, groups = plan_stage(problem)
    _expost(rec, problem, messages, groups, nxt)
    return rec.expost_regret


def stage_regret(
    snapshot: TopologySnapshot,
    h: int,
    states: np.ndarray,
    action_model: ActionModel,
    potentials: Potentials,
    joint_actions,
    alpha_a: float = 1.0,
    alpha_b: float = 0.001,
    *,
    pair_weighting: str = "sum",
    t: float = 0.0,
) -> np.ndarray:
    """Global (stage-game) regret of every robot at the realised joint action.

    Robot i's payoff is eq. 1 over its neighbourhood N_i(h) in ``snapshot`` with the actual
    ``states`` (no virtual means); its regret is the most it could gain by changing only its
    own action, every other robot keeping its realised action. Pass the snapshot taken as the
    truth (for example instantaneous BFS on the geometry rather than lagging routing tables);
    ``t`` is the stage time the games carry (``LocalGameBatch.t``), seconds.

    Returns
    -------
    ndarray, shape (N,)
        >= 0; 0 for every robot iff the joint action is a pure NE of the stage game.
    """
    batch = local_games(snapshot, h, states, action_model, virtual_mean="off", t=t)
    payoffs = evaluate_payoffs(batch, potentials, alpha_a, alpha_b, pair_weighting=pair_weighting)
    return global_regret(payoffs, joint_actions)
