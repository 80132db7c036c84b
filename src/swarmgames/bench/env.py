"""Learning throughput: the vector environment against PettingZoo's MPE, side by side.

:func:`env_records` steps, with random valid actions and in alternating rounds within one
run (so that the machine's load weighs on both alike):

* ``env_vs_mpe`` — :func:`~swarmgames.env.vector.vector_env` on the default scenario with N
  UAVs and E envs (its default difference reward) against MPE's ``simple_spread`` with the same
  N agents (one env, as PettingZoo ships it), in agent-steps per second; with the share of
  the vector env's time in each part of a step (its ``timings``: the state messages, the
  network, the reward, the observations, the episodes built);
* ``env_single`` — one env (E = 1) with the default step against the same env measuring
  every step as :func:`swarmgames.run` does (``measure=True``: payoffs, local, global and
  ex-post regret, the mission's metrics), in steps per second.

MPE comes from the ``mpe2`` package (``pip install mpe2``); without it the ``env_vs_mpe``
records carry only the vector env's rate.

References
----------
.. [1] R. Lowe et al., "Multi-Agent Actor-Critic for Mixed Cooperative-Competitive
   Environments", NeurIPS 2017 (the particle environments, ``simple_spread``).
.. [2] J. K. Terry et al., "PettingZoo: Gym for Multi-Agent Reinforcement Learning",
   NeurIPS 2021.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

__all__ = ["ENV_CASES", "env_records"]

#: (N, E) of the ``env_vs_mpe`` records.
ENV_CASES = ((7, 64), (30, 16))


def _vector_rate(n: int, e: int, steps: int, seed: int, **options) -> tuple[float, dict]:
    """Agent-steps per second of ``steps`` vector steps (after one untimed), and the shares
    of the timed steps' parts."""
    from swarmgames.env.vector import vector_env

    env = vector_env("coverage", e, swarm__n_robots=n, **options)
    rng = np.random.default_rng(seed)
    _, info = env.reset(seed=seed)

    def step(info):
        mask = info["action_mask"].astype(bool)
        return env.step(np.argmax(rng.random(mask.shape) * mask, axis=2))[4]

    info = step(info)
    before = dict(env.timings)
    t0 = time.perf_counter()
    for _ in range(steps):
        info = step(info)
    wall = time.perf_counter() - t0
    parts = {k: env.timings[k] - before[k] for k in env.timings}
    env.close()
    shares = {f"share_{k}": v / wall for k, v in parts.items()}
    shares["share_other"] = max(0.0, 1.0 - sum(parts.values()) / wall)
    return steps * n * e / wall, shares


def _mpe_rate(n: int, steps: int, seed: int) -> float | None:
    """Agent-steps per second of MPE ``simple_spread`` with ``n`` agents (None without
    mpe2)."""
    try:
        from mpe2 import simple_spread_v3
    except ImportError:
        return None
    env = simple_spread_v3.parallel_env(N=n, max_cycles=10**9, continuous_actions=False)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    n_act = env.action_space(env.agents[0]).n
    env.step({a: int(rng.integers(n_act)) for a in env.agents})
    t0 = time.perf_counter()
    for _ in range(steps):
        env.step({a: int(rng.integers(n_act)) for a in env.agents})
    wall = time.perf_counter() - t0
    env.close()
    return steps * n / wall


def env_records(
    quick: bool = False, seed: int = 0, rounds: int | None = None, cases=ENV_CASES
) -> list[dict]:
    """The ``env_vs_mpe`` records of ``cases`` ((N, E) pairs) and the ``env_single`` record
    (module notes); ``rounds`` alternating rounds of each side (default 3, quick 2), the
    medians reported."""
    rounds = (2 if quick else 3) if rounds is None else int(rounds)
    records: list[dict[str, Any]] = []
    for n, e in cases:
        steps = max(2, (8 if quick else 20) * 64 // (e * max(1, n // 7)))
        ours, mpe, shares = [], [], []
        for _ in range(rounds):
            rate, share = _vector_rate(n, e, steps, seed)
            ours.append(rate)
            shares.append(share)
            other = _mpe_rate(n, max(20, int(rate / n * 0.5)), seed)
            if other is not None:
                mpe.append(other)
        rec = {
            "benchmark": "env_vs_mpe",
            "n_robots": n,
            "num_envs": e,
            "agent_steps_per_s": float(np.median(ours)),
            "median_s": float(1.0 / np.median(ours)),
        }
        rec.update({k: float(np.median([s[k] for s in shares])) for k in shares[0]})
        if mpe:
            rec["mpe_agent_steps_per_s"] = float(np.median(mpe))
            rec["mpe_per_swarmgames"] = rec["mpe_agent_steps_per_s"] / rec["agent_steps_per_s"]
        records.append(rec)
    default, measured = [], []
    steps = 10 if quick else 30
    for _ in range(rounds):
        default.append(_vector_rate(7, 1, steps, seed)[0] / 7)
        measured.append(_vector_rate(7, 1, max(3, steps // 4), seed, measure=True)[0] / 7)
    records.append(
        {
            "benchmark": "env_single",
            "n_robots": 7,
            "num_envs": 1,
            "steps_per_s": float(np.median(default)),
            "measured_steps_per_s": float(np.median(measured)),
            "median_s": float(1.0 / np.median(default)),
            "measured_per_default": float(np.median(measured) / np.median(default)),
        }
    )
    return records
