"""A shared 802.11a channel: the flood of a stage's state messages under CSMA/CA, compiled.

Every frame of the stage — each robot's own state message, each relay, each OLSR control
frame — is simulated on one channel, event by event (:func:`simulate`):

* **Start times.** A message frame becomes ready at its node a uniform jitter in
  ``[0, jitter_s]`` after its origin: the stage time for a robot's own message, the reception
  time for a relay (as the ``ns3`` model and OLSR do, RFC 3626 section 3.5). A control frame
  is ready at its given time.
* **Carrier sense and DCF** (IEEE 802.11-2016 10.3; ns-3's ``ChannelAccessManager``). A node
  senses the medium busy while the frames on the air reach it with at least ``cca_dbm`` (-82
  dBm, ns-3's ``CcaSensitivity``) together, or while it transmits. A frame that becomes ready at
  an idle MAC whose medium has been idle for DIFS (34 µs) and whose backoff has run out goes at
  once; otherwise the node draws a backoff of ``U{0..15}`` slots of 9 µs where none is left
  (ns-3's ``NeedBackoffUponAccess``) and counts it down while the medium is idle, DIFS after
  each busy period, frozen while busy. After each transmission it draws a new backoff
  (post-backoff), so a node's next frame, a relay say, waits behind it. Broadcasts have no ACK
  and no retry. Two nodes whose countdowns end within the clear-channel assessment time (4 µs)
  of each other both transmit: robots that hear each other collide only when they end their
  backoffs in the same slot.
* **Airtime** at the PHY rate: the 20 µs preamble and SIGNAL field, then the 16 SERVICE bits,
  the frame and the 6 tail bits in whole OFDM symbols of 4 µs
  (:func:`~swarmgames.comms.wire.ofdm_airtime_s`).
* **Reception by SINR, with capture** (ns-3's ``InterferenceHelper`` and preamble detection):
  an idle receiver that is not transmitting locks onto a frame received at or above the
  threshold whose SINR at its start is at least ``detect_db``; the frame is received when
  its SINR stays at least ``decode_db`` until its end: against the thermal noise plus the power of
  every other frame on the air at the receiver, audible or not (down to ``floor_dbm``). A
  frame that starts while the receiver is locked onto another is interference only; a
  receiver that starts transmitting loses the frame it was receiving. Hidden terminals and
  same-slot starts lose frames by this rule alone.
* **Flooding.** A robot that receives a message frame from a transmitter whose routing table
  lists it as a 1-hop neighbour (``link``) holds the message from that instant; on its first
  reception at depth d < ``ttl`` it relays the message once.

The simulation runs until the channel is quiet, so a message may arrive after the decision;
the caller decides what counts. Random draws (jitter, backoffs, configured loss) come from a
counter-based generator (SplitMix64) keyed by one 64-bit seed that the caller draws from the
run's numpy Generator: the result depends on the seed alone, never on threads.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from swarmgames.arrays import freeze_fields

__all__ = ["ChannelResult", "Mac", "simulate"]

_END, _ACCESS, _READY = 0, 1, 2  # event kinds, in the order they run at one instant


@dataclass(frozen=True)
class Mac:
    """802.11a OFDM DCF timing (IEEE 802.11-2016 Table 17-21; ns-3's defaults).

    Attributes
    ----------
    slot_s, difs_s : float
        Slot time (9 µs) and DIFS (SIFS 16 µs + 2 slots).
    cw_min : int
        Backoffs are drawn from ``U{0..cw_min}`` (broadcasts never widen the window).
    cca_s : float
        Clear-channel assessment time: a node does not sense a frame that started less than
        this long before it transmits.
    noise_dbm : float
        Thermal noise over 20 MHz with ns-3's 7 dB noise figure.
    detect_db : float
        SINR a frame needs at its start for the receiver to lock onto it.
    decode_db : float
        SINR the frame needs throughout to be decoded. Both are calibrated against the
        recorded ns-3 runs (docs/comms.md, "Fidelity against ns-3"): ns-3 detects a
        preamble from 4 dB and then decodes by a packet error rate that is still small at
        2 dB for these short frames at 6 Mbit/s; one threshold of 2 dB for both reproduces its
        delivery at every recorded density.
    floor_dbm : float
        Frames received below this power are not counted as interference.
    cca_dbm : float
        A node senses the medium busy while the power it receives from the frames on the air
        adds up to at least this (ns-3's ``CcaSensitivity``, -82 dBm).
    """

    slot_s: float = 9e-6
    difs_s: float = 34e-6
    cw_min: int = 15
    cca_s: float = 4e-6
    noise_dbm: float = -93.97
    detect_db: float = 2.0
    decode_db: float = 2.0
    floor_dbm: float = -92.0
    cca_dbm: float = -82.0


@dataclass(frozen=True, eq=False)
class ChannelResult:
    """What one stage's channel did (read-only arrays).

    Attributes
    ----------
    receiver, sender, depth : ndarray of int64, shape (R,)
        First receptions of each message, sorted by (receiver, sender); depth 1 is the
        sender's own frame.
    arrival : ndarray of float64, shape (R,)
        Time of each first reception (the end of the frame), seconds.
    sent, forwarded : ndarray of int64, shape (N,)
        Message frames each robot transmitted: its own, and relays.
    bytes_forwarded : ndarray of int64, shape (N,)
        Payload of the relays each robot transmitted, bytes.
    airtime : ndarray of float64, shape (N,)
        Seconds each robot spent transmitting (message and control frames).
    collided : int
        Frame receptions lost at robots that locked onto them (interference or their own
        transmission).
    """

    receiver: np.ndarray
    sender: np.ndarray
    depth: np.ndarray
    arrival: np.ndarray
    sent: np.ndarray
    forwarded: np.ndarray
    bytes_forwarded: np.ndarray
    airtime: np.ndarray
    collided: int

    def __post_init__(self) -> None:
        freeze_fields(self)


@njit(cache=True, inline="always")
def _mix(x):
    """SplitMix64's finaliser on a uint64."""
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@njit(cache=True, inline="always")
def _uniform(seed, counter):
    """A uniform double in [0, 1) from draw number ``counter`` of ``seed``."""
    x = _mix(seed + np.uint64(counter) * np.uint64(0x9E3779B97F4A7C15))
    return float(x >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True)
def _grow(arr, size):
    out = np.empty(max(size, 2 * arr.size), arr.dtype)
    out[: arr.size] = arr
    return out


@njit(cache=True, inline="always")
def _earlier(et, ev, a, b):
    """Whether heap entry ``a`` runs before ``b``: by time, then kind, then sequence."""
    if et[a] != et[b]:
        return et[a] < et[b]
    if ev[a, 0] != ev[b, 0]:
        return ev[a, 0] < ev[b, 0]
    return ev[a, 1] < ev[b, 1]


@njit(cache=True, inline="always")
def _swap(et, ev, a, b):
    """Exchange heap entries ``a`` and ``b``."""
    et[a], et[b] = et[b], et[a]
    for c in range(4):
        ev[a, c], ev[b, c] = ev[b, c], ev[a, c]


@njit(cache=True)
def _push(ev, et, ne, seq, t, kind, arg, ver):
    """Add an event to the heap (``et`` its times; ``ev`` rows of kind, sequence, argument
    and version); returns the arrays, possibly grown."""
    if ne == et.size:
        et = _grow(et, ne + 1)
        grown = np.empty((2 * ev.shape[0], 4), np.int64)
        grown[: ev.shape[0]] = ev
        ev = grown
    et[ne] = t
    ev[ne, 0], ev[ne, 1], ev[ne, 2], ev[ne, 3] = kind, seq, arg, ver
    j = ne
    while j > 0:
        p = (j - 1) // 2
        if _earlier(et, ev, j, p):
            _swap(et, ev, j, p)
            j = p
        else:
            break
    return ev, et


@njit(cache=True)
def _pop(ev, et, ne):
    """Remove the earliest event (heap of ``ne`` entries); returns it."""
    t, kind, arg, ver = et[0], ev[0, 0], ev[0, 2], ev[0, 3]
    last = ne - 1
    et[0] = et[last]
    for c in range(4):
        ev[0, c] = ev[last, c]
    j = 0
    while True:
        a = 2 * j + 1
        if a >= last:
            break
        if a + 1 < last and _earlier(et, ev, a + 1, a):
            a += 1
        if _earlier(et, ev, a, j):
            _swap(et, ev, j, a)
            j = a
        else:
            break
    return t, kind, arg, ver


@njit(cache=True)
def _draw_backoff(seed, draws, cw):
    return int(_uniform(seed, draws) * (cw + 1))


@njit(cache=True)
def _kernel(
    n,
    hptr,
    hv,
    hpow,
    hlink,
    own_ready,
    own_air,
    own_bytes,
    ctl_node,
    ctl_ready,
    ctl_air,
    active,
    ttl,
    jitter_s,
    loss,
    seed,
    slot,
    difs,
    cw,
    cca,
    noise_mw,
    detect,
    decode,
    rx_mw,
    cs_mw,
):
    # Frames: node, message (-1: control), depth, airtime; a FIFO queue per node.
    cap = 4 * n + ctl_node.size + 16
    f_node = np.empty(cap, np.int64)
    f_msg = np.empty(cap, np.int64)
    f_depth = np.empty(cap, np.int64)
    f_air = np.empty(cap, np.float64)
    f_next = np.empty(cap, np.int64)
    nf = 0
    # Events: a binary heap on (time, kind, sequence).
    et = np.empty(2 * cap, np.float64)
    ev = np.empty((2 * cap, 4), np.int64)
    ne = 0
    seq = 0
    draws = 0
    # Nodes.
    head = np.full(n, -1, np.int64)
    tail = np.full(n, -1, np.int64)
    busy_from = np.zeros(n, np.float64)
    txing = np.zeros(n, np.bool_)
    idle_since = np.full(n, -1e30)
    backoff = np.zeros(n, np.int64)
    contending = np.zeros(n, np.bool_)
    access_at = np.zeros(n, np.float64)
    version = np.zeros(n, np.int64)
    lock = np.full(n, -1, np.int64)
    lock_ok = np.zeros(n, np.bool_)
    lock_p = np.zeros(n, np.float64)
    total = np.zeros(n, np.float64)
    n_on = np.zeros(n, np.int64)
    sent = np.zeros(n, np.int64)
    forwarded = np.zeros(n, np.int64)
    fwd_bytes = np.zeros(n, np.int64)
    airtime = np.zeros(n, np.float64)
    # First receptions: an open-addressing set of message * n + node, and their records.
    hcap = 1
    while hcap < 64 * n:  # grown as it fills
        hcap *= 2
    hkeys = np.full(hcap, -1, np.int64)
    r_node = np.empty(cap, np.int64)
    r_msg = np.empty(cap, np.int64)
    r_depth = np.empty(cap, np.int64)
    r_time = np.empty(cap, np.float64)
    nr = 0
    collided = 0

    for i in range(n):  # own messages first (frame i is robot i's), then control frames
        f_node[nf], f_msg[nf], f_depth[nf], f_air[nf] = i, i, 1, own_air[i]
        nf += 1
    for c in range(ctl_node.size):
        f_node[nf], f_msg[nf], f_depth[nf], f_air[nf] = ctl_node[c], -1, 0, ctl_air[c]
        nf += 1
    for f in range(nf):
        if not active[f_node[f]]:
            continue
        if f < n:
            when = own_ready[f] + jitter_s * _uniform(seed, draws)
            draws += 1
        else:
            when = ctl_ready[f - n]
        ev, et = _push(ev, et, ne, seq, when, _READY, f, 0)
        ne += 1
        seq += 1

    while ne > 0:
        now, kind, arg, ver = _pop(ev, et, ne)
        ne -= 1
        start_node = -1
        if kind == _READY:
            f = arg
            v = f_node[f]
            f_next[f] = -1
            if tail[v] >= 0:
                f_next[tail[v]] = f
            else:
                head[v] = f
            tail[v] = f
            if not contending[v] and not txing[v] and head[v] == f:
                contending[v] = True
                if total[v] < cs_mw:
                    idle = now - idle_since[v]
                    left = backoff[v]
                    if idle >= difs:
                        left = max(0, backoff[v] - int((idle - difs) / slot))
                    if left == 0 and idle >= difs:
                        start_node = v
                    else:
                        if left == 0:  # a backoff for a frame that found the medium busy
                            backoff[v] = _draw_backoff(seed, draws, cw)
                            draws += 1
                        access_at[v] = max(now, idle_since[v] + difs + backoff[v] * slot)
                        version[v] += 1
                        ev, et = _push(ev, et, ne, seq, access_at[v], _ACCESS, v, version[v])
                        ne += 1
                        seq += 1
                elif (
                    now - busy_from[v] < cca
                    and backoff[v] == 0
                    and (busy_from[v] - idle_since[v] >= difs)
                ):
                    start_node = v  # the frame on the air started too recently to be sensed
                elif backoff[v] == 0:
                    backoff[v] = _draw_backoff(seed, draws, cw)
                    draws += 1
        elif kind == _ACCESS:
            if ver == version[arg] and contending[arg]:
                start_node = arg
        else:  # the end of frame ``arg``
            f = arg
            u = f_node[f]
            for e in range(hptr[u], hptr[u + 1]):
                v = hv[e]
                was = total[v] >= cs_mw
                n_on[v] -= 1
                total[v] = 0.0 if n_on[v] == 0 else total[v] - hpow[e]
                if was and total[v] < cs_mw and not txing[v]:  # the medium turns idle
                    idle_since[v] = now
                    if contending[v]:
                        access_at[v] = now + difs + backoff[v] * slot
                        version[v] += 1
                        ev, et = _push(ev, et, ne, seq, access_at[v], _ACCESS, v, version[v])
                        ne += 1
                        seq += 1
                if lock[v] != f:
                    continue
                lock[v] = -1
                if not lock_ok[v]:
                    collided += 1
                    continue
                m = f_msg[f]
                if not hlink[e] or m < 0 or m == v:
                    continue
                if loss > 0.0:  # lost besides the channel (configured, i.i.d.)
                    draws += 1
                    if _uniform(seed, draws - 1) < loss:
                        continue
                key = m * n + v
                h = (key * 0x9E3779B1) & (hcap - 1)
                fresh = True
                while hkeys[h] >= 0:
                    if hkeys[h] == key:
                        fresh = False
                        break
                    h = (h + 1) & (hcap - 1)
                if not fresh:
                    continue
                hkeys[h] = key
                if nr == r_node.size:
                    r_node = _grow(r_node, nr + 1)
                    r_msg = _grow(r_msg, nr + 1)
                    r_depth = _grow(r_depth, nr + 1)
                    r_time = _grow(r_time, nr + 1)
                r_node[nr], r_msg[nr], r_depth[nr], r_time[nr] = v, m, f_depth[f], now
                nr += 1
                if 8 * nr > 3 * hcap:  # keep the set at most 3/8 full
                    old = hkeys
                    hcap *= 2
                    hkeys = np.full(hcap, -1, np.int64)
                    for s in range(old.size):
                        if old[s] >= 0:
                            h2 = (old[s] * 0x9E3779B1) & (hcap - 1)
                            while hkeys[h2] >= 0:
                                h2 = (h2 + 1) & (hcap - 1)
                            hkeys[h2] = old[s]
                if f_depth[f] < ttl:  # relayed once, after its own jitter
                    if nf == f_node.size:
                        f_node = _grow(f_node, nf + 1)
                        f_msg = _grow(f_msg, nf + 1)
                        f_depth = _grow(f_depth, nf + 1)
                        f_air = _grow(f_air, nf + 1)
                        f_next = _grow(f_next, nf + 1)
                    f_node[nf], f_msg[nf], f_depth[nf], f_air[nf] = v, m, f_depth[f] + 1, own_air[m]
                    when = now + jitter_s * _uniform(seed, draws)
                    draws += 1
                    ev, et = _push(ev, et, ne, seq, when, _READY, nf, 0)
                    ne += 1
                    seq += 1
                    nf += 1
            # the transmitter: a post-backoff, then its next frame
            txing[u] = False
            backoff[u] = _draw_backoff(seed, draws, cw)
            draws += 1
            if total[u] < cs_mw:
                idle_since[u] = now
            if head[u] >= 0:
                contending[u] = True
                if total[u] < cs_mw:
                    access_at[u] = now + difs + backoff[u] * slot
                    version[u] += 1
                    ev, et = _push(ev, et, ne, seq, access_at[u], _ACCESS, u, version[u])
                    ne += 1
                    seq += 1

        if start_node >= 0:  # the node's head frame goes on the air now
            u = start_node
            f = head[u]
            head[u] = f_next[f]
            if head[u] < 0:
                tail[u] = -1
            contending[u] = False
            txing[u] = True
            if lock[u] >= 0:  # a transmitter receives nothing
                lock[u] = -1
                collided += 1
            airtime[u] += f_air[f]
            if f_msg[f] >= 0:
                if f_depth[f] == 1:
                    sent[u] += 1
                else:
                    forwarded[u] += 1
                    fwd_bytes[u] += own_bytes[f_msg[f]]
            for e in range(hptr[u], hptr[u + 1]):
                v = hv[e]
                pw = hpow[e]
                was = total[v] >= cs_mw
                total[v] += pw
                n_on[v] += 1
                if not was and total[v] >= cs_mw:
                    busy_from[v] = now
                    if not txing[v]:
                        # the medium turns busy: the countdown stops at the slots elapsed
                        counted = now - (idle_since[v] + difs)
                        if counted > 0:
                            backoff[v] = max(0, backoff[v] - int(counted / slot))
                        if contending[v] and access_at[v] - now > cca:
                            version[v] += 1  # cancelled; rescheduled when the medium is idle
                if lock[v] >= 0:
                    if lock_p[v] < decode * (noise_mw + total[v] - lock_p[v]):
                        lock_ok[v] = False
                elif (
                    active[v]
                    and not txing[v]
                    and pw >= rx_mw
                    and pw >= detect * (noise_mw + total[v] - pw)
                ):
                    lock[v] = f
                    lock_p[v] = pw
                    lock_ok[v] = True
            ev, et = _push(ev, et, ne, seq, now + f_air[f], _END, f, 0)
            ne += 1
            seq += 1
    return (
        r_node[:nr].copy(),
        r_msg[:nr].copy(),
        r_depth[:nr].copy(),
        r_time[:nr].copy(),
        sent,
        forwarded,
        fwd_bytes,
        airtime,
        collided,
    )


def simulate(
    heard_indptr: np.ndarray,
    heard: np.ndarray,
    power_dbm: np.ndarray,
    link: np.ndarray,
    own_ready_s: np.ndarray,
    own_airtime_s: np.ndarray,
    own_bytes: np.ndarray,
    *,
    ttl: int,
    jitter_s: float,
    seed: int,
    loss_rate: float = 0.0,
    active: np.ndarray | None = None,
    control_node: np.ndarray | None = None,
    control_ready_s: np.ndarray | None = None,
    control_airtime_s: np.ndarray | None = None,
    mac: Mac | None = None,
    rx_threshold_dbm: float = -82.0,
) -> ChannelResult:
    """Simulate one stage's flood on the shared channel (module docstring).

    Parameters
    ----------
    heard_indptr, heard : ndarray of int64
        CSR rows: row u lists every robot that receives u's frames at or above
        ``mac.floor_dbm`` (u itself excluded).
    power_dbm : ndarray of float64, shape (E,)
        The received power of each entry of ``heard``, dBm.
    link : ndarray of bool, shape (E,)
        Whether u's routing table lists the receiver as a 1-hop neighbour: only then does a
        received message count (and get relayed).
    own_ready_s : ndarray of float64, shape (N,)
        When each robot's own message is composed (before its jitter), seconds.
    own_airtime_s : ndarray of float64, shape (N,)
        Airtime of each robot's message frame (its relays too), seconds.
    own_bytes : ndarray of int64, shape (N,)
        Payload of each robot's message, bytes (for the relays' byte count).
    ttl : int
        Hops a message travels at most (>= 1).
    jitter_s : float
        Upper end of every message frame's uniform jitter, seconds.
    seed : int
        Key of the generator of the jitter, backoff and loss draws (64 bits).
    loss_rate : float
        Probability that a message frame the channel delivered is lost all the same
        (i.i.d., outside interference the model does not see).
    active : ndarray of bool, shape (N,), optional
        Robots whose radio works (default all): the others send, relay and hear nothing.
    control_node, control_ready_s, control_airtime_s : ndarray, optional
        Control frames (OLSR): transmitter, ready time and airtime of each.
    mac : Mac, optional
    rx_threshold_dbm : float
        Frames received below this power are neither sensed nor decoded.

    Returns
    -------
    ChannelResult

    Examples
    --------
    Two robots 300 m apart, alone on the channel: each hears the other's message once.

    >>> from swarmgames.comms.wire import ofdm_airtime_s
    >>> ptr, rows = np.array([0, 1, 2]), np.array([1, 0])
    >>> res = simulate(ptr, rows, np.array([-80.2, -80.2]), np.ones(2, bool),
    ...                np.zeros(2), ofdm_airtime_s(np.array([75, 75])), np.array([75, 75]), ttl=2,
    ...                jitter_s=0.04, seed=1)
    >>> res.receiver.tolist(), res.sender.tolist(), res.collided
    ([0, 1], [1, 0], 0)
    """
    mac = Mac() if mac is None else mac
    n = own_ready_s.size
    active = np.ones(n, dtype=bool) if active is None else np.asarray(active, dtype=bool)
    empty_i, empty_f = np.zeros(0, np.int64), np.zeros(0, np.float64)
    ctl_node = empty_i if control_node is None else np.asarray(control_node, np.int64)
    ctl_ready = empty_f if control_ready_s is None else np.asarray(control_ready_s, np.float64)
    ctl_air = empty_f if control_airtime_s is None else np.asarray(control_airtime_s, np.float64)
    mw = 10.0 ** (np.asarray(power_dbm, np.float64) / 10.0)
    rx_mw = 10.0 ** (rx_threshold_dbm / 10.0)
    keep = mw >= 10.0 ** (mac.floor_dbm / 10.0)
    indptr = np.asarray(heard_indptr, np.int64)
    if not keep.all():
        rows = np.repeat(np.arange(n), np.diff(indptr))[keep]
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))])
    node, msg, depth, when, sent, fwd, fwd_bytes, air, collided = _kernel(
        np.int64(n),
        indptr,
        np.asarray(heard, np.int64)[keep],
        mw[keep],
        np.asarray(link, dtype=bool)[keep],
        np.asarray(own_ready_s, np.float64),
        np.asarray(own_airtime_s, np.float64),
        np.asarray(own_bytes, np.int64),
        ctl_node,
        ctl_ready,
        ctl_air,
        active,
        np.int64(ttl),
        float(jitter_s),
        float(loss_rate),
        np.uint64(int(seed) & 0xFFFFFFFFFFFFFFFF),
        mac.slot_s,
        mac.difs_s,
        np.int64(mac.cw_min),
        mac.cca_s,
        10.0 ** (mac.noise_dbm / 10.0),
        10.0 ** (mac.detect_db / 10.0),
        10.0 ** (mac.decode_db / 10.0),
        rx_mw,
        10.0 ** (mac.cca_dbm / 10.0),
    )
    order = np.argsort(node * max(n, 1) + msg)
    return ChannelResult(
        receiver=node[order],
        sender=msg[order],
        depth=depth[order],
        arrival=when[order],
        sent=sent,
        forwarded=fwd,
        bytes_forwarded=fwd_bytes,
        airtime=air,
        collided=int(collided),
    )
