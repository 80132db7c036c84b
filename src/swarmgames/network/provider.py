"""The interface every neighbourhood provider (OLSR model, oracle, disk, knn, ns-3) implements."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from swarmgames.topology import TopologySnapshot

__all__ = ["NeighbourhoodProvider"]


@runtime_checkable
class NeighbourhoodProvider(Protocol):
    """A source of routing-table snapshots for a moving swarm.

    A provider owns the time axis of the network: ``reset`` places the robots at time
    ``start_time`` and ``advance`` moves the network forward. Positions passed to ``advance``
    hold, piecewise constant, from the provider's current time until ``to_time`` (the convention
    of ``positions.csv`` traces: a row holds from its ``t`` until the node's next row).
    """

    name: str

    @property
    def time(self) -> float:
        """Current simulated time, in seconds."""
        ...

    def reset(self, positions: np.ndarray, start_time: float = 0.0) -> TopologySnapshot:
        """Start a fresh network with robots at ``positions`` (shape (N, 3), metres)."""
        ...

    def advance(self, to_time: float, positions: np.ndarray) -> TopologySnapshot:
        """Run the network until ``to_time`` with robots held at ``positions`` and return every
        robot's routing-table view at ``to_time``."""
        ...
