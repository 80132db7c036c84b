"""Network layer: radio propagation, link reception, OLSR routing, k-hop neighbourhoods."""

from swarmgames.network.baselines import DiskProvider, KnnProvider
from swarmgames.network.conformance import check_provider
from swarmgames.network.factory import BACKENDS, make_provider
from swarmgames.network.links import LinkGraph, link_graph
from swarmgames.network.olsr.provider import OlsrProvider
from swarmgames.network.olsr.traffic import ControlTraffic
from swarmgames.network.oracle import OracleProvider
from swarmgames.network.parameters import OlsrParameters, RadioParameters
from swarmgames.network.propagation import PropagationModel, max_range
from swarmgames.network.provider import NeighbourhoodProvider, NetworkState, SnapshotUnsupported
from swarmgames.network.trace import PositionTrace, read_positions
from swarmgames.topology import TopologySnapshot

__all__ = [
    "BACKENDS",
    "ControlTraffic",
    "DiskProvider",
    "KnnProvider",
    "LinkGraph",
    "NeighbourhoodProvider",
    "NetworkState",
    "OlsrParameters",
    "OlsrProvider",
    "OracleProvider",
    "PositionTrace",
    "PropagationModel",
    "RadioParameters",
    "SnapshotUnsupported",
    "TopologySnapshot",
    "check_provider",
    "link_graph",
    "make_provider",
    "max_range",
    "read_positions",
]
