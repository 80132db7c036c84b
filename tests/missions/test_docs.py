"""The walk-through of docs/missions.md runs, block after block, as a user would paste it."""

from __future__ import annotations

import re
from pathlib import Path

from swarmgames.missions import unregister_mission

DOC = Path(__file__).resolve().parents[2] / "docs" / "missions.md"
EXAMPLE = DOC.parent / "examples" / "moving_target.py"


def test_missions_walkthrough_runs(capsys):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) >= 5
    namespace: dict = {}
    try:
        for i, block in enumerate(blocks):
            # dont_inherit: as pasted, without this file's `from __future__ import annotations`
            exec(compile(block, f"{DOC.name}[{i}]", "exec", dont_inherit=True), namespace)
    finally:
        unregister_mission("perimeter")
        unregister_mission("moving_target")
    out = capsys.readouterr().out
    assert "perimeter.radius_m: must be > 0" in out
    result = namespace["result"]
    assert result.summary["mission"] == "perimeter"
    assert set(result.to_frame().columns) >= {"ring_error_m", "crowded_pairs", "oscillation"}
    assert namespace["track"]["target_distance_m"].notna().all()


def test_the_moving_target_section_shows_the_example_file_as_it_is():
    text = DOC.read_text(encoding="utf-8")
    section = text.split("## 7. A moving target", 1)[1]
    shown = re.findall(r"```python\n(.*?)```", section, flags=re.S)[0]
    assert shown == EXAMPLE.read_text(encoding="utf-8")
