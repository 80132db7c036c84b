"""Local-game solvers behind one interface, the solver registry and the stage-level entry point.

Every solver is a configured, immutable object with

    solve(batch, potentials, rng=None) -> GameSolution      # all B local games at once
    solve_payoffs(payoffs, rng=None)   -> GameSolution      # same, on evaluated tables

Solvers (``name``):

``mean_field``        Algorithm 1 (:mod:`swarmgames.game.meanfield`).
``exact``             the M-maximising profile by enumeration (small neighbourhoods).
``best_response``     best-response dynamics from the unary argmax.
``random``            a uniformly random valid action.

A solver only solves the games it is given. How the games of a stage are built (with or
without virtual means, as N local games or one centralised game) is a parameter of the stage
pipeline, :func:`swarmgames.game.stage.solve`, which a simulation loop calls once per
control period.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C and Algorithm 1.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

import numpy as np

from swarmgames.arrays import freeze_fields
from swarmgames.game.baselines import best_response, exact_profiles, random_profiles
from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.capabilities import SolverCapabilities, capabilities_of
from swarmgames.game.equilibrium import OwnerPayoffs, owner_payoffs
from swarmgames.game.meanfield import ENGINES, check_parameters, mean_field, resolve_engine
from swarmgames.game.potentials import GamePayoffs, Potentials, evaluate_payoffs
from swarmgames.names import SOLVERS
from swarmgames.rng import as_generator

__all__ = [
    "SOLVERS",
    "BestResponseSolver",
    "ExactSolver",
    "GameSolution",
    "MeanFieldSolver",
    "RandomSolver",
    "Solver",
    "make_solver",
    "sample_actions",
]


def sample_actions(
    marginals: np.ndarray,
    action_mask: np.ndarray,
    fallback: np.ndarray,
    rng: int | np.random.Generator | None,
) -> np.ndarray:
    """One draw per row from ``marginals`` ``(M, A)`` (inverse CDF, one uniform per row, in
    row order); ``fallback`` where rounding lands on an invalid action."""
    gen = as_generator(rng)
    draw = gen.random(marginals.shape[0])
    cdf = np.cumsum(marginals, axis=1)
    pick = np.minimum((cdf < draw[:, None]).sum(axis=1), marginals.shape[1] - 1)
    ok = action_mask[np.arange(marginals.shape[0]), pick]
    return np.where(ok, pick, fallback)


@dataclass(frozen=True, eq=False)
class GameSolution:
    """Result of solving B local games.

    Parameters
    ----------
    solver : str
        Name of the solver.
    owner : ndarray of int32, shape (B,)
    actions : ndarray of int, shape (B,)
        Action chosen by each owner (variable 0 of its game).
    profile : ndarray of int, shape (B, K)
        Pure action of every variable (argmax of its marginal for mean-field); 0 at padding.
    marginals : ndarray, shape (B, K, A)
        Q_k(x); one-hot for the pure baselines, uniform over valid actions for ``random``.
    iterations : ndarray of int, shape (B,)
    converged : ndarray of bool, shape (B,)
    kl : ndarray, shape (B,)
        Final KL(Q_old ‖ Q) (mean-field), 0 for the pure baselines.
    solve_time_s : float
        Wall time of the solve (all B games), seconds.
    eval_time_s : float
        Wall time of evaluating the potentials, seconds (0 for ``solve_payoffs``).
    """

    solver: str
    owner: np.ndarray
    actions: np.ndarray
    profile: np.ndarray
    marginals: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    kl: np.ndarray
    solve_time_s: float
    eval_time_s: float = 0.0

    def __post_init__(self) -> None:
        freeze_fields(self)

    @property
    def n_games(self) -> int:
        """B."""
        return int(self.owner.size)

    def select(self, games) -> GameSolution:
        """The solution of a subset of games (indices or boolean mask over B)."""
        idx = np.arange(self.n_games)[games]
        return GameSolution(
            solver=self.solver,
            owner=self.owner[idx],
            actions=self.actions[idx],
            profile=self.profile[idx],
            marginals=self.marginals[idx],
            iterations=self.iterations[idx],
            converged=self.converged[idx],
            kl=self.kl[idx],
            solve_time_s=self.solve_time_s,
            eval_time_s=self.eval_time_s,
        )

    @classmethod
    def concat(cls, solutions) -> GameSolution:
        """The games of ``solutions`` in order, padded to the widest K and A; times add up."""
        solutions = list(solutions)
        if not solutions:
            raise ValueError("solutions must not be empty")
        k = max(s.profile.shape[1] for s in solutions)
        a = max(s.marginals.shape[2] for s in solutions)
        return cls(
            solver=solutions[0].solver,
            owner=np.concatenate([s.owner for s in solutions]),
            actions=np.concatenate([s.actions for s in solutions]),
            profile=np.concatenate(
                [np.pad(s.profile, ((0, 0), (0, k - s.profile.shape[1]))) for s in solutions]
            ),
            marginals=np.concatenate(
                [
                    np.pad(
                        s.marginals,
                        ((0, 0), (0, k - s.marginals.shape[1]), (0, a - s.marginals.shape[2])),
                    )
                    for s in solutions
                ]
            ),
            iterations=np.concatenate([s.iterations for s in solutions]),
            converged=np.concatenate([s.converged for s in solutions]),
            kl=np.concatenate([s.kl for s in solutions]),
            solve_time_s=sum(s.solve_time_s for s in solutions),
            eval_time_s=sum(s.eval_time_s for s in solutions),
        )

    def to_frame(self):
        """One row per game: owner, action, iterations, converged, kl (pandas DataFrame)."""
        import pandas as pd

        return pd.DataFrame(
            {
                "owner": self.owner,
                "action": self.actions,
                "iterations": self.iterations,
                "converged": self.converged,
                "kl": self.kl,
            }
        )


def _one_hot(profile: np.ndarray, payoffs: GamePayoffs) -> np.ndarray:
    b, k, a = payoffs.shape
    q = np.zeros((b, k, a))
    np.put_along_axis(q, profile[:, :, None], 1.0, axis=2)
    return q * payoffs.mask[:, :, None]


def _pure_solution(name, payoffs, profile, iterations, converged, t0, marginals=None):
    b = payoffs.shape[0]
    return GameSolution(
        solver=name,
        owner=payoffs.owner,
        actions=profile[:, 0].copy(),
        profile=profile,
        marginals=_one_hot(profile, payoffs) if marginals is None else marginals,
        iterations=iterations,
        converged=converged,
        kl=np.zeros(b),
        solve_time_s=time.perf_counter() - t0,
    )


@runtime_checkable
class Solver(Protocol):
    """What every solver offers (the object :func:`make_solver` returns).

    Attributes
    ----------
    name : str
        Registry name (one of :data:`SOLVERS`).
    """

    name: str

    def evaluate(self, batch: LocalGameBatch, potentials: Potentials) -> GamePayoffs:
        """Weighted payoff tables of ``batch``."""
        ...

    def evaluate_owners(self, batch: LocalGameBatch, potentials: Potentials) -> OwnerPayoffs:
        """The owners' rows of :meth:`evaluate`, bit for bit (what the global and ex-post
        regret read)."""
        ...

    def capabilities(self, potentials: Potentials) -> SolverCapabilities:
        """What this solver does with ``potentials`` (read once per stage)."""
        ...

    def solve(
        self,
        batch: LocalGameBatch,
        potentials: Potentials,
        rng: int | np.random.Generator | None = None,
    ) -> GameSolution:
        """Solve every game of ``batch``."""
        ...

    def solve_payoffs(
        self, payoffs: GamePayoffs, rng: int | np.random.Generator | None = None
    ) -> GameSolution:
        """Solve every game of already evaluated tables."""
        ...


@dataclass(frozen=True)
class _Base:
    alpha_a: float = 1.0
    alpha_b: float = 0.001
    dtype: str = "float64"
    pair_weighting: str = "sum"

    name = "base"

    def _weights(self) -> dict:
        return {
            "alpha_a": self.alpha_a,
            "alpha_b": self.alpha_b,
            "dtype": self.dtype,
            "pair_weighting": self.pair_weighting,
        }

    def evaluate(self, batch: LocalGameBatch, potentials: Potentials) -> GamePayoffs:
        """The weighted payoff tables of ``batch`` under this solver's α_a, α_b, pairwise
        weighting and dtype."""
        return evaluate_payoffs(batch, potentials, **self._weights())

    def evaluate_owners(self, batch: LocalGameBatch, potentials: Potentials) -> OwnerPayoffs:
        """The owners' rows of :meth:`evaluate`, bit for bit, with only the owners' unary
        evaluated where the potentials offer it
        (:func:`~swarmgames.game.equilibrium.owner_payoffs`)."""
        return owner_payoffs(batch, potentials, **self._weights())

    def capabilities(self, potentials: Potentials) -> SolverCapabilities:
        """What this solver does with ``potentials``: every game's table held, the owner
        playing its profile's action (the mean-field solver overrides it)."""
        capabilities_of(potentials)
        return SolverCapabilities()

    def solve(
        self,
        batch: LocalGameBatch,
        potentials: Potentials,
        rng: int | np.random.Generator | None = None,
    ) -> GameSolution:
        """Solve every game of ``batch``; see the class docstring for the method."""
        t0 = time.perf_counter()
        payoffs = self.evaluate(batch, potentials)
        t_eval = time.perf_counter() - t0
        sol = self.solve_payoffs(payoffs, rng)
        return GameSolution(**{**sol.__dict__, "eval_time_s": t_eval})

    def solve_payoffs(
        self, payoffs: GamePayoffs, rng: int | np.random.Generator | None = None
    ) -> GameSolution:  # pragma: no cover - every solver overrides it
        raise NotImplementedError


