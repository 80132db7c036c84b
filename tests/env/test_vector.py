"""The vector environment: Gymnasium's vector API with the agents on a second axis, E swarms
in one stage problem, autoreset with the true final observation, seeding, masks, rewards
against hand computations, and the PettingZoo env as its E = 1 case."""

import os
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason='pip install "swarmgames[env]"')

from swarmgames.env import parallel_env, vector_env
from swarmgames.game.stage import measure_stage, solve

SMALL = {"swarm__n_robots": 5, "sim__duration_s": 4.0, "sim__warmup_s": 3.0}


def _venv(e=3, **extra):
    return vector_env("coverage", e, **{**SMALL, **extra})


def _random_actions(rng, info):
    mask = info["action_mask"].astype(bool)
    return np.argmax(rng.random(mask.shape) * mask, axis=2)


def _rollout(env, seed, steps, action_seed=0):
    rng = np.random.default_rng(action_seed)
    obs, info = env.reset(seed=seed)
    out = [obs]
    for _ in range(steps):
        obs, rew, term, trunc, info = env.step(_random_actions(rng, info))
        out.append((obs, rew, term, trunc, info.get("_final_obs")))
    return out


def test_shapes_and_spaces_hold_every_step():
    env = _venv(max_neighbours=3, mask_in_obs=True)
    obs, info = env.reset(seed=0)
    e, n, k, a = 3, 5, 3, env.n_actions
    assert obs["self"].shape == (e, n, 3) and obs["neighbours"].shape == (e, n, k, 3)
    assert obs["action_mask"].shape == (e, n, a) and info["action_mask"].shape == (e, n, a)
    assert env.observation_space.contains(obs)
    # Bounded spaces: hops within the horizon h, ages within the messages' lifetime.
    space = env.single_observation_space
    assert space["hops"].high.max() == env.config.network.hops
    assert space["age"].high.max() == env.config.comms.max_age_s
    rng = np.random.default_rng(1)
    for _ in range(6):  # past the end of the 4-stage episodes: autoreset included
        obs, rew, term, trunc, info = env.step(_random_actions(rng, info))
        assert rew.shape == term.shape == trunc.shape == (e, n)
        assert env.observation_space.contains(obs)
        np.testing.assert_array_equal(obs["action_mask"], info["action_mask"])


def test_e1_is_the_parallel_env():
    vec = _venv(1)
    par = parallel_env("coverage", **SMALL)
    rng = np.random.default_rng(3)
    obs_v, info = vec.reset(seed=11)
    obs_p, _ = par.reset(seed=11)
    for _ in range(4):
        for i, agent in enumerate(par.possible_agents):
            for part in obs_p[agent]:
                np.testing.assert_array_equal(obs_v[part][0, i], obs_p[agent][part])
        acts = _random_actions(rng, info)
        obs_v, rew_v, _term_v, trunc_v, info = vec.step(acts)
        obs_p, rew_p, _term_p, _trunc_p, _ = par.step(
            {a: int(acts[0, i]) for i, a in enumerate(par.possible_agents)}
        )
        assert [rew_p[a] for a in par.possible_agents] == rew_v[0].tolist()
        if trunc_v.any():  # the parallel env returns the true final observation
            final = info["final_obs"][0]
            for i, agent in enumerate(par.possible_agents):
                np.testing.assert_array_equal(final["self"][i], obs_p[agent]["self"])
    assert not par.agents


def test_autoreset_keeps_the_final_observation_and_starts_the_next_episode():
    env = _venv(2)
    steps = _rollout(env, 5, 4)
    obs, _rew, term, trunc, ended = steps[-1]
    assert trunc.all() and not term.any() and ended.all()
    # The returned observation is the next episode's first: every env back at stage 0.
    assert (env.stage_times == env.config.sim.warmup_s).all()
    # The final one is where the last step took the robots, as the parallel env shows it.
    par = parallel_env("coverage", **SMALL)
    par.reset(seed=5)
    rng = np.random.default_rng(0)
    _, info = env.reset(seed=5)
    final = None
    while par.agents:
        acts = _random_actions(rng, info)
        _, _, _, _, info = env.step(acts)
        got, *_ = par.step({a: int(acts[0, i]) for i, a in enumerate(par.possible_agents)})
        final = info.get("final_obs")
    np.testing.assert_array_equal(final[0]["self"][2], got["uav_2"]["self"])
    assert not np.array_equal(final[0]["self"], obs["self"][0])


