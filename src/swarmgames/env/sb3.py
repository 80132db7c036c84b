"""The vector environment as a stable-baselines3 ``VecEnv``: E × N robots, one policy.

:class:`SwarmSB3VecEnv` presents the E envs × N robots of a
:class:`~swarmgames.env.vector.SwarmVectorEnv` as E N parameter-sharing agents, each one
sub-environment of a stable-baselines3 ``VecEnv`` (agent ``e N + i`` is robot i of env e), so
that one policy learns from every robot without SuperSuit:

* observations: each robot's flat observation as float32 (the vector env's
  ``observation="flat"``, F values), shape (E N, F);
* actions: ``Discrete(A)`` each, shape (E N,);
* rewards and dones: (E N,); a robot is done when it crashes or its env's episode ends, and
  its ``info`` then holds ``terminal_observation`` (its true final observation) and
  ``TimeLimit.truncated`` (True when the scenario's duration ended the episode, so that the
  learner bootstraps from the final observation);
* ``env_method("action_masks")`` (and :meth:`action_masks`) gives every agent's action mask,
  as sb3-contrib's ``MaskablePPO`` asks for it;
* ``seed(s)`` (what ``PPO(..., seed=s)`` calls) seeds the next reset: env e runs seed s + e.

Needs the ``rl`` extra (``pip install "swarmgames[rl]"``: stable-baselines3 and torch; for
the CPU build of torch, first ``pip install torch --index-url
https://download.pytorch.org/whl/cpu``).

References
----------
.. [1] A. Raffin et al., "Stable-Baselines3: Reliable Reinforcement Learning
   Implementations", JMLR 22(268), 2021 (the ``VecEnv`` interface).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from swarmgames.errors import BackendUnavailableError

try:
    from stable_baselines3.common.vec_env import VecEnv
except ImportError as exc:  # the rl extra is missing
    raise BackendUnavailableError(
        f"the stable-baselines3 adapter needs stable-baselines3 and torch ({exc.name} is "
        'missing): pip install "swarmgames[rl]"'
    ) from None

from swarmgames.env.vector import SwarmVectorEnv, vector_env

__all__ = ["SwarmSB3VecEnv", "sb3_vec_env"]


def sb3_vec_env(scenario: str = "coverage", num_envs: int = 1, **options: Any) -> SwarmSB3VecEnv:
    """A :class:`SwarmSB3VecEnv` over :func:`~swarmgames.env.vector.vector_env` of the same
    arguments (``observation`` is always ``"flat"``)."""
    options = {**options, "observation": "flat"}
    return SwarmSB3VecEnv(vector_env(scenario, num_envs, **options))


class SwarmSB3VecEnv(VecEnv):
    """The robots of a :class:`~swarmgames.env.vector.SwarmVectorEnv` (built with
    ``observation="flat"`` and autoreset) as one stable-baselines3 ``VecEnv`` (see the module
    docstring).

    Parameters
    ----------
    env : SwarmVectorEnv

    Raises
    ------
    ValueError
        ``env`` does not give flat observations or does not reset itself.
    """

    def __init__(self, env: SwarmVectorEnv) -> None:
        if not env.flat:
            raise ValueError('the adapter needs flat observations: observation="flat"')
        if not env.autoreset:
            raise ValueError("the adapter needs an env that resets itself: autoreset=True")
        self.env = env
        self.render_mode = None
        e, n = env.num_envs, env.n_robots
        box = env.single_observation_space
        space = gym.spaces.Box(
            box.low[0].astype(np.float32), box.high[0].astype(np.float32), dtype=np.float32
        )
        super().__init__(e * n, space, gym.spaces.Discrete(env.n_actions))
        self._actions: np.ndarray | None = None
        self._masks = np.ones((e * n, env.n_actions), dtype=bool)
        self._seed: int | None = None

    # ------------------------------------------------------------------ VecEnv
    def seed(self, seed: int | None = None) -> list[int | None]:
        """Seed the next :meth:`reset`: env e runs seed ``seed + e``."""
        self._seed = None if seed is None else int(seed)
        if seed is None:
            return [None] * self.num_envs
        return [int(seed) + a // self.env.n_robots for a in range(self.num_envs)]

    def reset(self) -> np.ndarray:
        """Every env's new episode; the observations (E N, F) float32."""
        obs, info = self.env.reset(seed=self._seed)
        self._seed = None
        self._masks = info["action_mask"].reshape(self.num_envs, -1).astype(bool)
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return self._flat(obs)

    def step_async(self, actions: np.ndarray) -> None:
        """Keep the actions (E N,) for :meth:`step_wait`."""
        self._actions = np.asarray(actions).reshape(self.env.num_envs, self.env.n_robots)

    def step_wait(self):
        """One step of every env: observations, rewards, dones and infos of every agent."""
        if self._actions is None:
            raise RuntimeError("call step_async(actions) before step_wait()")
        obs, rew, term, trunc, info = self.env.step(self._actions.astype(np.int64))
        self._actions = None
        self._masks = info["action_mask"].reshape(self.num_envs, -1).astype(bool)
        done = (term | trunc).reshape(-1)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        n = self.env.n_robots
        final = info.get("_final_obs", np.zeros(self.env.num_envs, bool))
        for a in np.flatnonzero(done):
            e, i = divmod(int(a), n)
            last = info["final_obs"][e] if final[e] else obs[e]
            infos[a]["terminal_observation"] = np.asarray(last[i], dtype=np.float32)
            infos[a]["TimeLimit.truncated"] = bool(trunc[e, i] and not term[e, i])
        return self._flat(obs), rew.reshape(-1).astype(np.float32), done, infos

    def close(self) -> None:
        """Release every env's run."""
        self.env.close()

    def action_masks(self) -> np.ndarray:
        """Every agent's allowed actions now, (E N, A) bool."""
        return self._masks.copy()

    def env_method(self, method_name: str, *args, indices=None, **kwargs) -> list:
        """``"action_masks"``: every (or each indexed) agent's action mask."""
        if method_name != "action_masks":
            raise AttributeError(f"agents have no method {method_name!r} (only 'action_masks')")
        return [self._masks[a] for a in self._indices(indices)]

    def get_attr(self, attr_name: str, indices=None) -> list:
        """An attribute of the vector env, once per (indexed) agent."""
        if attr_name == "render_mode":
            return [None for _ in self._indices(indices)]
        value = getattr(self.env, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        """Agents share one environment: attributes cannot be set per agent."""
        raise AttributeError(f"cannot set {attr_name!r}: the agents share one environment")

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        """False for every agent: the agents are robots, not wrapped environments."""
        return [False for _ in self._indices(indices)]

    # ------------------------------------------------------------------ helpers
    def _indices(self, indices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, int):
            return [indices]
        return list(indices)

    def _flat(self, obs: np.ndarray) -> np.ndarray:
        return np.asarray(obs, dtype=np.float32).reshape(self.num_envs, -1)
