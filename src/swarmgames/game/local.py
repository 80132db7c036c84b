"""Local game decomposition: robot i's game built only from what robot i has received.

The decomposition has three stages, and each one can only see what the previous one hands it:

1. :func:`broadcast` — what every robot j sends: its own state S_j, its neighbourhood N_j read
   from its own routing table (N_j(h) = {k : Hops(j, k) <= h}, j included) and the mean S̄_j
   of the states its neighbours reported (eq. 3). This is the only step that sees the whole
   swarm, and only to simulate every robot's transmission (:class:`Messages`).
2. :func:`receive` / :func:`gather_views` — the "radio": robot i's inbox, the messages of the
   members of its own N_i and nothing else (:class:`LocalView`, or :class:`LocalViews` padded
   for a whole stage).
3. :func:`build_local_game` / :func:`build_local_games` — the local game, a
   :class:`~swarmgames.game.batch.LocalGameBatch`. The builders take a view, not the swarm:
   they cannot read global state because they are never given it.

How the members whose neighbourhoods reach outside N_i stand in for the outside is
``virtual_mean`` (:data:`~swarmgames.names.VIRTUAL_MEANS`, :mod:`swarmgames.game.virtual`):
eq. 3's virtual mean (``"eq3"``), the mean over N_j − N_i (``"outside"``), nothing
(``"off"``), or the outside robots themselves (``"exact"``): then the inbox also holds the
*context* of robot i, C_i = ∪_{j ∈ N_i} N_j − N_i, with their reported states, and the game
holds them as variables with a single action that keeps them where they are. They decide
nothing, but the members' unary and pairwise potentials see them as they are.

:func:`local_games` chains the three for a whole stage; :func:`centralised_game` builds the
single swarm-wide game of the centralised baseline.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.A (neighbourhoods from routing
   tables), II.C and Algorithm 1 lines 1-3 (local games, virtual means).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
import scipy.sparse as sp

from swarmgames.arrays import csr_gather, frozen, sorted_unique
from swarmgames.game.actions import ActionModel, action_mask_of
from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.virtual import (
    member_columns,
    neighbourhood_means,
    outside_means,
    reaches_outside,
    virtual_mode,
)
from swarmgames.topology import TopologySnapshot

__all__ = [
    "Inbox",
    "LocalView",
    "LocalViews",
    "Messages",
    "broadcast",
    "build_local_game",
    "build_local_games",
    "centralised_game",
    "context_rows",
    "gather_views",
    "local_games",
    "pad_rows",
    "receive",
]


@runtime_checkable
class Inbox(Protocol):
    """What the robots of a stage know of their neighbourhoods; the local games are built from
    this and nothing else.

    :class:`Messages` is the exact, instant inbox; :mod:`swarmgames.comms` builds inboxes from
    what a communication model delivered (late, lost, stale). For ``virtual_mean = "exact"``
    an inbox also needs ``context_sizes`` (|C_i| of every robot, shape (N,)) and
    ``views(owners, context=True)``; the other variants use only the members below.
    """

    @property
    def exact(self) -> bool:
        """Whether every robot holds the exact current state of every member of its N_i(h)
        (then the stage takes these messages as the truth its measurements need)."""
        ...

    @property
    def sizes(self) -> np.ndarray:
        """|N_i| of the local game each robot would build (owner included), shape (N,)."""
        ...

    def views(self, owners=None, *, context: bool = False) -> LocalViews:
        """The inboxes of ``owners`` (default: every robot), padded; with ``context``, the
        states of their contexts C_i too (``virtual_mean = "exact"``)."""
        ...


@dataclass(frozen=True, eq=False)
class Messages:
    """What every robot broadcasts in one stage.

    Parameters
    ----------
    state : ndarray, shape (N, D)
        Reported state S_j of every robot.
    indptr, indices : ndarray of int
        CSR rows: ``indices[indptr[j]:indptr[j + 1]]`` is N_j, sorted, j included.
    mean_state : ndarray, shape (N, D)
        S̄_j of eq. 3, computed by j from its neighbours' reports.
    """

    state: np.ndarray
    indptr: np.ndarray
    indices: np.ndarray
    mean_state: np.ndarray

    @classmethod
    def concat(cls, parts) -> Messages:
        """The messages of independent swarms side by side: swarm ``e``'s robot ``j`` becomes
        robot ``offset_e + j`` (``offset_e`` the robots of the swarms before it), as in
        :meth:`~swarmgames.topology.TopologySnapshot.concat`."""
        parts = list(parts)
        sizes = np.array([p.n_robots for p in parts], dtype=np.int64)
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        entries = np.array([p.indices.size for p in parts], dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(entries)[:-1]])
        return cls(
            state=frozen(np.concatenate([p.state for p in parts])),
            indptr=frozen(
                np.concatenate(
                    [
                        [0],
                        *(np.asarray(p.indptr[1:]) + s for p, s in zip(parts, starts, strict=True)),
                    ]
                ),
                np.int64,
            ),
            indices=frozen(
                np.concatenate(
                    [np.asarray(p.indices) + o for p, o in zip(parts, offsets, strict=True)]
                ),
                np.int32,
            ),
            mean_state=frozen(np.concatenate([p.mean_state for p in parts])),
        )

    @property
    def exact(self) -> bool:
        """True: every member receives every message of its neighbourhood, at once."""
        return True

    @property
    def n_robots(self) -> int:
        """N, the number of robots that broadcast."""
        return int(self.state.shape[0])

    def neighbourhood(self, j: int) -> np.ndarray:
        """N_j as robot j reported it."""
        return self.indices[self.indptr[j] : self.indptr[j + 1]]

    @property
    def sizes(self) -> np.ndarray:
        """|N_i| of every robot's local game (owner included), shape (N,)."""
        return np.diff(self.indptr)

    @property
    def context_sizes(self) -> np.ndarray:
        """|C_i|, the robots of the members' neighbourhoods outside N_i, shape (N,)."""
        n = self.n_robots
        nbh = sp.csr_array(
            (np.ones(self.indices.size, dtype=np.int32), self.indices, self.indptr), shape=(n, n)
        )
        return np.diff((nbh @ nbh).indptr) - self.sizes

    def views(self, owners=None, *, context: bool = False) -> LocalViews:
        """The inboxes of ``owners`` (:func:`gather_views`): every member's exact message,
        delivered instantly (the ``ideal`` delivery of :mod:`swarmgames.comms`); with
        ``context``, the exact states of C_i as well."""
        return gather_views(self, owners, context=context)