def test_same_seed_same_rollouts_other_seeds_differ():
    a, b, c = (_rollout(_venv(), s, 5) for s in (4, 4, 9))
    for x, y in zip(a[1:], b[1:], strict=True):
        np.testing.assert_array_equal(x[0]["neighbours"], y[0]["neighbours"])
        np.testing.assert_array_equal(x[1], y[1])
    assert not np.array_equal(a[1][0]["self"], c[1][0]["self"])
    # Env e runs seed s + e: env 1 of seed 4 is env 0 of seed 5.
    d = _rollout(_venv(1), 5, 1)
    np.testing.assert_array_equal(a[0]["self"][1], d[0]["self"][0])


_THREADS = """
import numpy as np
from swarmgames.env import vector_env
env = vector_env("coverage", 2, swarm__n_robots=4, sim__duration_s=3.0, sim__warmup_s=3.0)
obs, info = env.reset(seed=3)
rng = np.random.default_rng(0)
total = 0.0
for _ in range(3):
    mask = info["action_mask"].astype(bool)
    obs, rew, term, trunc, info = env.step(np.argmax(rng.random(mask.shape) * mask, axis=2))
    total += rew.sum()
expert = env.expert_actions()
print(repr(float(total)), obs["self"].tobytes().hex()[:64], expert.tolist())
"""


def test_same_rollouts_on_any_thread_count():
    outs = []
    for threads in ("1", "2"):
        env = {**os.environ, "NUMBA_NUM_THREADS": threads, "OMP_NUM_THREADS": threads}
        done = subprocess.run(
            [sys.executable, "-c", _THREADS], env=env, capture_output=True, text=True, check=True
        )
        outs.append(done.stdout)
    assert outs[0] == outs[1]


def test_forbidden_actions_are_replaced_by_stay_and_said_so(monkeypatch):
    env = _venv(2)
    _, info = env.reset(seed=0)
    allowed = np.ones((2, 5, env.n_actions), dtype=bool)
    allowed[:, :, 4] = False
    monkeypatch.setattr(env, "_masks", lambda states: allowed)
    before = env.state()
    acts = np.zeros((2, 5), dtype=np.int64)
    acts[1, 2] = 4
    _, _, _, _, info = env.step(acts)
    assert info["replaced"].tolist() == [[False] * 5, [False, False, True, False, False]]
    np.testing.assert_array_equal(env.state()[1, 2], before[1, 2])


def test_one_stage_problem_holds_every_env_and_the_expert_is_each_envs_controller():
    env = _venv(3)
    env.reset(seed=2)
    problem = env.stage_problem()
    assert problem.swarms == 3 and problem.n_robots == 15
    expert = env.expert_actions()
    for e in range(3):
        loop = env.env_loop(e)
        own = loop.controller.problem(*loop.observe().problem_fields)
        np.testing.assert_array_equal(solve(own, 0).actions, expert[e])
    np.testing.assert_array_equal(env.expert_actions(), expert)  # asked twice: kept


def _eq1_payoffs(problem, actions):
    """Eq. 1 summed by hand from the true local games' full tables: α_a Σ_k φ_u(k, x_k) +
    α_b Σ_{k<l} (φ_p(k, x_k, l, x_l) + φ_p(l, x_l, k, x_k))."""
    from swarmgames.game.local import local_games

    batch = local_games(problem.snapshot, problem.h, problem.states, problem.action_model)
    pot, solver = problem.potentials, problem.solver
    unary = pot.unary(batch)
    pair = pot.pair_table(batch, np.float64)
    out = np.zeros(problem.n_robots)
    for b in range(batch.members.shape[0]):
        ks = np.flatnonzero(batch.mask[b])
        x = actions[batch.members[b, ks]]
        total = solver.alpha_a * sum(unary[b, k, xk] for k, xk in zip(ks, x, strict=True))
        for i, k in enumerate(ks):
            for j in range(i + 1, len(ks)):
                total += solver.alpha_b * pair[b, k, x[i], ks[j], x[j]]
        out[int(batch.owner[b])] = total
    return out


