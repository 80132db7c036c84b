"""The shared channel (``comms.model = "csma"``): carrier sense, backoff, collisions, airtime.

Reference behaviour: IEEE 802.11-2016 DCF (10.3) for 802.11a OFDM (17.4.3, Table 17-21:
9 µs slots, DIFS 34 µs, CWmin 15), as ns-3 3.44 implements it for broadcasts (no ACK, no
retry); docs/comms.md derives the airtime ns-3 measures (232 µs for a 91-byte message).
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse import csgraph

from swarmgames.comms import CsmaComms, RoutedComms
from swarmgames.comms.channel import Mac, simulate
from swarmgames.comms.wire import ofdm_airtime_s
from swarmgames.network.propagation import PropagationModel
from swarmgames.topology import TopologySnapshot

FRIIS = PropagationModel()


def _snapshot(pos: np.ndarray, radius: float = 368.84) -> TopologySnapshot:
    """Settled tables: BFS hop counts over the links within range."""
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=-1)
    hops = csgraph.shortest_path(sp.csr_array((d <= radius) & (d > 0)), unweighted=True)
    hops[~np.isfinite(hops)] = 0
    return TopologySnapshot.from_hop_matrix(0.0, hops.astype(int))


def _heard(pos: np.ndarray):
    """Every ordered pair with its Friis power (CSR by transmitter), and the decodable ones."""
    n = pos.shape[0]
    u, v = np.nonzero(~np.eye(n, dtype=bool))
    power = FRIIS.mean_rx_power(np.linalg.norm(pos[u] - pos[v], axis=1))
    indptr = np.concatenate([[0], np.cumsum(np.bincount(u, minlength=n))])
    return indptr, v, power, power >= -82.0


def _csma(n: int, hops: int = 2, **kw) -> CsmaComms:
    return CsmaComms(n, 3, hops, hello_interval_s=None, **kw)


def test_airtime_is_ns3s_whole_ofdm_symbols():
    # docs/comms.md: ns-3 keeps a 91-byte message 232 µs on the air at 6 Mbit/s:
    # 20 µs + 4 µs x ceil((16 + 8 x (91 + 64) + 6) / 24) = 20 + 4 x 53.
    assert ofdm_airtime_s(91) == pytest.approx(232e-6, abs=1e-12)
    # An empty payload: 64 bytes of headers, 534 bits, 23 symbols; 7 bytes more: 25 symbols.
    assert ofdm_airtime_s(np.array([0, 7])).tolist() == pytest.approx([112e-6, 120e-6])


def test_a_single_link_without_other_traffic_delivers_what_routed_delivers():
    pos = np.array([[0.0, 0, 30], [300, 0, 30]])
    snap = _snapshot(pos)
    csma, routed = _csma(2), RoutedComms(2, 3, 2)
    _, a = csma.exchange(20.0, snap, pos, np.random.default_rng(1))
    _, b = routed.exchange(20.0, snap, pos, np.random.default_rng(1))
    for name in ("messages_sent", "messages_forwarded", "messages_received", "bytes_received"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for model in (csma, routed):
        assert sorted(
            zip(model.table.owner.tolist(), model.table.sender.tolist(), strict=False)
        ) == [
            (0, 1),
            (1, 0),
        ]
    # Nothing to contend with: a frame arrives its airtime after its jitter at the latest.
    age = csma.table.arrival - csma.table.stamp
    assert np.all(age >= ofdm_airtime_s(15 + 16 * 3 + 4 * 2))
    assert np.all(age <= csma.jitter_s + ofdm_airtime_s(15 + 16 * 3 + 4 * 2))


def test_robots_out_of_each_others_range_receive_nothing():
    pos = np.column_stack([np.arange(6) * 500.0, np.zeros(6), np.full(6, 30.0)])
    _, stats = _csma(6).exchange(0.0, _snapshot(pos), pos, np.random.default_rng(0))
    assert stats.messages_received.sum() == 0 == stats.messages_forwarded.sum()


def test_two_hidden_terminals_sending_at_one_instant_lose_both_frames_at_the_middle():
    # 0 -- 1 -- 2, 300 m apart: 0 and 2 are 600 m apart, out of each other's carrier sense
    # (-82 dBm at 368.84 m) but both audible at 1. Zero jitter: both go at t = 0.
    pos = np.array([[0.0, 0, 30], [300, 0, 30], [600, 0, 30]])
    indptr, heard, power, link = _heard(pos)
    ready = np.array([0.0, 10.0, 0.0])  # robot 1 sends much later, on a quiet channel
    air = ofdm_airtime_s(np.full(3, 75))
    res = simulate(indptr, heard, power, link, ready, air, np.full(3, 75), ttl=1,
                   jitter_s=0.0, seed=7)  # fmt: skip
    got = set(zip(res.receiver.tolist(), res.sender.tolist(), strict=False))
    assert (1, 0) not in got and (1, 2) not in got
    assert {(0, 1), (2, 1)} <= got  # robot 1's own frame, alone on the air, reaches both
    assert res.collided == 1  # 1 locked onto one of them, and the other drowned it


def test_robots_that_hear_each_other_collide_only_when_they_draw_the_same_slot():
    # A clique whose frames all become ready while the medium is busy: every robot draws a
    # backoff and waits for the frame on the air. Those that draw distinct slots never
    # collide; two that draw the same slot lose their frames at every listener.
    rng = np.random.default_rng(3)
    same_slot_runs = 0
    for seed in range(40):
        pos = np.column_stack([rng.uniform(0, 150, (4, 2)), np.full(4, 30.0)])
        indptr, heard, power, link = _heard(pos)
        air = ofdm_airtime_s(np.full(4, 75))
        # Robot 0 goes at t = 0; the others become ready 50 µs later, while it is on the air.
        ready = np.array([0.0, 50e-6, 50e-6, 50e-6])
        res = simulate(indptr, heard, power, link, ready, air, np.full(4, 75), ttl=1,
                       jitter_s=0.0, seed=seed)  # fmt: skip
        got = {(r, s) for r, s in zip(res.receiver.tolist(), res.sender.tolist(), strict=False)}
        missing = [(r, s) for r in range(4) for s in range(4) if r != s and (r, s) not in got]
        if res.collided == 0:
            assert missing == []
        else:
            same_slot_runs += 1
            # every lost frame is one of the waiting robots', never robot 0's
            assert all(s != 0 for _, s in missing)
    # With 3 draws from 16 slots, about 19 % of the runs have two in the same slot.
    assert 2 <= same_slot_runs <= 20


def test_zero_jitter_in_a_clique_loses_frames_and_jitter_saves_them():
    rng = np.random.default_rng(0)
    pos = np.column_stack([rng.uniform(0, 100, (10, 2)), np.full(10, 30.0)])
    indptr, heard, power, link = _heard(pos)
    air = ofdm_airtime_s(np.full(10, 75))
    kw = {"ttl": 1, "seed": 3}
    bare = simulate(indptr, heard, power, link, np.zeros(10), air, np.full(10, 75),
                    jitter_s=0.0, **kw)  # fmt: skip
    spread = simulate(indptr, heard, power, link, np.zeros(10), air, np.full(10, 75),
                      jitter_s=0.04, **kw)  # fmt: skip
    assert bare.receiver.size == 0  # all ten start at once: every frame collides
    assert spread.receiver.size == 90


def test_delivery_falls_as_density_rises():
    # The same number of robots in ever smaller squares (the layouts of docs/comms.md).
    ratios = []
    for side in (2400.0, 1200.0, 700.0):
        rng = np.random.default_rng(11)
        pos = np.column_stack([rng.uniform(0, side, (60, 2)), np.full(60, 30.0)])
        snap = _snapshot(pos)
        comms = _csma(60)
        comms.exchange(0.0, snap, pos, rng)
        want = int((snap.hops <= 2).sum())
        got = int((comms.table.arrival <= 0.1 + 1e-12).sum())
        ratios.append(got / want)
    assert ratios[0] > ratios[1] > ratios[2]


def test_same_seed_same_channel_on_any_thread_count_and_other_seeds_differ():
    rng = np.random.default_rng(5)
    pos = np.column_stack([rng.uniform(0, 900, (40, 2)), np.full(40, 30.0)])
    snap = _snapshot(pos)
    before = numba.get_num_threads()

    def once(seed: int, threads: int):
        numba.set_num_threads(threads)
        try:
            comms = _csma(40)
            comms.exchange(0.0, snap, pos, np.random.default_rng(seed))
            t = comms.table
            return t.owner.tolist(), t.sender.tolist(), t.arrival.tolist()
        finally:
            numba.set_num_threads(before)

    assert once(1, 1) == once(1, numba.config.NUMBA_NUM_THREADS)
    assert once(1, 1) != once(2, 1)


def test_a_dead_radio_neither_sends_relays_nor_hears():
    pos = np.array([[0.0, 0, 30], [300, 0, 30], [600, 0, 30]])
    comms = _csma(3)
    _, stats = comms.exchange(
        0.0, _snapshot(pos), pos, np.random.default_rng(0), active=np.array([True, False, True])
    )
    assert stats.messages_sent.tolist() == [1, 0, 1]
    assert stats.messages_received.sum() == 0  # the middle robot was the only bridge


def test_one_robot_and_colocated_robots_are_handled():
    one = np.array([[0.0, 0.0, 30.0]])
    _, stats = _csma(1).exchange(0.0, _snapshot(one), one, np.random.default_rng(0))
    assert stats.messages_sent.tolist() == [1] and stats.messages_received.tolist() == [0]
    same = np.zeros((4, 3))
    comms = _csma(4)
    snap = TopologySnapshot.from_hop_matrix(0.0, 1 - np.eye(4, dtype=int))
    _, stats = comms.exchange(0.0, snap, same, np.random.default_rng(0))
    assert np.all(np.isfinite(stats.channel_load))
    assert stats.messages_received.sum() == 12  # jitter spreads them: every frame arrives


def test_olsr_frames_share_the_air_and_load_the_channel():
    rng = np.random.default_rng(2)
    pos = np.column_stack([rng.uniform(0, 600, (30, 2)), np.full(30, 30.0)])
    snap = _snapshot(pos)
    quiet = _csma(30)
    busy = CsmaComms(30, 3, 2, hello_interval_s=0.01, tc_interval_s=0.01)
    _, a = quiet.exchange(0.0, snap, pos, np.random.default_rng(0))
    _, b = busy.exchange(0.0, snap, pos, np.random.default_rng(0))
    assert b.channel_load.max() > a.channel_load.max()


def test_mac_defaults_are_80211a():
    mac = Mac()
    assert (mac.slot_s, mac.difs_s, mac.cw_min) == (9e-6, 34e-6, 15)
