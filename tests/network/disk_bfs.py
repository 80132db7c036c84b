"""Instantaneous BFS hop counts on the disk graph: the geometric truth that settled ns-3 routes
equal (REFERENCE.md section 4: 16 226 of 16 226 routes over 35 static layouts)."""

from __future__ import annotations

import numpy as np
from scipy.sparse import csr_array
from scipy.sparse.csgraph import shortest_path
from scipy.spatial import cKDTree

from swarmgames.network.topology import TopologySnapshot

#: Friis at 5.15 GHz, 16.0206 dBm, -82 dBm gate (REFERENCE.md section 2).
RANGE_M = 368.84


class DiskBfs:
    """Test double of a neighbourhood provider: BFS on the disk graph of radius ``radius``."""

    name = "bfs"

    def __init__(self, radius: float = RANGE_M) -> None:
        self.radius = radius
        self._time = 0.0

    @property
    def time(self) -> float:
        return self._time

    def _snap(self, positions: np.ndarray) -> TopologySnapshot:
        p = np.asarray(positions, dtype=float)
        n = p.shape[0]
        pairs = cKDTree(p).query_pairs(self.radius, output_type="ndarray")
        a = csr_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        d = shortest_path(a, directed=False, unweighted=True)
        return TopologySnapshot.from_hop_matrix(self._time, d)

    def reset(self, positions: np.ndarray, start_time: float = 0.0) -> TopologySnapshot:
        self._time = start_time
        return self._snap(positions)

    def advance(self, to_time: float, positions: np.ndarray) -> TopologySnapshot:
        self._time = to_time
        return self._snap(positions)
