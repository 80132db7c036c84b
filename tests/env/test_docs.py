"""docs/env.md runs as a user would paste it (on small budgets: fewer envs, steps and
training)."""

import re
from pathlib import Path

import pytest

pytest.importorskip("pettingzoo", reason='pip install "swarmgames[env]"')
pytest.importorskip("stable_baselines3", reason='pip install "swarmgames[rl]"')

DOC = Path(__file__).resolve().parents[2] / "docs" / "env.md"

SMALL = {
    'vector_env("coverage", 64,': 'vector_env("coverage", 2,',
    "range(40)": "range(3)",
    'sb3_vec_env("coverage", 16,': 'sb3_vec_env("coverage", 2,',
    "batch_size=1024)": "batch_size=128)",  # 2 x 7 agents x 64 steps = 896 = 7 x 128
    "model.learn(10_000)": "model.learn(200)",
    'recipe_config("coverage")': 'recipe_config("coverage", ["sim.duration_s=3.0"])',
    "num_envs=16": "num_envs=2",
    "minutes=30)": "minutes=None, agent_steps=200)",
    "seeds=(100, 101, 102, 103, 104)": "seeds=(100,)",
}


def test_env_walkthrough_runs(capsys):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) == 4
    namespace: dict = {}
    for i, block in enumerate(blocks):
        for old, new in SMALL.items():
            block = block.replace(old, new)
        exec(compile(block, f"{DOC.name}[{i}]", "exec"), namespace)
    out = capsys.readouterr().out
    assert "(2, 7, 6, 3) (2, 7)" in out
    assert "'policy': 'trained'" in out
    assert namespace["frame"].shape == (400, 400, 3)
