"""swarmgames: decentralised UAV swarm control with graphical games over time-varying
communication networks.

The public names are imported on first use, so that ``import swarmgames`` (and the CLI, and
``import swarmgames.game``) stays fast and loads no layer it does not need.
"""

__version__ = "0.1.0"

#: Public name -> the module that defines it.
_LAZY = {
    "BackendUnavailableError": "swarmgames.errors",
    "ConfigError": "swarmgames.errors",
    "InputDataError": "swarmgames.errors",
    "RunFolderError": "swarmgames.errors",
    "SwarmgamesError": "swarmgames.errors",
    "Mission": "swarmgames.missions",
    "MissionEntry": "swarmgames.missions",
    "check_mission": "swarmgames.missions",
    "register_mission": "swarmgames.missions",
    "NeighbourhoodProvider": "swarmgames.network",
    "TopologySnapshot": "swarmgames.network",
    "RunResult": "swarmgames.sim",
    "resume": "swarmgames.sim",
    "run": "swarmgames.sim",
    "ScenarioConfig": "swarmgames.config",
    "reproduce_fig2": "swarmgames.experiments.fig2",
    "sweep": "swarmgames.experiments.sweep",
    "reuse_freed_memory": "swarmgames.allocator",
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'swarmgames' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*_LAZY, "__version__"])


__all__ = sorted([*_LAZY, "__version__"])
