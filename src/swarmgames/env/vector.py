"""E swarms stepped together: a Gymnasium vector environment whose agents are the robots.

Every env is one run of the scenario (:func:`swarmgames.run`), with its own network, its own
communication model, its own faults and its own random streams; what the E envs share is the
work of a step. One step gathers the E swarms' routing tables and inboxes side by side
(:meth:`~swarmgames.topology.TopologySnapshot.concat`) into one
:class:`~swarmgames.game.problem.StageProblem` of E × N robots
(``swarms = E``: no game joins two envs, each env draws from its own Generator), so the
payoffs of every robot, and the expert's actions, cost one stage call for all envs.

Shapes (E envs, N robots, A actions, K neighbour rows, D state columns):

``actions``
    int (E, N): robot i of env e takes action ``actions[e, i]`` (``Discrete(A)`` each; an
    action its mask forbids is replaced by the first allowed one, ``stay`` for the UAV
    motion models, and ``info["replaced"]`` says so).
``obs``
    ``observation="dict"``: a dict of arrays with leading axes (E, N): ``self`` (D),
    ``neighbours`` (K, D), ``ids`` (K), ``age`` (K), ``hops`` (K), ``mask`` (K) and, with
    ``mask_in_obs``, ``action_mask`` (A); ``observation="flat"``: one float64 array
    (E, N, F), the same values in that order.
``rewards``, ``terminations``, ``truncations``
    (E, N).
``info``
    ``action_mask`` (E, N, A) int8, ``alive`` (E, N) bool, ``replaced`` (E, N) bool,
    ``stage_time`` (E,) seconds; after an episode ends, ``final_obs`` and ``final_info``
    (object arrays of E entries, with ``_final_obs``/``_final_info`` saying which hold one);
    with ``measure=True``, ``records``: every env's
    :class:`~swarmgames.sim.loop.StageRecord` (the rows ``metrics.csv`` and ``swarm.csv``
    would hold: payoffs, regrets, information age, bytes, coverage).

Observation of robot i, what it has at its decision:

``self``
    Its own state (metres; positions are not bounded by the space: the action mask keeps
    the robots in the mission's arena).
``neighbours``, ``ids``
    The states it uses for the other members of its neighbourhood N_i(h) (the last it heard
    from each, or the exact ones with ideal delivery) and their robot ids within the env
    (-1 padded). K is ``max_neighbours`` (default N - 1); a robot that knows more keeps the
    nearest in hops, then the lowest ids.
``age``
    The age of each state, seconds, in [0, ``comms.max_age_s``] (older messages are
    dropped; 0 with ideal delivery).
``hops``
    Their hop counts in robot i's own routing table, in [0, h] (members of N_i(h) lie within
    h hops; 0 on padding).
``mask``
    Which rows hold a neighbour.

A robot that has crashed (``[faults]``) terminates at the step it crashes; until its env
resets, its observation rows are zeros, its reward 0, its action ignored and
``info["alive"]`` false. An env whose scenario duration is reached truncates its robots
alive; an env ends when every robot has terminated or been truncated and, by default,
resets itself in the same step (Gymnasium's ``AutoresetMode.SAME_STEP``): the observation
returned is the new episode's first, and the true final observation is
``info["final_obs"][e]``.

Rewards (``reward``), all computed from what the step simulated:

``"difference"`` (the default)
    The team metric minus the metric of the same states with robot i at the state it held
    before the step (its move undone): robot i's own contribution, D_i = G(z) − G(z_{−i})
    (the mission's ``moves_undone`` hook gives every G(z_{−i}) at once where it has one).
    It trains PPO to the best coverage of the three (docs/env.md).
``"payoff"``
    Robot i's payoff M_i (eq. 1) in its true local game (actual states, N_i(h) from its
    routing table, no virtual means) at the joint action: the ``payoff`` column of
    ``metrics.csv``, to float32 rounding of the integral.
``"team"``
    The mission's first swarm metric (coverage, dBm, for the coverage mission) of the states
    the step reached, the same for every robot of the env.

Seeding: ``reset(seed=s)`` runs env e with ``seed = s + e`` (Gymnasium's convention; a list
gives each env its own), every draw of :func:`swarmgames.run` from it; ``reset()`` without a
seed, and every autoreset, starts the env's next episode from the generator its last seed
started. The same seeds give the same rollouts on any thread count.

References
----------
.. [1] M. Towers et al., "Gymnasium: A Standard Interface for Reinforcement Learning
   Environments", 2024 (the vector API and its autoreset modes).
.. [2] D. H. Wolpert and K. Tumer, "Optimal payoff functions for members of collectives",
   Advances in Complex Systems 4, 2001 (the difference reward).
.. [3] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, eq. 1 and section IV.
"""

