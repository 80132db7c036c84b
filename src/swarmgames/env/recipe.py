"""A training recipe: PPO with one policy shared by every robot, on the vector environment.

:func:`train_ppo` trains stable-baselines3's PPO on E swarms of a scenario through
:class:`~swarmgames.env.sb3.SwarmSB3VecEnv` (the E × N robots one parameter-sharing batch),
with observations and rewards normalised by ``VecNormalize``, for a wall-clock budget or a
number of agent-steps. :func:`evaluate` then flies a policy on evaluation seeds and reports
each episode's return and the mission's metric at its end; :func:`compare` does so for a
random policy, the game controller (the expert) and the trained policy side by side.
``swarmgames learn`` runs the three and writes the table.

The defaults are those of the table in docs/env.md: the coverage mission with 7 UAVs for
30 stages, the difference reward (each robot's own contribution to the coverage), 16 envs,
PPO with γ = 0.95, learning rate 10⁻³, 10 epochs per update, 64 steps per env and update,
minibatches of 1 024, two hidden layers of 128 units. An action the mask forbids is
replaced by ``stay`` by the environment.

Needs the ``rl`` extra (stable-baselines3 and torch).

References
----------
.. [1] J. Schulman et al., "Proximal Policy Optimization Algorithms", arXiv 1707.06347, 2017.
.. [2] A. Raffin et al., "Stable-Baselines3: Reliable Reinforcement Learning
   Implementations", JMLR 22(268), 2021.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from swarmgames.env.sb3 import SwarmSB3VecEnv
from swarmgames.env.vector import REWARDS, SwarmVectorEnv

__all__ = ["RECIPE_OVERRIDES", "Trained", "compare", "evaluate", "recipe_config", "train_ppo"]

#: The recipe's scenario overrides, before the user's: 7 UAVs, 30 stages.
RECIPE_OVERRIDES = ("swarm.n_robots=7", "sim.duration_s=30.0")

#: PPO's settings of the recipe.
PPO_SETTINGS = {
    "n_steps": 64,
    "batch_size": 1024,
    "n_epochs": 10,
    "gamma": 0.95,
    "learning_rate": 1e-3,
    "ent_coef": 0.0,
}


def recipe_config(scenario: str = "coverage", overrides=()):
    """The scenario (a built-in name or a TOML file) with :data:`RECIPE_OVERRIDES`, then
    ``overrides`` (``--set`` strings such as ``"swarm.n_robots=5"``) applied."""
    from swarmgames.config import resolve_scenario

    return resolve_scenario(scenario, [*RECIPE_OVERRIDES, *overrides])


@dataclass
class Trained:
    """A trained policy and what it took.

    Attributes
    ----------
    model : stable_baselines3.PPO
    normalize : stable_baselines3.common.vec_env.VecNormalize
        The observation statistics the policy reads its inputs through.
    agent_steps : int
    wall_s : float
    curve : list of (seconds, agent-steps, mean episode reward) tuples
    """

    model: Any
    normalize: Any
    agent_steps: int
    wall_s: float
    curve: list[tuple[float, int, float]] = field(default_factory=list)

    def policy(self):
        """The deterministic policy as a function of (flat observations (E, N, F), info) to
        actions (E, N)."""

        def act(obs: np.ndarray, info: dict) -> np.ndarray:
            flat = obs.reshape(-1, obs.shape[-1]).astype(np.float32)
            actions, _ = self.model.predict(self.normalize.normalize_obs(flat), deterministic=True)
            return np.asarray(actions).reshape(obs.shape[:2])

        return act

    def save(self, folder) -> list[Path]:
        """``model.zip`` and ``normalize.pkl`` into ``folder``."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        self.model.save(folder / "model.zip")
        self.normalize.save(str(folder / "normalize.pkl"))
        return [folder / "model.zip", folder / "normalize.pkl"]


