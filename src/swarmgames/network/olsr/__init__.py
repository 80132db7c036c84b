"""OLSR (RFC 3626) as ns-3 implements it: MPR selection, routing tables, the event engine."""

from swarmgames.network.olsr.engine import OlsrEngine
from swarmgames.network.olsr.mpr import select_mprs
from swarmgames.network.olsr.routing import compute_routes

__all__ = ["OlsrEngine", "compute_routes", "select_mprs"]
