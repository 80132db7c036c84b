"""Reception model: which pairs of robots hear each other, as a symmetric link graph.

Candidate pairs come from a scipy ``cKDTree.query_pairs`` within the model's largest possible
range (never an all-pairs loop), then the received power of each candidate is computed
vectorised and compared with the reception threshold. One draw of shadowing / fading is made per
unordered pair, so the graph is symmetric (OLSR only uses symmetric links anyway). Shadowing is
the pair's static draw when the model has a shadowing key (providers always give it one);
fading is drawn anew at every call, that is at every position update.

With a deterministic model (the default Friis) the range is a hard cut: ``d <= 368.84 m``
(docs/reference.md section 2). With shadowing or fading the range is probabilistic; the KD-tree
radius is then the distance beyond which a link has probability below ``1e-6``
(:func:`swarmgames.network.propagation.max_range`), so dropping those pairs changes the graph
with negligible probability.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from swarmgames.arrays import sorted_unique
from swarmgames.network.propagation import PropagationModel

__all__ = ["LinkGraph", "link_graph"]


@dataclass(frozen=True, eq=False)
class LinkGraph:
    """Symmetric radio link graph of ``n_robots`` robots (immutable).

    Parameters
    ----------
    n_robots : int
        Number of robots.
    i, j : ndarray of int32, shape (E,)
        Endpoints of each undirected link, ``i < j``, sorted.
    indptr, indices : ndarray of int32
        CSR adjacency (both directions): the neighbours of node ``k`` are
        ``indices[indptr[k]:indptr[k + 1]]``, sorted.
    """

    n_robots: int
    i: np.ndarray
    j: np.ndarray
    indptr: np.ndarray
    indices: np.ndarray

    @classmethod
    def from_pairs(cls, n_robots: int, i: np.ndarray, j: np.ndarray) -> LinkGraph:
        """Build from undirected pairs (any order, ``i != j``)."""
        a = np.minimum(i, j).astype(np.int32)
        b = np.maximum(i, j).astype(np.int32)
        n = np.int64(n_robots)
        # Sorted by (a, b) through one stable sort of a composite key (lexsort's order), and
        # the CSR pattern of both directions from the sorted, unique keys u N + v.
        order = np.argsort(a.astype(np.int64) * n + b, kind="stable")
        a, b = a[order], b[order]
        keys = sorted_unique(
            np.concatenate([a.astype(np.int64) * n + b, b.astype(np.int64) * n + a])
        )
        indptr = np.zeros(int(n_robots) + 1, dtype=np.int32)
        np.cumsum(np.bincount(keys // n, minlength=int(n_robots)), out=indptr[1:])
        arrays = [a, b, indptr, (keys % n).astype(np.int32)]
        for arr in arrays:
            arr.setflags(write=False)
        return cls(n_robots, *arrays)

    @property
    def n_links(self) -> int:
        """Number of undirected links."""
        return int(self.i.size)

    def adjacency(self) -> sp.csr_array:
        """Boolean symmetric CSR adjacency matrix."""
        data = np.ones(self.indices.size, dtype=bool)
        return sp.csr_array((data, self.indices, self.indptr), shape=(self.n_robots,) * 2)

    def degree(self) -> np.ndarray:
        """Number of links of every node, shape (N,)."""
        return np.diff(self.indptr)

    def neighbours(self, k: int) -> np.ndarray:
        """Sorted neighbours of node ``k``."""
        return self.indices[self.indptr[k] : self.indptr[k + 1]]


def link_graph(
    positions: np.ndarray,
    model: PropagationModel | None = None,
    rng: np.random.Generator | None = None,
) -> LinkGraph:
    """Links between robots at ``positions``: ``i ~ j`` iff ``Pr(d_ij) >= rx_threshold_dbm``.

    Parameters
    ----------
    positions : ndarray, shape (N, 3) or (N, 2)
        Robot positions, metres.
    model : PropagationModel, optional
        Propagation and reception model (default: ns-3 defaults, Friis at 5.15 GHz).
    rng : numpy Generator, optional
        Needed when the model draws shadowing or fading.

    Returns
    -------
    LinkGraph

    Examples
    --------
    >>> g = link_graph(np.array([[0.0, 0, 0], [368.5, 0, 0], [737.5, 0, 0]]))
    >>> g.n_links
    1
    """
    model = model or PropagationModel()
    pos = np.asarray(positions, dtype=float)
    n = pos.shape[0]
    radius = model.max_range()
    if n < 2 or radius <= 0:
        empty = np.zeros(0, dtype=np.int32)
        return LinkGraph.from_pairs(n, empty, empty)
    # Slightly enlarged radius: the exact threshold test below decides.
    pairs = cKDTree(pos).query_pairs(radius * (1 + 1e-9) + 1e-9, output_type="ndarray")
    if pairs.size == 0:
        empty = np.zeros(0, dtype=np.int32)
        return LinkGraph.from_pairs(n, empty, empty)
    d = np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1)
    power = model.rx_power(d, rng, pairs=(pairs[:, 0], pairs[:, 1]))
    keep = power >= model.radio.rx_threshold_dbm
    return LinkGraph.from_pairs(n, pairs[keep, 0], pairs[keep, 1])
