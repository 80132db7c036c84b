"""Belief tables: what each robot last heard from each other robot, and how old it is.

Every reception of a state message (:mod:`swarmgames.comms.flooding`) becomes an entry of the
receiver's belief table: the sender, the time the message was sent (its timestamp), the time
it arrived, and its content (state, N_j, S̄_j). A robot decides with the newest message it has
*received by then* from each robot; a message older than ``max_age_s`` is dropped, and with it
the robot, from the games it builds. The age of a state is the decision time minus the
message's timestamp: it comes from when messages were sent and arrived, nothing else.

:class:`BeliefInbox` is what the game layer builds local games from (the
:class:`~swarmgames.game.local.Inbox` protocol): robot i's game holds i itself (its own state,
exactly) and every member of its own N_i(h) whose state it holds fresh enough; for
``game.virtual_mean = "exact"`` also its context, the robots of those members' reported
neighbourhoods outside its own table row whose states it holds fresh enough.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmgames.arrays import freeze_fields, pad_columns
from swarmgames.game.local import LocalViews, pad_rows

__all__ = ["BeliefInbox", "BeliefTable"]


@dataclass(frozen=True, eq=False)
class BeliefTable:
    """The belief entries of every robot, sorted by (owner, sender, timestamp).

    Parameters
    ----------
    n_robots : int
    owner, sender : ndarray of int64, shape (E,)
    stamp, arrival : ndarray, shape (E,)
        When the message was sent and when it arrived, seconds.
    state, mean : ndarray, shape (E, D)
        The sender's reported S_j and S̄_j.
    nbh : ndarray of int32, shape (E, L)
        The sender's reported N_j, -1 padded.
    """

    n_robots: int
    owner: np.ndarray
    sender: np.ndarray
    stamp: np.ndarray
    arrival: np.ndarray
    state: np.ndarray
    mean: np.ndarray
    nbh: np.ndarray

    def __post_init__(self) -> None:
        freeze_fields(self)

    @classmethod
    def empty(cls, n_robots: int, state_dim: int) -> BeliefTable:
        """No robot has heard anything yet."""
        z = np.zeros(0, dtype=np.int64)
        return cls(
            n_robots,
            z,
            z,
            np.zeros(0),
            np.zeros(0),
            np.zeros((0, state_dim)),
            np.zeros((0, state_dim)),
            np.full((0, 1), -1, dtype=np.int32),
        )

    @property
    def n_entries(self) -> int:
        """E."""
        return int(self.owner.size)

    def merge(self, new: BeliefTable, now: float, max_age_s: float) -> BeliefTable:
        """This table with ``new``'s entries added, pruned at time ``now``: per (owner,
        sender) only the newest message that has arrived is kept (and any still in flight);
        messages older than ``max_age_s`` are dropped."""
        width = max(self.nbh.shape[1], new.nbh.shape[1])

        def padded(t: BeliefTable) -> np.ndarray:
            return pad_columns(t.nbh, width, -1)

        owner = np.concatenate([self.owner, new.owner])
        sender = np.concatenate([self.sender, new.sender])
        stamp = np.concatenate([self.stamp, new.stamp])
        arrival = np.concatenate([self.arrival, new.arrival])
        # (owner, sender, stamp) order, stable: one composite key for the first two.
        order = np.lexsort((stamp, owner * self.n_robots + sender))
        owner, sender, stamp, arrival = owner[order], sender[order], stamp[order], arrival[order]
        keep = stamp >= now - max_age_s - 1e-9
        arrived = arrival <= now + 1e-12
        arrived_key = np.where(arrived, owner * self.n_robots + sender, -1)
        # Sorted by (key, stamp): an arrived entry followed by another arrived entry of the
        # same pair is superseded by it.
        idx = np.flatnonzero(arrived)
        superseded = np.zeros(owner.size, dtype=bool)
        superseded[idx[:-1][arrived_key[idx[:-1]] == arrived_key[idx[1:]]]] = True
        keep &= ~superseded
        rows = order[keep]
        cat = {
            "state": np.concatenate([self.state, new.state])[rows],
            "mean": np.concatenate([self.mean, new.mean])[rows],
            "nbh": np.concatenate([padded(self), padded(new)])[rows],
        }
        return BeliefTable(
            self.n_robots,
            owner[keep],
            sender[keep],
            stamp[keep],
            arrival[keep],
            cat["state"],
            cat["mean"],
            cat["nbh"],
        )

    def lookup(self, owner, sender, now: float, max_age_s: float) -> np.ndarray:
        """Index of the entry each (owner, sender) pair uses at time ``now`` — the newest
        message arrived by then, at most ``max_age_s`` old — or -1."""
        owner = np.asarray(owner, dtype=np.int64)
        sender = np.asarray(sender, dtype=np.int64)
        usable = np.flatnonzero(
            (self.arrival <= now + 1e-12) & (self.stamp >= now - max_age_s - 1e-9)
        )
        # Sorted by (owner, sender, stamp): the last usable entry of a pair is its newest.
        keys = self.owner[usable] * self.n_robots + self.sender[usable]
        want = owner * self.n_robots + sender
        if keys.size == 0:
            return np.full(want.shape, -1, dtype=np.int64)
        pos = np.maximum(np.searchsorted(keys, want, side="right") - 1, 0)
        return np.where(keys[pos] == want, usable[pos], -1)


@dataclass(frozen=True, eq=False)
class BeliefInbox:
    """Every robot's inbox at one decision, from its belief table (an
    :class:`~swarmgames.game.local.Inbox`).

    Parameters
    ----------
    indptr : ndarray of int64, shape (N + 1,)
        Row i holds the entries of robot i's game: i first, then the members it uses in
        increasing id.
    member : ndarray of int32, shape (E,)
    state, mean : ndarray, shape (E, D)
        The state used (i's own, exactly; the others' reported, dead-reckoned if asked) and
        the reported S̄_j.
    nbh : ndarray of int32, shape (E, L)
        The reported N_j (i's own table row for i), -1 padded.
    age : ndarray, shape (E,)
        Age of each state at the decision, seconds (0 for the owner).
    ctx_indptr : ndarray of int64, shape (N + 1,), optional
        Row i holds robot i's context entries in increasing id (``virtual_mean =
        "exact"``); None: the inbox holds no context.
    ctx_member : ndarray of int32, shape (E_c,), optional
    ctx_state : ndarray, shape (E_c, D), optional
        The context's states as used (dead-reckoned if asked).
    ctx_age : ndarray, shape (E_c,), optional
        Their ages at the decision, seconds.
    """

    indptr: np.ndarray
    member: np.ndarray
    state: np.ndarray
    mean: np.ndarray
    nbh: np.ndarray
    age: np.ndarray
    ctx_indptr: np.ndarray | None = None
    ctx_member: np.ndarray | None = None
    ctx_state: np.ndarray | None = None
    ctx_age: np.ndarray | None = None

    def __post_init__(self) -> None:
        freeze_fields(self)

    @classmethod
    def concat(cls, parts) -> BeliefInbox:
        """The inboxes of independent swarms side by side: swarm ``e``'s robot ``j`` becomes
        robot ``offset_e + j`` (``offset_e`` the robots of the swarms before it), as in
        :meth:`~swarmgames.topology.TopologySnapshot.concat`. Either every part holds a
        context or none does."""
        parts = list(parts)
        sizes = np.array([p.indptr.size - 1 for p in parts], dtype=np.int64)
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])

        def rows(indptr_of):
            ends = np.cumsum([indptr_of(p)[-1] for p in parts])
            starts = np.concatenate([[0], ends[:-1]])
            return np.concatenate(
                [
                    [0],
                    *(np.asarray(indptr_of(p)[1:]) + s for p, s in zip(parts, starts, strict=True)),
                ]
            ).astype(np.int64)

        def ids(values):
            return np.concatenate(
                [np.where(v >= 0, v + o, -1) for v, o in zip(values, offsets, strict=True)]
            ).astype(np.int32)

        width = max(p.nbh.shape[1] for p in parts)
        nbh = [pad_columns(p.nbh, width, -1) for p in parts]
        context = [p.ctx_indptr is not None for p in parts]
        if any(context) and not all(context):
            raise ValueError("either every inbox holds a context or none does")
        extra = {}
        if all(context):
            extra = {
                "ctx_indptr": rows(lambda p: p.ctx_indptr),
                "ctx_member": ids([p.ctx_member for p in parts]),
                "ctx_state": np.concatenate([p.ctx_state for p in parts]),
                "ctx_age": np.concatenate([p.ctx_age for p in parts]),
            }
        return cls(
            indptr=rows(lambda p: p.indptr),
            member=ids([p.member for p in parts]),
            state=np.concatenate([p.state for p in parts]),
            mean=np.concatenate([p.mean for p in parts]),
            nbh=ids(nbh),
            age=np.concatenate([p.age for p in parts]),
            **extra,
        )

    @property
    def exact(self) -> bool:
        """False: what a robot holds may be late, stale or missing (the stage builds the
        true neighbourhoods for its measurements)."""
        return False

    @property
    def sizes(self) -> np.ndarray:
        """|N_i| of every robot's game as it knows it (owner included), shape (N,)."""
        return np.diff(self.indptr)

    @property
    def context_sizes(self) -> np.ndarray:
        """|C_i| of every robot's context as it knows it, shape (N,) (0 without context)."""
        if self.ctx_indptr is None:
            return np.zeros(self.indptr.size - 1, dtype=np.int64)
        return np.diff(self.ctx_indptr)

    def views(self, owners=None, *, context: bool = False) -> LocalViews:
        """The padded inboxes of ``owners`` (default: every robot); with ``context`` their
        contexts too (the inbox must hold them: a model delivering to 2h hops)."""
        n = self.indptr.size - 1
        owners = np.arange(n) if owners is None else np.asarray(owners, dtype=np.int64)
        owners = owners.reshape(-1)
        entry = pad_rows(self.indptr, np.arange(self.member.size), owners)
        mask = entry >= 0
        safe = np.where(mask, entry, 0)
        zero = ~mask[:, :, None]
        nbh = np.where(mask[:, :, None], self.nbh[safe], -1)
        extra = {}
        if context:
            if self.ctx_indptr is None:
                raise ValueError(
                    "this inbox holds no context states: the communication model delivered "
                    "to h hops only (build it with context=True for virtual_mean = 'exact')"
                )
            ce = pad_rows(self.ctx_indptr, np.arange(self.ctx_member.size), owners)
            cm = ce >= 0
            # One padding entry past the end, so that an empty context indexes nothing.
            ids = np.append(self.ctx_member, -1).astype(np.int32)
            states = np.concatenate([self.ctx_state, np.zeros((1, self.state.shape[1]))])
            cs = np.where(cm, ce, ids.size - 1)
            extra = {"context": ids[cs], "context_states": states[cs]}
        return LocalViews(
            owner=owners.astype(np.int32),
            members=np.where(mask, self.member[safe], -1).astype(np.int32),
            mask=mask,
            states=np.where(zero, 0.0, self.state[safe]),
            mean_states=np.where(zero, 0.0, self.mean[safe]),
            neighbourhoods=nbh.astype(np.int32),
            **extra,
        )

    def info_age(self) -> np.ndarray:
        """Mean age of the others' states each robot uses, seconds, shape (N,): its
        members' and, with a context, its context's; NaN for a robot that uses none."""
        n = self.indptr.size - 1
        row = np.repeat(np.arange(n), np.diff(self.indptr))
        others = self.member != row
        rows, ages = row[others], self.age[others]
        if self.ctx_indptr is not None:
            rows = np.concatenate([rows, np.repeat(np.arange(n), np.diff(self.ctx_indptr))])
            ages = np.concatenate([ages, self.ctx_age])
        total = np.bincount(rows, weights=ages, minlength=n)
        count = np.bincount(rows, minlength=n)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(count > 0, total / np.maximum(count, 1), np.nan)