@dataclass(frozen=True)
class MeanFieldSolver(_Base):
    """Mean-field solver of Algorithm 1 (payoff-maximising sign, see
    :mod:`swarmgames.game.meanfield`).

    Parameters
    ----------
    alpha_a, alpha_b : float
        Weights of eq. 1 (paper: 1, 0.001).
    dtype : {"float64", "float32"}
        Precision of the payoff tables and marginals.
    beta : float
        Inverse temperature, > 0.
    delta : float
        KL stopping threshold, > 0.
    max_iter : int
        Maximum sweeps, >= 1.
    action_choice : {"argmax", "sample"}
        Owner's action: argmax of its marginal (ties to the lowest index) or a draw from it.
    engine : {"auto", "compiled", "blas", "sequential"}
        See :func:`~swarmgames.game.meanfield.mean_field`.
    """

    beta: float = 50.0
    delta: float = 1e-6
    max_iter: int = 200
    action_choice: Literal["argmax", "sample"] = "argmax"
    engine: Literal["auto", "compiled", "blas", "sequential"] = "auto"

    def __post_init__(self) -> None:
        check_parameters(self.beta, self.delta, self.max_iter)
        if self.action_choice not in ("argmax", "sample"):
            raise ValueError(
                f"action_choice must be 'argmax' or 'sample' (got {self.action_choice!r})"
            )
        if self.engine not in ENGINES:
            raise ValueError(
                f"engine must be one of {', '.join(map(repr, ENGINES))} (got {self.engine!r})"
            )

    name = "mean_field"

    def capabilities(self, potentials: Potentials) -> SolverCapabilities:
        """What this solver does with ``potentials``.

        ``pairs_on_demand``: the compiled engine computes the pairwise tables per chunk of
        games where the potentials declare ``pair_source`` and their ``pair_on_demand(dtype)``
        says they give a :class:`~swarmgames.game.potentials.PairSource` in this dtype; the
        stage then sizes its batches by the measurements' rows
        (:func:`~swarmgames.game.stage.size_groups`). ``held_sharing_min``: with the
        compiled engine, the potentials' declared ``held_sharing_min(dtype)``, the smallest
        game from which the equal games of a batch share one held table, solved once per
        group; the stage then budgets a batch of such games by its tables. Both need
        ``alpha_b > 0``. ``samples_actions`` and ``draws``: ``action_choice == "sample"``.
        """
        caps = capabilities_of(potentials)
        compiled = self.alpha_b > 0 and resolve_engine(self.engine) == "compiled"
        dtype = np.dtype(self.dtype)
        least = potentials.held_sharing_min(dtype) if compiled and caps.held_sharing else None
        return SolverCapabilities(
            pairs_on_demand=compiled
            and caps.pair_source
            and bool(potentials.pair_on_demand(dtype)),
            held_sharing_min=None if least is None else int(least),
            samples_actions=self.action_choice == "sample",
            draws=self.action_choice == "sample",
        )

    def solve_payoffs(self, payoffs, rng=None) -> GameSolution:
        """Mean-field marginals of every game, then each owner's action."""
        t0 = time.perf_counter()
        res = mean_field(payoffs, self.beta, self.delta, self.max_iter, engine=self.engine)
        q = res.marginals
        masked = np.where(payoffs.action_mask, q, -1.0)
        profile = np.where(payoffs.mask, masked.argmax(axis=2), 0)
        actions = profile[:, 0].copy()
        if self.action_choice == "sample":
            actions = sample_actions(q[:, 0], payoffs.action_mask[:, 0], actions, rng)
        return GameSolution(
            solver=self.name,
            owner=payoffs.owner,
            actions=actions,
            profile=profile,
            marginals=q,
            iterations=res.iterations,
            converged=res.converged,
            kl=res.kl,
            solve_time_s=time.perf_counter() - t0,
        )


