"""Communication models: what reaches each robot of a stage, when, and at what cost.

Once per control period, at the stage time t, every robot composes its state message
(:mod:`swarmgames.comms.wire`) and the model delivers it; the robots decide at
``t + decide_after_s`` with what they hold by then.

``ideal``
    Every member of N_i(h) — robot i's own routing table — receives the exact message
    instantly and for free: the local games of the paper (the golden runs of
    ``tests/sim/test_golden.py`` use it).
``routed``
    The message is flooded hop by hop for at most h hops over the links that exist now, both
    physically (the radio model at the current positions) and in the forwarder's routing
    table (:func:`~swarmgames.comms.flooding.flood`); each hop takes ``hop_delay_s`` plus the
    frame's airtime at ``rate_mbps``. A transmission arrives when the radio channel lets it
    (with fading or shadowing on, the reception model's own draw against the threshold) and
    the loss model spares it: i.i.d. with probability ``loss_rate``, or a Gilbert–Elliott
    channel per link (a good state losing ``loss_rate``, a bad state losing
    ``ge_loss_bad``, switching between them from stage to stage with probabilities
    ``ge_good_to_bad`` and ``ge_bad_to_good``: losses in bursts).
    Each robot keeps a belief table of the newest message heard from each robot
    (:class:`~swarmgames.comms.beliefs.BeliefTable`) and builds its local game from the
    members of its own N_i(h) it heard from within ``max_age_s``; with ``dead_reckoning`` a
    reported position is advanced by its reported velocity over the message's age. A robot's
    S̄_j is the mean of the states it *knows* (its own and its fresh beliefs), and its N_j the
    row of its own table.

``ns3``
    The same belief tables, but the messages are UDP packets in ns-3
    (:class:`~swarmgames.comms.ns3_comms.Ns3Comms`): delivery, delay and loss come from the
    packet simulator.

With ``context`` (``game.virtual_mean = "exact"``) each robot's game also needs the states of
its context C_i = ∪_{j ∈ N_i} N_j − N_i, robots up to 2h hops away: ``ideal`` then delivers
every message to the robots whose N_i ∪ C_i holds its sender (and counts those receptions),
``routed`` and ``ns3`` flood every message for 2h hops instead of h, so the relays, bytes,
airtime and ages of the longer flood are what the run measures.

All return the inbox the stage pipeline builds the games from and :class:`CommsStats`, the
per-robot measurements of the stage (information age, freshness, messages and bytes).
:class:`BeliefComms` is what ``routed`` and ``ns3`` share: composing the messages, merging
what arrived into the belief tables and building the inboxes at the decision; they differ
only in :meth:`BeliefComms.deliver`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from swarmgames.arrays import freeze_fields, pad_columns, sorted_unique
from swarmgames.comms.beliefs import BeliefInbox, BeliefTable
from swarmgames.comms.flooding import flood
from swarmgames.comms.load import offered_load
from swarmgames.comms.wire import FRAME_OVERHEAD_BYTES, PREAMBLE_S, airtime_s, message_bytes
from swarmgames.game.local import broadcast, pad_rows
from swarmgames.names import COMMS_MODELS
from swarmgames.network.links import link_graph
from swarmgames.network.olsr.tables import sorted_contains
from swarmgames.network.propagation import PropagationModel
from swarmgames.topology import TopologySnapshot

__all__ = [
    "COMMS_MODELS",
    "BeliefComms",
    "CommsStats",
    "Composed",
    "IdealComms",
    "RoutedComms",
    "table_links",
]


@dataclass(frozen=True, eq=False)
class CommsStats:
    """Per-robot communication measurements of one stage (arrays of shape (N,)).

    Parameters
    ----------
    info_age_s : ndarray
        Mean age of the other robots' states the robot's game used, seconds (NaN: it used
        none).
    fresh_fraction : ndarray
        Share of the other members of its own N_i(h) whose state it held within
        ``max_age_s`` (1 when N_i(h) holds nobody else).
    messages_sent, messages_forwarded, messages_received : ndarray of int64
    bytes_sent, bytes_forwarded, bytes_received : ndarray of int64
        State-message payload bytes (:mod:`swarmgames.comms.wire`).
    channel_load : ndarray of float64
        Airtime that the robot and the robots it hears transmitted in the stage, over
        ``decide_after_s`` (:func:`~swarmgames.comms.load.offered_load`; above 1 the
        stage's traffic cannot fit the decision window). NaN under ``ideal``, which has no
        channel.
    """

    info_age_s: np.ndarray
    fresh_fraction: np.ndarray
    messages_sent: np.ndarray
    messages_forwarded: np.ndarray
    messages_received: np.ndarray
    bytes_sent: np.ndarray
    bytes_forwarded: np.ndarray
    bytes_received: np.ndarray
    channel_load: np.ndarray

    def __post_init__(self) -> None:
        freeze_fields(self)

    def columns(self) -> dict[str, np.ndarray]:
        """The per-robot columns of ``metrics.csv``."""
        return dict(vars(self))


def _table_rows(snapshot: TopologySnapshot, h: int):
    """Each robot's N_i(h) from its own table as CSR (sorted, the robot included)."""
    indptr, indices = snapshot.neighbourhood_rows(int(h))
    return indptr, indices.astype(np.int64)


def table_links(snapshot: TopologySnapshot) -> sp.csr_array:
    """``[u, v]`` = 1 where u's own table lists v as a 1-hop (symmetric) neighbour, (N, N)."""
    n = snapshot.n_robots
    one = np.asarray(snapshot.hops) == 1
    owner, dest = np.asarray(snapshot.owner)[one], np.asarray(snapshot.dest)[one]
    ones = np.ones(owner.size, dtype=np.int8)
    return sp.csr_array((ones, (owner, dest)), shape=(n, n))


@dataclass(eq=False)
class IdealComms:
    """Exact, instant, free delivery to every member of N_i(h) (see the module docstring).

    Parameters
    ----------
    hops : int
        h, the neighbourhood radius.
    context : bool, default False
        Deliver the messages of every robot's context too (``virtual_mean = "exact"``).
    """

    hops: int
    context: bool = False

    def reset(self) -> None:
        """Nothing is remembered between stages."""

    def state(self) -> None:
        """Nothing to keep: ideal delivery remembers nothing between stages."""

    def restore(self, state: None) -> None:
        """Nothing to take back (see :meth:`state`)."""

    def exchange(self, t: float, snapshot: TopologySnapshot, states, rng=None, active=None):
        """``(messages, stats)``: the exact broadcast of the stage
        (:func:`~swarmgames.game.local.broadcast`, exact messages); every member receives
        every message of its neighbourhood once. A robot without a radio (``active`` false) is
        known only through the routing tables, which forget it after their hold times."""
        states = np.asarray(states, dtype=float)
        messages = broadcast(snapshot, self.hops, states)
        count = messages.sizes
        sizes = message_bytes(states.shape[1], count)
        heard_ptr, heard = messages.indptr, messages.indices
        if self.context:  # N_i ∪ C_i: the rows of the members' rows
            n = count.size
            nbh = sp.csr_array((np.ones(heard.size, dtype=np.int32), heard, heard_ptr), (n, n))
            reach = nbh @ nbh
            reach.sort_indices()
            heard_ptr, heard = reach.indptr, reach.indices
        row = np.repeat(np.arange(count.size), np.diff(heard_ptr))
        other = heard != row
        received = np.bincount(row[other], minlength=count.size).astype(np.int64)
        rx_bytes = np.bincount(
            row[other], weights=sizes[heard[other]], minlength=count.size
        ).astype(np.int64)
        n = count.size
        stats = CommsStats(
            info_age_s=np.where(count > 1, 0.0, np.nan),
            fresh_fraction=np.ones(n),
            messages_sent=np.ones(n, dtype=np.int64),
            messages_forwarded=np.zeros(n, dtype=np.int64),
            messages_received=received,
            bytes_sent=sizes.astype(np.int64),
            bytes_forwarded=np.zeros(n, dtype=np.int64),
            bytes_received=rx_bytes,
            channel_load=np.full(n, np.nan),
        )
        return messages, stats


@dataclass(frozen=True, eq=False)
class Composed:
    """The messages of one stage as their senders composed them (read-only arrays).

    Parameters
    ----------
    indptr, members : ndarray of int64
        Each robot's N_i(h) from its own table (CSR, sorted, the robot included).
    report_indptr, report_members : ndarray of int64
        The N_i its message carries (CSR, sorted): the table row, or with ``averaged_rows``
        the members whose states its S̄ averaged (the robot and its fresh beliefs).
    reported : ndarray, shape (N, D)
        The state each robot reports (its own, with the GPS error if any).
    mean : ndarray, shape (N, D)
        Each robot's S̄ over the states it knows (its own and its fresh beliefs).
    sizes : ndarray of int64, shape (N,)
        Wire bytes of each message.
    nbh : ndarray of int32, shape (N, L)
        The N_i each message carries, -1 padded.
    """

    indptr: np.ndarray
    members: np.ndarray
    report_indptr: np.ndarray
    report_members: np.ndarray
    reported: np.ndarray
    mean: np.ndarray
    sizes: np.ndarray
    nbh: np.ndarray

    def __post_init__(self) -> None:
        freeze_fields(self)


@dataclass(eq=False)
class BeliefComms:
    """Messages into belief tables (what ``routed`` and ``ns3`` share; module docstring).

    Every stage :meth:`exchange` composes the messages (:meth:`compose`), lets the subclass
    deliver them (:meth:`deliver`: the new belief entries and the message counters), merges
    what arrived by the decision into the belief tables and builds the inboxes from them.

    Parameters
    ----------
    n_robots, state_dim, hops : int
    decide_after_s : float
        The robots decide this long after the stage time, seconds; later messages wait for
        the next decision.
    max_age_s : float
        Beliefs older than this are dropped, seconds.
    dead_reckoning : bool
        Advance reported positions by reported velocities (states with velocities only).
    gps_error_m : float
        Standard deviation of the error of the x and y a robot reports, metres.
    context : bool
        Flood every message for 2h hops and give every robot's inbox its context
        C_i = ∪_{j ∈ N_i} N_j − N_i (``virtual_mean = "exact"``, module docstring).
    averaged_rows : bool
        A message's N_j lists the members whose states its S̄_j averaged (the sender, with
        its reported state, and the members it holds fresh beliefs of) instead of its whole
        table row (``virtual_mean = "outside"``: a receiver then takes exactly the shared
        members out of |N_j| S̄_j).
    """

    n_robots: int
    state_dim: int
    hops: int
    decide_after_s: float = field(default=0.1, kw_only=True)
    max_age_s: float = field(default=3.0, kw_only=True)
    dead_reckoning: bool = field(default=False, kw_only=True)
    gps_error_m: float = field(default=0.0, kw_only=True)
    context: bool = field(default=False, kw_only=True)
    averaged_rows: bool = field(default=False, kw_only=True)
    table: BeliefTable = field(init=False)

    @property
    def reach(self) -> int:
        """How many hops a message travels: h, or 2h with ``context``."""
        return 2 * int(self.hops) if self.context else int(self.hops)

    def __post_init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget every belief (the start of a run)."""
        self.table = BeliefTable.empty(self.n_robots, self.state_dim)

    def _believed(self, idx: np.ndarray, now: float) -> tuple[np.ndarray, np.ndarray]:
        """The states of belief entries ``idx`` as used at ``now``, and their ages."""
        tab = self.table
        age = now - tab.stamp[idx]
        state = tab.state[idx].copy()
        if self.dead_reckoning and self.state_dim >= 5:
            state[:, :2] += tab.state[idx, 3:5] * age[:, None]
        return state, age

    def compose(
        self, t: float, snapshot: TopologySnapshot, states: np.ndarray, rng: np.random.Generator
    ) -> Composed:
        """Every robot's message at ``t``: its own state, its own table row (or, with
        ``averaged_rows``, the members it averaged), and S̄ over what it knows now."""
        n, dim = states.shape
        indptr, members = _table_rows(snapshot, self.hops)
        row = np.repeat(np.arange(n), np.diff(indptr))
        other = members != row
        known = self.table.lookup(row[other], members[other], t, self.max_age_s)
        found = known >= 0
        reported = states
        if self.gps_error_m > 0:  # what each robot reports of its own position
            reported = states.copy()
            reported[:, :2] += rng.normal(0.0, self.gps_error_m, (n, 2))
        # With averaged_rows the receivers subtract their copies of the states averaged,
        # the sender's own among them: its reported state is what they hold.
        total = (reported if self.averaged_rows else states).copy()
        count = np.ones(n)
        if found.any():
            believed, _ = self._believed(known[found], t)
            np.add.at(total, row[other][found], believed)
            np.add.at(count, row[other][found], 1.0)
        rep_indptr, rep_members = indptr, members
        if self.averaged_rows:
            keep = ~other
            keep[np.flatnonzero(other)[found]] = True
            rep_members = members[keep]
            rep_indptr = np.concatenate([[0], np.cumsum(np.bincount(row[keep], minlength=n))])
        return Composed(
            indptr=indptr,
            members=members,
            report_indptr=rep_indptr,
            report_members=rep_members,
            reported=reported,
            mean=total / count[:, None],
            sizes=message_bytes(dim, np.diff(rep_indptr)),
            nbh=pad_rows(rep_indptr, rep_members, np.arange(n)),
        )

    def deliver(
        self,
        t: float,
        snapshot: TopologySnapshot,
        states: np.ndarray,
        composed: Composed,
        rng: np.random.Generator,
        active: np.ndarray,
    ) -> tuple[BeliefTable, dict[str, np.ndarray]]:
        """The belief entries that the stage's delivery adds, and the per-robot counters
        (``messages_sent``, ``messages_forwarded``, ``messages_received`` and the same in
        ``bytes_``), for the subclass to define."""
        raise NotImplementedError

    def exchange(
        self,
        t: float,
        snapshot: TopologySnapshot,
        states,
        rng: np.random.Generator,
        active: np.ndarray | None = None,
    ):
        """Send, deliver and remember one stage's messages; the inbox at the decision.

        ``active`` (default: all) marks the robots whose radio works: the others send,
        forward and receive nothing."""
        states = np.asarray(states, dtype=float)
        n = states.shape[0]
        active = np.ones(n, dtype=bool) if active is None else np.asarray(active, dtype=bool)
        composed = self.compose(t, snapshot, states, rng)
        new, counters = self.deliver(t, snapshot, states, composed, rng, active)
        decide = t + self.decide_after_s
        self.table = self.table.merge(new, decide, self.max_age_s)
        # The inbox at the decision: own state first, then the members heard from.
        indptr, members = composed.indptr, composed.members
        row = np.repeat(np.arange(n), np.diff(indptr))
        other = members != row
        idx = self.table.lookup(row[other], members[other], decide, self.max_age_s)
        use = idx >= 0
        believed, age = self._believed(idx[use], decide)
        own = np.arange(n)
        ent_owner = np.concatenate([own, row[other][use]])
        ent_member = np.concatenate([own, members[other][use]])
        rows_padded = composed.nbh
        if self.averaged_rows:  # the robot's own row in its game is its table row
            rows_padded = pad_rows(indptr, members, np.arange(n))
        width = max(rows_padded.shape[1], self.table.nbh.shape[1])
        own_nbh = pad_columns(rows_padded, width, -1)
        their_nbh = pad_columns(self.table.nbh[idx[use]], width, -1)
        # By owner, its own entry first, then its members in increasing order: one key, unique
        # per entry, whose two blocks (own entries, then the members' in row order) are each
        # sorted already, so the stable sort merges two runs.
        key = ent_owner * (n + 1) + np.where(ent_member == ent_owner, 0, ent_member + 1)
        order = np.argsort(key, kind="stable")
        extra = {}
        if self.context:
            extra = self._context(
                decide, indptr, members, ent_owner, np.concatenate([own_nbh, their_nbh])
            )
        inbox = BeliefInbox(
            indptr=np.concatenate([[0], np.cumsum(np.bincount(ent_owner, minlength=n))]),
            member=ent_member[order].astype(np.int32),
            state=np.concatenate([states, believed])[order],
            mean=np.concatenate([composed.mean, self.table.mean[idx[use]]])[order],
            nbh=np.concatenate([own_nbh, their_nbh])[order].astype(np.int32, copy=False),
            age=np.concatenate([np.zeros(n), age])[order],
            **extra,
        )
        expected = np.bincount(row[other], minlength=n)
        used = np.bincount(row[other][use], minlength=n)
        stats = CommsStats(
            info_age_s=inbox.info_age(),
            fresh_fraction=np.where(expected > 0, used / np.maximum(expected, 1), 1.0),
            **counters,
        )
        return inbox, stats

    def _context(self, decide, indptr, members, ent_owner, ent_nbh) -> dict[str, np.ndarray]:
        """Every robot's context at the decision: the robots of the reported neighbourhoods
        of the members it uses (``ent_nbh``, one row per entry of ``ent_owner``) that are
        not in its own table row, as far as it holds their states fresh enough."""
        n = self.n_robots
        owner = np.broadcast_to(np.asarray(ent_owner, np.int64)[:, None], ent_nbh.shape)
        ok = ent_nbh >= 0
        keys = sorted_unique(owner[ok] * n + ent_nbh[ok])
        row = np.repeat(np.arange(n), np.diff(indptr))
        inside = np.sort(row * n + members)  # the table rows (the owner included)
        pos = np.minimum(np.searchsorted(inside, keys), inside.size - 1)
        keys = keys[inside[pos] != keys]
        who, ctx = np.divmod(keys, n)
        idx = self.table.lookup(who, ctx, decide, self.max_age_s)
        use = idx >= 0
        state, age = self._believed(idx[use], decide)
        return {
            "ctx_indptr": np.concatenate([[0], np.cumsum(np.bincount(who[use], minlength=n))]),
            "ctx_member": ctx[use].astype(np.int32),
            "ctx_state": state,
            "ctx_age": age,
        }


@dataclass(eq=False)
class RoutedComms(BeliefComms):
    """State messages flooded over the links that exist now, with delay and loss, into belief
    tables (see the module docstring).

    Parameters
    ----------
    n_robots, state_dim, hops : int
    propagation : PropagationModel
        The radio: which links exist physically at the current positions.
    hop_delay_s : float
        Delay of every hop besides the frame's airtime (channel access, queueing), seconds.
    rate_mbps : float
        PHY rate of the state messages, Mbit/s.
    loss_rate : float
        Probability that one transmission is lost (i.i.d.; the good state of the
        Gilbert–Elliott channel).
    loss_model : {"iid", "gilbert_elliott"}
    ge_good_to_bad, ge_bad_to_good : float
        Per-stage transition probabilities of a link's Gilbert–Elliott state.
    ge_loss_bad : float
        Loss probability of a link in the bad state.
    decide_after_s, max_age_s, dead_reckoning, gps_error_m
        Keyword only, see :class:`BeliefComms`.
    """

    propagation: PropagationModel = field(default_factory=PropagationModel)
    hop_delay_s: float = 0.002
    rate_mbps: float = 6.0
    loss_rate: float = 0.0
    loss_model: str = "iid"
    ge_good_to_bad: float = 0.05
    ge_bad_to_good: float = 0.5
    ge_loss_bad: float = 1.0
    bad_links: np.ndarray = field(init=False)

    def reset(self) -> None:
        """Forget every belief and every link's channel state (the start of a run)."""
        super().reset()
        self.bad_links = np.zeros(0, dtype=np.int64)

    def state(self) -> dict[str, Any]:
        """What the robots remember between stages: the belief tables and every link's
        Gilbert–Elliott state (both immutable: the model replaces them, never edits them)."""
        return {"table": self.table, "bad_links": self.bad_links}

    def restore(self, state: dict[str, Any]) -> None:
        """Continue from ``state`` (taken by :meth:`state`)."""
        table = state["table"]
        if table.n_robots != self.n_robots:
            raise ValueError(
                f"this state is of {table.n_robots} robots; the model has {self.n_robots}"
            )
        self.table = table
        self.bad_links = np.asarray(state["bad_links"], dtype=np.int64)

    def _links(self, snapshot: TopologySnapshot, pos: np.ndarray, rng) -> sp.csr_array:
        """Links a message can take now: in the transmitter's table (a 1-hop neighbour) and
        physically possible (within range; with a random channel, within the range beyond
        which a link is negligibly likely; each transmission then draws its own power)."""
        n = pos.shape[0]
        if self.propagation.random:
            from scipy.spatial import cKDTree

            pairs = cKDTree(pos).query_pairs(self.propagation.max_range(), output_type="ndarray")
            a, b = np.r_[pairs[:, 0], pairs[:, 1]], np.r_[pairs[:, 1], pairs[:, 0]]
            phys = sp.csr_array((np.ones(a.size, dtype=np.int8), (a, b)), shape=(n, n))
            return phys.multiply(table_links(snapshot)).tocsr()
        # Both link sets as sorted keys u N + v; their intersection, the product's pattern,
        # without scipy's element-wise product and its conversions.
        g = link_graph(pos, self.propagation, rng)
        rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(g.indptr))
        phys = rows * n + g.indices  # sorted: the graph's rows are sorted
        one = np.asarray(snapshot.hops) == 1
        listed = np.sort(
            np.asarray(snapshot.owner)[one].astype(np.int64) * n + np.asarray(snapshot.dest)[one]
        )
        both = phys[sorted_contains(listed, phys)]
        indptr = np.concatenate([[0], np.cumsum(np.bincount(both // n, minlength=n))])
        return sp.csr_array(
            (np.ones(both.size, dtype=np.int8), (both % n).astype(np.int32), indptr), shape=(n, n)
        )

    def _evolve_channel(self, adjacency: sp.csr_array, rng) -> None:
        """One stage of every usable link's Gilbert–Elliott state (new links start good)."""
        coo = sp.coo_array(adjacency)
        keys = np.sort(coo.row.astype(np.int64) * self.n_robots + coo.col)
        was_bad = np.isin(keys, self.bad_links, assume_unique=True)
        draw = rng.random(keys.size)
        bad = np.where(was_bad, draw >= self.ge_bad_to_good, draw < self.ge_good_to_bad)
        self.bad_links = keys[bad]

    def _arrives(self, u: np.ndarray, v: np.ndarray, pos: np.ndarray, rng) -> np.ndarray:
        """Whether each transmission u -> v arrives: the reception draw, then the loss."""
        ok = np.ones(u.size, dtype=bool)
        model = self.propagation
        if model.random:
            d = np.linalg.norm(pos[u] - pos[v], axis=1)
            power = model.rx_power(d, rng, pairs=(np.minimum(u, v), np.maximum(u, v)))
            ok &= power >= model.radio.rx_threshold_dbm
        loss = np.full(u.size, float(self.loss_rate))
        if self.loss_model == "gilbert_elliott" and self.bad_links.size:
            bad = np.isin(u * self.n_robots + v, self.bad_links)
            loss[bad] = self.ge_loss_bad
        if np.any(loss > 0):
            ok &= rng.random(u.size) >= loss
        return ok

    def deliver(self, t, snapshot, states, composed, rng, active):
        """Flood over the links that exist physically and in the forwarder's table, for h hops
        (2h with ``context``); each hop takes ``hop_delay_s`` plus the frame's airtime."""
        n = states.shape[0]
        pos = states[:, :3]
        adjacency = self._links(snapshot, pos, rng)
        if not active.all():  # a dead radio neither sends, relays nor hears
            on = sp.diags_array(active.astype(np.int8), dtype=np.int8)
            adjacency = sp.csr_array(on @ adjacency @ on)
        if self.loss_model == "gilbert_elliott":
            self._evolve_channel(adjacency, rng)
        sizes = composed.sizes
        delivery = flood(
            adjacency,
            self.reach,
            sizes,
            link_success=lambda u, v: self._arrives(u, v, pos, rng),
            senders=active,
        )
        hop_s = self.hop_delay_s + airtime_s(sizes, self.rate_mbps)
        s = delivery.sender
        new = BeliefTable(
            n,
            delivery.receiver,
            s,
            np.full(s.size, float(t)),
            t + delivery.hops * hop_s[s],
            composed.reported[s],
            composed.mean[s],
            composed.nbh[s].astype(np.int32),
        )
        counters = {
            "messages_sent": delivery.sent,
            "messages_forwarded": delivery.forwarded,
            "messages_received": delivery.received,
            "bytes_sent": delivery.bytes_sent,
            "bytes_forwarded": delivery.bytes_forwarded,
            "bytes_received": delivery.bytes_received,
            "channel_load": self._load(adjacency, delivery),
        }
        return new, counters

    def _load(self, adjacency: sp.csr_array, delivery) -> np.ndarray:
        """Each robot's offered load (:func:`~swarmgames.comms.load.offered_load`) over the
        links the messages travel: every frame a sent or relayed message at ``rate_mbps``."""
        frames = delivery.sent + delivery.forwarded
        payload = delivery.bytes_sent + delivery.bytes_forwarded
        bits = 8.0 * (payload + frames * FRAME_OVERHEAD_BYTES)
        air = frames * PREAMBLE_S + bits / (self.rate_mbps * 1e6)
        coo = sp.coo_array(adjacency)
        return offered_load(coo.row, coo.col, air, self.decide_after_s)
