"""docs/env.md runs as a user would paste it (the comparison on a small budget)."""

import re
from pathlib import Path

import pytest

pytest.importorskip("pettingzoo", reason='pip install "swarmgames[env]"')
pytest.importorskip("supersuit", reason="the vector example needs supersuit")

DOC = Path(__file__).resolve().parents[2] / "docs" / "env.md"

SMALL = {
    "EPISODES = 150": "EPISODES = 2",
    "CLONE_EPISODES = 20": "CLONE_EPISODES = 1",
    "EVAL_SEEDS = [100, 101, 102]": "EVAL_SEEDS = [100]",
    "sim__duration_s=30.0": "sim__duration_s=4.0",
}


def test_env_walkthrough_runs(capsys):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) == 3
    namespace: dict = {}
    for i, block in enumerate(blocks):
        for old, new in SMALL.items():
            block = block.replace(old, new)
        exec(compile(block, f"{DOC.name}[{i}]", "exec"), namespace)
    out = capsys.readouterr().out
    for name in ("random", "game controller", "tabular Q", "cloned expert"):
        assert name in out
    assert namespace["frame"].shape == (400, 400, 3)
