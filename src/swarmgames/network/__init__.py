"""Network layer: radio propagation, link reception, OLSR routing, k-hop neighbourhoods."""

from swarmgames.network.provider import NeighbourhoodProvider
from swarmgames.network.topology import TopologySnapshot

__all__ = ["NeighbourhoodProvider", "TopologySnapshot"]
