"""The ``oracle`` provider: instant shortest-path hop counts on the current link graph.

It is what OLSR converges to when nothing moves (REFERENCE.md section 4: 16 226 of 16 226
routes equal BFS after settling), without OLSR's start-up time and lag.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import csgraph

from swarmgames.config import RadioConfig
from swarmgames.network.baselines import _InstantProvider
from swarmgames.network.links import link_graph
from swarmgames.network.propagation import PropagationModel
from swarmgames.network.topology import TopologySnapshot
from swarmgames.network.validation import as_generator

__all__ = ["OracleProvider", "bfs_hops"]


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


class OracleProvider(_InstantProvider):
    """N_i(h) from instant BFS hop counts on the radio link graph (no protocol, no lag).

    Parameters
    ----------
    n_nodes : int
        Number of robots.
    radio : RadioConfig, optional
        Propagation and reception model.
    max_hops : int, optional
        Keep only routes of at most this many hops.
    seed : int, Generator or None
        Seed of shadowing / fading draws (unused by deterministic models).

    Examples
    --------
    >>> p = OracleProvider(3)
    >>> p.reset(np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]])).hop_matrix()[0].tolist()
    [0, 1, 2]
    """

    name = "oracle"

    def __init__(
        self,
        n_nodes: int,
        radio: RadioConfig | None = None,
        max_hops: int | None = None,
        seed: int | np.random.Generator | None = None,
    ) -> None:
        super().__init__(n_nodes)
        self.model = PropagationModel(radio or RadioConfig())
        self.max_hops = max_hops
        self._rng = as_generator(seed)

    def _snapshot(self, pos: np.ndarray) -> TopologySnapshot:
        g = link_graph(pos, self.model, self._rng)
        hops, nxt = bfs_hops(g.adjacency(), self.max_hops)
        return TopologySnapshot.from_hop_matrix(self._time, hops, nxt)
