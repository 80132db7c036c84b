"""OLSR's own control traffic, counted from the messages the engine sends (RFC 3626 sizes)."""

from pathlib import Path

import numpy as np
import pytest

from swarmgames.network.baselines import DiskProvider, KnnProvider
from swarmgames.network.olsr.provider import OlsrProvider
from swarmgames.network.olsr.wire import UDP_IP_HEADER, hello_size, tc_size
from swarmgames.network.oracle import OracleProvider
from swarmgames.network.parameters import OlsrParameters
from swarmgames.network.trace import read_positions

OLSR = OlsrParameters(hello_interval_s=2.0, tc_interval_s=5.0)
DATA = Path(__file__).parents[2] / "data" / "ns3"


def _line(n):
    return np.array([[300.0 * i, 0.0, 30.0] for i in range(n)])


def _hello_bytes(engine, node):
    """Size of ``node``'s latest HELLO, link messages grouped by code (RFC 3626 6.1)."""
    msg = engine.hello_message(node)
    return int(hello_size(len({code for _, code in msg}), len(msg)))


def _tc_bytes(engine, node):
    adv = engine.tc_message(node)
    return 0 if adv is None else int(tc_size(len(adv)))


@pytest.mark.parametrize("seed", range(5))
def test_three_node_line(seed):
    line = _line(3)
    p = OlsrProvider(3, olsr=OLSR, seed=seed)
    p.reset(line)
    p.step(30.0, line)
    first = p.control_traffic()
    assert (first.since, first.until) == (0.0, 30.0)
    # HELLO rounds are built at 0, 2, ..., 30 s and each goes out after a jitter in [0, 0.5] s:
    # the 15 rounds built at 0..28 s are on the air by 30 s, the one built at 30 s after it.
    assert first.hello_sent.tolist() == [15, 15, 15]
    # The middle node is the MPR of both ends, the only node with MPR selectors: it alone
    # originates TCs (RFC 3626 9.3). Selectors exist from the HELLO round of 6 s (links turn
    # symmetric in the 2 s round, the 2-hop sets fill in the 4 s one), so the TC rounds built at
    # 10, 15, 20 and 25 s are sent by 30 s.
    assert first.tc_sent.tolist() == [0, 4, 0]
    # The ends receive its TCs but are nobody's MPR: no forwarding (RFC 3626 3.4.1).
    assert first.tc_forwarded.tolist() == [0, 0, 0]

    p.step(60.0, line)
    settled = p.control_traffic()
    e = p.engine
    assert settled.hello_sent.tolist() == [15, 15, 15]
    # Settled, every HELLO of the window is the one hello_message reports now: the ends list
    # the middle node as their MPR (one link code, one address: 28 bytes), the middle node
    # lists both ends as symmetric (one link code, two addresses: 32 bytes).
    sizes = [_hello_bytes(e, i) for i in range(3)]
    assert sizes == [28, 32, 28]
    assert settled.hello_bytes.tolist() == [15 * s for s in sizes]
    # TC rounds built at 30, 35, ..., 55 s; the middle node advertises both ends (28 bytes).
    assert e.tc_message(1) == [0, 2]
    assert settled.tc_sent.tolist() == [0, 6, 0]
    assert settled.tc_bytes.tolist() == [0, 6 * 28, 0]
    assert settled.tc_forwarded_bytes.tolist() == [0, 0, 0]


@pytest.mark.parametrize("seed", range(3))
def test_four_node_line_mprs_forward_their_selectors_tcs(seed):
    # 0 - 1 - 2 - 3: 1 is the MPR of 0 and 2, 2 of 1 and 3. Each inner node originates a TC
    # listing its selectors and forwards the other's, because it came from one of its MPR
    # selectors (RFC 3626 3.4.1); the ends forward nothing.
    line = _line(4)
    p = OlsrProvider(4, olsr=OLSR, seed=seed)
    p.reset(line)
    p.step(30.0, line)
    p.control_traffic()
    p.step(60.0, line)
    tr = p.control_traffic()
    e = p.engine
    assert (e.tc_message(1), e.tc_message(2)) == ([0, 2], [1, 3])
    assert tr.tc_sent.tolist() == [0, 6, 6, 0]
    assert tr.tc_forwarded.tolist() == [0, 6, 6, 0]
    # A forwarded copy has the original's size: each inner node forwards the other's 28 bytes.
    assert tr.tc_forwarded_bytes.tolist() == [0, 6 * 28, 6 * 28, 0]
    assert tr.hello_bytes.tolist() == [15 * _hello_bytes(e, i) for i in range(4)]


def test_counters_reset_after_each_call():
    line = _line(3)
    p = OlsrProvider(3, olsr=OLSR, seed=0)
    p.reset(line)
    p.step(30.0, line)
    assert p.control_traffic().hello_sent.sum() == 45
    again = p.control_traffic()
    assert (again.since, again.until) == (30.0, 30.0)
    assert again.messages.sum() == again.bytes.sum() == 0
    p.step(32.0, line)  # the round built at 30 s
    assert p.control_traffic().hello_sent.tolist() == [1, 1, 1]


def test_a_tc_counts_when_it_is_sent_not_when_it_is_built():
    # The first TC round is built at 10 s and leaves after a jitter in [0, 0.5] s.
    line = _line(3)
    p = OlsrProvider(3, olsr=OLSR, seed=1)
    p.reset(line)
    p.step(10.0, line)
    assert p.control_traffic().tc_sent.tolist() == [0, 0, 0]
    p.step(10.5, line)
    assert p.control_traffic().tc_sent.tolist() == [0, 1, 0]