def _validate_states(states, n: int) -> np.ndarray:
    states = np.asarray(states, dtype=float)
    if states.ndim != 2 or states.shape[0] != n:
        raise ValueError(f"states must have shape ({n}, D) (got {states.shape})")
    if not np.all(np.isfinite(states)):
        bad = int(np.argwhere(~np.isfinite(states))[0, 0])
        raise ValueError(f"states must be finite (robot {bad} is not)")
    return states


def broadcast(snapshot: TopologySnapshot, h: int, states: np.ndarray) -> Messages:
    """Every robot's message of one stage: its state, its N_j(h) and its S̄_j (eq. 3).

    Parameters
    ----------
    snapshot : TopologySnapshot
        Every robot's routing table; robot j reads N_j(h) from its own entries only.
    h : int
        Neighbourhood radius in hops, >= 1 (paper: 2).
    states : ndarray, shape (N, D)
        Each robot's own state (positions, and velocities where the model needs them).

    Returns
    -------
    Messages
    """
    if not isinstance(h, (int, np.integer)) or h < 1:
        raise ValueError(f"h must be an integer >= 1 (got {h})")
    states = _validate_states(states, snapshot.n_robots)
    nbh = snapshot.neighbourhood_matrix(int(h))
    nbh.sort_indices()
    return Messages(
        state=frozen(states),
        indptr=frozen(nbh.indptr, np.int64),
        indices=frozen(nbh.indices, np.int32),
        mean_state=frozen(neighbourhood_means(nbh, states)),
    )


@dataclass(frozen=True, eq=False)
class LocalView:
    """Robot i's inbox: the messages of the members of its own neighbourhood.

    Parameters
    ----------
    owner : int
        Robot i.
    members : ndarray of int32, shape (K,)
        N_i, owner first, then the others in increasing id.
    states : ndarray, shape (K, D)
        Their reported states.
    mean_states : ndarray, shape (K, D)
        Their reported S̄_j (eq. 3).
    neighbourhoods : tuple of ndarray
        Their reported N_j.
    context : ndarray of int32, shape (C,), optional
        C_i = ∪_j N_j − N_i in increasing id (only for ``virtual_mean = "exact"``).
    context_states : ndarray, shape (C, D), optional
        Their reported states.
    """

    owner: int
    members: np.ndarray
    states: np.ndarray
    mean_states: np.ndarray
    neighbourhoods: tuple[np.ndarray, ...]
    context: np.ndarray | None = None
    context_states: np.ndarray | None = None


