"""Simulation layer: the stage loop, controllers, run results and their files."""

from swarmgames.sim.controllers import Decision, GameController, LloydController
from swarmgames.sim.lloyd import lloyd_actions, voronoi_centroids
from swarmgames.sim.loop import StageLog, run_stages, start_positions
from swarmgames.sim.providers import provider_from_config
from swarmgames.sim.result import RunResult
from swarmgames.sim.runner import build_mission, check_config, run

__all__ = [
    "Decision",
    "GameController",
    "LloydController",
    "RunResult",
    "StageLog",
    "build_mission",
    "check_config",
    "lloyd_actions",
    "provider_from_config",
    "run",
    "run_stages",
    "start_positions",
    "voronoi_centroids",
]
