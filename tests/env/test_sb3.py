"""The stable-baselines3 adapter and the training recipe's pipeline (a few hundred steps,
no learning asserted): PPO with ``seed=``, the final observation at truncation, masks."""

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason='pip install "swarmgames[env]"')
pytest.importorskip("stable_baselines3", reason='pip install "swarmgames[rl]"')

from stable_baselines3.common.vec_env import VecEnv

from swarmgames.env.recipe import compare, recipe_config, train_ppo
from swarmgames.env.sb3 import SwarmSB3VecEnv, sb3_vec_env
from swarmgames.env.vector import vector_env

SMALL = {"swarm__n_robots": 3, "sim__duration_s": 3.0}


def test_the_robots_of_every_env_are_one_batch():
    venv = sb3_vec_env("coverage", 2, **SMALL)
    assert isinstance(venv, VecEnv) and venv.num_envs == 6
    assert venv.seed(7) == [7, 7, 7, 8, 8, 8]
    obs = venv.reset()
    assert obs.shape == (6, venv.observation_space.shape[0]) and obs.dtype == np.float32
    assert venv.action_masks().shape == (6, venv.action_space.n)
    assert len(venv.env_method("action_masks", indices=[0, 5])) == 2
    done_at = []
    for k in range(3):
        venv.step_async(np.zeros(6, dtype=np.int64))
        obs, rew, done, infos = venv.step_wait()
        assert rew.shape == done.shape == (6,)
        if done.any():
            done_at.append(k)
            assert all(i["TimeLimit.truncated"] for i in infos)
            final = np.stack([i["terminal_observation"] for i in infos])
            assert not np.array_equal(final, obs)  # the final one, not the next episode's
    assert done_at == [2]
    venv.close()


def test_the_adapter_needs_flat_autoresetting_envs():
    with pytest.raises(ValueError, match="flat observations"):
        SwarmSB3VecEnv(vector_env("coverage", 1, **SMALL))
    with pytest.raises(ValueError, match="resets itself"):
        SwarmSB3VecEnv(vector_env("coverage", 1, observation="flat", autoreset=False, **SMALL))


def test_the_recipe_runs_end_to_end():
    # PPO(..., seed=0) through the adapter for a few hundred agent-steps, then the
    # comparison of random, expert and trained policies on two evaluation seeds.
    config = recipe_config("coverage", ["swarm.n_robots=3", "sim.duration_s=3.0"])
    seen = []
    trained = train_ppo(
        config,
        num_envs=2,
        agent_steps=300,
        minutes=None,
        seed=0,
        progress=lambda *a: seen.append(a),
    )
    assert trained.agent_steps >= 300 and seen
    rows = compare(trained, config, seeds=(100, 101))
    assert [r["policy"] for r in rows] == ["random"] * 2 + ["expert"] * 2 + ["trained"] * 2
    assert all(np.isfinite(r["coverage"]) and np.isfinite(r["return"]) for r in rows)