def test_reset_starts_the_counters_again():
    line = _line(3)
    p = OlsrProvider(3, olsr=OLSR, seed=0)
    p.reset(line)
    p.step(10.0, line)
    p.reset(line, start_time=10.0)
    p.step(11.0, line)
    tr = p.control_traffic()
    assert (tr.since, tr.until) == (10.0, 11.0)
    # One round (built at 10 s), empty: nothing heard yet, headers only (RFC 3626 3.3, 6.1).
    assert tr.hello_sent.tolist() == [1, 1, 1]
    assert tr.hello_bytes.tolist() == [20, 20, 20]


def test_isolated_robot_sends_empty_hellos_and_no_tcs():
    p = OlsrProvider(1, olsr=OLSR, seed=0)
    x = np.zeros((1, 3))
    p.reset(x)
    p.step(30.0, x)
    tr = p.control_traffic()
    assert tr.hello_sent.tolist() == [15]
    assert tr.hello_bytes.tolist() == [15 * 20]
    assert tr.tc_sent.tolist() == tr.tc_forwarded.tolist() == [0]


def test_hello_only_sends_no_tcs():
    line = _line(4)
    p = OlsrProvider(4, olsr=OLSR, hello_only=True, seed=0)
    p.reset(line)
    p.step(30.0, line)
    tr = p.control_traffic()
    assert tr.hello_sent.tolist() == [15] * 4
    assert tr.tc_sent.sum() == tr.tc_forwarded.sum() == tr.tc_bytes.sum() == 0


@pytest.mark.parametrize("seed", range(3))
def test_bytes_equal_the_messages_round_by_round(seed):
    # A random swarm on the move: read every node's HELLO and TC after each round has gone
    # out (jitter <= 0.5 s) and before the next is built, and add up their sizes.
    n = 30
    rng = np.random.default_rng(seed)
    x0 = np.column_stack([rng.uniform(0, 1200, (n, 2)), np.full(n, 30.0)])
    v = np.column_stack([rng.normal(0, 8, (n, 2)), np.zeros(n)])
    p = OlsrProvider(n, olsr=OLSR, seed=seed)
    p.reset(x0)
    hello = np.zeros(n, dtype=np.int64)
    tc = np.zeros(n, dtype=np.int64)
    tc_rounds = np.zeros(n, dtype=np.int64)
    builds = sorted({*np.arange(0, 40, 2.0), *np.arange(0, 40, 5.0)})
    for b in builds:
        p.step(b + 0.75, x0 + v * b)
        if b % 2 == 0:
            hello += [_hello_bytes(p.engine, i) for i in range(n)]
        if b % 5 == 0:
            tc += [_tc_bytes(p.engine, i) for i in range(n)]
            tc_rounds += [p.engine.tc_message(i) is not None for i in range(n)]
    tr = p.control_traffic()
    assert tr.hello_sent.tolist() == [len(np.arange(0, 40, 2.0))] * n
    assert tr.hello_bytes.tolist() == hello.tolist()
    assert tr.tc_bytes.tolist() == tc.tolist()
    assert tr.tc_sent.tolist() == tc_rounds.tolist()
    assert tr.tc_forwarded.sum() > 0
    # Only MPRs retransmit (RFC 3626 3.4.1), and an MPR has selectors, so it sends TCs too.
    assert (tr.tc_sent[tr.tc_forwarded > 0] > 0).all()
    # Forwarded copies are whole TCs of someone else: at least 20 + 4 bytes each.
    assert (tr.tc_forwarded_bytes >= 24 * tr.tc_forwarded).all()


def test_totals_and_read_only_arrays():
    line = _line(4)
    p = OlsrProvider(4, olsr=OLSR, seed=0)
    p.reset(line)
    p.step(60.0, line)
    tr = p.control_traffic()
    assert tr.hello_sent.dtype == np.int64
    assert (tr.messages == tr.hello_sent + tr.tc_sent + tr.tc_forwarded).all()
    assert (tr.bytes == tr.hello_bytes + tr.tc_bytes + tr.tc_forwarded_bytes).all()
    # One message per packet: 28 bytes of UDP/IPv4 headers each.
    assert (tr.udp_ip_bytes == UDP_IP_HEADER * tr.messages).all()
    with pytest.raises(ValueError, match="read-only"):
        tr.hello_sent[0] = 0


def test_control_traffic_before_reset_raises():
    with pytest.raises(RuntimeError, match="reset"):
        OlsrProvider(2).control_traffic()


@pytest.mark.parametrize("seed", [0, 1])
def test_reading_the_counters_leaves_the_tables_bit_identical(seed):
    trace = read_positions(DATA / "waypoint_20" / "positions.csv")
    hops = []
    for read in (False, True):
        p = OlsrProvider(trace.n_robots, seed=seed)
        p.reset(trace.at(0.0))
        t, run = 0.0, []
        while t < 60.0:
            nxt = t + 0.5
            run.append(p.advance(nxt, trace.at(t)).hop_matrix())
            if read:
                p.control_traffic()
            t = nxt
        hops.append(np.stack(run))
    assert np.array_equal(hops[0], hops[1])


def test_other_providers_send_no_control_traffic():
    # Only a protocol has control traffic; callers use getattr(provider, "control_traffic").
    for provider in (OracleProvider(3), DiskProvider(3, 100.0), KnnProvider(3, 1)):
        assert not hasattr(provider, "control_traffic")
