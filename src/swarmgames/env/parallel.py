"""A PettingZoo ``ParallelEnv`` over any swarmgames mission: the robots are the agents.

Each step is one stage of the run :func:`swarmgames.run` would make of the same scenario: the
network advances, the state messages are exchanged through the communication layer, and then
the agents (instead of the game controller) choose every robot's action.

Observation of robot i (a ``gymnasium.spaces.Dict``), what robot i has at its decision:

``self`` (D,)
    Its own state.
``neighbours`` (K, D)
    The states it uses for the other members of its neighbourhood N_i(h): the last it heard
    from each (routed or ns-3 delivery, dead-reckoned if configured) or the exact ones (ideal
    delivery); 0 where ``mask`` is false.
``ids`` (K,)
    Their robot ids, -1 padded.
``age`` (K,)
    The age of each of those states, seconds (0 with ideal delivery).
``hops`` (K,)
    Their hop counts in robot i's own routing table.
``mask`` (K,)
    Which rows hold a neighbour. K is ``max_neighbours`` (default: N - 1); a robot that knows
    more keeps the nearest in hops (then the lowest ids).

With ``observation="flat"`` the same values come as one float64 vector, in this order
(``self``, ``neighbours`` row by row, ``ids``, ``age``, ``hops``, ``mask``; length
D + K D + 4 K): the form vectorising wrappers such as SuperSuit's need.

Action: the index of a discrete action of the mission's action model, ``Discrete(A)``; the
allowed ones are ``infos[agent]["action_mask"]``. An action the mask forbids is replaced by
the first allowed one (``stay`` for the UAV motion models), and ``infos[agent]["replaced"]``
says so.

Reward: robot i's payoff M_i in its true local game at the joint action (the ``payoff`` column
of ``metrics.csv``); with ``reward="mission"``, its share of the mission's first swarm metric
(the metric over the robots alive, divided by their number).

Termination and truncation: a robot that has crashed by the next stage (``[faults]``)
terminates and leaves ``agents``; when the scenario's duration is reached every remaining
robot is truncated.

Seeding: ``reset(seed=s)`` runs the scenario with ``seed = s`` (every draw of
:func:`swarmgames.run` from it: the same seed, the same episode); ``reset()`` without a seed
starts the next episode of the generator the last seed started.

References
----------
.. [1] J. K. Terry et al., "PettingZoo: Gym for Multi-Agent Reinforcement Learning",
   NeurIPS 2021 (the Parallel API).
.. [2] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section IV (learning as future work).
"""

from __future__ import annotations

import functools
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from pettingzoo import ParallelEnv

from swarmgames.missions.protocol import NETWORK_COLUMNS, SWARM_HEAD

__all__ = ["SwarmParallelEnv", "parallel_env"]


def parallel_env(scenario: str = "coverage", render_mode: str | None = None, **options: Any):
    """A :class:`SwarmParallelEnv` of a built-in scenario (or TOML file) with overrides.

    Parameters
    ----------
    scenario : str
        A built-in scenario name or a TOML file, as ``swarmgames run`` takes it.
    render_mode : {"rgb_array", None}
    **options
        ``reward``, ``max_neighbours``, ``observation`` (see :class:`SwarmParallelEnv`), and
        configuration
        overrides with ``__`` for the dots: ``swarm__n_robots=5`` is ``--set
        swarm.n_robots=5``.

    Examples
    --------
    >>> env = parallel_env("coverage", swarm__n_robots=3, sim__duration_s=2.0)  # doctest: +SKIP
    >>> obs, infos = env.reset(seed=0)                                         # doctest: +SKIP
    """
    from swarmgames.config import resolve_scenario
    from swarmgames.config.io import toml_literal

    env_keys = {"reward", "max_neighbours", "observation"}
    kwargs = {k: options.pop(k) for k in list(options) if k in env_keys}
    overrides = [f"{k.replace('__', '.')}={toml_literal(v)}" for k, v in options.items()]
    config = resolve_scenario(scenario, overrides)
    return SwarmParallelEnv(config, render_mode=render_mode, **kwargs)


