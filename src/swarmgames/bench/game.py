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
from swarmgames.rng import as_generator

__all__ = [
    "bench_local_game",
    "bench_memory",
    "bench_stage",
    "pairwise_table_bytes",
    "random_local_games",
]


def random_local_games(
    n_games: int, n_vars: int, n_actions: int, seed: int | np.random.Generator | None = 0
) -> tuple[LocalGameBatch, TablePotentials]:
    """B full local games (no padding) with standard-normal unary and pairwise tables.

    States are random 2-D points and next states are the points themselves (the tables carry
    the payoffs); every variable is valid and has every action.
    """
    rng = as_generator(seed)
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
    engine: str = "auto",
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
    engine : str
        Mean-field engine (:func:`~swarmgames.game.meanfield.mean_field`). One untimed solve
        of a batch and of a single game comes first, so compilation is not timed.

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
    mean_field(payoffs.select(slice(0, 1)), beta, delta, max_iter, engine=engine)
    res = mean_field(payoffs, beta, delta, max_iter, engine=engine)
    best = np.inf
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        res = mean_field(payoffs, beta, delta, max_iter, engine=engine)
        best = min(best, time.perf_counter() - t0)
    m = n_games if n_single is None else min(int(n_single), n_games)
    single = np.empty(m)
    for g in range(m):
        one = payoffs.select(slice(g, g + 1))
        t0 = time.perf_counter()
        mean_field(one, beta, delta, max_iter, engine=engine)
        single[g] = time.perf_counter() - t0
    single_ms = single * 1e3
    per_game_ms = best / n_games * 1e3
    return {
        "n_games": int(n_games),
        "n_vars": int(n_vars),
        "n_actions": int(n_actions),
        "dtype": np.dtype(dtype).name,
        "engine": engine,
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


def bench_memory(
    n_games: int = 10_000, n_vars: int = 10, n_actions: int = 9, seed: int = 0, dtype=np.float64
) -> dict:
    """Peak memory of evaluating the payoff tables and of mean-field solving, via tracemalloc.

    The user's ``(B, K, K, A, A)`` pairwise table exists before the measurement and is not
    counted in the peaks; ``pair_table_mb`` gives its size.

    Returns
    -------
    dict
        ``pair_table_mb``, ``eval_peak_mb`` (extra memory while building the tables),
        ``solve_peak_mb`` (extra memory while solving, the tables already held), ``eval_s``,
        ``solve_s`` and ``per_game_ms``.
    """
    import tracemalloc

    batch, pot = random_local_games(n_games, n_vars, n_actions, seed)
    if np.dtype(dtype) == np.float32:
        pot = TablePotentials(
            pot.unary_table.astype(np.float32), pot.pairwise_table.astype(np.float32)
        )
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        t0 = time.perf_counter()
        payoffs = evaluate_payoffs(batch, pot, 1.0, 0.2, dtype=dtype)
        eval_s = time.perf_counter() - t0
        eval_peak = tracemalloc.get_traced_memory()[1] - base
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        t0 = time.perf_counter()
        res = mean_field(payoffs, 50.0, 1e-6, 200)
        solve_s = time.perf_counter() - t0
        solve_peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    mb = 2.0**20
    return {
        "n_games": int(n_games),
        "n_vars": int(n_vars),
        "n_actions": int(n_actions),
        "dtype": np.dtype(dtype).name,
        "pair_table_mb": pairwise_table_bytes(n_games, n_vars, n_actions, dtype) / mb,
        "eval_peak_mb": eval_peak / mb,
        "solve_peak_mb": solve_peak / mb,
        "eval_s": eval_s,
        "solve_s": solve_s,
        "per_game_ms": solve_s / n_games * 1e3,
        "iterations_mean": float(res.iterations.mean()),
    }


def bench_stage(
    n_robots: int = 1000,
    mean_neighbours: float = 8.0,
    h: int = 2,
    seed: int = 0,
    *,
    radius_m: float = 368.84,
    beta: float = 50.0,
    alpha_b: float = 0.001,
    buckets: int = 0,
) -> dict:
    """Time one stage of the whole pipeline on a random swarm: routing-table neighbourhoods →
    local games (virtual means) → potentials → mean-field → actions.

    Robots are uniform in a square sized so that N_i(h) holds about ``mean_neighbours``
    robots on average (disk graph of ``radius_m``, the 802.11a/Friis range of docs/reference.md
    section 2; BFS hop counts as settled OLSR, section 4). Actions: stay + 8 headings of 10 m.
    Potentials: a smooth unary (distance to the centre) and a pairwise link-quality term of
    the form of eq. 6 (log-distance signal), so the evaluation cost is representative.

    buckets : int
        Passed to :class:`~swarmgames.game.problem.StageProblem` (0 = automatic).

    Returns
    -------
    dict
        Timings (``build_s``, ``eval_s``, ``solve_s``, ``per_robot_ms``), the local game size
        distribution (``k_mean``, ``k_max``) and convergence statistics.
    """
    import scipy.sparse.csgraph as csgraph
    from scipy.spatial import cKDTree

    from swarmgames.game.actions import DisplacementActions
    from swarmgames.game.potentials import FunctionPotentials
    from swarmgames.game.problem import StageProblem
    from swarmgames.game.solvers import MeanFieldSolver
    from swarmgames.game.stage import solve
    from swarmgames.topology import TopologySnapshot

    rng = np.random.default_rng(seed)
    # Area such that a disc of radius 0.8 h radius_m holds ~mean_neighbours robots (the
    # effective reach of h hops on a random disk graph, calibrated on this generator).
    reach = 0.8 * h * radius_m
    side = np.sqrt(n_robots * np.pi * reach**2 / max(mean_neighbours, 1.0))
    pos = rng.uniform(0.0, side, size=(n_robots, 2))
    pairs = cKDTree(pos).query_pairs(radius_m, output_type="ndarray")
    import scipy.sparse as sp

    adj = sp.coo_array(
        (np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n_robots, n_robots)
    ).tocsr()
    hops = csgraph.dijkstra(adj, directed=False, unweighted=True, limit=h)
    snap = TopologySnapshot.from_hop_matrix(0.0, hops)
    model = DisplacementActions.headings(10.0, 8)
    centre = np.array([side / 2, side / 2])

    def signal(d):
        return 16.0206 - (46.6777 + 30.0 * np.log10(np.maximum(d, 1.0)))

    pot = FunctionPotentials(
        lambda s: signal(np.linalg.norm(s - centre, axis=-1)) / 100.0,
        lambda s, t: signal(np.linalg.norm(s - t, axis=-1)),
    )
    problem = StageProblem.ideal(
        snap,
        h,
        pos,
        model,
        pot,
        MeanFieldSolver(alpha_b=alpha_b, beta=beta),
        buckets=buckets,
        global_regret=False,
        keep_games=True,
    )
    stage = solve(problem)
    batch, sol, build_s = stage.batch, stage.solution, stage.build_s
    k = batch.mask.sum(axis=1)
    return {
        "n_robots": int(n_robots),
        "h": int(h),
        "buckets": int(buckets),
        "k_mean": float(k.mean()),
        "k_max": int(k.max()),
        "virtual_fraction": float(batch.is_virtual[batch.mask].mean()),
        "build_s": build_s,
        "eval_s": sol.eval_time_s,
        "solve_s": sol.solve_time_s,
        "per_robot_ms": (build_s + sol.eval_time_s + sol.solve_time_s) / n_robots * 1e3,
        "solve_per_robot_ms": sol.solve_time_s / n_robots * 1e3,
        "iterations_mean": float(sol.iterations.mean()),
        "iterations_max": int(sol.iterations.max()),
        "converged_fraction": float(sol.converged.mean()),
    }


def main() -> None:  # pragma: no cover - a command-line convenience
    """Print the standard game benchmarks (``python -m swarmgames.bench.game``)."""
    import json

    records = [
        bench_local_game(1000, 8, 9, 0, beta=50.0),
        bench_local_game(1000, 8, 9, 0, beta=5.0),
        bench_local_game(1000, 8, 9, 0, beta=5.0, dtype=np.float32),
        bench_memory(10_000, 10, 9),
        bench_memory(10_000, 10, 9, dtype=np.float32),
        bench_stage(1000, 8.0, buckets=1),
        bench_stage(1000, 8.0, buckets=8),
    ]
    for rec in records:
        print(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in rec.items()}))


if __name__ == "__main__":  # pragma: no cover
    main()
