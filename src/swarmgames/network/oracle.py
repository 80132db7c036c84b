"""The ``oracle`` provider: instant shortest-path hop counts on the current link graph.

It is what OLSR converges to when nothing moves (docs/reference.md section 4: 16 226 of 16 226
routes equal BFS after settling), without OLSR's start-up time and lag.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import csgraph

from swarmgames.network.baselines import _InstantProvider
from swarmgames.network.links import LinkGraph, link_graph
from swarmgames.network.olsr.tables import sorted_contains
from swarmgames.network.parameters import RadioParameters
from swarmgames.network.propagation import channel_model
from swarmgames.rng import as_generator
from swarmgames.topology import TopologySnapshot

__all__ = ["OracleProvider", "bfs_hops", "sparse_bfs_routes"]

#: Above this many robots, a hop-limited oracle uses sparse level-by-level BFS instead of a
#: dense (N, N) distance matrix.
DENSE_NODES = 2000


def bfs_hops(adjacency, max_hops: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Hop counts and next hops by breadth-first search (scipy ``csgraph``).

    Parameters
    ----------
    adjacency : sparse matrix, shape (N, N)
        Symmetric link graph.
    max_hops : int, optional
        Ignore paths longer than this.

    Returns
    -------
    hops : ndarray of float, shape (N, N)
        ``inf`` where unreachable, 0 on the diagonal.
    next_hop : ndarray of int, shape (N, N)
        ``next_hop[i, j]`` is i's first relay toward j (-1 if none). Because the graph is
        undirected, it is the predecessor of ``i`` on the BFS tree rooted at ``j``.
    """
    limit = np.inf if max_hops is None else float(max_hops)
    hops, pred = csgraph.shortest_path(
        adjacency, method="D", unweighted=True, directed=False, return_predecessors=True
    )
    if np.isfinite(limit):
        hops[hops > limit] = np.inf
    nxt = pred.T.copy()
    nxt[~np.isfinite(hops)] = -1
    nxt[nxt < 0] = -1
    return hops, nxt


def sparse_bfs_routes(
    graph: LinkGraph, max_hops: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Routes of at most ``max_hops`` hops, level by level on sparse arrays (memory ~ number
    of routes, not N^2: what makes 10 000 robots with h <= 2 affordable).

    Level ``k + 1`` holds the pairs ``(i, d)`` with a neighbour ``n`` of ``i`` at level ``k``
    from ``d`` and no shorter route; the next hop is the lowest-numbered such ``n``.

    Returns
    -------
    owner, dest, hops, next_hop : ndarray
        Sorted by ``(owner, dest)``.
    """
    n = np.int64(graph.n_robots)
    deg = np.diff(graph.indptr)
    owner = np.repeat(np.arange(graph.n_robots, dtype=np.int64), deg)
    dest = graph.indices.astype(np.int64)
    keys = [owner * n + dest]
    hops = [np.ones(dest.size, dtype=np.int16)]
    nexts = [dest]
    known = keys[0]  # sorted: CSR rows are sorted
    level_owner, level_dest = owner, dest
    for h in range(2, max_hops + 1):
        # Extend every level-(h-1) route (n -> d) backwards by a link (i, n): i reaches d via n.
        # By symmetry, routes (n, d) at level h-1 give candidates (i, d) for i ~ n.
        counts = deg[level_owner]
        total = int(counts.sum())
        if total == 0:
            break
        starts = np.repeat(graph.indptr[level_owner], counts)
        pos = starts + np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
        i = graph.indices[pos].astype(np.int64)
        via = np.repeat(level_owner, counts)
        d = np.repeat(level_dest, counts)
        cand = i * n + d
        fresh = (i != d) & ~sorted_contains(known, cand)
        cand, via = cand[fresh], via[fresh]
        if cand.size == 0:
            break
        order = np.lexsort((via, cand))
        cand, via = cand[order], via[order]
        first = np.r_[True, cand[1:] != cand[:-1]]
        cand, via = cand[first], via[first]
        keys.append(cand)
        hops.append(np.full(cand.size, h, dtype=np.int16))
        nexts.append(via)
        known = np.union1d(known, cand)
        level_owner, level_dest = cand // n, cand % n
    all_k = np.concatenate(keys)
    order = np.argsort(all_k, kind="stable")
    all_k = all_k[order]
    return (
        (all_k // n).astype(np.int32),
        (all_k % n).astype(np.int32),
        np.concatenate(hops)[order],
        np.concatenate(nexts)[order].astype(np.int32),
    )


class OracleProvider(_InstantProvider):
    """N_i(h) from instant BFS hop counts on the radio link graph (no protocol, no lag).

    Parameters
    ----------
    n_robots : int
        Number of robots.
    radio : RadioParameters, optional
        Propagation and reception model.
    max_hops : int, optional
        Keep only routes of at most this many hops (N_i(h) needs no more). With more than
        2 000 robots the routes are then found by sparse BFS, so memory grows with the number
        of routes rather than N^2.
    seed : int, Generator or None
        Seed of shadowing / fading draws (unused by deterministic models).
    shadowing_key : int, optional
        Key of the static per-pair shadowing field (see
        :func:`~swarmgames.network.propagation.pair_gaussians`); providers given the same key
        see the same channel. Default: drawn from ``seed`` when shadowing is on.

    Examples
    --------
    >>> p = OracleProvider(3)
    >>> p.reset(np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]])).hop_matrix()[0].tolist()
    [0, 1, 2]
    """

    name = "oracle"

    def __init__(
        self,
        n_robots: int,
        radio: RadioParameters | None = None,
        max_hops: int | None = None,
        seed: int | np.random.Generator | None = None,
        shadowing_key: int | None = None,
    ) -> None:
        super().__init__(n_robots)
        self.max_hops = max_hops
        self._rng = as_generator(seed)
        self.model = channel_model(radio or RadioParameters(), self._rng, shadowing_key)

    def _snapshot(self, pos: np.ndarray) -> TopologySnapshot:
        g = link_graph(pos, self.model, self._rng)
        if self.max_hops is not None and self.n_robots > DENSE_NODES:
            return TopologySnapshot(self._time, self.n_robots, *sparse_bfs_routes(g, self.max_hops))
        hops, nxt = bfs_hops(g.adjacency(), self.max_hops)
        return TopologySnapshot.from_hop_matrix(self._time, hops, nxt)
