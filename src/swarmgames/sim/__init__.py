"""Simulation layer: the stage loop, controllers, run results and their files."""

from swarmgames.sim.controllers import (
    GameController,
    LloydController,
    make_controller,
    solver_from_config,
)
from swarmgames.sim.loop import StageLog, oscillation, run_stages
from swarmgames.sim.providers import provider_from_config
from swarmgames.sim.result import RunResult
from swarmgames.sim.runner import NotResumableError, build_mission, resume, run

__all__ = [
    "GameController",
    "LloydController",
    "NotResumableError",
    "RunResult",
    "StageLog",
    "build_mission",
    "make_controller",
    "oscillation",
    "provider_from_config",
    "resume",
    "run",
    "run_stages",
    "solver_from_config",
]
