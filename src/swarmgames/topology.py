"""Immutable topology snapshots: every robot's routing-table view of the swarm at one instant.

A snapshot stores, in sparse coordinate form sorted by ``(owner, dest)``, the entries of every
robot's own routing table (jraph's ``GraphsTuple`` idea: flat ``senders``/``receivers`` arrays).
Sparse storage keeps 10 000-robot swarms affordable: a robot only stores the destinations its
routing protocol knows about.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.A: N_i(h) = {j : Hops(i, j) <= h}.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from swarmgames.arrays import frozen

__all__ = ["TopologySnapshot"]


@dataclass(frozen=True, eq=False)
class TopologySnapshot:
    """Routing-table view of a swarm of ``n_robots`` robots at time ``time``.

    Parameters
    ----------
    time : float
        Simulated time of the snapshot, in seconds.
    n_robots : int
        Number of robots, indexed ``0 .. n_robots - 1``.
    owner : ndarray of int32, shape (E,)
        Robot whose routing table holds the entry.
    dest : ndarray of int32, shape (E,)
        Destination of the entry (never equal to ``owner``).
    hops : ndarray of int16, shape (E,)
        Hop count of the entry (>= 1).
    next_hop : ndarray of int32, shape (E,), optional
        First relay on the route; ``-1`` where the provider has no routes (disk, knn).

    Notes
    -----
    Entries are sorted by ``(owner, dest)``; unreachable destinations have no entry.
    The arrays are read-only: a time-varying network is a sequence of snapshots.
    """

    time: float
    n_robots: int
    owner: np.ndarray
    dest: np.ndarray
    hops: np.ndarray
    next_hop: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        owner = np.asarray(self.owner)
        if self.next_hop is None:
            object.__setattr__(self, "next_hop", np.full(owner.shape, -1, dtype=np.int32))
        _check_entries(self.n_robots, owner, self.dest, self.hops, self.next_hop)
        order = np.lexsort((np.asarray(self.dest), owner))
        for name, dtype in (
            ("owner", np.int32),
            ("dest", np.int32),
            ("hops", np.int16),
            ("next_hop", np.int32),
        ):
            arr = np.asarray(getattr(self, name))
            if arr.shape != owner.shape:
                raise ValueError(f"{name} must have shape {owner.shape} (got {arr.shape})")
            object.__setattr__(self, name, frozen(arr[order], dtype))

    @classmethod
    def from_hop_matrix(
        cls, time: float, hops: np.ndarray, next_hop: np.ndarray | None = None
    ) -> TopologySnapshot:
        """Build a snapshot from a dense ``(N, N)`` hop matrix (``<= 0`` or ``inf`` = no route,
        the diagonal is ignored)."""
        hops = np.asarray(hops, dtype=float)
        n = hops.shape[0]
        mask = np.isfinite(hops) & (hops > 0)
        np.fill_diagonal(mask, False)
        owner, dest = np.nonzero(mask)
        nh = None if next_hop is None else np.asarray(next_hop)[owner, dest]
        return cls(time, n, owner, dest, hops[owner, dest].astype(np.int16), nh)

    @classmethod
    def concat(cls, snapshots, time: float | None = None) -> TopologySnapshot:
        """Independent swarms side by side as one snapshot: swarm ``e``'s robot ``i`` becomes
        robot ``offset_e + i`` (``offset_e`` the robots of the swarms before it), and no entry
        joins two swarms (a block-diagonal network). The swarms' snapshots must be taken at
        one time, unless ``time`` gives the one the result holds (swarms whose own clocks
        differ).

        Examples
        --------
        >>> one = TopologySnapshot.from_hop_matrix(0.0, np.array([[0, 1], [1, 0]]))
        >>> two = TopologySnapshot.concat([one, one])
        >>> two.n_robots, two.owner.tolist(), two.dest.tolist()
        (4, [0, 1, 2, 3], [1, 0, 3, 2])
        """
        snaps = list(snapshots)
        if not snaps:
            raise ValueError("concat needs at least one snapshot")
        times = {float(s.time) for s in snaps}
        if time is None and len(times) != 1:
            raise ValueError(f"snapshots must share one time (got {sorted(times)})")
        sizes = np.array([s.n_robots for s in snaps], dtype=np.int64)
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        counts = [s.owner.size for s in snaps]
        shift = np.repeat(offsets, counts)
        nh = np.concatenate([s.next_hop for s in snaps]).astype(np.int64)
        return cls(
            snaps[0].time if time is None else float(time),
            int(sizes.sum()),
            np.concatenate([s.owner for s in snaps]) + shift,
            np.concatenate([s.dest for s in snaps]) + shift,
            np.concatenate([s.hops for s in snaps]),
            np.where(nh >= 0, nh + shift, -1),
        )

    @property
    def n_entries(self) -> int:
        """Number of routing-table entries over all robots."""
        return int(self.owner.size)

    def hop_matrix(self, unreachable: int = -1) -> np.ndarray:
        """Dense ``(N, N)`` int16 matrix of hop counts; 0 on the diagonal, ``unreachable``
        where robot i has no route to j."""
        m = np.full((self.n_robots, self.n_robots), unreachable, dtype=np.int16)
        m[self.owner, self.dest] = self.hops
        np.fill_diagonal(m, 0)
        return m

    def neighbourhood_rows(self, h: int) -> tuple[np.ndarray, np.ndarray]:
        """Every ``N_i(h)`` as CSR rows: ``indptr`` (N + 1,) int64 and ``indices`` int32,
        row i sorted and holding ``i`` itself (paper, section II.A).

        The entries are sorted by ``(owner, dest)`` and unique, so each robot's own key
        ``i (N + 1)`` is inserted at its place in the sorted keys ``owner N + dest``: no
        sort and no sparse-matrix conversion.

        Examples
        --------
        >>> snap = TopologySnapshot.from_hop_matrix(0.0, np.array([[0, 1, 2], [1, 0, 1],
        ...                                                         [2, 1, 0]]))
        >>> indptr, indices = snap.neighbourhood_rows(1)
        >>> indptr.tolist(), indices.tolist()
        ([0, 2, 5, 7], [0, 1, 0, 1, 2, 1, 2])
        """
        if h < 1:
            raise ValueError(f"h must be >= 1 (got {h})")
        n = int(self.n_robots)
        keep = self.hops <= h
        keys = self.owner[keep].astype(np.int64) * n + self.dest[keep]
        own = np.arange(n, dtype=np.int64) * (n + 1)
        keys = np.insert(keys, np.searchsorted(keys, own), own)
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(keys // n, minlength=n), out=indptr[1:])
        return indptr, (keys % n).astype(np.int32)

    def neighbourhood_matrix(self, h: int) -> sp.csr_array:
        """Boolean CSR matrix ``A`` with ``A[i, j]`` true iff ``j`` is in ``N_i(h)``
        (:meth:`neighbourhood_rows`, sorted indices).

        ``N_i(h)`` always contains ``i`` itself (paper, section II.A).
        """
        indptr, indices = self.neighbourhood_rows(h)
        data = np.ones(indices.size, dtype=bool)
        return sp.csr_array((data, indices, indptr), shape=(self.n_robots, self.n_robots))

    def neighbourhood(self, i: int, h: int) -> np.ndarray:
        """Sorted indices of ``N_i(h)``, ``i`` included."""
        lo, hi = np.searchsorted(self.owner, [i, i + 1])
        sel = self.dest[lo:hi][self.hops[lo:hi] <= h]
        return np.sort(np.append(sel, np.int32(i)))

    def degree(self) -> np.ndarray:
        """Number of 1-hop (direct) neighbours of every robot, shape (N,)."""
        return np.bincount(self.owner[self.hops == 1], minlength=self.n_robots)

    def to_networkx(self, h: int = 1):
        """Directed networkx graph with an edge ``i -> j`` (attribute ``hops``) for every entry
        of ``i``'s table with at most ``h`` hops."""
        import networkx as nx

        g = nx.DiGraph(time=self.time)
        g.add_nodes_from(range(self.n_robots))
        keep = self.hops <= h
        g.add_edges_from(
            (int(a), int(b), {"hops": int(c)})
            for a, b, c in zip(self.owner[keep], self.dest[keep], self.hops[keep], strict=True)
        )
        return g