def _owner_first(row: np.ndarray, owner: int) -> np.ndarray:
    return np.concatenate([[owner], row[row != owner]]).astype(np.int32)


def receive(messages: Messages, owner: int, *, context: bool = False) -> LocalView:
    """Robot ``owner``'s inbox: the messages of N_owner, as its own routing table gives it;
    with ``context``, also the states of C_owner = ∪_{j ∈ N_owner} N_j − N_owner (written
    with set operations: the reference of :func:`gather_views`)."""
    if not 0 <= owner < messages.n_robots:
        raise ValueError(f"owner must be in [0, {messages.n_robots}) (got {owner})")
    members = _owner_first(messages.neighbourhood(owner), owner)
    nbhs = tuple(frozen(messages.neighbourhood(int(j))) for j in members)
    extra = {}
    if context:
        ctx = set().union(*(set(nb.tolist()) for nb in nbhs)) - set(members.tolist())
        ids = np.array(sorted(ctx), dtype=np.int32)
        extra = {
            "context": frozen(ids),
            "context_states": frozen(messages.state[ids]),
        }
    return LocalView(
        owner=int(owner),
        members=frozen(members),
        states=frozen(messages.state[members]),
        mean_states=frozen(messages.mean_state[members]),
        neighbourhoods=nbhs,
        **extra,
    )


@dataclass(frozen=True, eq=False)
class LocalViews:
    """The inboxes of B robots as padded arrays (the batched :class:`LocalView`).

    Parameters
    ----------
    owner : ndarray of int32, shape (B,)
    members : ndarray of int32, shape (B, K)
        N_i, owner first, ``-1`` padded.
    mask : ndarray of bool, shape (B, K)
    states, mean_states : ndarray, shape (B, K, D)
        Reported S_j and S̄_j; 0 at padding.
    neighbourhoods : ndarray of int32, shape (B, K, L)
        Reported N_j, ``-1`` padded (L = largest |N_j|).
    context : ndarray of int32, shape (B, C), optional
        C_i = ∪_{j ∈ N_i} N_j − N_i as far as the owner holds their states, increasing id,
        ``-1`` padded (only in views asked for with ``context=True``).
    context_states : ndarray, shape (B, C, D), optional
        Their reported states; 0 at padding.
    """

    owner: np.ndarray
    members: np.ndarray
    mask: np.ndarray
    states: np.ndarray
    mean_states: np.ndarray
    neighbourhoods: np.ndarray
    context: np.ndarray | None = None
    context_states: np.ndarray | None = None


PAD_COMPILED_MIN = 4096
"""Rows asked of :func:`pad_rows` from which the compiled copy is used."""


def pad_rows(indptr: np.ndarray, indices: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """CSR rows ``rows`` (any shape) as a ``rows.shape + (L,)`` array, -1 padded; -1 rows are
    empty (L = the longest row asked for, at least 1).

    Examples
    --------
    >>> pad_rows(np.array([0, 2, 3]), np.array([5, 6, 7]), np.array([1, 0])).tolist()
    [[7, -1], [5, 6]]

    Many rows (:data:`PAD_COMPILED_MIN` entries, a dense swarm's neighbourhoods) are copied
    by a compiled loop (:mod:`~swarmgames.game.local_compiled`), with the same result.
    """
    if rows.size >= PAD_COMPILED_MIN:
        from swarmgames.game.local_compiled import compiled_pad_rows

        return compiled_pad_rows(indptr, indices, rows)
    flat = rows.ravel()
    ok = flat >= 0
    entry, row_id = csr_gather(indptr, flat[ok])
    row_id = np.flatnonzero(ok)[row_id]
    count = np.bincount(row_id, minlength=flat.size)
    out = np.full((flat.size, max(int(count.max(initial=0)), 1)), -1, dtype=np.int32)
    col = np.arange(row_id.size) - np.repeat(np.cumsum(count) - count, count)
    out[row_id, col] = indices[entry]
    return out.reshape((*rows.shape, out.shape[1]))


def context_rows(members: np.ndarray, mask: np.ndarray, neighbourhoods: np.ndarray):
    """C_i = ∪_{j ∈ N_i} N_j − N_i of every game: the robots of the members' reported
    neighbourhoods that are not members, shape (B, C), increasing id, ``-1`` padded
    (vectorised over the games).

    Examples
    --------
    >>> members = np.array([[1, 0, 2]])
    >>> nbh = np.array([[[0, 1, 2], [0, 1, -1], [1, 2, 3]]])
    >>> context_rows(members, members >= 0, nbh).tolist()
    [[3]]
    """
    nbh = np.asarray(neighbourhoods, dtype=np.int64)
    b = nbh.shape[0]
    outside = (nbh >= 0) & (member_columns(members, mask, nbh) < 0)
    game = np.broadcast_to(np.arange(b)[:, None, None], nbh.shape)[outside]
    span = int(nbh.max(initial=0)) + 1
    keys = sorted_unique(game * span + nbh[outside])
    game, ids = np.divmod(keys, span)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(game, minlength=b))])
    return pad_rows(indptr, ids.astype(np.int32), np.arange(b))


