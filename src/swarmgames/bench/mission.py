"""A whole mission, timed: ``swarmgames run coverage-large`` with every output.

The ``stage`` records of the suite time one control period of the bench's own loop
(:class:`~swarmgames.bench.stage.StageBench`: the network advance and the decision, no
measurement beyond the stage). A run does more every stage: routed messages, the global
regret, the hop statistics and the coverage metric, the tables appended and the checkpoint;
and at the end the figures and the animation. :func:`mission_record` runs the
``coverage-large`` preset (1 000 UAVs at the bench's density, 60 stages) through
:func:`swarmgames.run` into a temporary folder and reports its wall time, split into the
stage loop and the rest.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["MISSION_ROBOTS", "mission_record"]

#: Robots of the whole-mission benchmark (the ``coverage-large`` preset's swarm).
MISSION_ROBOTS = 1_000


def mission_record(n_robots: int, seed: int = 0, stages: int | None = None) -> dict[str, Any]:
    """Run ``coverage-large`` with ``n_robots`` UAVs (and ``stages`` stages; default the
    preset's 60) with every output and time it.

    Returns
    -------
    dict
        ``benchmark = "mission"``; ``total_s`` (the whole :func:`swarmgames.run`: building
        the mission, the stage loop, the tables, figures, animation and summary), ``loop_s``
        (the stage loop with the tables written stage by stage, ``summary["wall_s"]``),
        ``outputs_s`` (the rest: figures, animation, summary, and building the mission),
        ``median_stage_s`` (a stage inside the run), ``stages`` and ``files``.
    """
    from swarmgames.config import resolve_scenario
    from swarmgames.sim import run

    over = [f"swarm.n_robots={int(n_robots)}", f"seed={int(seed)}"]
    if stages is not None:
        over.append(f"sim.duration_s={float(stages)}")
    config = resolve_scenario("coverage-large", over)
    with tempfile.TemporaryDirectory(prefix="swarmgames-bench-") as tmp:
        t0 = time.perf_counter()
        result = run(config, out=Path(tmp) / "run", progress=False)
        total = time.perf_counter() - t0
        files = sorted(p.name for p in result.files)
    summary = result.summary
    loop = float(summary["wall_s"])
    return {
        "benchmark": "mission",
        "n_robots": int(n_robots),
        "stages": int(summary["stages"]),
        "total_s": total,
        "median_s": total,
        "loop_s": loop,
        "outputs_s": total - loop,
        "median_stage_s": float(summary["median_stage_ms"]) / 1e3,
        "files": files,
    }