from __future__ import annotations

import time
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv

from swarmgames.missions.protocol import NETWORK_COLUMNS, SWARM_HEAD

__all__ = ["OBSERVATION_PARTS", "REWARDS", "TIMED_PARTS", "SwarmVectorEnv", "vector_env"]

#: Values of ``reward``.
REWARDS = ("difference", "payoff", "team")

#: The parts of a dict observation, in the order of the flat one.
OBSERVATION_PARTS = ("self", "neighbours", "ids", "age", "hops", "mask", "action_mask")

#: The parts of a step :attr:`SwarmVectorEnv.timings` splits its time into.
TIMED_PARTS = ("comms", "network", "reward", "observation", "expert", "reset")

#: The environment's own options (the rest of a factory's keywords are overrides).
ENV_OPTIONS = frozenset({"reward", "max_neighbours", "observation", "mask_in_obs", "measure"})


def vector_env(scenario: str = "coverage", num_envs: int = 1, **options: Any) -> SwarmVectorEnv:
    """A :class:`SwarmVectorEnv` of ``num_envs`` swarms of a built-in scenario (or TOML file).

    Parameters
    ----------
    scenario : str
        A built-in scenario name or a TOML file, as ``swarmgames run`` takes it.
    num_envs : int
        E, the swarms stepped together, >= 1.
    **options
        ``reward``, ``max_neighbours``, ``observation``, ``mask_in_obs``, ``measure``,
        ``autoreset``, ``render_mode`` (see :class:`SwarmVectorEnv`), and configuration
        overrides with ``__`` for the dots: ``swarm__n_robots=5`` is ``--set
        swarm.n_robots=5``.

    Examples
    --------
    >>> env = vector_env("coverage", 4, swarm__n_robots=3, sim__duration_s=2.0)  # doctest: +SKIP
    >>> obs, info = env.reset(seed=0)                                           # doctest: +SKIP
    >>> obs["self"].shape, info["action_mask"].shape                            # doctest: +SKIP
    ((4, 3, 3), (4, 3, 9))
    """
    config, kwargs = scenario_and_options(scenario, options, {"autoreset", "render_mode"})
    return SwarmVectorEnv(config, num_envs, **kwargs)


def scenario_and_options(scenario: str, options: dict, extra: set[str]) -> tuple[Any, dict]:
    """The scenario with the overrides among ``options`` applied, and the environment's own
    options (:data:`ENV_OPTIONS` and ``extra``)."""
    from swarmgames.config import resolve_scenario
    from swarmgames.config.io import toml_literal

    own = ENV_OPTIONS | extra
    kwargs = {k: options.pop(k) for k in list(options) if k in own}
    overrides = [f"{k.replace('__', '.')}={toml_literal(v)}" for k, v in options.items()]
    return resolve_scenario(scenario, overrides), kwargs