def test_payoff_reward_is_eq1_at_the_joint_action_on_three_robots():
    env = vector_env(
        "coverage", 1, reward="payoff", swarm__n_robots=3, sim__duration_s=3.0, comms__model="ideal"
    )
    _, info = env.reset(seed=0)
    rng = np.random.default_rng(5)
    for _ in range(2):
        problem = env.stage_problem()
        acts = _random_actions(rng, info)
        want = _eq1_payoffs(problem, acts[0])
        measured = measure_stage(problem, acts[0], expost=False).payoff
        _, rew, _, _, info = env.step(acts)
        np.testing.assert_allclose(rew[0], want, rtol=1e-6)
        np.testing.assert_allclose(rew[0], measured, rtol=1e-6)


def test_team_and_difference_rewards_by_hand_on_three_robots():
    kw = {"swarm__n_robots": 3, "sim__duration_s": 3.0}
    team, diff = (
        vector_env("coverage", 1, reward="team", **kw),
        vector_env("coverage", 1, reward="difference", **kw),
    )
    team.reset(seed=1)
    diff.reset(seed=1)
    mission = team.mission
    acts = np.array([[1, 3, 5]])
    before = team.state()[0].copy()
    _, r_team, *_ = team.step(acts)
    _, r_diff, *_ = diff.step(acts)
    after = team.state()[0]
    cover = mission.swarm_metrics(after, before, 0.0)["coverage"]
    assert r_team[0].tolist() == [cover] * 3
    for i in range(3):
        undone = after.copy()
        undone[i] = before[i]
        want = cover - mission.swarm_metrics(undone, before, 0.0)["coverage"]
        assert r_diff[0, i] == pytest.approx(want, abs=1e-12)


def test_a_crash_terminates_the_robot_and_zeroes_its_rows():
    env = _venv(2, sim__duration_s=5.0, faults__crash=[[4.0, 1]])
    _, info = env.reset(seed=0)
    rng = np.random.default_rng(0)
    _, _, term, _, info = env.step(_random_actions(rng, info))
    assert term[:, 1].all() and term.sum() == 2  # robot 1 of both envs, dead by t = 4 s
    obs, rew, term, _trunc, info = env.step(_random_actions(rng, info))
    assert not info["alive"][:, 1].any() and (rew[:, 1] == 0).all() and not term.any()
    assert (obs["self"][:, 1] == 0).all() and (obs["ids"][:, 1] == -1).all()
    # The others learn of it only as their routing tables and its messages' age tell them.


def test_one_robot_and_flat_observations():
    env = vector_env("coverage", 2, swarm__n_robots=1, sim__duration_s=3.0, observation="flat")
    obs, _info = env.reset(seed=0)
    assert obs.shape == (2, 1, env.obs_size) == (2, 1, 3 + 3 + 4)
    obs, rew, *_ = env.step(np.zeros((2, 1), dtype=np.int64))
    assert np.isfinite(rew).all() and env.observation_space.contains(obs)


def test_measure_gives_the_runs_records():
    env = _venv(2, measure=True, reward="payoff")
    _, info = env.reset(seed=0)
    _, rew, _, _, info = env.step(env.expert_actions())
    records = info["records"]
    assert len(records) == 2 and "global_regret" in records[0].robot
    np.testing.assert_allclose(rew[0], records[0].robot["payoff"], rtol=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"reward": "score"}, "reward must be one of difference, payoff, team"),
        ({"observation": "image"}, "observation must be"),
        ({"max_neighbours": 0}, "max_neighbours must be an integer >= 1"),
    ],
)
def test_bad_options_are_named(kwargs, match):
    with pytest.raises(ValueError, match=match):
        _venv(**kwargs)


def test_bad_actions_are_named():
    env = _venv(2)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros((2, 5), dtype=int))
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions must be an integer array of shape \(2, 5\)"):
        env.step(np.zeros(5, dtype=int))
    bad = np.zeros((2, 5), dtype=int)
    bad[1, 3] = 99
    with pytest.raises(ValueError, match=r"actions\[1, 3\] must be in \[0, 9\) \(got 99\)"):
        env.step(bad)
    with pytest.raises(ValueError, match="num_envs must be an integer >= 1"):
        vector_env("coverage", 0)