def train_ppo(
    config=None,
    *,
    num_envs: int = 16,
    reward: str = "difference",
    minutes: float | None = 30.0,
    agent_steps: int | None = None,
    seed: int = 0,
    progress=None,
) -> Trained:
    """Train PPO on ``num_envs`` swarms of ``config`` (default :func:`recipe_config`) for
    ``minutes`` of wall time or ``agent_steps`` agent-steps, whichever comes first (at
    least one update).

    Parameters
    ----------
    config : ScenarioConfig, optional
    progress : callable, optional
        Called with ``(seconds, agent_steps, mean_reward)`` after every update.
    """
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    if reward not in REWARDS:
        raise ValueError(f"reward must be one of {', '.join(REWARDS)} (got {reward!r})")
    if minutes is None and agent_steps is None:
        raise ValueError("give minutes or agent_steps (or both)")
    torch.set_num_threads(1)  # the environment has the other core
    config = recipe_config() if config is None else config
    venv = SwarmSB3VecEnv(SwarmVectorEnv(config, num_envs, reward=reward, observation="flat"))
    norm = VecNormalize(VecMonitor(venv), gamma=PPO_SETTINGS["gamma"])
    settings = dict(PPO_SETTINGS)  # minibatches no larger than one update's rollout
    settings["batch_size"] = min(settings["batch_size"], settings["n_steps"] * venv.num_envs)
    model = PPO(
        "MlpPolicy", norm, seed=seed, verbose=0, policy_kwargs={"net_arch": [128, 128]}, **settings
    )
    chunk = PPO_SETTINGS["n_steps"] * venv.num_envs
    budget = np.inf if agent_steps is None else int(agent_steps)
    limit = np.inf if minutes is None else 60.0 * float(minutes)
    t0 = time.perf_counter()
    curve = []
    while True:
        model.learn(chunk, reset_num_timesteps=False)
        wall = time.perf_counter() - t0
        buffer = model.ep_info_buffer
        mean = float(np.mean([ep["r"] for ep in buffer])) if buffer else float("nan")
        curve.append((wall, int(model.num_timesteps), mean))
        if progress is not None:
            progress(*curve[-1])
        if model.num_timesteps >= budget or wall >= limit:
            break
    norm.training = False
    return Trained(model, norm, int(model.num_timesteps), time.perf_counter() - t0, curve)


def evaluate(
    env: SwarmVectorEnv, policy, seeds, metric: str | None = None
) -> list[dict[str, float]]:
    """Fly ``policy`` (``(obs, info) -> actions (E, N)``) for one episode of each seed of
    ``seeds`` (E = len(seeds) envs of ``env``, which must not reset itself), and return per
    episode its ``return`` (the sum over steps of the robots' mean reward) and the mission's
    first swarm metric (or ``metric``) of the states where the episode ended."""
    seeds = [int(s) for s in seeds]
    if env.num_envs != len(seeds) or env.autoreset:
        raise ValueError("evaluate needs an env of len(seeds) envs built with autoreset=False")
    obs, info = env.reset(seed=seeds)
    total = np.zeros(len(seeds))
    ended = np.zeros(len(seeds), dtype=bool)
    while not ended.all():
        obs, rew, _, _, info = env.step(np.asarray(policy(obs, info), dtype=np.int64))
        total += rew.mean(axis=1)  # an ended env's rewards are 0
        ended |= info.get("_final_obs", False)
    out = []
    for e, states in enumerate(env.state()):
        measured = env.mission.swarm_metrics(states, None, float(env.stage_times[e]))
        name = metric if metric is not None else next(iter(measured))
        out.append({"seed": seeds[e], "return": float(total[e]), name: float(measured[name])})
    return out


def compare(
    trained: Trained | None,
    config=None,
    *,
    seeds=(100, 101, 102, 103, 104),
    reward: str = "difference",
) -> list[dict[str, Any]]:
    """Every evaluation episode of a random policy (uniform over the allowed actions, its
    draws seeded), the game controller and ``trained`` (if given) on ``seeds``, with
    ``config`` (default :func:`recipe_config`) and ``reward``; one row per policy and
    seed."""
    config = recipe_config() if config is None else config
    env = SwarmVectorEnv(
        config, len(tuple(seeds)), reward=reward, observation="flat", autoreset=False
    )
    rng = np.random.default_rng(0)

    def random_policy(obs, info):
        mask = info["action_mask"].astype(bool)
        return np.argmax(rng.random(mask.shape) * mask, axis=2)

    policies = {"random": random_policy, "expert": lambda obs, info: env.expert_actions()}
    if trained is not None:
        policies["trained"] = trained.policy()
    rows = []
    for name, policy in policies.items():
        for row in evaluate(env, policy, seeds):
            rows.append({"policy": name, **row})
    env.close()
    return rows
