"""Test fixtures of the simulation layer: a small instantaneous disk-graph provider, so that
the loop can be tested independently of the network layer's OLSR model."""

import numpy as np
import pytest
from scipy.sparse import csgraph, csr_array
from scipy.spatial import cKDTree

from swarmgames.topology import TopologySnapshot


class DiskOracle:
    """Instant BFS hop counts on the unit-disk graph of radius ``radius`` (no OLSR lag)."""

    name = "test-disk"

    def __init__(self, radius: float = 368.84) -> None:
        self.radius = radius
        self._time = 0.0
        self.calls: list[float] = []

    @property
    def time(self) -> float:
        return self._time

    def _snap(self, positions):
        pos = np.asarray(positions, dtype=float)
        n = len(pos)
        pairs = cKDTree(pos).query_pairs(self.radius, output_type="ndarray")
        adj = csr_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        hops = csgraph.shortest_path(adj, directed=False, unweighted=True)
        return TopologySnapshot.from_hop_matrix(self._time, hops)

    def reset(self, positions, start_time=0.0):
        self._time = start_time
        return self._snap(positions)

    def advance(self, to_time, positions):
        self.calls.append(to_time)
        self._time = to_time
        return self._snap(positions)


@pytest.fixture
def disk():
    return DiskOracle()
