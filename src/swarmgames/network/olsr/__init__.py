"""OLSR (RFC 3626) as ns-3 implements it: MPR selection, routing tables, the event engine."""

from swarmgames.network.olsr.engine import OlsrEngine
from swarmgames.network.olsr.mpr import select_mprs
from swarmgames.network.olsr.routing import compute_routes
from swarmgames.network.olsr.traffic import ControlTraffic
from swarmgames.network.olsr.wire import hello_size, tc_size

__all__ = ["ControlTraffic", "OlsrEngine", "compute_routes", "hello_size", "select_mprs", "tc_size"]
