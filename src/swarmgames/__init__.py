"""swarmgames: decentralised UAV swarm control with graphical games over time-varying
communication networks."""

from swarmgames.errors import (
    BackendUnavailableError,
    ConfigError,
    InputDataError,
    NotAvailableError,
    RunFolderError,
    SwarmgamesError,
)
from swarmgames.network import NeighbourhoodProvider, TopologySnapshot

__version__ = "0.1.0"

#: Names imported on first use, so that ``import swarmgames`` (and the CLI) stays fast.
_LAZY = {
    "run": "swarmgames.sim",
    "RunResult": "swarmgames.sim",
    "ScenarioConfig": "swarmgames.config",
    "reproduce_fig2": "swarmgames.experiments.fig2",
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'swarmgames' has no attribute {name!r}")


__all__ = [
    "BackendUnavailableError",
    "ConfigError",
    "InputDataError",
    "NeighbourhoodProvider",
    "NotAvailableError",
    "RunFolderError",
    "RunResult",
    "ScenarioConfig",
    "SwarmgamesError",
    "TopologySnapshot",
    "__version__",
    "reproduce_fig2",
    "run",
]