def gather_views(messages: Messages, owners=None, *, context: bool = False) -> LocalViews:
    """The inboxes of ``owners`` (default: every robot), padded.

    Each inbox holds only the messages of the owner's own N_i; the local-game builder receives
    nothing else. With ``context`` it also holds the states of the owner's context
    C_i = ∪_{j ∈ N_i} N_j − N_i (robots within 2h hops, for ``virtual_mean = "exact"``).
    """
    n = messages.n_robots
    owners = np.arange(n) if owners is None else np.asarray(owners, dtype=np.int64).reshape(-1)
    if owners.size and (owners.min() < 0 or owners.max() >= n):
        raise ValueError(f"owners must be in [0, {n}) (got {owners.min()}..{owners.max()})")
    rows = pad_rows(messages.indptr, messages.indices, owners)  # (B, K), sorted, owner inside
    mask = rows >= 0
    # Owner first, the rest in increasing id (stable sort on "is not the owner").
    key = (~mask).astype(np.int8) + (rows != owners[:, None])
    order = np.argsort(key, axis=1, kind="stable")
    members = np.take_along_axis(rows, order, axis=1)
    mask = members >= 0
    safe = np.where(mask, members, 0)
    zero = ~mask[:, :, None]
    nbh = pad_rows(messages.indptr, messages.indices, members)
    extra = {}
    if context:
        ctx = context_rows(members, mask, nbh)
        extra = {
            "context": frozen(ctx, np.int32),
            "context_states": frozen(
                np.where(ctx[:, :, None] < 0, 0.0, messages.state[np.maximum(ctx, 0)])
            ),
        }
    return LocalViews(
        owner=frozen(owners, np.int32),
        members=frozen(members, np.int32),
        mask=frozen(mask),
        states=frozen(np.where(zero, 0.0, messages.state[safe])),
        mean_states=frozen(np.where(zero, 0.0, messages.mean_state[safe])),
        neighbourhoods=frozen(nbh),
        **extra,
    )


def _game_from_states(
    owner,
    members,
    mask,
    states,
    is_virtual,
    action_model: ActionModel,
    pair_mask=None,
    is_context=None,
    *,
    t: float = 0.0,
) -> LocalGameBatch:
    n_actions = int(action_model.n_actions)
    if n_actions < 1:
        raise ValueError(f"action model n_actions must be >= 1 (got {n_actions})")
    next_states = np.asarray(action_model.apply(states), dtype=float)
    expected = (*states.shape[:2], n_actions, states.shape[2])
    if next_states.shape != expected:
        raise ValueError(
            f"action model apply() must return shape {expected} (got {next_states.shape})"
        )
    action_mask = action_mask_of(action_model, states) & mask[:, :, None]
    if is_context is not None and is_context.any():
        # A context robot decides nothing: one action, the "stay" of the model where it has
        # one (else the first), and every action leaves it where it is.
        stays = np.all(next_states == states[:, :, None, :], axis=3) & action_mask
        only = np.where(stays.any(axis=2), np.argmax(stays, axis=2), 0)
        one = np.arange(n_actions) == only[:, :, None]
        action_mask = np.where(is_context[:, :, None], one, action_mask)
        next_states = np.where(is_context[:, :, None, None], states[:, :, None, :], next_states)
    return LocalGameBatch(
        owner=owner,
        members=members,
        mask=mask,
        states=states,
        is_virtual=is_virtual,
        next_states=next_states,
        action_mask=action_mask,
        pair_mask=pair_mask,
        is_context=is_context,
        t=t,
    )


