"""One stage of the graphical game as a problem: everything the stage pipeline reads.

A :class:`StageProblem` holds, for one control period, what the robots and the solver know
and nothing else; :func:`~swarmgames.game.stage.solve` turns it into a
:class:`~swarmgames.game.stage.StageSolution`. The simulation's controllers, the benchmarks,
the environment, the MPC controller and the public API all build one and solve it, so a
stage is computed the same way wherever it is used.

The messages are what every robot holds of its neighbourhood N_i(h) at the decision (the
paper's routed state messages, section II.B): :class:`~swarmgames.game.local.Messages` for
exact, instant delivery (:meth:`StageProblem.ideal` builds them from the routing tables), or
the inbox a communication model delivered (:mod:`swarmgames.comms`), whose states may be
late, stale or missing. An inbox declares whether it is exact (``messages.exact``): exact
messages holding the problem's states are taken as the truth the measurements need
(:attr:`StageProblem.exact`), and the stage builds N_i(h) from the routing tables only when
they are not.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, sections II.B-C and Algorithm 1.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from swarmgames.arrays import frozen
from swarmgames.game.actions import ActionModel
from swarmgames.game.capabilities import capabilities_of
from swarmgames.game.kept import RowTables
from swarmgames.game.local import Inbox, broadcast
from swarmgames.game.potentials import Potentials
from swarmgames.game.refine import REFINE_METHODS
from swarmgames.game.solvers import Solver
from swarmgames.game.virtual import virtual_mode
from swarmgames.topology import TopologySnapshot

__all__ = ["StageProblem"]


@dataclass(frozen=True, eq=False)
class StageProblem:
    """One stage's game: the network, the states, the messages, the payoff and the solver.

    Parameters
    ----------
    t : float
        Stage time, seconds (the simulation's clock: the warm-up, then one control period a
        stage). The games built from this problem carry it (``LocalGameBatch.t``), so that
        potentials may depend on time.
    snapshot : TopologySnapshot
        Every robot's routing table, N robots; robot i's game holds N_i(h) from its own table.
    h : int
        Neighbourhood radius in hops (paper: 2), >= 1.
    states : ndarray of float, shape (N, D)
        Every robot's true state (read-only copy).
    messages : Inbox
        What every robot holds of its neighbourhood at the decision: ``sizes`` (N,),
        ``views(owners, context=...)``, ``exact``; :class:`~swarmgames.game.local.Messages`
        (exact, instant delivery, from :func:`~swarmgames.game.local.broadcast`) or a
        communication model's inbox. Exact messages must be those of ``snapshot``, ``h`` and
        ``states``: they are taken as the truth.
    action_model : ActionModel
        The robots' discrete actions, A of them.
    potentials : Potentials
        The payoff's potentials (paper eq. 1).
    solver : Solver
        The solver and its weights (:func:`~swarmgames.game.solvers.make_solver`).
    virtual_mean : {"eq3", "outside", "exact", "off"}, default "eq3"
        How a member j with N_j − N_i ≠ ∅ stands in for the robots outside N_i
        (:func:`~swarmgames.game.local.build_local_games`); ``True`` and ``False`` are read as
        ``"eq3"`` and ``"off"``. ``"exact"`` needs messages that hold every robot's context.
    centralised : bool, default False
        Solve the swarm as one game over every robot (pairwise terms between robots within h
        hops of each other) instead of N local games; for small swarms (N² A² table).
    buckets : int, default 0
        Solve the local games in this many batches of similar size |N_i|
        (:func:`~swarmgames.game.stage.size_groups`); 0 = automatic, one batch per 128
        robots, at most 8. Results do not depend on it, except through the draws of the
        stage's Generator and up to rounding with ``engine="blas"``.
    global_regret : bool, default True
        Measure every robot's global and ex-post regret (NaN otherwise).
    keep_games : bool, default False
        Return the games and their solution in robot order (``StageSolution.batch``,
        ``.solution``).
    refine : {"none", "best_response"}, default "none"
        ``"best_response"``: refine every game's solved profile by best-response sweeps to a
        pure Nash equilibrium (:func:`~swarmgames.game.refine.refine_profiles`).
    kept : RowTables or None, default None
        The tables of per-row values the run keeps across its stages
        (:class:`~swarmgames.game.kept.RowTables`): a controller holds one for its run and
        puts it in every problem, so that potentials compute a row once while it stays
        there. None: nothing is kept beyond the stage. The results do not depend on it.
    swarms : int, default 1
        The problem holds this many independent swarms of N / ``swarms`` robots each, side
        by side: robot ``e n + i`` is swarm ``e``'s robot ``i``
        (:meth:`~swarmgames.topology.TopologySnapshot.concat`). No routing entry may join
        two swarms, co-located robots of different swarms are not tied, and each swarm draws
        from its own Generator (:func:`~swarmgames.game.stage.solve`). A vector
        environment's E swarms are one stage this way. Not with ``centralised``.

    Attributes
    ----------
    exact : bool
        Whether the messages are the truth: they declare themselves exact and hold every
        robot's state as ``states`` does (an exact inbox built from other states is read as
        a delivery like any other).

    Raises
    ------
    ValueError
        A field out of its range or of the wrong shape, named with the value.
    TypeError
        Potentials without a valid ``capabilities`` declaration
        (:func:`~swarmgames.game.capabilities.capabilities_of`).

    Examples
    --------
    >>> import numpy as np
    >>> from swarmgames.game import DisplacementActions, FunctionPotentials, MeanFieldSolver
    >>> from swarmgames.network import TopologySnapshot
    >>> snap = TopologySnapshot.from_hop_matrix(0.0, np.array([[0, 1], [1, 0]]))
    >>> goal = FunctionPotentials(lambda s: -np.linalg.norm(s - [5.0, 0.0], axis=-1))
    >>> problem = StageProblem.ideal(snap, 1, np.array([[0.0, 0.0], [0.0, 2.0]]),
    ...                              DisplacementActions.headings(1.0, 4), goal,
    ...                              MeanFieldSolver())
    >>> problem.n_robots, problem.exact
    (2, True)
    """

    t: float
    snapshot: TopologySnapshot
    h: int
    states: np.ndarray
    messages: Inbox
    action_model: ActionModel
    potentials: Potentials
    solver: Solver
    virtual_mean: str = "eq3"
    centralised: bool = False
    buckets: int = 0
    global_regret: bool = True
    keep_games: bool = False
    refine: str = "none"
    kept: RowTables | None = field(default=None, repr=False)
    swarms: int = 1
    exact: bool = field(init=False, repr=False)

    def __post_init__(self) -> None:
        t = float(self.t)
        if not np.isfinite(t):
            raise ValueError(f"t must be a finite time in seconds (got {self.t!r})")
        object.__setattr__(self, "t", t)
        if isinstance(self.h, bool) or not isinstance(self.h, (int, np.integer)) or self.h < 1:
            raise ValueError(f"h must be an integer >= 1 (got {self.h!r})")
        object.__setattr__(self, "h", int(self.h))
        states = np.asarray(self.states, dtype=float)
        n = int(self.snapshot.n_robots)
        if states.ndim != 2 or states.shape[0] != n:
            raise ValueError(
                f"states must have shape ({n}, D), one row per robot of the snapshot "
                f"(got {states.shape})"
            )
        object.__setattr__(self, "states", frozen(states))
        sizes = np.shape(self.messages.sizes)
        if sizes != (n,):
            raise ValueError(f"messages must hold {n} robots (got sizes of shape {sizes})")
        exact = bool(self.messages.exact) and np.array_equal(self.messages.state, states)
        object.__setattr__(self, "exact", exact)
        object.__setattr__(self, "virtual_mean", virtual_mode(self.virtual_mean))
        b = self.buckets
        if isinstance(b, bool) or not isinstance(b, (int, np.integer)) or b < 0:
            raise ValueError(f"buckets must be an integer >= 0 (got {b!r})")
        object.__setattr__(self, "buckets", int(b))
        if self.refine not in REFINE_METHODS:
            raise ValueError(
                f"refine must be one of {', '.join(map(repr, REFINE_METHODS))} "
                f"(got {self.refine!r})"
            )
        capabilities_of(self.potentials)
        object.__setattr__(self, "centralised", bool(self.centralised))
        object.__setattr__(self, "global_regret", bool(self.global_regret))
        object.__setattr__(self, "keep_games", bool(self.keep_games))
        self._check_swarms(n)
        if self.kept is not None and not isinstance(self.kept, RowTables):
            raise ValueError(f"kept must be a RowTables or None (got {type(self.kept).__name__})")

    def _check_swarms(self, n: int) -> None:
        e = self.swarms
        if isinstance(e, bool) or not isinstance(e, (int, np.integer)) or e < 1 or n % e:
            raise ValueError(
                f"swarms must be an integer >= 1 that divides the {n} robots (got {e!r})"
            )
        object.__setattr__(self, "swarms", int(e))
        if e == 1:
            return
        if self.centralised:
            raise ValueError(f"a centralised problem holds one swarm (got swarms = {e})")
        size = n // e
        snap = self.snapshot
        crossing = np.asarray(snap.owner) // size != np.asarray(snap.dest) // size
        if crossing.any():
            k = int(np.flatnonzero(crossing)[0])
            raise ValueError(
                f"swarms = {e}: robot {int(snap.owner[k])}'s routing table reaches robot "
                f"{int(snap.dest[k])} of another swarm of {size} robots"
            )

    @property
    def swarm(self) -> np.ndarray:
        """The swarm of every robot, (N,) int64."""
        return np.arange(self.n_robots) // (self.n_robots // self.swarms)

    @classmethod
    def ideal(
        cls,
        snapshot: TopologySnapshot,
        h: int,
        states: np.ndarray,
        action_model: ActionModel,
        potentials: Potentials,
        solver: Solver,
        *,
        t: float = 0.0,
        **options,
    ) -> StageProblem:
        """The problem of a stage with exact, instant delivery: every robot holds the exact
        state of every member of its N_i(h) (:func:`~swarmgames.game.local.broadcast`).
        ``options``: the other fields (``virtual_mean``, ``centralised``, ...)."""
        states = np.asarray(states, dtype=float)
        messages = broadcast(snapshot, h, states)
        return cls(t, snapshot, h, states, messages, action_model, potentials, solver, **options)

    @property
    def n_robots(self) -> int:
        """N."""
        return int(self.states.shape[0])

    @property
    def n_actions(self) -> int:
        """A."""
        return int(self.action_model.n_actions)
