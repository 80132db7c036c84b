"""Geometric baselines the paper argues against: fixed-radius (``disk``) and k-nearest (``knn``)
neighbourhoods, computed instantly from positions with a KD-tree.

Both give only 1-hop entries (``next_hop = -1``): N_i(h) is the same set for every h, which is
exactly the assumption of a fixed communication disk or a fixed neighbour count, with no routing
lag and no multi-hop structure.
"""

from __future__ import annotations

import copy

import numpy as np
from scipy.spatial import cKDTree

from swarmgames.network.provider import NetworkState, check_state
from swarmgames.network.validation import check_positions, check_time
from swarmgames.topology import TopologySnapshot

__all__ = ["DiskProvider", "KnnProvider"]


class _InstantProvider:
    """A provider whose snapshot is a pure function of the current positions."""

    name = "instant"

    def __init__(self, n_robots: int) -> None:
        if int(n_robots) < 1:
            raise ValueError(f"n_robots must be >= 1 (got {n_robots})")
        self.n_robots = int(n_robots)
        self._time = 0.0

    @property
    def time(self) -> float:
        """Current time, seconds."""
        return self._time

    def reset(self, positions: np.ndarray, start_time: float = 0.0) -> TopologySnapshot:
        """Place the robots at ``start_time``."""
        self._time = float(start_time)
        return self._snapshot(check_positions(positions, self.n_robots))

    def advance(self, to_time: float, positions: np.ndarray) -> TopologySnapshot:
        """Snapshot of the robots at ``positions`` at ``to_time`` (no lag)."""
        pos = check_positions(positions, self.n_robots)
        self._time = check_time(to_time, self._time)
        return self._snapshot(pos)

    def step(self, to_time: float, positions: np.ndarray) -> None:
        """Move the clock to ``to_time`` without building a snapshot (nothing to simulate)."""
        check_positions(positions, self.n_robots)
        self._time = check_time(to_time, self._time)

    def state(self) -> NetworkState:
        """The provider's state: its time (and the state of its random draws, if it has any);
        the tables are a function of the positions."""
        rng = getattr(self, "_rng", None)
        return NetworkState(
            self.name,
            self.n_robots,
            self._time,
            None if rng is None else copy.deepcopy(rng.bit_generator.state),
        )

    def restore(self, state: NetworkState) -> None:
        """Continue from ``state`` (taken by :meth:`state` of a provider like this one)."""
        check_state(self, state)
        self._time = float(state.time)
        rng = getattr(self, "_rng", None)
        if rng is not None and state.rng is not None:
            rng.bit_generator.state = copy.deepcopy(state.rng)

    def _snapshot(self, pos: np.ndarray) -> TopologySnapshot:  # pragma: no cover - abstract
        raise NotImplementedError


class DiskProvider(_InstantProvider):
    """N_i = every robot within ``radius`` metres (1 hop), ``i`` included.

    Parameters
    ----------
    n_robots : int
        Number of robots.
    radius : float
        Communication radius, metres (> 0).

    Examples
    --------
    >>> p = DiskProvider(3, radius=100.0)
    >>> p.reset(np.array([[0.0, 0, 0], [50, 0, 0], [200, 0, 0]])).degree().tolist()
    [1, 1, 0]
    """

    name = "disk"

    def __init__(self, n_robots: int, radius: float = 368.84) -> None:
        super().__init__(n_robots)
        if not np.isfinite(radius) or radius <= 0:
            raise ValueError(f"radius must be > 0 (got {radius})")
        self.radius = float(radius)

    def _snapshot(self, pos: np.ndarray) -> TopologySnapshot:
        pairs = cKDTree(pos).query_pairs(self.radius, output_type="ndarray")
        owner = np.r_[pairs[:, 0], pairs[:, 1]]
        dest = np.r_[pairs[:, 1], pairs[:, 0]]
        return TopologySnapshot(self._time, self.n_robots, owner, dest, np.ones(owner.size))


class KnnProvider(_InstantProvider):
    """N_i = the ``k`` nearest robots (1 hop, directed: j may not count i among its k).

    Co-located robots count at distance 0; ties are broken by index (KD-tree order). With
    fewer than ``k + 1`` robots every other robot is a neighbour.

    Examples
    --------
    >>> p = KnnProvider(3, k=1)
    >>> p.reset(np.array([[0.0, 0, 0], [50, 0, 0], [200, 0, 0]])).dest.tolist()
    [1, 0, 1]
    """

    name = "knn"

    def __init__(self, n_robots: int, k: int = 4) -> None:
        super().__init__(n_robots)
        if int(k) < 1:
            raise ValueError(f"k must be >= 1 (got {k})")
        self.k = int(k)

    def _snapshot(self, pos: np.ndarray) -> TopologySnapshot:
        k = min(self.k, self.n_robots - 1)
        if k == 0:
            e = np.zeros(0, dtype=np.int32)
            return TopologySnapshot(self._time, self.n_robots, e, e, e)
        _, idx = cKDTree(pos).query(pos, k=k + 1)
        idx = np.asarray(idx).reshape(self.n_robots, k + 1)
        owner = np.repeat(np.arange(self.n_robots), k + 1)
        dest = idx.ravel()
        # Drop self (co-located robots may push self out of the first column).
        not_self = dest != owner
        owner, dest = owner[not_self], dest[not_self]
        # Keep the first k others per owner.
        rank = np.arange(owner.size) - np.repeat(
            np.searchsorted(owner, np.arange(self.n_robots)),
            np.bincount(owner, minlength=self.n_robots),
        )
        keep = rank < k
        owner, dest = owner[keep], dest[keep]
        return TopologySnapshot(self._time, self.n_robots, owner, dest, np.ones(owner.size))
