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

__all__ = [
    "BackendUnavailableError",
    "ConfigError",
    "InputDataError",
    "NeighbourhoodProvider",
    "NotAvailableError",
    "RunFolderError",
    "SwarmgamesError",
    "TopologySnapshot",
    "__version__",
]
