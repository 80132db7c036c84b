"""Simulation layer: the stage loop, controllers, run results and their files."""

from importlib import import_module

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


def __getattr__(name: str):
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{home}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
