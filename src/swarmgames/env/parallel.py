"""A PettingZoo ``ParallelEnv`` over any swarmgames mission: the robots are the agents.

Each step is one stage of the run :func:`swarmgames.run` would make of the same scenario: the
network advances, the state messages are exchanged through the communication layer, and then
the agents (instead of the game controller) choose every robot's action. It is the vector
environment :class:`~swarmgames.env.vector.SwarmVectorEnv` with one env (E = 1) and no
autoreset, in PettingZoo's dictionaries keyed by agent: the observations, rewards, spaces
and seeding are that module's (its docstring documents them).

Agents are ``uav_0`` ... ``uav_{N-1}``; a robot that has crashed by the next stage
(``[faults]``) terminates and leaves ``agents``; when the scenario's duration is reached
every remaining robot is truncated, with its true final observation. An agent given no
action takes the first allowed one.

References
----------
.. [1] J. K. Terry et al., "PettingZoo: Gym for Multi-Agent Reinforcement Learning",
   NeurIPS 2021 (the Parallel API).
.. [2] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section IV (learning as future work).
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from pettingzoo import ParallelEnv

from swarmgames.env.vector import SwarmVectorEnv, scenario_and_options

__all__ = ["SwarmParallelEnv", "parallel_env"]


def parallel_env(scenario: str = "coverage", render_mode: str | None = None, **options: Any):
    """A :class:`SwarmParallelEnv` of a built-in scenario (or TOML file) with overrides.

    Parameters
    ----------
    scenario : str
        A built-in scenario name or a TOML file, as ``swarmgames run`` takes it.
    render_mode : {"rgb_array", None}
    **options
        ``reward``, ``max_neighbours``, ``observation``, ``mask_in_obs``, ``measure`` (see
        :class:`~swarmgames.env.vector.SwarmVectorEnv`), and configuration overrides with
        ``__`` for the dots: ``swarm__n_robots=5`` is ``--set swarm.n_robots=5``.

    Examples
    --------
    >>> env = parallel_env("coverage", swarm__n_robots=3, sim__duration_s=2.0)  # doctest: +SKIP
    >>> obs, infos = env.reset(seed=0)                                         # doctest: +SKIP
    """
    config, kwargs = scenario_and_options(scenario, options, set())
    return SwarmParallelEnv(config, render_mode=render_mode, **kwargs)


class SwarmParallelEnv(ParallelEnv):
    """The PettingZoo Parallel environment of a scenario (see the module docstring).

    Parameters
    ----------
    config : ScenarioConfig
    render_mode : {"rgb_array", None}
    mission : Mission, optional
        A mission object instead of the one ``config.scenario`` names.
    **options
        ``reward``, ``max_neighbours``, ``observation``, ``mask_in_obs``, ``measure`` of
        :class:`~swarmgames.env.vector.SwarmVectorEnv`.

    Notes
    -----
    :meth:`expert_actions` gives the actions the game controller of :func:`swarmgames.run`
    would take on the current observations (every local game built from the robots' inboxes
    and solved by the configured solver), for imitation or as a baseline; asking for them
    changes nothing in the episode. ``infos[agent]`` holds its ``action_mask``, whether its
    action was ``replaced``, and with ``measure=True`` the stage's ``record``.
    """

    metadata: ClassVar[dict] = {
        "name": "swarmgames_v0",
        "render_modes": ["rgb_array"],
        "is_parallelizable": True,
    }

    def __init__(
        self, config, render_mode: str | None = None, mission: Any = None, **options: Any
    ) -> None:
        self.vec = SwarmVectorEnv(
            config, 1, autoreset=False, render_mode=render_mode, mission=mission, **options
        )
        v = self.vec
        self.config, self.mission, self.render_mode = config, v.mission, render_mode
        self.n_robots, self.n_actions, self.state_dim, self.k = (
            v.n_robots,
            v.n_actions,
            v.state_dim,
            v.k,
        )
        self.possible_agents = [f"uav_{i}" for i in range(self.n_robots)]
        self.agents: list[str] = []
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self._obs_space = _one_robot(v.single_observation_space)
        self._act_space = gym.spaces.Discrete(self.n_actions)
        self._masks: np.ndarray | None = None
        self._started = False

    # ----------------------------------------------------------------- spaces
    def observation_space(self, agent: str):
        """The observation space of ``agent`` (the same object every call)."""
        return self._obs_space

    def action_space(self, agent: str):
        """The action space of ``agent`` (the same object every call)."""
        return self._act_space

    # ----------------------------------------------------------------- episode
    def reset(self, seed: int | None = None, options: dict | None = None):
        """Start an episode: ``reset(seed=s)`` runs the scenario with ``seed = s``;
        ``reset()`` starts the next episode of the generator the last seed started. Returns
        the observations and infos of every robot."""
        obs, info = self.vec.reset(seed=seed)
        self._started = True
        self.agents = list(self.possible_agents)
        self._masks = info["action_mask"][0]
        return self._per_agent(obs, self.agents), self._infos(info, self.agents)

    def step(self, actions: dict[str, int]):
        """Apply every live agent's action for one stage; returns observations, rewards,
        terminations, truncations and infos of the agents that were live."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if not self.agents:
            return {}, {}, {}, {}, {}
        chosen = np.argmax(self._masks, axis=1)  # the first allowed, for robots not given one
        for agent, action in actions.items():
            i = self._agent(agent)
            if not 0 <= int(action) < self.n_actions:
                raise ValueError(f"action of {agent} must be in [0, {self.n_actions})")
            chosen[i] = int(action)
        given = np.zeros(self.n_robots, dtype=bool)
        given[[self._agent(a) for a in actions]] = True
        obs, rew, term, trunc, info = self.vec.step(chosen[None, :])
        live = list(self.agents)
        if info.get("_final_obs", np.zeros(1, bool))[0]:
            obs = _batch_of_one(info["final_obs"][0])
        rewards = {a: float(rew[0, self._index[a]]) for a in live}
        terminations = {a: bool(term[0, self._index[a]]) for a in live}
        truncations = {a: bool(trunc[0, self._index[a]]) for a in live}
        infos = self._infos(info, live)
        for a in live:
            infos[a]["replaced"] = bool(
                info["replaced"][0, self._index[a]] and given[self._index[a]]
            )
            if "records" in info:
                infos[a]["record"] = info["records"][0]
        self._masks = info["action_mask"][0]
        self.agents = [a for a in live if not (terminations[a] or truncations[a])]
        return self._per_agent(obs, live), rewards, terminations, truncations, infos

    def expert_actions(self) -> dict[str, int]:
        """The game controller's action for every live agent at the current observations
        (:meth:`~swarmgames.env.vector.SwarmVectorEnv.expert_actions`): an episode that
        takes these actions at every step is the run :func:`swarmgames.run` makes of the
        same scenario and seed."""
        if not self._started:
            raise RuntimeError("call reset() before expert_actions()")
        acts = self.vec.expert_actions()[0]
        return {a: int(acts[self._index[a]]) for a in self.agents}

    def render(self):
        """The current stage as an RGB array (H, W, 3), like a frame of animation.gif
        (``render_mode="rgb_array"``; None otherwise)."""
        if not self._started:
            return None
        frames = self.vec.render()
        return None if frames is None else frames[0]

    def close(self) -> None:
        """Release the run (a network backend such as ns-3 is closed)."""
        self.vec.close()
        self._started = False

    @property
    def stage_time(self) -> float:
        """The time of the stage the agents observe now, seconds: the network's warm-up, then
        one control period a step (the ``t`` a mission's metrics and potentials see)."""
        if not self._started:
            raise RuntimeError("call reset() before stage_time")
        return float(self.vec.stage_times[0])

    def state(self) -> np.ndarray:
        """The true states of every robot, (N, D) (PettingZoo's global state)."""
        if not self._started:
            raise RuntimeError("call reset() before state()")
        return self.vec.state()[0]

    @property
    def loop(self):
        """The run's :class:`~swarmgames.sim.loop.StageLoop`, for inspection."""
        return self.vec.env_loop(0)

    # ----------------------------------------------------------------- helpers
    def _agent(self, agent: str) -> int:
        try:
            return self._index[agent]
        except KeyError:
            raise KeyError(f"unknown agent {agent!r}") from None

    def _per_agent(self, obs, agents) -> dict:
        if isinstance(obs, dict):
            return {a: {k: v[0, self._index[a]] for k, v in obs.items()} for a in agents}
        return {a: obs[0, self._index[a]] for a in agents}

    def _infos(self, info: dict, agents) -> dict[str, dict]:
        return {a: {"action_mask": info["action_mask"][0, self._index[a]]} for a in agents}


def _one_robot(space):
    """A robot's space from one env's (every part's leading N axis dropped)."""
    if isinstance(space, gym.spaces.Dict):
        return gym.spaces.Dict({k: _one_robot(s) for k, s in space.spaces.items()})
    if isinstance(space, gym.spaces.MultiBinary):
        return gym.spaces.MultiBinary(space.shape[1:])
    return gym.spaces.Box(space.low[0], space.high[0], dtype=space.dtype)


def _batch_of_one(obs):
    """One env's observation as a batch of one."""
    if isinstance(obs, dict):
        return {k: v[None] for k, v in obs.items()}
    return obs[None]