#: Largest hop count a snapshot holds (``int16``).
MAX_HOPS = int(np.iinfo(np.int16).max)


def _check_entries(n_robots, owner, dest, hops, next_hop) -> None:
    """Raise ``ValueError`` naming the first broken rule of a snapshot's entries: robot ids in
    ``[0, n_robots)``, no route to oneself, hop counts whole numbers in ``[1, MAX_HOPS]``
    (so that none overflows), next hops ``-1`` or a robot id, no (owner, dest) twice. The
    boundary where a provider's tables enter the simulation."""
    n = int(n_robots)
    if n < 0 or n != n_robots:
        raise ValueError(f"n_robots must be an integer >= 0 (got {n_robots!r})")
    owner, dest = np.asarray(owner), np.asarray(dest)
    hops, nxt = np.asarray(hops), np.asarray(next_hop)
    if owner.size == 0:
        return
    for name, arr, low in (("owner", owner, 0), ("dest", dest, 0), ("next_hop", nxt, -1)):
        if arr.shape != owner.shape:
            continue  # the shape rule reports it
        bad = (arr < low) | (arr >= n)
        if arr.dtype.kind not in "iu":  # whole numbers: integer arrays are, by their type
            bad |= ~np.isfinite(arr) | (arr != np.round(arr))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"{name} must be robot ids in [{low}, {n}) (got {arr[k].item()!r} in entry {k})"
            )
    if hops.shape == owner.shape:
        bad = (hops < 1) | (hops > MAX_HOPS)
        if hops.dtype.kind not in "iu":
            bad |= ~np.isfinite(hops) | (hops != np.round(hops))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"hops must be whole numbers in [1, {MAX_HOPS}] (got {hops[k].item()!r} for "
                f"owner {owner[k].item()}, dest {dest[k].item()})"
            )
    if dest.shape == owner.shape:
        self_route = owner == dest
        if self_route.any():
            k = int(np.flatnonzero(self_route)[0])
            raise ValueError(
                f"a robot's table must not hold a route to itself (robot {owner[k].item()})"
            )
        key = np.sort(owner.astype(np.int64) * max(n, 1) + dest.astype(np.int64))
        twice = np.flatnonzero(np.diff(key) == 0)
        if twice.size:
            k = key[twice[0]]
            raise ValueError(f"the route {k // n} -> {k % n} appears twice")
