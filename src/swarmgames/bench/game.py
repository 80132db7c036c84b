"""Benchmarks of the game engine: batched vs one-by-one mean-field solving of local games.

Each function returns a flat ``dict`` record (numbers and strings only) so that records can be
collected into a table (``pandas.DataFrame(records)``) or written as CSV/JSON. These are
benchmarks, not tests: nothing here asserts a time.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, Fig. 2b: the local game optimisation converges
   "within a few milliseconds".
"""

from __future__ import annotations

import time

import numpy as np

from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.meanfield import mean_field
from swarmgames.game.potentials import TablePotentials, evaluate_payoffs

__all__ = ["bench_local_game", "pairwise_table_bytes", "random_local_games"]


def random_local_games(
    n_games: int, n_vars: int, n_actions: int, seed: int | np.random.Generator | None = 0
) -> tuple[LocalGameBatch, TablePotentials]:
    """B full local games (no padding) with standard-normal unary and pairwise tables.

    States are random 2-D points and next states are the points themselves (the tables carry
    the payoffs); every variable is valid and has every action.
    """
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    b, k, a = int(n_games), int(n_vars), int(n_actions)
    states = rng.normal(size=(b, k, 2))
    batch = LocalGameBatch(
        owner=np.arange(b),
        members=np.broadcast_to(np.arange(k), (b, k)),
        mask=np.ones((b, k), dtype=bool),
        states=states,
        is_virtual=np.zeros((b, k), dtype=bool),
        next_states=np.broadcast_to(states[:, :, None, :], (b, k, a, 2)),
        action_mask=np.ones((b, k, a), dtype=bool),
    )
    pot = TablePotentials(rng.normal(size=(b, k, a)), rng.normal(size=(b, k, k, a, a)))
    return batch, pot


def pairwise_table_bytes(n_games: int, n_vars: int, n_actions: int, dtype=np.float64) -> int:
    """Bytes of one ``(B, K, K, A, A)`` pairwise table (the engine holds the user's table and its
    symmetrised copy while evaluating, so the peak is about twice this)."""
    return int(n_games) * int(n_vars) ** 2 * int(n_actions) ** 2 * np.dtype(dtype).itemsize


def bench_local_game(
    n_games: int = 1000,
    n_vars: int = 8,
    n_actions: int = 9,
    seed: int = 0,
    *,
    beta: float = 5.0,
    alpha_b: float = 0.2,
    delta: float = 1e-6,
    max_iter: int = 200,
    n_single: int | None = 200,
    dtype=np.float64,
    repeats: int = 3,
) -> dict:
    """Time mean-field solving of ``n_games`` random local games, batched and one by one.

    Parameters
    ----------
    n_games, n_vars, n_actions : int
        B, K, A.
    seed : int
    beta, alpha_b, delta, max_iter
        Solver settings (α_a = 1).
    n_single : int or None
        Number of games solved one by one (None: all); the one-by-one time is extrapolated.
    dtype : float64 or float32
    repeats : int
        The batched time is the best of ``repeats`` runs.

    Returns
    -------
    dict
        ``batched_s`` (all B games), ``batched_per_game_ms``, ``single_per_game_ms`` (mean of the
        one-by-one solves), ``speedup``, the one-by-one distribution ``single_p50_ms``,
        ``single_p90_ms``, ``single_p99_ms``, ``single_max_ms``, iteration statistics, the
        converged fraction, ``eval_s`` (building the tables) and ``pair_table_mb``.
    """
    batch, pot = random_local_games(n_games, n_vars, n_actions, seed)
    t0 = time.perf_counter()
    payoffs = evaluate_payoffs(batch, pot, 1.0, alpha_b, dtype=dtype)
    eval_s = time.perf_counter() - t0
    best = np.inf
    res = None
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        res = mean_field(payoffs, beta, delta, max_iter)
        best = min(best, time.perf_counter() - t0)
    m = n_games if n_single is None else min(int(n_single), n_games)
    single = np.empty(m)
    for g in range(m):
        one = payoffs.select(slice(g, g + 1))
        t0 = time.perf_counter()
        mean_field(one, beta, delta, max_iter)
        single[g] = time.perf_counter() - t0
    single_ms = single * 1e3
    per_game_ms = best / n_games * 1e3
    return {
        "n_games": int(n_games),
        "n_vars": int(n_vars),
        "n_actions": int(n_actions),
        "dtype": np.dtype(dtype).name,
        "beta": float(beta),
        "alpha_b": float(alpha_b),
        "eval_s": eval_s,
        "batched_s": best,
        "batched_per_game_ms": per_game_ms,
        "single_per_game_ms": float(single_ms.mean()),
        "speedup": float(single_ms.mean() / per_game_ms),
        "single_p50_ms": float(np.percentile(single_ms, 50)),
        "single_p90_ms": float(np.percentile(single_ms, 90)),
        "single_p99_ms": float(np.percentile(single_ms, 99)),
        "single_max_ms": float(single_ms.max()),
        "iterations_mean": float(res.iterations.mean()),
        "iterations_max": int(res.iterations.max()),
        "converged_fraction": float(res.converged.mean()),
        "pair_table_mb": pairwise_table_bytes(n_games, n_vars, n_actions, dtype) / 2**20,
    }