@dataclass(frozen=True)
class ExactSolver(_Base):
    """Enumerates every joint profile of each local game and plays the M-maximising one."""

    max_profiles: int = 1_000_000
    name = "exact"

    def solve_payoffs(self, payoffs, rng=None) -> GameSolution:
        """The M-maximising profile of every game."""
        t0 = time.perf_counter()
        profile = exact_profiles(payoffs, self.max_profiles)
        b = profile.shape[0]
        return _pure_solution(
            self.name, payoffs, profile, np.ones(b, dtype=np.int64), np.ones(b, bool), t0
        )


@dataclass(frozen=True)
class BestResponseSolver(_Base):
    """Best-response dynamics (stops at a pure NE of each local game)."""

    max_iter: int = 200
    name = "best_response"

    def solve_payoffs(self, payoffs, rng=None) -> GameSolution:
        """Best-response profile of every game."""
        t0 = time.perf_counter()
        profile, it, conv = best_response(payoffs, self.max_iter)
        return _pure_solution(self.name, payoffs, profile, it, conv, t0)


@dataclass(frozen=True)
class RandomSolver(_Base):
    """A uniformly random valid action for every variable (lower baseline)."""

    name = "random"

    def capabilities(self, potentials: Potentials) -> SolverCapabilities:
        """Every game's table held; the profiles are drawn (``draws``)."""
        capabilities_of(potentials)
        return SolverCapabilities(draws=True)

    def solve_payoffs(self, payoffs, rng=None) -> GameSolution:
        """Random profile of every game."""
        t0 = time.perf_counter()
        profile = random_profiles(payoffs, as_generator(rng))
        amask = payoffs.action_mask
        q = amask / np.maximum(amask.sum(axis=2, keepdims=True), 1)
        b = profile.shape[0]
        return _pure_solution(
            self.name, payoffs, profile, np.zeros(b, np.int64), np.ones(b, bool), t0, q
        )