def _with_context(views: LocalViews):
    """Members then context, left-packed per game: members, mask, states, is_context."""
    if views.context is None or views.context_states is None:
        raise ValueError(
            "virtual_mean = 'exact' needs the states of every game's context: build the views "
            "with context=True (gather_views(..., context=True), inbox.views(..., context=True))"
        )
    k = views.members.shape[1]
    members = np.concatenate([views.members, views.context], axis=1)
    states = np.concatenate([views.states, views.context_states], axis=1)
    mask = members >= 0
    order = np.argsort(~mask, axis=1, kind="stable")
    is_context = np.broadcast_to(np.arange(members.shape[1]) >= k, members.shape)
    take = lambda a: np.take_along_axis(a, order, axis=1)  # noqa: E731
    states = np.take_along_axis(states, order[:, :, None], axis=1)
    mask = take(mask)
    width = max(int(mask.sum(axis=1).max(initial=1)), 1)
    return (
        take(members)[:, :width],
        mask[:, :width],
        states[:, :width],
        take(is_context)[:, :width] & mask[:, :width],
    )


def build_local_games(
    views: LocalViews,
    action_model: ActionModel,
    *,
    virtual_mean: bool | str = "eq3",
    t: float = 0.0,
) -> LocalGameBatch:
    """The local games of a batch of inboxes (vectorised).

    Parameters
    ----------
    views : LocalViews
        The owners' inboxes (from :func:`gather_views`; with ``context=True`` for
        ``"exact"``).
    action_model : ActionModel
    virtual_mean : {"eq3", "outside", "exact", "off"} or bool, default "eq3"
        How a member j with N_j − N_i ≠ ∅ stands in for the robots outside N_i:
        ``"eq3"`` (or True) its virtual mean S̄_j over N_j (eq. 3); ``"outside"`` the mean
        over N_j − N_i (:func:`~swarmgames.game.virtual.outside_means`); ``"off"`` (or
        False) nothing, the reported states (the paper's comparison); ``"exact"`` every
        member keeps its reported state and the context C_i = ∪_j N_j − N_i joins the game
        as variables with a single action that keeps them in place (``is_context``).
    t : float, default 0.0
        The stage time in seconds (``LocalGameBatch.t``), for potentials that depend on time.

    Returns
    -------
    LocalGameBatch
    """
    mode = virtual_mode(virtual_mean)
    if mode == "exact":
        members, mask, states, is_context = _with_context(views)
        return _game_from_states(
            views.owner,
            members,
            mask,
            states,
            np.zeros(mask.shape, dtype=bool),
            action_model,
            is_context=is_context,
            t=t,
        )
    if mode == "off":
        is_virtual = np.zeros(np.shape(views.mask), dtype=bool)
    else:
        is_virtual = reaches_outside(views.members, views.mask, views.neighbourhoods)
        # The owner is never a virtual robot (N_i − N_i = ∅): its N_i is its own routing
        # table, which may list neighbours it has not heard from yet, but it knows its state.
        is_virtual[:, 0] = False
    means = views.mean_states
    if mode == "outside":
        means = outside_means(
            views.members, views.mask, views.states, views.mean_states, views.neighbourhoods
        )
    states = np.where(is_virtual[:, :, None], means, views.states)
    return _game_from_states(
        views.owner, views.members, views.mask, states, is_virtual, action_model, t=t
    )


