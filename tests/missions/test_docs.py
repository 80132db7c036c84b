"""The walk-through of docs/missions.md runs, block after block, as a user would paste it."""

from __future__ import annotations

import re
from pathlib import Path

from swarmgames.missions import unregister_mission

DOC = Path(__file__).resolve().parents[2] / "docs" / "missions.md"


def test_missions_walkthrough_runs(capsys):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) >= 5
    namespace: dict = {}
    try:
        for i, block in enumerate(blocks):
            exec(compile(block, f"{DOC.name}[{i}]", "exec"), namespace)
    finally:
        unregister_mission("perimeter")
    out = capsys.readouterr().out
    assert "perimeter.radius_m: must be > 0" in out
    result = namespace["result"]
    assert result.summary["mission"] == "perimeter"
    assert set(result.to_frame().columns) >= {"ring_error_m", "crowded_pairs", "oscillation"}
