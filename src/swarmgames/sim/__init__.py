"""Simulation layer: the stage loop, controllers, run results and their files."""

from swarmgames.lazy import lazy_names

__all__ = [
    "BaselineController",
    "GameController",
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

#: Where each public name lives: imported on first use, so that importing a light submodule
#: (``swarmgames.sim.signals``, as a sweep's own process does) loads no mission, game or
#: compiled kernel.
_HOMES = {
    "BaselineController": "controllers",
    "GameController": "controllers",
    "make_controller": "controllers",
    "solver_from_config": "controllers",
    "StageLog": "loop",
    "oscillation": "loop",
    "run_stages": "loop",
    "provider_from_config": "providers",
    "RunResult": "result",
    "NotResumableError": "runner",
    "build_mission": "runner",
    "resume": "runner",
    "run": "runner",
}


__getattr__, __dir__ = lazy_names(__name__, _HOMES, __all__)
