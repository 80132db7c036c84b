"""Discrete-event OLSR (RFC 3626) for a whole swarm, vectorised over nodes and messages.

Timing follows ns-3 3.44: every node starts at ``start_time``; its HELLO timer fires at
``start + k * hello_interval`` and its TC timer at ``start + k * tc_interval``; each message is
built when its timer fires and sent after a uniform jitter in ``[0, max_jitter]``. A message
reaches the nodes linked to its sender at the moment it is sent (:mod:`..links`).

Because every node's timers fire together, all HELLOs of one round are built from the same
state and their receptions commute: a round is processed as one batch of sparse array updates
(split only where an ``advance`` call ends or the positions change). State lives in
:class:`~.tables.KeyedTable` arrays for the whole swarm:

* link set ``(r, j)``: ``L_ASYM_time``, ``L_SYM_time``, ``L_time`` and the time first heard;
* 2-hop set ``(r, j, x)`` and MPR-selector set ``(r, j)``: expiry times;
* topology set: for each ``(r, last)`` the TC round last received from ``last``, its ANSN and
  its expiry (the tuples ``(dest, last)`` are that TC's advertised set, stored once per round),
  plus the *lingering* tuples ``(r, last, dest)`` that an earlier TC of the same ANSN listed
  and the latest no longer does, each with its own expiry (RFC 9.5; see below).

Link sensing (RFC 7.1.1): a HELLO from ``j`` sets ``L_ASYM_time = t + V``; if it lists ``r`` as
a symmetric or asymmetric link, ``L_SYM_time = t + V`` and ``L_time = L_SYM_time + V``; listed as
lost, ``L_SYM_time = t - 1``. ``V`` is the neighbour hold time (6 s). A link tuple is gone once
``L_time`` passes (ns-3 ``LinkTupleTimerExpire``): the next HELLO from ``j`` creates a new one.

Routing tables are recomputed, as in ns-3, only when a node receives an OLSR packet or loses a
symmetric neighbour, not when a tuple expires. Node ``r``'s table at time ``t`` is therefore the
RFC section 10 computation on its tuples still valid at ``c_r`` = the later of its last packet
reception and its last symmetric-link expiry before ``t``; it is evaluated lazily when a
snapshot is read. A 2-hop or topology tuple is therefore kept until it expired before its
owner's ``c_r``, not merely before ``t``.

Topology set, as ns-3 ``ProcessTc`` keeps it (RFC 9.5): a TC with a newer ANSN than the
tuples ``r`` holds from its originator replaces them; one with the same ANSN refreshes the
tuples it lists and leaves the others until their own expiry. ns-3 increments a node's ANSN
when it gains a neighbour tuple (a new link tuple) or an MPR selector, and when a selector
tuple expires on its own timer, but not when ``NeighborLoss`` erases a selector whose link
lapsed: the TCs after such a loss keep the ANSN, and the lost neighbour stays in the
receivers' topology sets for up to the topology hold time.

TC flooding (RFC 3.4, 9): each copy is sent when its jitter has elapsed and reaches the nodes
linked to its sender then; a node accepts a copy only from a neighbour it has a symmetric link
to at that moment, processes only the first copy, and retransmits (after a new jitter) when the
sender is one of its MPR selectors at that moment (ns-3 ``ProcessTc`` and ``ForwardDefault``
check both on arrival). The HELLOs of a round are on the air while the TCs built at the same
instant are flooded; the MPR selectors they add relay those TCs. (Taking the link and selector
state of the instant a TC is built would cut nodes off for whole rounds in fast swarms.)

Approximations, documented in ``docs/network.md``: the copies due within one ``run_until`` step
are processed wave by wave (the earliest copy of a wave counts) with the link and selector state
at the end of the step; MPR sets are recomputed when HELLOs are built rather than after every
reception; HELLO and TC messages are not aggregated into one packet; every frame in range
arrives (ns-3 loses about 2 % of them to collisions in a 40-UAV swarm, ``docs/ns3.md``).

Control traffic: every HELLO and every TC a node originates or forwards is counted, with its
size in bytes (:mod:`.wire`), when it is sent (its jitter elapsed);
:meth:`OlsrEngine.take_control_traffic` hands the counts over. Counting draws no random numbers
and changes no state that the tables read.

References
----------
.. [1] RFC 3626 sections 3.4, 6-10, 18.
.. [2] ns-3 3.44 ``src/olsr/model/olsr-routing-protocol.cc``.
.. [3] docs/reference.md section 3.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from swarmgames.arrays import csr_gather, sorted_unique
from swarmgames.network.links import LinkGraph
from swarmgames.network.olsr import tables, wire
from swarmgames.network.olsr.mpr import select_mprs
from swarmgames.network.olsr.routing import compute_routes
from swarmgames.network.olsr.tables import (
    KeyedTable,
    KeySet,
    first_per_key,
    live_at,
    sorted_contains,
)
from swarmgames.network.olsr.traffic import ControlTraffic
from swarmgames.network.olsr.twohop import round_tuples, strict_two_hop
from swarmgames.network.parameters import OlsrParameters

__all__ = ["OlsrEngine"]

_LOST, _ASYM, _SYM = 0, 1, 2
_NOT_NEIGH, _SYM_NEIGH, _MPR_NEIGH = 0, 1, 2


def _link_codes(link: np.ndarray, neigh: np.ndarray) -> np.ndarray:
    """RFC 3626 section 6.1.1 link codes ``link_type | neighbour_type << 2`` (lost = 3)."""
    return np.where(link == _LOST, 3, link).astype(np.int64) | (neigh.astype(np.int64) << 2)


class OlsrEngine:
    """Mutable OLSR state of ``n_robots`` robots (OLSR nodes) and its event loop.

    Parameters
    ----------
    n_robots : int
        Number of nodes.
    olsr : OlsrParameters
        Intervals, jitter, hold times, willingness.
    rng : numpy Generator
        Source of the message jitter.
    hello_only : bool
        Send no TCs (routes of at most 2 hops).
    start_time : float
        Time at which every node starts (first HELLO and TC timers).
    """

    def __init__(
        self,
        n_robots: int,
        olsr: OlsrParameters,
        rng: np.random.Generator,
        hello_only: bool = False,
        start_time: float = 0.0,
    ) -> None:
        self.n = int(n_robots)
        self.cfg = olsr
        self.rng = rng
        self.hello_only = hello_only
        self.time = float(start_time)
        n = self.n
        self._nn = np.int64(n)
        self.links = KeyedTable(("asym", "sym", "ltime", "created"))
        self.two_hop = KeyedTable(("expiry",))
        self.selectors = KeyedTable(("expiry",))
        self.topology = KeyedTable(("expiry", "round", "ansn"))
        # Topology tuples (r, last, dest) that r keeps from an earlier TC of the same ANSN
        # although the latest TC of ``last`` it received no longer lists ``dest``.
        self.lingering = KeyedTable(("expiry",))
        # Advertised neighbour sequence number of each node (ns-3 IncrementAnsn).
        self.ansn = np.zeros(n, dtype=np.int64)
        self.last_rx = np.full(n, -np.inf)
        # Latest symmetric-link lapse of each node among link tuples already removed.
        self._lapsed = np.full(n, -np.inf)
        self.next_hello = float(start_time)
        self.next_tc = float(start_time)
        # Current HELLO round: content (sorted keys sender*N+listed), codes, send times.
        self._hello_keys = np.zeros(0, dtype=np.int64)
        self._hello_link = np.zeros(0, dtype=np.int8)
        self._hello_neigh = np.zeros(0, dtype=np.int8)
        self._hello_send = np.full(n, np.inf)
        self._hello_bytes = np.zeros(n, dtype=np.int64)  # size of each node's HELLO this round
        # TC rounds: content (sorted keys originator*N+selector), row pointers, ANSN of each node.
        self._tc_rounds: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._tc_round_id = 0
        self._last_tc: int | None = None  # round id of the latest TC round, if any TC was sent
        # Floods under way: pending transmissions (originator, sender, send time, round) and,
        # per round, the (originator, node) pairs that processed their copy (duplicate set).
        self._fl_msg = np.zeros(0, dtype=np.int64)
        self._fl_node = np.zeros(0, dtype=np.int64)
        self._fl_t = np.zeros(0)
        self._fl_round = np.zeros(0, dtype=np.int64)
        self._reached: dict[int, KeySet] = {}
        self._traffic_since = float(start_time)
        self._traffic = self._zero_traffic()

    #: Attributes that are configuration or shared, not state (see :meth:`state`).
    _NOT_STATE = frozenset({"cfg", "rng", "n", "hello_only", "_nn"})

    def state(self) -> dict[str, Any]:
        """A deep copy of every mutable attribute (tables, queues, timers, counters); the
        configuration and the random generator (the provider's) are not part of it."""
        return {k: copy.deepcopy(v) for k, v in vars(self).items() if k not in self._NOT_STATE}

    def restore(self, state: dict[str, Any]) -> None:
        """Take back a :meth:`state` (copied again, so that it can be restored many times)."""
        for k, v in state.items():
            setattr(self, k, copy.deepcopy(v))

    # ------------------------------------------------------------------ event loop
    def run_until(self, to_time: float, graph: LinkGraph) -> None:
        """Process every event in ``(time, to_time]`` with the links of ``graph``."""
        while True:
            build = self.next_hello if self.hello_only else min(self.next_hello, self.next_tc)
            if build > to_time:
                break
            self._deliver_until(build, graph)
            # Before building: a TC carries the ANSN after the selector expiries up to now.
            self._prune(build)
            if self.next_hello == build:
                self._build_hellos(build)
                self.next_hello = build + self.cfg.hello_interval_s
            if not self.hello_only and self.next_tc == build:
                self._build_tc(build)
                self.next_tc = build + self.cfg.tc_interval_s
        self._deliver_until(to_time, graph)
        self.time = float(to_time)

    def _jitter(self, size: int) -> np.ndarray:
        return self.rng.uniform(0.0, self.cfg.max_jitter_s, size=size)

    def _deliver_until(self, t: float, graph: LinkGraph) -> None:
        due = np.flatnonzero(self._hello_send <= t)
        if due.size:
            # Every node sends its HELLO, heard by anyone or not (ns-3 sends empty ones too).
            self._traffic["hello_sent"][due] += 1
            self._traffic["hello_bytes"][due] += self._hello_bytes[due]
            self._receive_hellos(due, graph)
            self._hello_send[due] = np.inf
        self._flood(t, graph)

    def _flood(self, t: float, graph: LinkGraph) -> None:
        """Send every TC copy due by ``t`` and process its receptions (RFC 3626 3.4.1, ns-3
        ``RecvOlsr``, ``ProcessTc`` and ``ForwardDefault``), wave after wave until none is due.

        A node accepts a copy only from a neighbour it has a symmetric link to when the copy
        arrives, processes only the first copy of each message (the earliest of a wave), and
        retransmits it after a new jitter when the sender is one of its MPR selectors at that
        moment. Link and selector state are those after every HELLO received by ``t``: the HELLOs
        of a round go out while the TCs built at the same instant are flooded, and the MPR
        selectors they add forward those TCs, as in ns-3.
        """
        if not (self._fl_t <= t).any():
            return
        n = self._nn
        size = int(n * n)
        got = []  # receptions (node, originator, time, round); applied together at the end
        sym_time = self.links.getter("sym", size)
        selector_expiry = self.selectors.getter("expiry", size)
        while True:
            now = self._fl_t <= t
            if not now.any():
                break
            msg, fwd, ts, rd = (
                a[now] for a in (self._fl_msg, self._fl_node, self._fl_t, self._fl_round)
            )
            self._fl_msg, self._fl_node = self._fl_msg[~now], self._fl_node[~now]
            self._fl_t, self._fl_round = self._fl_t[~now], self._fl_round[~now]
            pos, idx = csr_gather(graph.indptr, fwd)
            r = graph.indices[pos].astype(np.int64)
            m, f, tt, rid = msg[idx], fwd[idx], ts[idx], rd[idx]
            np.maximum.at(self.last_rx, r, tt)  # every packet heard recomputes the table
            ok = (r != m) & (sym_time(r * n + f) >= tt)
            sent = []
            for k in np.unique(rd):
                ptr = self._tc_rounds[int(k)][1]
                this = rd == k
                sent.append((fwd[this], wire.tc_size(np.diff(ptr))[msg[this]], msg[this]))
                at = np.flatnonzero(ok & (rid == k))
                mk = m[at] * n + r[at]
                fresh = ~self._reached[int(k)].contains(mk)
                at, mk = at[fresh], mk[fresh]
                if not at.size:
                    continue
                at = at[first_per_key(mk, size, np.argsort(tt[at], kind="stable"))]
                self._reached[int(k)].add(m[at] * n + r[at])
                got.append((r[at], m[at], tt[at], np.full(at.size, k)))
                relay = at[selector_expiry(r[at] * n + f[at]) >= tt[at]]
                self._fl_msg = np.concatenate([self._fl_msg, m[relay]])
                self._fl_node = np.concatenate([self._fl_node, r[relay]])
                self._fl_t = np.concatenate([self._fl_t, tt[relay] + self._jitter(relay.size)])
                self._fl_round = np.concatenate([self._fl_round, np.full(relay.size, k)])
            node, nbytes, orig = (np.concatenate(x) for x in zip(*sent, strict=True))
            self._count_tcs(node, nbytes, node != orig)
        if got:
            self._receive_tcs(*(np.concatenate(x) for x in zip(*got, strict=True)))
        live = set(np.unique(self._fl_round).tolist())
        self._reached = {k: v for k, v in self._reached.items() if k in live}

    def _count_tcs(self, node: np.ndarray, size: np.ndarray, forwarded: np.ndarray) -> None:
        tr, orig = self._traffic, ~forwarded
        np.add.at(tr["tc_sent"], node[orig], 1)
        np.add.at(tr["tc_bytes"], node[orig], size[orig])
        np.add.at(tr["tc_forwarded"], node[forwarded], 1)
        np.add.at(tr["tc_forwarded_bytes"], node[forwarded], size[forwarded])

    def _prune(self, t: float) -> None:
        """Drop the tuples that can no longer matter at ``t``.

        Link and MPR-selector tuples go when they expire, as ns-3's timers remove them. A
        selector tuple that expires on its own increments its node's ANSN
        (``MprSelTupleTimerExpire`` -> ``RemoveMprSelectorTuple`` -> ``IncrementAnsn``); one
        whose link lapses at the same instant (the same HELLO refreshed both) is erased first
        by ``NeighborLoss`` (``EraseMprSelectorTuples``), which leaves the ANSN alone: the link
        timer was scheduled earlier. Then :meth:`_forget`.
        """
        n = self._nn
        gone = self.selectors.cols["expiry"] < t
        if gone.any():
            keys = self.selectors.keys[gone]
            own_timer = self.selectors.cols["expiry"][gone] < self.links.get("sym", keys)
            np.add.at(self.ansn, keys[own_timer] // n, 1)
            self.selectors.keep(~gone)
        gone = self.links.cols["ltime"] < t
        if gone.any():
            # Keep their lapse instants: they are routing-table recomputations (ns-3
            # NeighborLoss) that the clock of :meth:`_clock` must not forget.
            np.maximum.at(self._lapsed, self.links.keys[gone] // n, self.links.cols["sym"][gone])
            self.links.keep(~gone)
        self._forget(t)
        live = set(np.unique(self._fl_round).tolist())
        live |= set(np.unique(self.topology.cols["round"]).astype(int).tolist())
        if self._last_tc is not None:
            live.add(self._last_tc)
        self._tc_rounds = {k: v for k, v in self._tc_rounds.items() if k in live}

    def _forget(self, t: float) -> None:
        """Drop the 2-hop and topology tuples that expired before their owner's last
        routing-table computation (:meth:`_clock` at ``t``): no table can use them again.

        Only those: a tuple that expires later still gives its route until the owner
        recomputes, since ns-3 removes an expired tuple (``Nb2hopTupleTimerExpire``,
        ``TopologyTupleTimerExpire``) without recomputing the table. Memory only: the tables
        are the same whether or not this runs.
        """
        n = self._nn
        clock = self._clock(t)
        for table, base in ((self.two_hop, n * n), (self.topology, n), (self.lingering, n * n)):
            table.keep(live_at(table.keys, base, table.cols["expiry"], clock))

    # ------------------------------------------------------------------ state views
    def _clock(self, t: float) -> np.ndarray:
        """Per-node time of the last routing-table computation at or before ``t``."""
        clock = np.maximum(self.last_rx, self._lapsed)
        sym = self.links.cols["sym"]
        lapsed = sym <= t
        if lapsed.any():
            np.maximum.at(clock, self.links.keys[lapsed] // self._nn, sym[lapsed])
        return np.minimum(clock, t)

    def _valid(self, clock: np.ndarray):
        """Symmetric links and strict 2-hop triples (:func:`~.twohop.strict_two_hop`) valid
        at each owner's ``clock``."""
        n = self._nn
        lk = self.links.keys
        owner = lk // n
        sym_ok = self.links.cols["sym"] > clock[owner]
        sym_keys = lk[sym_ok]
        s_owner, s_neigh = owner[sym_ok], sym_keys % n
        s_created = self.links.cols["created"][sym_ok]
        th = self.two_hop
        strict = strict_two_hop(th.keys, th.cols["expiry"], clock, sym_keys, n)
        return (s_owner, s_neigh, s_created, *strict)

    def routes(self, t: float | None = None, max_hops: int | None = None):
        """Every node's routing table at time ``t`` (default: now).

        Returns
        -------
        owner, dest, hops, next_hop : ndarray
            Sorted by ``(owner, dest)``.
        """
        t = self.time if t is None else t
        clock = self._clock(t)
        s_owner, s_neigh, _, t_owner, t_neigh, t_x = self._valid(clock)
        tp = None
        if not self.hello_only and len(self.topology):
            tp = _RoundTopology(self, clock)
        if self.hello_only:
            max_hops = 2 if max_hops is None else min(max_hops, 2)
        return compute_routes(
            self.n,
            s_owner,
            s_neigh,
            t_owner,
            t_neigh,
            t_x,
            tp,
            max_hops=max_hops,
            strict=True,
        )

    def mpr_keys(self, t: float) -> np.ndarray:
        """Sorted keys ``r * N + m`` of every node's MPR set, computed on the state at ``t``."""
        clock = np.full(self.n, float(t))
        s_owner, s_neigh, s_created, t_owner, t_neigh, t_x = self._valid(clock)
        return select_mprs(
            self.n,
            s_owner,
            s_neigh,
            s_created,
            t_owner,
            t_neigh,
            t_x,
            self.cfg.willingness,
        )

    # ------------------------------------------------------------------ control traffic
    def _zero_traffic(self) -> dict[str, np.ndarray]:
        names = ("hello_sent", "hello_bytes", "tc_sent", "tc_bytes")
        names += ("tc_forwarded", "tc_forwarded_bytes")
        return {k: np.zeros(self.n, dtype=np.int64) for k in names}

    def take_control_traffic(self) -> ControlTraffic:
        """HELLOs and TCs each node sent since the previous call (or the start), and their
        bytes; the counters then start again from zero."""
        out = ControlTraffic(self._traffic_since, self.time, **self._traffic)
        self._traffic = self._zero_traffic()
        self._traffic_since = self.time
        return out

    # ------------------------------------------------------------------ messages
    def hello_message(self, node: int) -> list[tuple[int, int]]:
        """Link messages of ``node``'s latest HELLO: ``(neighbour, link_code)`` pairs, with the
        RFC 3626 section 6.1.1 code ``link_type | neighbour_type << 2`` (link type 1 asym,
        2 sym, 3 lost; neighbour type 0 not, 1 sym, 2 MPR): 1 = asymmetric, 6 = symmetric,
        10 = symmetric and selected as MPR."""
        n = self._nn
        lo, hi = np.searchsorted(self._hello_keys, [node * n, (node + 1) * n])
        codes = _link_codes(self._hello_link[lo:hi], self._hello_neigh[lo:hi])
        return [(int(k % n), int(c)) for k, c in zip(self._hello_keys[lo:hi], codes, strict=True)]

    def tc_message(self, node: int) -> list[int] | None:
        """Advertised neighbours (its MPR selectors) of ``node``'s TC in the latest TC round,
        or ``None`` if it sent none (ns-3 sends no empty TC)."""
        if self._last_tc is None:
            return None
        keys, ptr, _ = self._tc_rounds[self._last_tc]
        sel = keys[ptr[node] : ptr[node + 1]] % self._nn
        return sel.astype(int).tolist() if sel.size else None

    # ------------------------------------------------------------------ HELLO
    def _build_hellos(self, b: float) -> None:
        lk = self.links.keys
        alive = self.links.cols["ltime"] >= b
        keys = lk[alive]
        sym = self.links.cols["sym"][alive] >= b
        asym = self.links.cols["asym"][alive] >= b
        link = np.where(sym, _SYM, np.where(asym, _ASYM, _LOST)).astype(np.int8)
        neigh = np.where(sym, _SYM_NEIGH, _NOT_NEIGH).astype(np.int8)
        neigh[sorted_contains(self.mpr_keys(b), keys) & sym] = _MPR_NEIGH
        self._hello_keys, self._hello_link, self._hello_neigh = keys, link, neigh
        # One link message per distinct link code (RFC 3626 section 6.1), as hello_message lists.
        owner = keys // self._nn
        groups = sorted_unique(owner * 16 + _link_codes(link, neigh)) // 16
        self._hello_bytes = wire.hello_size(
            np.bincount(groups, minlength=self.n), np.bincount(owner, minlength=self.n)
        )
        self._hello_send = b + self._jitter(self.n)

    def _receive_hellos(self, senders: np.ndarray, graph: LinkGraph) -> None:
        n, V = self._nn, self.cfg.neighbour_hold_s
        pos, idx = csr_gather(graph.indptr, senders)
        j = senders[idx].astype(np.int64)
        r = graph.indices[pos].astype(np.int64)
        if r.size == 0:
            return
        d = self._hello_send[j]
        np.maximum.at(self.last_rx, r, d)
        # How j's HELLO lists r.
        hk = self._hello_keys
        hi, found = self._lookup(hk, j * n + r)
        code = np.full(r.size, -1, dtype=np.int8)
        ntype = np.full(r.size, -1, dtype=np.int8)
        code[found] = self._hello_link[hi[found]]
        ntype[found] = self._hello_neigh[hi[found]]
        # Link sensing, RFC 7.1.1.
        lkey = r * n + j
        # ns-3 removes a link tuple once its L_time passes (LinkTupleTimerExpire): a HELLO
        # after that creates a new one, and with it a neighbour tuple (AddNeighborTuple),
        # which increments the ANSN.
        lfound = self.links.get("ltime", lkey) >= d
        np.add.at(self.ansn, r[~lfound], 1)
        sym_t = np.where(lfound, self.links.get("sym", lkey), d - 1.0)
        ltime = np.where(lfound, self.links.get("ltime", lkey), d + V)
        created = np.where(lfound, self.links.get("created", lkey), d)
        asym_t = d + V
        listed = code >= _ASYM
        sym_t = np.where(code == _LOST, d - 1.0, np.where(listed, d + V, sym_t))
        ltime = np.where(listed, d + 2 * V, ltime)
        ltime = np.maximum(ltime, asym_t)
        self.links.upsert(lkey, asym=asym_t, sym=sym_t, ltime=ltime, created=created)
        # 2-hop set, RFC 8.2.1: only from symmetric neighbours; replaces what j said before.
        is_sym = sym_t >= d
        rs, js = r[is_sym], j[is_sym]
        d_of_sender = self._hello_send
        self.two_hop.drop_prefixes(rs * n + js, n)
        two = self._hello_neigh >= _SYM_NEIGH
        c_keys = hk[two]
        if c_keys.size and rs.size:
            ptr = np.searchsorted(c_keys, np.arange(self.n + 1, dtype=np.int64) * n)
            keys, expiry = round_tuples(rs, js, c_keys, ptr, d_of_sender + V, n)
            self.two_hop.upsert(keys, expiry=expiry)
        # MPR-selector set, RFC 8.4.1.
        sel = ntype == _MPR_NEIGH
        if sel.any():
            # A new selector tuple increments the ANSN (AddMprSelectorTuple).
            new = self.selectors.get("expiry", lkey[sel]) < d[sel]
            np.add.at(self.ansn, r[sel][new], 1)
            self.selectors.upsert(lkey[sel], expiry=d[sel] + V)

    @staticmethod
    def _lookup(keys: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        idx = np.searchsorted(keys, q)
        found = idx < keys.size
        found[found] = keys[idx[found]] == q[found]
        return idx, found

    # ------------------------------------------------------------------ TC
    def _build_tc(self, b: float) -> None:
        n = self._nn
        live = self.selectors.cols["expiry"] >= b
        sk = self.selectors.keys[live]
        self._last_tc = None
        if sk.size == 0:
            return
        # TC of o lists its MPR selectors: content keys o*N + selector.
        origins = sorted_unique(sk // n).astype(np.int64)
        rid = self._tc_round_id
        self._tc_round_id += 1
        self._last_tc = rid
        ptr = np.searchsorted(sk, np.arange(self.n + 1) * n)
        self._tc_rounds[rid] = (sk, ptr, self.ansn.copy())
        reached = KeySet(int(n * n))
        reached.add(origins * n + origins)
        self._reached[rid] = reached
        # Each originator sends its TC after a jitter; :meth:`_flood` takes it from there.
        self._fl_msg = np.concatenate([self._fl_msg, origins])
        self._fl_node = np.concatenate([self._fl_node, origins])
        self._fl_t = np.concatenate([self._fl_t, b + self._jitter(origins.size)])
        self._fl_round = np.concatenate([self._fl_round, np.full(origins.size, rid)])

    def _receive_tcs(self, r: np.ndarray, o: np.ndarray, t: np.ndarray, rounds: np.ndarray):
        """TC processing, RFC 3626 section 9.5 as ns-3 3.44 ``ProcessTc`` does it.

        Receiver ``r`` of originator ``o``'s TC with sequence number ``ansn``: (2) ignores it if
        it holds a tuple of ``o`` with a newer ANSN; (3) removes ``o``'s tuples with an older
        ANSN; (4) refreshes or adds a tuple per advertised neighbour. Tuples of the same ANSN
        that the TC no longer lists are therefore kept until their own expiry: they move to
        :attr:`lingering` with the expiry of the TC that last listed them. Within one ANSN
        the advertised set only shrinks (a selector is added, or expires on its own, only with
        a new ANSN), so the lingering tuples are those of the previous TC that the new one
        leaves out.
        """
        n, hold = self._nn, self.cfg.topology_hold_s
        for rid in np.unique(rounds):
            sel = rounds == rid
            rr, oo, tt = r[sel], o[sel], t[sel]
            content, _, ansn = self._tc_rounds[int(rid)]
            key, a = rr * n + oo, ansn[oo].astype(float)
            idx, found = self.topology.find(key)
            old_a = np.full(key.size, -np.inf)
            old_a[found] = self.topology.cols["ansn"][idx[found]]
            accept = ~(old_a > a)
            key, oo, tt, a, old_a = key[accept], oo[accept], tt[accept], a[accept], old_a[accept]
            same = old_a == a
            # Step 3: a new ANSN erases the older tuples, lingering ones included.
            if len(self.lingering):
                erase = KeySet(int(n * n))
                erase.add(key[~same])
                self.lingering.keep(~erase.contains(self.lingering.keys // n))
            if same.any():
                self._linger(key[same], oo[same], content)
            self.topology.upsert(key, expiry=tt + hold, round=float(rid), ansn=a)

    def _linger(self, key: np.ndarray, o: np.ndarray, content: np.ndarray) -> None:
        """For receptions ``key = r * N + o`` of a TC with the same ANSN as the one ``r``
        holds: keep the previously advertised neighbours the new TC (``content``, sorted keys
        ``o * N + dest``) leaves out, and drop the lingering tuples it lists again."""
        n = self._nn
        old_round = self.topology.get("round", key).astype(np.int64)
        old_expiry = self.topology.get("expiry", key)
        for rid in np.unique(old_round):
            at = np.flatnonzero(old_round == rid)
            prev, ptr, _ = self._tc_rounds[int(rid)]
            pos, k = csr_gather(ptr, o[at])
            dest = prev[pos] % n
            left_out = ~sorted_contains(content, o[at][k] * n + dest)
            keys = key[at][k][left_out] * n + dest[left_out]
            self.lingering.upsert(keys, expiry=old_expiry[at][k][left_out])
        lk = self.lingering.keys
        relisted = sorted_contains(sorted_unique(key), lk // n) & sorted_contains(
            content, (lk // n) % n * n + lk % n
        )
        if relisted.any():
            self.lingering.keep(~relisted)


class _RoundTopology:
    """Topology tuples of every node, as the TC round each ``(r, last)`` holds plus the
    lingering tuples (see :func:`~.routing.compute_routes`)."""

    def __init__(self, engine: OlsrEngine, clock: np.ndarray) -> None:
        n = engine._nn
        table = engine.topology
        ok = live_at(table.keys, n, table.cols["expiry"], clock)
        self.keys = table.keys[ok]
        self.round = table.cols["round"][ok].astype(np.int64)
        self.rounds = engine._tc_rounds
        self.n = n
        lk = engine.lingering.keys
        ok = live_at(lk, n * n, engine.lingering.cols["expiry"], clock)
        self.linger_last = lk[ok] // n  # sorted owner * N + last
        self.linger_dest = lk[ok] % n
        self.lingers = KeySet(int(n * n))
        self.lingers.add(self.linger_last)
        self.dense = None
        if n * n <= tables.DENSE_LIMIT:
            self.dense = np.full(int(n * n), -1, dtype=np.int32)
            self.dense[self.keys] = self.round

    def advertised(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = self.n
        if self.dense is not None:
            rid = self.dense[keys]
            hit = np.flatnonzero(rid >= 0)
            rid = rid[hit]
        else:
            idx = np.searchsorted(self.keys, keys)
            found = idx < self.keys.size
            found[found] = self.keys[idx[found]] == keys[found]
            hit = np.flatnonzero(found)
            rid = self.round[idx[hit]]
        src_all, dest_all = [], []
        for r in np.unique(rid):
            sel = hit[rid == r]
            content, ptr, _ = self.rounds[int(r)]
            pos, k = csr_gather(ptr, keys[sel] % n)
            src_all.append(sel[k])
            dest_all.append(content[pos] % n)
        if self.linger_last.size:
            q = np.flatnonzero(self.lingers.contains(keys))
            lo = np.searchsorted(self.linger_last, keys[q], "left")
            hi = np.searchsorted(self.linger_last, keys[q], "right")
            ptr = np.concatenate([[0], np.cumsum(hi - lo)])
            pos, k = csr_gather(ptr, np.arange(q.size))
            src_all.append(q[k])
            dest_all.append(self.linger_dest[lo[k] + pos - ptr[k]])
        if not src_all:
            e = np.zeros(0, dtype=np.int64)
            return e, e
        return np.concatenate(src_all), np.concatenate(dest_all)
