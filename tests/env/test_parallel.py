"""The PettingZoo environment: PettingZoo's own API and seed tests, the seeding contract,
observations from the robots' inboxes, crashes that terminate, and the expert."""

import numpy as np
import pytest

pytest.importorskip("pettingzoo", reason='pip install "swarmgames[env]"')

from pettingzoo.test import parallel_api_test, parallel_seed_test

from swarmgames.config import resolve_scenario
from swarmgames.env import SwarmParallelEnv, parallel_env
from swarmgames.sim import run

SMALL = {"swarm__n_robots": 5, "sim__duration_s": 8.0, "sim__warmup_s": 3.0}


def _env(**extra):
    return parallel_env("coverage", **{**SMALL, **extra})


def _episode(env, seed, policy):
    obs, infos = env.reset(seed=seed)
    steps = [obs]
    while env.agents:
        obs, rew, term, trunc, infos = env.step(policy(env, obs, infos))
        steps.append((obs, rew, term, trunc))
    return steps


def _random(env, obs, infos):
    return {a: env.action_space(a).sample(infos[a]["action_mask"]) for a in env.agents}


@pytest.mark.parametrize(
    "extra",
    [{}, {"comms__model": "ideal"}, {"reward": "team", "max_neighbours": 2}],
    ids=["routed", "ideal", "team-reward-k2"],
)
def test_pettingzoo_parallel_api(extra):
    parallel_api_test(_env(**extra), num_cycles=20)


def test_pettingzoo_seed_test():
    parallel_seed_test(lambda: _env(sim__duration_s=5.0), num_cycles=10)


def test_same_seed_same_episode_and_other_seeds_differ():
    def run_once(seed):
        env = _env()
        for i, a in enumerate(env.possible_agents):
            env.action_space(a).seed(i)
        return _episode(env, seed, _random)

    a, b, c = run_once(4), run_once(4), run_once(5)
    assert len(a) == len(b) == 9  # reset, then 8 stages
    np.testing.assert_array_equal(a[-1][0]["uav_0"]["self"], b[-1][0]["uav_0"]["self"])
    assert a[-1][1] == b[-1][1]
    assert not np.array_equal(a[0]["uav_0"]["self"], c[0]["uav_0"]["self"])


def test_reset_without_seed_starts_a_new_but_reproducible_episode():
    env1, env2 = _env(), _env()
    first = [env.reset(seed=7)[0]["uav_1"]["self"] for env in (env1, env2)]
    again = [env.reset()[0]["uav_1"]["self"] for env in (env1, env2)]
    np.testing.assert_array_equal(again[0], again[1])
    assert not np.array_equal(first[0], again[0])


def test_the_expert_flies_the_run_of_the_same_seed():
    # Stepping with the game controller's own actions is swarmgames.run, bit for bit.
    env = _env()
    env.reset(seed=2)
    positions = [env.state()[:, :3].copy()]
    while env.agents:
        expert = env.expert_actions()
        assert env.expert_actions() == expert  # asking twice changes nothing
        env.step(expert)
        positions.append(env.state()[:, :3].copy())
    cfg = resolve_scenario(
        "coverage",
        ["swarm.n_robots=5", "sim.duration_s=8.0", "sim.warmup_s=3.0", "seed=2"],
    )
    ref = run(cfg, progress=False).to_frame("trajectory")
    want = ref[["x", "y", "z"]].to_numpy().reshape(-1, 5, 3)
    np.testing.assert_array_equal(np.stack(positions), want)


def test_observations_are_what_the_robots_heard():
    env = _env(comms__loss_rate=0.5, max_neighbours=3)
    env.reset(seed=0)
    obs, *_ = env.step(env.expert_actions())
    view = env.loop.observe()  # the stage the observation was made from
    inbox = view.messages
    for a, o in obs.items():
        i = int(a.split("_")[1])
        row = slice(inbox.indptr[i] + 1, inbox.indptr[i + 1])  # i first, then the others
        heard = dict(zip(inbox.member[row].tolist(), inbox.age[row].tolist(), strict=True))
        ids = o["ids"][o["mask"] == 1]
        assert len(ids) == min(3, len(heard)) and set(ids.tolist()) <= set(heard)
        for j, age in zip(ids, o["age"][o["mask"] == 1], strict=True):
            assert age == heard[int(j)]
        np.testing.assert_array_equal(o["self"], view.states[i])
        assert o["mask"].sum() == 0 or (o["hops"][o["mask"] == 1] >= 1).all()
        assert (o["ids"][o["mask"] == 0] == -1).all()


def test_a_crashed_robot_terminates_and_leaves():
    env = _env(faults__crash=[[5.0, 3]])
    env.reset(seed=0)
    gone = None
    while env.agents:
        _, _, term, trunc, _ = env.step(env.expert_actions())
        if term.get("uav_3"):
            gone = env.loop.stage
            assert "uav_3" not in env.agents
        assert not any(term[a] for a in term if a != "uav_3")
    assert gone == 2  # stages at 3, 4, 5 s: dead at the stage at 5 s, it ends after the 2nd
    assert all(trunc.values())


def test_a_forbidden_action_is_replaced_and_said_so(monkeypatch):
    env = _env()
    env.reset(seed=0)
    allowed = np.ones((5, env.n_actions), dtype=bool)
    allowed[:, 3] = False  # as if heading 3 left the arena for everyone
    monkeypatch.setattr(env.vec, "_masks", lambda states: allowed[None])
    before = env.state().copy()
    _, _, _, _, infos = env.step({"uav_0": 3, "uav_1": 0})
    assert infos["uav_0"]["replaced"] and not infos["uav_1"]["replaced"]
    np.testing.assert_array_equal(env.state()[0], before[0])  # replaced by "stay"


def test_render_and_errors():
    env = _env(render_mode="rgb_array")
    assert env.render() is None  # before reset
    env.reset(seed=0)
    img = env.render()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    with pytest.raises(ValueError, match="render_mode"):
        SwarmParallelEnv(resolve_scenario("coverage", []), render_mode="human")
    with pytest.raises(ValueError, match="reward"):
        SwarmParallelEnv(resolve_scenario("coverage", []), reward="score")
    with pytest.raises(ValueError, match=r"action of uav_0 must be in \[0, 9\)"):
        env.step({"uav_0": 99})


def test_flat_observations():
    env = _env(observation="flat", max_neighbours=3)
    obs, _ = env.reset(seed=0)
    d = 3
    assert obs["uav_0"].shape == (d + 3 * d + 4 * 3,) == env.observation_space("uav_0").shape
    flat = _env(max_neighbours=3)
    dict_obs, _ = flat.reset(seed=0)
    parts = [np.ravel(dict_obs["uav_0"][k]) for k in ("self", "neighbours", "ids", "age")]
    np.testing.assert_array_equal(obs["uav_0"][: sum(p.size for p in parts)], np.concatenate(parts))
    assert env.observation_space("uav_0").contains(obs["uav_0"])


def test_the_stage_time_is_the_runs_clock():
    # The warm-up, then one control period a step: the t of the mission's potentials and
    # metrics (swarmgames.sim.loop), as a run of the same scenario has it.
    env = _env(sim__warmup_s=5.0)
    with pytest.raises(RuntimeError, match="reset"):
        env.stage_time
    env.reset(seed=0)
    period = env.config.sim.control_period_s
    assert env.stage_time == 5.0
    env.step(env.expert_actions())
    assert env.stage_time == 5.0 + period
