"""The Python examples of docs/game.md run."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOC = Path(__file__).resolve().parents[2] / "docs" / "game.md"


def _blocks() -> list[str]:
    text = DOC.read_text(encoding="utf-8")
    return [b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S) if "import" in b]


def test_docs_have_runnable_examples():
    assert len(_blocks()) >= 1


@pytest.mark.parametrize("index", range(len(_blocks())))
def test_doc_example_runs(index):
    block = _blocks()[index]
    if "bench_memory(10_000" in block:
        block = block.replace("bench_memory(10_000, 10, 9", "bench_memory(20, 3, 4")
        block = block.replace("n_robots=1000", "n_robots=20").replace("n_games=1000", "n_games=5")
    namespace: dict = {}
    exec(compile(block, f"{DOC.name}[{index}]", "exec"), namespace)
    if "stage" in namespace:
        assert namespace["stage"].actions.shape == (3,)