def build_local_game(
    view: LocalView,
    action_model: ActionModel,
    *,
    virtual_mean: bool | str = "eq3",
    t: float = 0.0,
) -> LocalGameBatch:
    """Robot ``view.owner``'s local game alone, as a batch of one game with no padding.

    Same result as :func:`build_local_games` on the same inbox and stage time ``t``; written
    per robot with set operations, it is the reference the batched builder is tested against.
    """
    mode = virtual_mode(virtual_mean)
    members = np.asarray(view.members, dtype=np.int32)
    states = np.asarray(view.states, dtype=float)
    inside = set(members.tolist())
    if mode == "exact":
        if view.context is None:
            raise ValueError("virtual_mean = 'exact' needs the view's context (context=True)")
        ctx = np.asarray(view.context, dtype=np.int32)
        all_members = np.concatenate([members, ctx])
        all_states = np.concatenate([states, np.asarray(view.context_states, dtype=float)])
        k = all_members.size
        return _game_from_states(
            np.array([view.owner]),
            all_members[None],
            np.ones((1, k), dtype=bool),
            all_states[None],
            np.zeros((1, k), dtype=bool),
            action_model,
            is_context=(np.arange(k) >= members.size)[None],
            t=t,
        )
    outside = [set(nb.tolist()) - inside for nb in view.neighbourhoods]
    outside[0] = set()  # the owner (column 0) is never virtual
    is_virtual = np.array([bool(o) for o in outside]) & (mode != "off")
    means = np.array(view.mean_states, dtype=float)
    if mode == "outside":
        # |N_j| S̄_j less the copies i holds of N_j ∩ N_i, over |N_j − N_i|.
        pos = {int(m): c for c, m in enumerate(members.tolist())}
        for c, nb in enumerate(view.neighbourhoods):
            if outside[c]:
                both = [pos[m] for m in nb.tolist() if m in inside]
                total = len(nb) * means[c] - states[both].sum(axis=0)
                means[c] = total / len(outside[c])
    states = np.where(is_virtual[:, None], means, states)
    k = members.size
    return _game_from_states(
        np.array([view.owner]),
        members[None],
        np.ones((1, k), dtype=bool),
        states[None],
        is_virtual[None],
        action_model,
        t=t,
    )


def local_games(
    snapshot: TopologySnapshot,
    h: int,
    states: np.ndarray,
    action_model: ActionModel,
    *,
    virtual_mean: bool | str = "eq3",
    owners=None,
    t: float = 0.0,
) -> LocalGameBatch:
    """Every robot's local game of one stage: ``broadcast`` → ``gather_views`` →
    ``build_local_games``.

    Parameters
    ----------
    snapshot : TopologySnapshot
    h : int
        Neighbourhood radius in hops (paper: 2).
    states : ndarray, shape (N, D)
    action_model : ActionModel
    virtual_mean : {"eq3", "outside", "exact", "off"} or bool, default "eq3"
        How members reaching outside N_i stand in for it (:func:`build_local_games`).
    owners : array_like of int, optional
        Robots whose games to build (default: all, in id order).
    t : float, default 0.0
        The stage time in seconds (``LocalGameBatch.t``).

    Returns
    -------
    LocalGameBatch
        B = len(owners) games, K = the largest |N_i|, at time ``t``.

    Examples
    --------
    >>> import numpy as np
    >>> from swarmgames.network import TopologySnapshot
    >>> from swarmgames.game.actions import DisplacementActions
    >>> hops = np.array([[0, 1, 2], [1, 0, 1], [2, 1, 0]])
    >>> snap = TopologySnapshot.from_hop_matrix(0.0, hops)
    >>> batch = local_games(snap, 1, np.array([[0.0, 0], [1, 0], [2, 0]]),
    ...                     DisplacementActions.headings(1.0, 4))
    >>> batch.members.tolist()
    [[0, 1, -1], [1, 0, 2], [2, 1, -1]]
    >>> batch.is_virtual.tolist()[0]
    [False, True, False]
    """
    mode = virtual_mode(virtual_mean)
    views = gather_views(broadcast(snapshot, h, states), owners, context=mode == "exact")
    return build_local_games(views, action_model, virtual_mean=mode, t=t)


def centralised_game(
    snapshot: TopologySnapshot,
    h: int,
    states: np.ndarray,
    action_model: ActionModel,
    *,
    t: float = 0.0,
) -> LocalGameBatch:
    """The whole swarm as one game (centralised baseline): every robot a variable, actual
    states, pairwise terms between j and k when k ∈ N_j(h) (``pair_mask``), at the stage
    time ``t`` (seconds, ``LocalGameBatch.t``).

    The pairwise table of this game has N² A² entries: meant for small swarms (N ≲ 300).
    """
    if not isinstance(h, (int, np.integer)) or h < 1:
        raise ValueError(f"h must be an integer >= 1 (got {h})")
    n = snapshot.n_robots
    states = _validate_states(states, n)
    pair = snapshot.neighbourhood_matrix(int(h)).toarray()
    return _game_from_states(
        np.array([-1]),
        np.arange(n)[None],
        np.ones((1, n), dtype=bool),
        states[None],
        np.zeros((1, n), dtype=bool),
        action_model,
        pair_mask=pair[None],
        t=t,
    )