class SwarmVectorEnv(VectorEnv):
    """E swarms of a scenario as one Gymnasium vector environment (see the module docstring).

    Parameters
    ----------
    config : ScenarioConfig
    num_envs : int
        E, >= 1.
    reward : {"difference", "payoff", "team"}
        Default ``"difference"`` (module notes).
    max_neighbours : int, optional
        K, the rows of the ``neighbours`` observation (default N - 1, every other robot).
    observation : {"dict", "flat"}
    mask_in_obs : bool, default False
        Put each robot's action mask in its observation (``action_mask``, A values of 0 or
        1), for learners that mask invalid actions in the policy (maskable PPO).
    measure : bool, default False
        Measure every step as :func:`swarmgames.run` does (payoffs, local, global and
        ex-post regret, the mission's metrics, the network's) into ``info["records"]``;
        several times the cost of a step.
    autoreset : bool, default True
        Reset an env in the step its episode ends; False: an ended env stays ended (its
        rows zero, its robots done) until :meth:`reset`.
    render_mode : {"rgb_array", None}
    mission : Mission, optional
        A mission object instead of the one ``config.scenario`` names.

    Attributes
    ----------
    num_envs, n_robots, n_actions, state_dim, k : int
    single_observation_space, single_action_space : gymnasium.spaces.Space
        One env's: a ``Dict`` of (N, ...) boxes (or one (N, F) box) and ``MultiDiscrete``
        of N actions.
    observation_space, action_space : gymnasium.spaces.Space
        The batch of E.
    timings : dict of float
        Seconds spent since construction in each part of the steps: ``comms`` (the state
        messages exchanged), ``network`` (the robots moved and the network advanced, or with
        ``measure`` the whole recorded stage), ``reward``, ``observation`` (built from the
        inboxes and routing tables), ``expert`` and ``reset`` (episodes built).

    Raises
    ------
    ValueError
        An option out of its range, named with its value.
    """

    metadata: ClassVar[dict] = {
        "render_modes": ["rgb_array"],
        "autoreset_mode": AutoresetMode.SAME_STEP,
    }

    def __init__(
        self,
        config,
        num_envs: int = 1,
        *,
        reward: str = "difference",
        max_neighbours: int | None = None,
        observation: str = "dict",
        mask_in_obs: bool = False,
        measure: bool = False,
        autoreset: bool = True,
        render_mode: str | None = None,
        mission: Any = None,
    ) -> None:
        from swarmgames.sim.runner import build_mission

        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)):
            raise ValueError(f"num_envs must be an integer >= 1 (got {num_envs!r})")
        if num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1 (got {num_envs!r})")
        if reward not in REWARDS:
            raise ValueError(f"reward must be one of {', '.join(REWARDS)} (got {reward!r})")
        if observation not in ("dict", "flat"):
            raise ValueError(f"observation must be 'dict' or 'flat' (got {observation!r})")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be 'rgb_array' or None (got {render_mode!r})")
        self.config = config
        self.mission = build_mission(config) if mission is None else mission
        n = int(config.swarm.n_robots)
        if max_neighbours is not None and (
            isinstance(max_neighbours, bool) or int(max_neighbours) != max_neighbours
        ):
            raise ValueError(f"max_neighbours must be an integer >= 1 (got {max_neighbours!r})")
        if max_neighbours is not None and max_neighbours < 1:
            raise ValueError(f"max_neighbours must be an integer >= 1 (got {max_neighbours!r})")
        self.num_envs, self.n_robots = int(num_envs), n
        self.k = max(1, n - 1 if max_neighbours is None else int(max_neighbours))
        self.reward_kind, self.flat, self.mask_in_obs = (
            reward,
            observation == "flat",
            bool(mask_in_obs),
        )
        self.measure, self.autoreset, self.render_mode = bool(measure), bool(autoreset), render_mode
        self.state_dim = int(self.mission.state_dim)
        self.n_actions = int(self.mission.action_model.n_actions)
        self.hops = int(config.network.hops)
        from swarmgames.missions.protocol import MissionHooks

        self._moves_undone = MissionHooks.of(self.mission).moves_undone
        ideal = config.comms.model == "ideal"
        self.max_age_s = 0.0 if ideal else float(config.comms.max_age_s)
        self._build_spaces()
        self._seeds: list[np.random.SeedSequence | None] = [None] * self.num_envs
        self._loops: list[Any] = [None] * self.num_envs
        self._n_stages = 0
        self._alive = np.zeros((self.num_envs, n), dtype=bool)
        self._ended = np.zeros(self.num_envs, dtype=bool)
        self._expert_cache: tuple[int, np.ndarray] | None = None
        self._clock = 0  # counts steps and resets: what the stage caches are keyed by
        self.timings = dict.fromkeys(TIMED_PARTS, 0.0)
        from swarmgames.game.kept import RowTables

        self._kept = RowTables()

    # ------------------------------------------------------------------ spaces
    def _build_spaces(self) -> None:
        n, k, d, a = self.n_robots, self.k, self.state_dim, self.n_actions
        f64 = np.float64
        parts = {
            "self": gym.spaces.Box(-np.inf, np.inf, (n, d), f64),
            "neighbours": gym.spaces.Box(-np.inf, np.inf, (n, k, d), f64),
            "ids": gym.spaces.Box(-1, n - 1, (n, k), np.int64),
            "age": gym.spaces.Box(0.0, self.max_age_s, (n, k), f64),
            "hops": gym.spaces.Box(0, self.hops, (n, k), np.int64),
            "mask": gym.spaces.MultiBinary((n, k)),
        }
        if self.mask_in_obs:
            parts["action_mask"] = gym.spaces.MultiBinary((n, a))
        if self.flat:
            lows = [np.broadcast_to(s.low if hasattr(s, "low") else 0, s.shape).reshape(n, -1)
                    for s in parts.values()]  # fmt: skip
            highs = [
                np.broadcast_to(s.high if hasattr(s, "high") else 1, s.shape).reshape(n, -1)
                for s in parts.values()
            ]
            low = np.concatenate(lows, axis=1).astype(f64)
            high = np.concatenate(highs, axis=1).astype(f64)
            self.single_observation_space = gym.spaces.Box(low, high, dtype=f64)
        else:
            self.single_observation_space = gym.spaces.Dict(parts)
        self.single_action_space = gym.spaces.MultiDiscrete(np.full(n, a))
        self.observation_space = gym.vector.utils.batch_space(
            self.single_observation_space, self.num_envs
        )
        self.action_space = gym.spaces.MultiDiscrete(np.full((self.num_envs, n), a))

    @property
    def obs_size(self) -> int:
        """F, the length of a robot's flat observation: D + K D + 4 K (+ A with
        ``mask_in_obs``)."""
        k, d = self.k, self.state_dim
        return d + k * d + 4 * k + (self.n_actions if self.mask_in_obs else 0)

    # ------------------------------------------------------------------ episodes
    def reset(self, *, seed=None, options: dict | None = None):
        """Start a new episode in every env (see the module docstring for seeding); returns
        the observations and the info."""
        if seed is None:
            seeds = [None] * self.num_envs
        elif isinstance(seed, (list, tuple, np.ndarray)):
            if len(seed) != self.num_envs:
                raise ValueError(f"seed must hold {self.num_envs} seeds (got {len(seed)})")
            seeds = [int(s) for s in seed]
        else:
            seeds = [int(seed) + e for e in range(self.num_envs)]
        for e, s in enumerate(seeds):
            self._start(e, s)
        self._clock += 1
        obs, masks = self._observe_all()
        return obs, self._info(masks, np.zeros((self.num_envs, self.n_robots), bool))

    def _start(self, e: int, seed: int | None) -> None:
        """Env ``e``'s next episode: the run of ``seed``, or the next of its generator."""
        from swarmgames.sim.runner import build_loop

        t0 = time.perf_counter()
        if seed is not None:
            self._seeds[e] = np.random.SeedSequence(int(seed))
            episode = int(seed)
        elif self._seeds[e] is None:
            episode = int(self.config.seed) + e
            self._seeds[e] = np.random.SeedSequence(episode)
        else:
            episode = int(self._seeds[e].spawn(1)[0].generate_state(1, np.uint32)[0])
        old = self._loops[e]
        if old is not None:
            _close(old)
        config = self.config.with_overrides({"seed": episode})
        states, loop, n_stages = build_loop(config, self.mission, None)
        loop.start(states)
        self._loops[e], self._n_stages = loop, n_stages
        self._alive[e] = loop.faults.alive(self._time(loop))
        self._ended[e] = False
        self.timings["reset"] += time.perf_counter() - t0

    def step(self, actions):
        """One control period in every env (see the module docstring)."""
        if any(loop is None for loop in self._loops):
            raise RuntimeError("call reset() before step()")
        e_n = (self.num_envs, self.n_robots)
        acts = np.asarray(actions)
        if acts.shape != e_n or not np.issubdtype(acts.dtype, np.integer):
            raise ValueError(f"actions must be an integer array of shape {e_n} (got {acts.shape})")
        if ((acts < 0) | (acts >= self.n_actions)).any():
            e, i = np.argwhere((acts < 0) | (acts >= self.n_actions))[0]
            raise ValueError(
                f"actions[{e}, {i}] must be in [0, {self.n_actions}) (got {int(acts[e, i])})"
            )
        views = [loop.observe() for loop in self._loops]
        states = np.stack([v.states for v in views])  # (E, N, D)
        masks = self._masks(states)
        first = np.argmax(masks, axis=2)
        live = self._alive & ~self._ended[:, None]
        chosen = np.where(live, acts, first).astype(np.int64)
        replaced = live & ~np.take_along_axis(masks, chosen[:, :, None], axis=2)[:, :, 0]
        chosen = np.where(replaced, first, chosen)
        nxt = np.asarray(self.mission.action_model.apply(states))  # (E, N, A, D)
        nxt = np.take_along_axis(nxt, chosen[:, :, None, None], axis=2)[:, :, 0]
        rewards = np.zeros(e_n)
        t0 = time.perf_counter()
        if self.reward_kind == "payoff":
            rewards = np.nan_to_num(self._payoffs(views, chosen))
        t1 = time.perf_counter()
        records = []
        reached = np.empty_like(states)
        for e, loop in enumerate(self._loops):
            if self._ended[e]:
                reached[e] = states[e]
                continue
            if self.measure:
                ctrl = loop.controller
                problem = ctrl.problem(*views[e].problem_fields)
                record = loop.act(ctrl.measure(problem, chosen[e]))
                records.append(record)
                reached[e] = record.after
            else:
                reached[e] = loop.move(nxt[e])
        t2 = time.perf_counter()
        if self.reward_kind != "payoff":
            rewards = self._team_rewards(states, reached)
        self.timings["reward"] += t1 - t0 + time.perf_counter() - t2
        self.timings["network"] += t2 - t1
        rewards = np.where(live, rewards, 0.0)
        terminations = np.zeros(e_n, dtype=bool)
        truncations = np.zeros(e_n, dtype=bool)
        done_env = np.zeros(self.num_envs, dtype=bool)
        for e, loop in enumerate(self._loops):
            if self._ended[e]:
                continue
            alive_next = loop.faults.alive(self._time(loop))
            terminations[e] = live[e] & ~alive_next
            self._alive[e] &= alive_next
            if loop.stage >= self._n_stages:
                truncations[e] = self._alive[e]
            done_env[e] = loop.stage >= self._n_stages or not self._alive[e].any()
        self._clock += 1
        obs, masks = self._observe_all()
        info = self._info(masks, replaced)
        if self.measure:
            info["records"] = tuple(records)
        if done_env.any():
            info = self._end(done_env, obs, info)
            if self.autoreset:
                obs, masks = self._observe_all()
                info.update(self._info(masks, replaced))
        return obs, rewards, terminations, truncations, info

    def _end(self, done_env: np.ndarray, obs, info: dict) -> dict:
        """The ended envs' final observations and infos kept, and the envs reset (with
        ``autoreset``) or marked ended."""
        final_obs = np.full(self.num_envs, None, dtype=object)
        final_info = np.full(self.num_envs, None, dtype=object)
        for e in np.flatnonzero(done_env):
            final_obs[e] = _take(obs, e)
            final_info[e] = {
                key: val[e] for key, val in info.items() if isinstance(val, np.ndarray)
            }
            if self.autoreset:
                self._start(int(e), None)
            else:
                self._ended[e] = True
        self._clock += 1
        return {
            **info,
            "final_obs": final_obs,
            "_final_obs": done_env.copy(),
            "final_info": final_info,
            "_final_info": done_env.copy(),
        }

    # ------------------------------------------------------------------ the stage
    def stage_problem(self, envs=None, *, keep_games: bool = False):
        """The stage the envs ``envs`` (default: all, which must share one stage time)
        observe now, as one :class:`~swarmgames.game.problem.StageProblem` of their robots'
        local games side by side (``swarms`` = their number; no global regret measured);
        env ``envs[j]``'s robot i is robot ``j N + i``."""
        from swarmgames.topology import TopologySnapshot

        envs = list(range(self.num_envs)) if envs is None else [int(e) for e in envs]
        views = [self._loops[e].observe() for e in envs]
        times = {v.t for v in views}
        if len(times) != 1:
            raise ValueError(f"envs {envs} observe different stage times {sorted(times)}")
        inbox = views[0].messages
        if len(views) > 1:
            inbox = type(inbox).concat([v.messages for v in views])
        return self._loops[envs[0]].controller.problem(
            views[0].t,
            TopologySnapshot.concat([v.snapshot for v in views]),
            np.concatenate([v.states for v in views]),
            inbox,
            centralised=False,  # the robots' local games: a centralised solve is per env
            global_regret=False,
            keep_games=keep_games,
            kept=self._kept,
            swarms=len(views),
        )

    def _same_time_groups(self) -> list[list[int]]:
        """The envs that observe the same stage time, grouped (usually one group)."""
        groups: dict[float, list[int]] = {}
        for e, loop in enumerate(self._loops):
            if not self._ended[e]:
                groups.setdefault(self._time(loop), []).append(e)
        return list(groups.values())

    def _payoffs(self, views, chosen: np.ndarray) -> np.ndarray:
        """Every robot's payoff M_i at the joint action ``chosen`` (E, N): one profile
        evaluation per group of envs at one stage time."""
        from swarmgames.game.stage import profile_payoffs

        out = np.zeros(chosen.shape)
        for envs in self._same_time_groups():
            problem = self.stage_problem(envs)
            out[envs] = profile_payoffs(problem, chosen[envs].reshape(-1)).reshape(len(envs), -1)
        return out

    def _team_rewards(self, before: np.ndarray, reached: np.ndarray) -> np.ndarray:
        """The team metric of the states reached (``"team"``), or each robot's difference
        reward against its move undone (``"difference"``), (E, N)."""
        out = np.zeros((self.num_envs, self.n_robots))
        for e, loop in enumerate(self._loops):
            if self._ended[e]:
                continue
            alive, t = self._alive[e], self._time(loop)
            if not alive.any():
                continue
            team = self._metric(reached[e][alive], before[e][alive], t)
            if self.reward_kind == "team":
                out[e] = team
                continue
            undone = None
            if self._moves_undone is not None:
                undone = self._moves_undone(reached[e][alive], before[e][alive], t)
            if undone is not None:
                out[e, alive] = team - np.asarray(undone, dtype=float)
                continue
            for i in np.flatnonzero(alive):
                undone = reached[e].copy()
                undone[i] = before[e][i]
                out[e, i] = team - self._metric(undone[alive], before[e][alive], t)
        return out

    def _metric(self, states: np.ndarray, previous: np.ndarray, t: float) -> float:
        """The mission's first swarm metric of ``states``."""
        measured = self.mission.swarm_metrics(states, previous, t)
        names = [k for k in measured if k not in _LOOP_COLUMNS]
        return float(measured[names[0]]) if names else 0.0

    # ------------------------------------------------------------------ expert
    def expert_actions(self) -> np.ndarray:
        """The actions the scenario's controller takes on the current inboxes, (E, N): the
        game controller solves every env's local games in one stage call (per group of envs
        at one stage time), each env with its own game Generator, which nothing else in the
        environment draws from; an env stepped with these actions is the run
        :func:`swarmgames.run` makes of its seed. Asked twice at one step, the answer is
        kept."""
        if any(loop is None for loop in self._loops):
            raise RuntimeError("call reset() before expert_actions()")
        if self._expert_cache is not None and self._expert_cache[0] == self._clock:
            return self._expert_cache[1].copy()
        t0 = time.perf_counter()
        out = np.zeros((self.num_envs, self.n_robots), dtype=np.int64)
        stacked = self.config.sim.controller == "game" and self.config.game.solver != "centralised"
        for envs in self._same_time_groups():
            if stacked:
                from swarmgames.game.stage import solve

                problem = self.stage_problem(envs)
                dec = solve(problem, [self._loops[e].rng for e in envs])
                out[envs] = np.asarray(dec.actions).reshape(len(envs), -1)
                continue
            for e in envs:
                loop = self._loops[e]
                loop.controller.plan(loop)
                view = loop.observe()
                problem = loop.controller.problem(*view.problem_fields)
                out[e] = loop.controller.decide(problem, loop.rng).actions
        self._expert_cache = (self._clock, out)
        self.timings["expert"] += time.perf_counter() - t0
        return out.copy()

    # ------------------------------------------------------------------ observations
    def _masks(self, states: np.ndarray) -> np.ndarray:
        from swarmgames.game.actions import action_mask_of

        return action_mask_of(self.mission.action_model, states)

    def _observe_all(self):
        """Every env's observation arrays (E, N, ...) and action masks (E, N, A)."""
        t0 = time.perf_counter()
        views = [loop.observe() for loop in self._loops]
        t1 = time.perf_counter()
        self.timings["comms"] += t1 - t0
        try:
            return self._observation_of(views)
        finally:
            self.timings["observation"] += time.perf_counter() - t1

    def _observation_of(self, views):
        """The observations and action masks of the stages ``views`` of every env."""
        states = np.stack([v.states for v in views])
        masks = self._masks(states)
        parts = self._observation_parts(views, states)
        parts["mask"] = parts["mask"] & (self._alive & ~self._ended[:, None])[:, :, None]
        off = ~(self._alive & ~self._ended[:, None])
        for name in ("self", "neighbours", "age"):
            parts[name] = np.where(_expand(off, parts[name]), 0.0, parts[name])
        for name in ("ids", "hops"):
            fill = -1 if name == "ids" else 0
            parts[name] = np.where(_expand(off, parts[name]), fill, parts[name])
        parts["mask"] = parts["mask"].astype(np.int8)
        if self.mask_in_obs:
            parts["action_mask"] = np.where(off[:, :, None], 0, masks).astype(np.int8)
        if self.flat:
            e, n = off.shape
            return np.concatenate(
                [np.asarray(parts[p], np.float64).reshape(e, n, -1) for p in parts], axis=2
            ), masks
        return parts, masks

    def _observation_parts(self, views, states: np.ndarray) -> dict[str, np.ndarray]:
        """The observation of every robot of every env from its inbox and routing table,
        vectorised over all E × N robots."""
        from swarmgames.game.local import pad_rows
        from swarmgames.topology import TopologySnapshot

        e_count, n, k = self.num_envs, self.n_robots, self.k
        inbox = views[0].messages
        if e_count > 1:
            inbox = type(inbox).concat([v.messages for v in views])
        snap = views[0].snapshot
        if e_count > 1:  # the envs' clocks may differ: hop counts do not depend on them
            snap = TopologySnapshot.concat([v.snapshot for v in views], time=0.0)
        total = e_count * n
        lv = inbox.views()
        if inbox.exact:  # ideal delivery: the exact states, age 0
            age = np.zeros(lv.members.shape)
        else:
            entry = pad_rows(inbox.indptr, np.arange(inbox.member.size), np.arange(total))
            age = np.where(entry >= 0, inbox.age[np.maximum(entry, 0)], 0.0)
        members = np.asarray(lv.members[:, 1:], dtype=np.int64)  # column 0 is the owner
        valid = np.asarray(lv.mask[:, 1:], dtype=bool)
        nb_states = np.asarray(lv.states[:, 1:], dtype=float)
        age = np.minimum(np.asarray(age[:, 1:], dtype=float), self.max_age_s)
        hops = np.minimum(_hops(snap, members, valid), self.hops)
        # Keep the K nearest in hops, then the lowest ids; padding last.
        take = np.argsort(
            np.where(valid, hops, self.hops + 1) * (total + 1) + np.where(valid, members, total),
            axis=1,
            kind="stable",
        )[:, :k]
        rows = np.arange(total)[:, None]
        members, valid = members[rows, take], valid[rows, take]
        nb_states, age, hops = nb_states[rows, take], age[rows, take], hops[rows, take]
        pad = k - members.shape[1]
        if pad > 0:
            members = np.pad(members, ((0, 0), (0, pad)), constant_values=-1)
            valid = np.pad(valid, ((0, 0), (0, pad)))
            nb_states = np.pad(nb_states, ((0, 0), (0, pad), (0, 0)))
            age = np.pad(age, ((0, 0), (0, pad)))
            hops = np.pad(hops, ((0, 0), (0, pad)))
        local = members - (np.arange(total) // n * n)[:, None]  # ids within the env
        d = self.state_dim
        return {
            "self": np.array(states, dtype=float),
            "neighbours": np.where(valid[:, :, None], nb_states, 0.0).reshape(e_count, n, k, d),
            "ids": np.where(valid, local, -1).reshape(e_count, n, k),
            "age": np.where(valid, age, 0.0).reshape(e_count, n, k),
            "hops": np.where(valid, hops, 0).reshape(e_count, n, k),
            "mask": valid.reshape(e_count, n, k),
        }

    def _info(self, masks: np.ndarray, replaced: np.ndarray) -> dict:
        live = self._alive & ~self._ended[:, None]
        return {
            "action_mask": np.where(live[:, :, None], masks, 0).astype(np.int8),
            "alive": live.copy(),
            "replaced": np.asarray(replaced, dtype=bool),
            "stage_time": np.array([self._time(loop) for loop in self._loops]),
        }

    # ------------------------------------------------------------------ the rest
    @staticmethod
    def _time(loop) -> float:
        return loop.warmup_s + loop.stage * loop.period_s

    @property
    def stage_times(self) -> np.ndarray:
        """Every env's stage time now, seconds (E,)."""
        return np.array([self._time(loop) for loop in self._loops])

    def state(self) -> np.ndarray:
        """The true states of every robot, (E, N, D)."""
        if any(loop is None for loop in self._loops):
            raise RuntimeError("call reset() before state()")
        return np.stack([np.array(loop.states) for loop in self._loops])

    def env_loop(self, e: int):
        """Env ``e``'s :class:`~swarmgames.sim.loop.StageLoop` (its network, comms, faults and
        random streams), for inspection."""
        return self._loops[int(e)]

    def render(self):
        """Every env's current stage as an RGB array (H, W, 3), a tuple of E, like a frame of
        animation.gif (``render_mode="rgb_array"``; None otherwise)."""
        if self.render_mode != "rgb_array" or any(loop is None for loop in self._loops):
            return None
        from swarmgames.sim.animation import draw_frame
        from swarmgames.sim.loop import swarm_graph_stats

        frames = []
        for loop in self._loops:
            edges = swarm_graph_stats(loop.observe().snapshot)[3]
            t = self._time(loop)
            alive, radio = loop.faults.alive(t), loop.faults.radio(t, loop.states)
            frames.append(draw_frame(self.mission, loop.states[:, :2], edges, alive, radio, t))
        return tuple(frames)

    def close(self, **kwargs) -> None:
        """Release every env's run (a network backend such as ns-3 is closed)."""
        for e, loop in enumerate(self._loops):
            if loop is not None:
                _close(loop)
            self._loops[e] = None


#: swarm.csv columns that the loop writes, not the mission (SWARM_HEAD and NETWORK_COLUMNS).
_LOOP_COLUMNS = frozenset((*SWARM_HEAD, *NETWORK_COLUMNS))


def _close(loop) -> None:
    closer = getattr(loop.provider, "close", None)
    if closer is not None:
        closer()


def _expand(mask: np.ndarray, like: np.ndarray) -> np.ndarray:
    """``mask`` (E, N) broadcast to the shape of ``like`` (E, N, ...)."""
    return mask.reshape(mask.shape + (1,) * (like.ndim - 2))


def _take(obs, e: int):
    """Env ``e``'s rows of a batch of observations (copies)."""
    if isinstance(obs, dict):
        return {key: np.array(val[e]) for key, val in obs.items()}
    return np.array(obs[e])


def _hops(snapshot, members: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Hop count of every (owner, member) pair in the owner's routing table, (R, K')."""
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
