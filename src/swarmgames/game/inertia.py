"""Inertia: a switching cost any mission can add to its potentials.

In a stage game every variable is scored with the others held at their current states, but
all robots move at once. Near an optimum this lets neighbours swap back and forth between two
positions for ever, each step gaining a little against the others' old positions: a myopic
game cycles. A small cost on every action that moves the robot,

.. math:: \\phi_u^{inertia}(k, x_k) = \\phi_u(k, x_k)
          - c\\,[\\lVert S_k(x_k) - S_k \\rVert_\\infty > \\epsilon],

removes these 2-cycles: a robot moves only while a move gains more than ``c``. It changes no
deviation gain between two moving actions, only between moving and staying.
:class:`Inertia` wraps any :class:`~swarmgames.game.potentials.Potentials` and adds the cost
to its unary; the pairwise forms and the other optional forms are the wrapped object's, and
it declares them as the wrapped object does
(:class:`~swarmgames.game.capabilities.PotentialCapabilities`), with the owner's unary row
(``owner_unary``) wherever that needs no owner row of a pairwise table the wrapped object
lacks.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, eq. 1 (the unary term this cost enters).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.capabilities import PotentialCapabilities, capabilities_of
from swarmgames.game.potentials import Potentials

__all__ = ["Inertia"]


@dataclass(frozen=True, eq=False)
class Inertia:
    """``potentials`` with a cost ``cost`` on every action that moves the robot.

    Parameters
    ----------
    potentials : Potentials
        The mission's potentials.
    cost : float
        The switching cost, in the unary's units, >= 0 (0 = the wrapped potentials exactly).
    dims : int, default 3
        A move is a change of more than ``tol`` in one of the first ``dims`` state columns
        (the position, by default; velocity columns do not count).
    tol : float, default 1e-9
        Changes up to this size are no move.

    Examples
    --------
    >>> import numpy as np
    >>> from swarmgames.game import FunctionPotentials, DisplacementActions, local_games
    >>> from swarmgames.topology import TopologySnapshot
    >>> snap = TopologySnapshot.from_hop_matrix(0.0, np.zeros((1, 1), int))
    >>> batch = local_games(snap, 1, np.zeros((1, 3)), DisplacementActions.headings(1.0, 4, dim=3))
    >>> pot = Inertia(FunctionPotentials(lambda s: np.zeros(s.shape[:-1])), cost=0.5)
    >>> pot.unary(batch)[0, 0].tolist()
    [0.0, -0.5, -0.5, -0.5, -0.5]
    """

    potentials: Potentials
    cost: float
    dims: int = 3
    tol: float = 1e-9

    def __post_init__(self) -> None:
        if not (np.isfinite(self.cost) and self.cost >= 0):
            raise ValueError(f"cost must be >= 0 and finite (got {self.cost})")
        if isinstance(self.dims, bool) or not isinstance(self.dims, int) or self.dims < 1:
            raise ValueError(f"dims must be an integer >= 1 (got {self.dims!r})")

    @property
    def capabilities(self) -> PotentialCapabilities:
        """The wrapped potentials' declared forms, and ``owner_rows`` wherever the wrapped
        ones declare it or have no pairwise table (whose owner rows would be needed)."""
        inner = capabilities_of(self.potentials)
        return replace(inner, owner_rows=inner.owner_rows or not inner.pair_table)

    def unary(self, batch: LocalGameBatch) -> np.ndarray:
        """The wrapped unary minus ``cost`` wherever the action moves the robot, (B, K, A)."""
        out = np.asarray(self.potentials.unary(batch), dtype=float)
        if not self.cost:
            return out
        d = self.dims
        nxt = np.asarray(batch.next_states, dtype=float)[..., :d]
        now = np.asarray(batch.states, dtype=float)[..., None, :d]
        moved = np.any(np.abs(nxt - now) > self.tol, axis=-1)
        return out - np.where(moved, self.cost, 0.0)

    def owner_unary(self, batch: LocalGameBatch) -> np.ndarray:
        """:meth:`unary` of every game's variable 0 only, (B, A), bit for bit (the wrapped
        potentials' ``owner_unary`` if they have one)."""
        if capabilities_of(self.potentials).owner_rows:
            out = np.asarray(self.potentials.owner_unary(batch), dtype=float)
        else:
            out = np.asarray(self.potentials.unary(batch), dtype=float)[:, 0]
        if not self.cost:
            return out
        d = self.dims
        nxt = np.asarray(batch.next_states, dtype=float)[:, 0, :, :d]
        now = np.asarray(batch.states, dtype=float)[:, 0, None, :d]
        moved = np.any(np.abs(nxt - now) > self.tol, axis=-1)
        return out - np.where(moved, self.cost, 0.0)

    def pairwise(self, batch: LocalGameBatch) -> np.ndarray | None:
        """The wrapped pairwise term, unchanged."""
        return self.potentials.pairwise(batch)

    def pair_table(self, batch: LocalGameBatch, dtype=np.float64) -> np.ndarray | None:
        """The wrapped ``pair_table`` (declared ``pair_table``)."""
        return self.potentials.pair_table(batch, dtype)

    def owner_pair_table(self, batch: LocalGameBatch, dtype=np.float64) -> np.ndarray | None:
        """The wrapped ``owner_pair_table`` (declared ``owner_rows`` and ``pair_table``)."""
        return self.potentials.owner_pair_table(batch, dtype)

    def pair_source(self, batch: LocalGameBatch, weights, dtype=np.float64):
        """The wrapped ``pair_source`` (declared ``pair_source``)."""
        return self.potentials.pair_source(batch, weights, dtype)

    def pair_on_demand(self, dtype) -> bool:
        """The wrapped ``pair_on_demand`` (declared ``pair_source``)."""
        return self.potentials.pair_on_demand(dtype)

    def held_sharing_min(self, dtype) -> int | None:
        """The wrapped ``held_sharing_min`` (declared ``held_sharing``)."""
        return self.potentials.held_sharing_min(dtype)

    def neighbourhood(self, batch: LocalGameBatch) -> np.ndarray:
        """The wrapped neighbourhood term, unchanged (declared ``neighbourhood``)."""
        return self.potentials.neighbourhood(batch)

    def stage_bytes(self, k: int, a: int, games: int, n: int) -> tuple[float, float, float]:
        """The wrapped ``stage_bytes`` (declared ``memory``): the cost adds no array."""
        return self.potentials.stage_bytes(k, a, games, n)