class SwarmParallelEnv(ParallelEnv):
    """The PettingZoo Parallel environment of a scenario (see the module docstring).

    Parameters
    ----------
    config : ScenarioConfig
    render_mode : {"rgb_array", None}
    reward : {"payoff", "mission"}
    max_neighbours : int, optional
        K, the rows of the ``neighbours`` observation (default N - 1, every other robot).
    observation : {"dict", "flat"}
        A ``Dict`` of the named parts, or one flat ``Box`` vector.
    mission : Mission, optional
        A mission object instead of the one ``config.scenario`` names.

    Notes
    -----
    :meth:`expert_actions` gives the actions the game controller of :func:`swarmgames.run`
    would take on the current observations (every local game built from the robots' inboxes
    and solved by the configured solver), for imitation or as a baseline; asking for them
    changes nothing in the episode.
    """

    metadata: ClassVar[dict] = {
        "name": "swarmgames_v0",
        "render_modes": ["rgb_array"],
        "is_parallelizable": True,
    }

    def __init__(
        self,
        config,
        render_mode: str | None = None,
        reward: str = "payoff",
        max_neighbours: int | None = None,
        mission: Any = None,
        observation: str = "dict",
    ) -> None:
        from swarmgames.sim.runner import build_mission

        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be 'rgb_array' or None (got {render_mode!r})")
        if reward not in ("payoff", "mission"):
            raise ValueError(f"reward must be 'payoff' or 'mission' (got {reward!r})")
        if observation not in ("dict", "flat"):
            raise ValueError(f"observation must be 'dict' or 'flat' (got {observation!r})")
        self.flat = observation == "flat"
        self.config = config
        self.render_mode = render_mode
        self.reward_kind = reward
        self.mission = build_mission(config) if mission is None else mission
        n = int(config.swarm.n_robots)
        self.n_robots = n
        self.k = max(1, n - 1 if max_neighbours is None else int(max_neighbours))
        self.possible_agents = [f"uav_{i}" for i in range(n)]
        self.agents: list[str] = []
        d, a = int(self.mission.state_dim), int(self.mission.action_model.n_actions)
        self.state_dim, self.n_actions = d, a
        box = functools.partial(gym.spaces.Box, -np.inf, np.inf, dtype=np.float64)
        self._obs_space = gym.spaces.Dict(
            {
                "self": box(shape=(d,)),
                "neighbours": box(shape=(self.k, d)),
                "ids": gym.spaces.Box(-1, n - 1, shape=(self.k,), dtype=np.int64),
                "age": gym.spaces.Box(0.0, np.inf, shape=(self.k,), dtype=np.float64),
                "hops": gym.spaces.Box(0, np.iinfo(np.int32).max, (self.k,), dtype=np.int64),
                "mask": gym.spaces.MultiBinary(self.k),
            }
        )
        if self.flat:
            size = d + self.k * d + 4 * self.k
            self._obs_space = gym.spaces.Box(-np.inf, np.inf, (size,), dtype=np.float64)
        self._obs_spaces = dict.fromkeys(self.possible_agents, self._obs_space)
        self._act_spaces = {ag: gym.spaces.Discrete(a) for ag in self.possible_agents}
        self._seeds: np.random.SeedSequence | None = None
        self._loop = None
        self._n_stages = 0
        self._expert_stage, self._expert_actions = -1, None

    # ----------------------------------------------------------------- spaces
    def observation_space(self, agent: str):
        """The observation space of ``agent`` (the same object every call)."""
        return self._obs_spaces[agent]

    def action_space(self, agent: str):
        """The action space of ``agent`` (the same object every call)."""
        return self._act_spaces[agent]

    # ----------------------------------------------------------------- episode
    def reset(self, seed: int | None = None, options: dict | None = None):
        """Start an episode (see the module docstring for seeding); returns the observations
        and infos of every robot."""
        from swarmgames.sim.runner import build_loop

        if seed is not None:
            self._seeds = np.random.SeedSequence(int(seed))
            episode = int(seed)
        else:
            if self._seeds is None:
                self._seeds = np.random.SeedSequence(int(self.config.seed))
                episode = int(self.config.seed)
            else:
                episode = int(self._seeds.spawn(1)[0].generate_state(1, np.uint32)[0])
        config = self.config.with_overrides({"seed": episode})
        states, loop, n_stages = build_loop(config, self.mission, None)
        loop.start(states)
        self._loop, self._n_stages = loop, n_stages
        self._expert_stage, self._expert_actions = -1, None
        self._expert = loop.controller  # the run's controller: the game's (or a baseline)
        self.agents = list(self.possible_agents)
        self._alive = np.ones(self.n_robots, dtype=bool)
        view = loop.observe()
        return self._observations(view), self._infos(view)

    def step(self, actions: dict[str, int]):
        """Apply every live agent's action for one stage; returns observations, rewards,
        terminations, truncations and infos of the agents that were live."""
        if self._loop is None:
            raise RuntimeError("call reset() before step()")
        if not self.agents:
            return {}, {}, {}, {}, {}
        loop, view = self._loop, self._loop.observe()
        mask = self._masks(view)
        chosen = np.argmax(mask, axis=1)  # the first allowed action, for robots not given one
        given = np.zeros(self.n_robots, dtype=bool)
        for agent, action in actions.items():
            i = self._index(agent)
            if not self._alive[i]:
                continue
            chosen[i] = int(action)
            given[i] = True
        if ((chosen < 0) | (chosen >= self.n_actions)).any():
            bad = int(np.flatnonzero((chosen < 0) | (chosen >= self.n_actions))[0])
            raise ValueError(f"action of uav_{bad} must be in [0, {self.n_actions})")
        replaced = ~mask[np.arange(self.n_robots), chosen]
        chosen = np.where(replaced, np.argmax(mask, axis=1), chosen)
        record = loop.act(self._expert.measure(self._expert.problem(*view.problem_fields), chosen))
        live = list(self.agents)
        rewards = self._rewards(record, live)
        done = loop.stage >= self._n_stages
        alive_next = self._loop.faults.alive(self.stage_time)
        terminations = {a: bool(not alive_next[self._index(a)]) for a in live}
        truncations = {a: bool(done and not terminations[a]) for a in live}
        self._alive &= alive_next
        self.agents = [a for a in live if not (terminations[a] or truncations[a])]
        if done:
            obs = {a: self._empty_obs() for a in live}
            infos = {a: {"action_mask": np.ones(self.n_actions, dtype=np.int8)} for a in live}
        else:
            view = loop.observe()
            obs_all, infos_all = self._observations(view, live), self._infos(view, live)
            obs = {a: obs_all[a] for a in live}
            infos = {a: infos_all[a] for a in live}
        for a in live:
            i = self._index(a)
            infos[a]["replaced"] = bool(replaced[i] and given[i])
        return obs, rewards, terminations, truncations, infos

    def expert_actions(self) -> dict[str, int]:
        """The game controller's action for every live agent at the current observations:
        their local games built from their inboxes and solved as :func:`swarmgames.run`
        solves them, with the game's own random generator, which nothing else in the
        environment draws from. An episode that takes these actions at every step is
        therefore the run :func:`swarmgames.run` makes of the same scenario and seed; asking
        changes nothing else (the answer is kept for the stage)."""
        if self._loop is None:
            raise RuntimeError("call reset() before expert_actions()")
        loop = self._loop
        if self._expert_stage != loop.stage:
            view = loop.observe()
            dec = self._expert.decide(self._expert.problem(*view.problem_fields), loop.rng)
            self._expert_actions, self._expert_stage = np.asarray(dec.actions), loop.stage
        return {a: int(self._expert_actions[self._index(a)]) for a in self.agents}

    def render(self):
        """The current stage as an RGB array (H, W, 3), like a frame of animation.gif
        (``render_mode="rgb_array"``; None otherwise)."""
        if self.render_mode != "rgb_array" or self._loop is None:
            return None
        from swarmgames.sim.animation import draw_frame
        from swarmgames.sim.loop import swarm_graph_stats

        loop = self._loop
        edges = swarm_graph_stats(loop.observe().snapshot)[3]
        t = self.stage_time
        alive = loop.faults.alive(t)
        radio = loop.faults.radio(t, loop.states)
        return draw_frame(self.mission, loop.states[:, :2], edges, alive, radio, t)

    def close(self) -> None:
        """Release the run (a network backend such as ns-3 is closed)."""
        loop, self._loop = self._loop, None
        closer = getattr(getattr(loop, "provider", None), "close", None)
        if closer is not None:
            closer()

    @property
    def stage_time(self) -> float:
        """The time of the stage the agents observe now, seconds: the network's warm-up, then
        one control period a step (the ``t`` a mission's metrics and potentials see)."""
        if self._loop is None:
            raise RuntimeError("call reset() before stage_time")
        loop = self._loop
        return loop.warmup_s + loop.stage * loop.period_s

    def state(self) -> np.ndarray:
        """The true states of every robot, (N, D) (PettingZoo's global state)."""
        if self._loop is None:
            raise RuntimeError("call reset() before state()")
        return np.array(self._loop.states)

    # ----------------------------------------------------------------- helpers
    def _index(self, agent: str) -> int:
        try:
            return self.possible_agents.index(agent)
        except ValueError:
            raise KeyError(f"unknown agent {agent!r}") from None

    def _masks(self, view) -> np.ndarray:
        from swarmgames.game.actions import action_mask_of

        return action_mask_of(self.mission.action_model, view.states)

    def _infos(self, view, agents=None) -> dict[str, dict]:
        mask = self._masks(view).astype(np.int8)
        agents = self.agents if agents is None else agents
        return {a: {"action_mask": mask[self._index(a)]} for a in agents}

    def _empty_obs(self) -> dict[str, np.ndarray] | np.ndarray:
        k, d = self.k, self.state_dim
        empty = {
            "self": np.zeros(d),
            "neighbours": np.zeros((k, d)),
            "ids": np.full(k, -1, dtype=np.int64),
            "age": np.zeros(k),
            "hops": np.zeros(k, dtype=np.int64),
            "mask": np.zeros(k, dtype=np.int8),
        }
        return _flatten(empty) if self.flat else empty

    def _observations(self, view, agents=None) -> dict[str, dict]:
        """Every agent's observation from the stage's messages (vectorised over robots)."""
        n, k = self.n_robots, self.k
        inbox = view.messages
        views = inbox.views()
        if inbox.exact:  # ideal delivery: the exact states, age 0
            age = np.zeros(views.members.shape)
        else:
            from swarmgames.game.local import pad_rows

            entry = pad_rows(inbox.indptr, np.arange(inbox.member.size), np.arange(n))
            age = np.where(entry >= 0, inbox.age[np.maximum(entry, 0)], 0.0)
        members = np.asarray(views.members[:, 1:], dtype=np.int64)  # column 0 is the owner
        valid = np.asarray(views.mask[:, 1:], dtype=bool)
        states = np.asarray(views.states[:, 1:], dtype=float)
        age = np.asarray(age[:, 1:], dtype=float)
        hops = _hops(view.snapshot, members, valid)
        # Keep the K nearest in hops, then the lowest ids; padding last.
        take = np.argsort(
            np.where(valid, hops, np.iinfo(np.int32).max) * (n + 1) + np.where(valid, members, n),
            axis=1,
            kind="stable",
        )[:, :k]
        rows = np.arange(n)[:, None]
        members, valid = members[rows, take], valid[rows, take]
        states, age, hops = states[rows, take], age[rows, take], hops[rows, take]
        width = members.shape[1]
        pad = k - width
        if pad > 0:
            members = np.pad(members, ((0, 0), (0, pad)), constant_values=-1)
            valid = np.pad(valid, ((0, 0), (0, pad)))
            states = np.pad(states, ((0, 0), (0, pad), (0, 0)))
            age = np.pad(age, ((0, 0), (0, pad)))
            hops = np.pad(hops, ((0, 0), (0, pad)))
        own = np.asarray(view.states, dtype=float)
        agents = self.agents if agents is None else agents
        out = {}
        for a in agents:
            i = self._index(a)
            ok = valid[i]
            out[a] = {
                "self": own[i].copy(),
                "neighbours": np.where(ok[:, None], states[i], 0.0),
                "ids": np.where(ok, members[i], -1).astype(np.int64),
                "age": np.where(ok, age[i], 0.0),
                "hops": np.where(ok, hops[i], 0).astype(np.int64),
                "mask": ok.astype(np.int8),
            }
            if self.flat:
                out[a] = _flatten(out[a])
        return out

    def _rewards(self, record, live) -> dict[str, float]:
        if self.reward_kind == "payoff":
            pay = record.robot["payoff"]
            return {a: float(np.nan_to_num(pay[self._index(a)])) for a in live}
        names = [k for k in record.swarm if k not in _LOOP_COLUMNS]
        value = float(record.swarm[names[0]]) if names else 0.0
        share = value / max(1, int(record.robot["alive"].sum()))
        return dict.fromkeys(live, share)


#: swarm.csv columns that the loop writes, not the mission (SWARM_HEAD and NETWORK_COLUMNS).
_LOOP_COLUMNS = frozenset((*SWARM_HEAD, *NETWORK_COLUMNS))


def _flatten(obs: dict[str, np.ndarray]) -> np.ndarray:
    """The ``observation="flat"`` vector of a ``Dict`` observation."""
    parts = ("self", "neighbours", "ids", "age", "hops", "mask")
    return np.concatenate([np.asarray(obs[p], dtype=np.float64).ravel() for p in parts])


def _hops(snapshot, members: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Hop count of every (owner, member) pair in the owner's routing table, (N, K')."""
    n = snapshot.n_robots
    keys = snapshot.owner.astype(np.int64) * n + snapshot.dest  # sorted: the snapshot's order
    out = np.zeros(members.shape, dtype=np.int64)
    if keys.size == 0:
        return out
    want = np.arange(members.shape[0])[:, None] * n + np.where(valid, members, 0)
    idx = np.minimum(np.searchsorted(keys, want), keys.size - 1)
    found = valid & (keys[idx] == want)
    out[found] = snapshot.hops[idx[found]]
    return out
