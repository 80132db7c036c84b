"""Benchmarks of the network layer. Each function returns a plain ``dict`` record.

Example::

    from swarmgames.bench.network import bench_olsr_advance
    bench_olsr_advance(1000, 60.0)            # TCs on, snapshot every simulated second
    bench_olsr_advance(10_000, 60.0, hello_only=True)
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from swarmgames.experiments.replay import replay
from swarmgames.network.olsr.provider import OlsrProvider
from swarmgames.network.oracle import OracleProvider
from swarmgames.network.trace import PositionTrace
from swarmgames.rng import as_generator

__all__ = ["bench_olsr_advance", "bench_oracle", "bench_replay", "random_swarm"]


def random_swarm(
    n_robots: int, mean_degree: float = 10.0, range_m: float = 368.84, seed=None
) -> np.ndarray:
    """Uniform random positions (N, 3) in a square sized so that the expected number of
    neighbours within ``range_m`` is about ``mean_degree`` (z = 0)."""
    rng = as_generator(seed)
    side = np.sqrt(n_robots * np.pi * range_m**2 / max(mean_degree, 1e-9))
    return np.c_[rng.uniform(0, side, (n_robots, 2)), np.zeros(n_robots)]


def bench_olsr_advance(
    n_robots: int,
    sim_seconds: float = 60.0,
    hello_only: bool = False,
    seed: int = 0,
    mean_degree: float = 10.0,
    step_s: float = 1.0,
    speed_mps: float = 5.0,
) -> dict:
    """Wall time of the OLSR provider over ``sim_seconds`` of simulated time.

    The swarm (random square layout, about ``mean_degree`` neighbours each) drifts in random
    directions at ``speed_mps``; positions change and a snapshot (every routing table) is read
    every ``step_s`` seconds.
    """
    rng = as_generator(seed)
    pos = random_swarm(n_robots, mean_degree, seed=rng)
    heading = rng.uniform(0, 2 * np.pi, n_robots)
    vel = speed_mps * np.c_[np.cos(heading), np.sin(heading), np.zeros(n_robots)]
    provider = OlsrProvider(n_robots, hello_only=hello_only, seed=rng)
    t0 = time.perf_counter()
    provider.reset(pos)
    t = 0.0
    snap = None
    while t < sim_seconds - 1e-9:
        t = min(t + step_s, sim_seconds)
        pos = pos + vel * step_s
        snap = provider.advance(t, pos)
    wall = time.perf_counter() - t0
    return {
        "benchmark": "olsr_advance",
        "n_robots": n_robots,
        "sim_seconds": sim_seconds,
        "hello_only": hello_only,
        "mean_degree_target": mean_degree,
        "mean_degree": float(snap.degree().mean()) if snap is not None else 0.0,
        "routes": snap.n_entries if snap is not None else 0,
        "wall_s": wall,
    }


def bench_oracle(n_robots: int, seed: int = 0, mean_degree: float = 10.0) -> dict:
    """Wall time of one oracle snapshot (link graph + BFS)."""
    pos = random_swarm(n_robots, mean_degree, seed=seed)
    provider = OracleProvider(n_robots)
    t0 = time.perf_counter()
    snap = provider.reset(pos)
    return {
        "benchmark": "oracle",
        "n_robots": n_robots,
        "routes": snap.n_entries,
        "wall_s": time.perf_counter() - t0,
    }


def bench_replay(
    n_robots: int,
    sim_seconds: float = 60.0,
    dt: float = 0.1,
    sample_every: float = 0.5,
    backend: str = "olsr",
    seed: int = 0,
    mean_degree: float = 10.0,
    speed_mps: float = 5.0,
) -> dict:
    """Wall time of :func:`~swarmgames.experiments.replay.replay` on a synthetic trace (random
    square layout drifting at ``speed_mps``, a row per node every ``dt`` seconds)."""
    rng = as_generator(seed)
    pos = random_swarm(n_robots, mean_degree, seed=rng)
    heading = rng.uniform(0, 2 * np.pi, n_robots)
    vel = speed_mps * np.c_[np.cos(heading), np.sin(heading), np.zeros(n_robots)]
    times = np.round(np.arange(0.0, sim_seconds + 1e-9, dt), 9)
    xyz = pos[None] + times[:, None, None] * vel[None]
    frame = pd.DataFrame(
        {
            "t": np.repeat(times, n_robots),
            "node": np.tile(np.arange(n_robots), times.size),
            "x": xyz[..., 0].ravel(),
            "y": xyz[..., 1].ravel(),
            "z": xyz[..., 2].ravel(),
        }
    )
    trace = PositionTrace.from_frame(frame)
    t0 = time.perf_counter()
    res = replay(trace, backend, sample_every=sample_every, seed=rng)
    return {
        "benchmark": "replay",
        "backend": backend,
        "n_robots": n_robots,
        "sim_seconds": sim_seconds,
        "dt": dt,
        "sample_every": sample_every,
        "rows": len(res.hops),
        "wall_s": time.perf_counter() - t0,
    }
