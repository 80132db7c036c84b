"""Padded batch of local games: one immutable container for the B local games of a stage.

Every field is an array whose leading axis is the game (one per deciding robot), in the
spirit of jraph's ``GraphsTuple``: the local game of robot ``owner[b]`` has ``mask[b].sum()``
variables, variable 0 being the owner itself, and each variable ``k`` has the actions
``action_mask[b, k]``. Padding (``members == -1``, ``mask`` false, ``action_mask`` false) never
carries probability or payoff.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C (local game decomposition).
"""

from __future__ import annotations

import copy
import numbers
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from swarmgames.arrays import frozen
from swarmgames.game.equal import EqualGames, equal_games
from swarmgames.game.rows import StageRows, row_ids

__all__ = ["LocalGameBatch"]


@dataclass(frozen=True, eq=False)
class LocalGameBatch:
    """B local games as padded arrays (K = most variables, A = most actions, D = state size).

    Parameters
    ----------
    owner : ndarray of int32, shape (B,)
        Robot whose local game each row is; ``-1`` for a game with no single owner (the
        centralised game).
    members : ndarray of int32, shape (B, K)
        Global robot ids of the local variables, ``-1`` = padding. Column 0 is the owner.
    mask : ndarray of bool, shape (B, K)
        Valid variables.
    states : ndarray of float, shape (B, K, D)
        State of each variable as the owner sees it: the member's reported state, or its
        virtual mean S̄_j (paper eq. 3) where ``is_virtual``. Zero at padding.
    is_virtual : ndarray of bool, shape (B, K)
        Variables replaced by a virtual mean neighbour.
    next_states : ndarray of float, shape (B, K, A, D)
        State of each variable after each action (from the action model).
    action_mask : ndarray of bool, shape (B, K, A)
        Valid actions; false everywhere on padded variables.
    pair_mask : ndarray of bool, shape (B, K, K), optional
        Pairs ``(k, l)`` whose pairwise potential counts. ``None`` (default): every pair of
        distinct valid variables, as in eq. 1 where the sum runs over all of N_i. The
        centralised game uses it to keep only pairs within h hops.
    is_context : ndarray of bool, shape (B, K), optional
        Variables that are context, not players (``virtual_mean = "exact"``: the robots of
        the members' neighbourhoods outside N_i, at their reported states, with a single
        action); ``None`` (default): none.
    t : float, default 0.0
        The stage time in seconds: the simulation's clock when the games are played (the
        warm-up plus the stage number times the control period). Potentials that depend on
        time (a moving target) read it here, never from the states; 0.0 for games built
        outside a run.
    stage : StageRows, optional
        The distinct rows of the stage the games belong to (:mod:`~swarmgames.game.rows`),
        shared by every batch of the stage; default: rows of this batch alone.

    Notes
    -----
    All arrays are copied and made read-only. Use :meth:`select` to take a subset of games
    and :meth:`trim` to drop padding columns no game uses; both keep ``t`` and ``stage``.
    :attr:`rows` refers every variable to its stage row, and :attr:`equal_games` names the
    games that hold the same rows; both are computed on first use.
    """

    owner: np.ndarray
    members: np.ndarray
    mask: np.ndarray
    states: np.ndarray
    is_virtual: np.ndarray
    next_states: np.ndarray
    action_mask: np.ndarray
    pair_mask: np.ndarray | None = field(default=None)
    is_context: np.ndarray | None = field(default=None)
    t: float = 0.0
    stage: StageRows | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.stage is None:
            object.__setattr__(self, "stage", StageRows())
        elif not isinstance(self.stage, StageRows):
            raise ValueError(f"stage must be a StageRows (got {type(self.stage).__name__})")
        t = self.t
        if isinstance(t, bool) or not isinstance(t, numbers.Real) or not np.isfinite(t):
            raise ValueError(f"t must be a finite number of seconds (got {t!r})")
        object.__setattr__(self, "t", float(t))
        members = np.asarray(self.members)
        if members.ndim != 2:
            raise ValueError(f"members must have shape (B, K) (got {members.shape})")
        b, k = members.shape
        states = np.asarray(self.states, dtype=float)
        if states.ndim != 3 or states.shape[:2] != (b, k):
            raise ValueError(f"states must have shape ({b}, {k}, D) (got {states.shape})")
        d = states.shape[2]
        nxt = np.asarray(self.next_states, dtype=float)
        if nxt.ndim != 4 or nxt.shape[:2] != (b, k) or nxt.shape[3] != d:
            raise ValueError(f"next_states must have shape ({b}, {k}, A, {d}) (got {nxt.shape})")
        a = nxt.shape[2]
        expected = {
            "owner": (b,),
            "mask": (b, k),
            "is_virtual": (b, k),
            "action_mask": (b, k, a),
        }
        for name, shape in expected.items():
            got = np.shape(getattr(self, name))
            if got != shape:
                raise ValueError(f"{name} must have shape {shape} (got {got})")
        object.__setattr__(self, "owner", frozen(self.owner, np.int32))
        object.__setattr__(self, "members", frozen(members, np.int32))
        object.__setattr__(self, "mask", frozen(self.mask, bool))
        object.__setattr__(self, "states", frozen(states))
        object.__setattr__(self, "is_virtual", frozen(self.is_virtual, bool))
        object.__setattr__(self, "next_states", frozen(nxt))
        amask = np.asarray(self.action_mask, dtype=bool) & self.mask[:, :, None]
        object.__setattr__(self, "action_mask", frozen(amask))
        if self.pair_mask is not None:
            if np.shape(self.pair_mask) != (b, k, k):
                raise ValueError(
                    f"pair_mask must have shape {(b, k, k)} (got {np.shape(self.pair_mask)})"
                )
            object.__setattr__(self, "pair_mask", frozen(self.pair_mask, bool))
        if self.is_context is not None:
            if np.shape(self.is_context) != (b, k):
                raise ValueError(
                    f"is_context must have shape {(b, k)} (got {np.shape(self.is_context)})"
                )
            object.__setattr__(self, "is_context", frozen(self.is_context, bool))

    @cached_property
    def rows(self) -> np.ndarray:
        """The stage row of every variable, (B, K) int64, -1 at padding: equal rows hold the
        same robot (or virtual mean) in the same state, with the same next states and valid
        actions, in every batch of the stage (:class:`~swarmgames.game.rows.StageRows`)."""
        out = self.stage.index(
            row_ids(self.members, self.is_virtual), self.mask, self.states, self.next_states,
            self.action_mask,
        )  # fmt: skip
        out.setflags(write=False)
        return out

    @cached_property
    def equal_games(self) -> EqualGames | None:
        """The games that hold the same rows as an earlier game of the batch, up to order
        (:func:`~swarmgames.game.equal.equal_games`); None when there is none."""
        return equal_games(self.rows, self.mask)

    def at(self, actions) -> LocalGameBatch:
        """The same games with every variable held at one action, its robot's in the joint
        action ``actions`` (N,) (a virtual mean at its member's, a context variable at its
        only one): games of one action whose payoff tables hold, at action 0, every
        variable's potentials at that joint action (whether the action model allows the
        action or not: it is the one taken). Their stage is a fresh one: their rows are not
        the full games' rows.

        Examples
        --------
        >>> import numpy as np
        >>> from swarmgames.game import DisplacementActions, local_games
        >>> from swarmgames.network import TopologySnapshot
        >>> snap = TopologySnapshot.from_hop_matrix(0.0, np.array([[0, 1], [1, 0]]))
        >>> moves = DisplacementActions.headings(1.0, 4)
        >>> one = local_games(snap, 1, np.zeros((2, 2)), moves).at(np.array([1, 2]))
        >>> one.next_states[0, :, 0].tolist()
        [[1.0, 0.0], [0.0, 1.0]]
        """
        acts = np.asarray(actions, dtype=np.int64).reshape(-1)
        members = np.asarray(self.members)
        take = np.where(self.mask, acts[np.maximum(members, 0)], 0)
        if self.is_context is not None:
            take = np.where(self.is_context, 0, take)
        return LocalGameBatch(
            self.owner,
            members,
            self.mask,
            self.states,
            self.is_virtual,
            np.take_along_axis(self.next_states, take[:, :, None, None], axis=2),
            self.mask[:, :, None],  # the action taken, allowed or not
            self.pair_mask,
            self.is_context,
            self.t,
        )

    def on(self, stage: StageRows) -> LocalGameBatch:
        """The same games as part of ``stage`` (its rows numbered there); the arrays are
        shared, not copied."""
        out = copy.copy(self)
        out.__dict__.pop("rows", None)
        out.__dict__.pop("equal_games", None)
        object.__setattr__(out, "stage", stage)
        return out

    def _with_rows(self, out: LocalGameBatch, rows) -> LocalGameBatch:
        """``out`` with the rows ``rows`` of this batch's (when computed already)."""
        if "rows" in self.__dict__:
            out.__dict__["rows"] = self.rows[rows]
        return out

    @property
    def players(self) -> np.ndarray:
        """Boolean ``(B, K)``: valid variables that decide (not context)."""
        if self.is_context is None:
            return self.mask
        return self.mask & ~self.is_context

    @property
    def n_games(self) -> int:
        """B, the number of local games."""
        return int(self.members.shape[0])

    @property
    def n_vars(self) -> int:
        """K, the padded number of variables per game."""
        return int(self.members.shape[1])

    @property
    def n_actions(self) -> int:
        """A, the padded number of actions per variable."""
        return int(self.next_states.shape[2])

    @property
    def state_dim(self) -> int:
        """D, the size of a state vector."""
        return int(self.states.shape[2])

    def valid_pairs(self) -> np.ndarray:
        """Boolean ``(B, K, K)``: pairs of distinct valid variables whose pairwise term counts."""
        k = self.n_vars
        pairs = self.mask[:, :, None] & self.mask[:, None, :] & ~np.eye(k, dtype=bool)
        if self.pair_mask is not None:
            pairs &= self.pair_mask
        return pairs

    def select(self, games) -> LocalGameBatch:
        """The sub-batch of the games ``games`` (indices or a boolean mask over B)."""
        idx = np.arange(self.n_games)[games]
        out = LocalGameBatch(
            owner=self.owner[idx],
            members=self.members[idx],
            mask=self.mask[idx],
            states=self.states[idx],
            is_virtual=self.is_virtual[idx],
            next_states=self.next_states[idx],
            action_mask=self.action_mask[idx],
            pair_mask=None if self.pair_mask is None else self.pair_mask[idx],
            is_context=None if self.is_context is None else self.is_context[idx],
            t=self.t,
            stage=self.stage,
        )
        return self._with_rows(out, idx)

    def trim(self) -> LocalGameBatch:
        """The same games with the trailing padding columns that no game uses dropped."""
        used_k = np.flatnonzero(self.mask.any(axis=0))
        used_a = np.flatnonzero(self.action_mask.any(axis=(0, 1)))
        k = int(used_k[-1]) + 1 if used_k.size else 1
        a = int(used_a[-1]) + 1 if used_a.size else 1
        return LocalGameBatch(
            owner=self.owner,
            members=self.members[:, :k],
            mask=self.mask[:, :k],
            states=self.states[:, :k],
            is_virtual=self.is_virtual[:, :k],
            next_states=self.next_states[:, :k, :a],
            action_mask=self.action_mask[:, :k, :a],
            pair_mask=None if self.pair_mask is None else self.pair_mask[:, :k, :k],
            is_context=None if self.is_context is None else self.is_context[:, :k],
            t=self.t,
            stage=self.stage,
        )

    @classmethod
    def concat(cls, batches) -> LocalGameBatch:
        """One batch holding the games of ``batches`` in order, padded to the widest K and A.

        All batches must have the same state size D and the same stage time ``t``.
        ``pair_mask`` is kept only if every batch has one (None otherwise); the batches'
        stage is kept when they share one.
        """
        batches = list(batches)
        if not batches:
            raise ValueError("batches must not be empty")
        d = {b.state_dim for b in batches}
        if len(d) != 1:
            raise ValueError(f"batches must share the state size D (got {sorted(d)})")
        times = {b.t for b in batches}
        if len(times) != 1:
            raise ValueError(f"batches must share the stage time t (got {sorted(times)})")
        k = max(b.n_vars for b in batches)
        a = max(b.n_actions for b in batches)

        def pad(arr, width, fill):
            widths = [(0, 0)] * arr.ndim
            for axis, size in width.items():
                widths[axis] = (0, size - arr.shape[axis])
            return np.pad(arr, widths, constant_values=fill)

        keep_pairs = all(b.pair_mask is not None for b in batches)
        any_context = any(b.is_context is not None for b in batches)

        def context(b):
            return np.zeros(b.mask.shape, dtype=bool) if b.is_context is None else b.is_context

        return cls(
            owner=np.concatenate([b.owner for b in batches]),
            members=np.concatenate([pad(b.members, {1: k}, -1) for b in batches]),
            mask=np.concatenate([pad(b.mask, {1: k}, False) for b in batches]),
            states=np.concatenate([pad(b.states, {1: k}, 0.0) for b in batches]),
            is_virtual=np.concatenate([pad(b.is_virtual, {1: k}, False) for b in batches]),
            next_states=np.concatenate([pad(b.next_states, {1: k, 2: a}, 0.0) for b in batches]),
            action_mask=np.concatenate([pad(b.action_mask, {1: k, 2: a}, False) for b in batches]),
            pair_mask=np.concatenate([pad(b.pair_mask, {1: k, 2: k}, False) for b in batches])
            if keep_pairs
            else None,
            is_context=np.concatenate([pad(context(b), {1: k}, False) for b in batches])
            if any_context
            else None,
            t=batches[0].t,
            stage=batches[0].stage if all(b.stage is batches[0].stage for b in batches) else None,
        )