_SOLVER_CLASSES = {
    "mean_field": MeanFieldSolver,
    "exact": ExactSolver,
    "best_response": BestResponseSolver,
    "random": RandomSolver,
}


def make_solver(name: str, **params) -> Solver:
    """The solver registered as ``name``, configured with ``params``.

    Parameters
    ----------
    name : {"mean_field", "exact", "best_response", "random"}
    **params
        Fields of the solver's class: ``alpha_a``, ``alpha_b``, ``dtype``, ``pair_weighting``
        (:func:`~swarmgames.game.potentials.pair_weights`) for every solver;
        ``beta``, ``delta``, ``max_iter``, ``action_choice``, ``engine`` for mean-field;
        ``max_profiles`` for exact; ``max_iter`` for best response.

    Returns
    -------
    MeanFieldSolver, ExactSolver, BestResponseSolver or RandomSolver

    Raises
    ------
    ValueError
        An unknown name, or a parameter the solver does not take.

    Examples
    --------
    >>> make_solver("mean_field", beta=20.0).beta
    20.0
    """
    try:
        cls = _SOLVER_CLASSES[name]
    except (KeyError, TypeError):
        raise ValueError(f"solver must be one of {', '.join(SOLVERS)} (got {name!r})") from None
    fields = set(cls.__dataclass_fields__)
    unknown = sorted(set(params) - fields)
    if unknown:
        raise ValueError(
            f"solver {name!r} takes no parameter {', '.join(map(repr, unknown))} "
            f"(it takes {', '.join(sorted(fields))})"
        )
    return cls(**params)
