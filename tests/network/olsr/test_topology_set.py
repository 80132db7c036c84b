"""The topology set as ns-3 3.44 keeps it: ANSN, RFC 3626 section 9.5, and tuple lifetimes."""

import numpy as np
import pytest

from swarmgames.network.olsr.engine import OlsrEngine
from swarmgames.network.olsr.provider import OlsrProvider

LINE = np.array([[0.0, 0, 0], [300.0, 0, 0], [600.0, 0, 0]])
C_AWAY = np.array([[0.0, 0, 0], [300.0, 0, 0], [1600.0, 0, 0]])
A, B, C = 0, 1, 2


def _walk(p, positions, start, until, every=0.5):
    t = start
    while t < until - 1e-9:
        t = round(t + every, 9)
        yield t, p.advance(t, positions)


@pytest.mark.parametrize("seed", range(4))
def test_ansn_counts_new_neighbours_and_selectors_but_not_neighbour_loss(seed):
    # ns-3 olsr-routing-protocol.cc: IncrementAnsn on AddNeighborTuple (a new link tuple) and
    # Add/RemoveMprSelectorTuple; NeighborLoss erases selectors without it
    # (EraseMprSelectorTuples).
    p = OlsrProvider(3, seed=seed)
    p.reset(LINE)
    p.advance(20.0, LINE)
    # a and c: one new neighbour each; b: two neighbours, then selected as MPR by both
    assert p.engine.ansn.tolist() == [1, 4, 1]
    for _ in _walk(p, C_AWAY, 20.0, 60.0):
        pass
    # c's selector tuple at b goes with c's link (no increment); a stops selecting b (its
    # 2-hop neighbour c is gone) while their link stays, so a's selector tuple expires on its
    # own timer: +1
    assert p.engine.ansn.tolist() == [1, 5, 1]


@pytest.mark.parametrize("seed", range(4))
def test_a_tc_with_the_same_ansn_leaves_earlier_tuples_until_they_expire(seed):
    # RFC 3626 section 9.5 steps 3-4 (ns-3 ProcessTc): only tuples with an older ANSN are
    # removed; a tuple the new TC leaves out keeps the expiry of the TC that listed it.
    p = OlsrProvider(3, seed=seed)
    p.reset(LINE)
    p.advance(21.0, LINE)
    e = p.engine
    assert e.tc_message(B) == [A, C]
    key = (A * 3 + B) * 3 + C
    held = []
    listed_c = e.topology.get("expiry", np.array([A * 3 + B]))[0]
    for t, _ in _walk(p, C_AWAY, 21.0, 50.0):
        if key in e.lingering.keys.tolist():
            assert e.tc_message(B) in ([A], None)  # b no longer lists c ...
            expiry = e.lingering.get("expiry", np.array([key]))[0]
            assert expiry == listed_c
            if expiry > t:
                held.append(t)
        elif not held:
            # expiry of the latest TC of b at a, which still lists c
            listed_c = e.topology.get("expiry", np.array([A * 3 + B]))[0]
    # ... but a keeps (c, b) from the last TC that listed c until it expires, 15 s later
    assert held and held[-1] == np.floor(listed_c * 2) / 2
    assert not e.lingering.keys.size


def test_a_new_ansn_erases_the_lingering_tuples():
    p = OlsrProvider(3, seed=0)
    p.reset(LINE)
    p.advance(20.0, LINE)
    e = p.engine
    for _ in _walk(p, C_AWAY, 20.0, 26.0):
        pass
    assert len(e.lingering) == 1
    ansn = e.ansn[B]
    p.advance(36.0, LINE)  # c is back: a new neighbour of b, so b's next TC has a new ANSN
    assert e.ansn[B] > ansn and len(e.lingering) == 0


def test_forgetting_expired_tuples_never_changes_a_table(monkeypatch):
    # ns-3 recomputes a table only when an OLSR packet arrives or a neighbour is lost, so a
    # tuple that expires afterwards still gives its route until then: the engine may drop only
    # the tuples that expired before their owner's last computation. Same runs with and
    # without dropping them: same tables at every step. (Before this rule, tuples were dropped
    # at every HELLO instant and 3- to 5-hop routes vanished up to 0.5 s early.)
    rng = np.random.default_rng(4)
    n, steps = 25, 400
    start = rng.uniform(0, 1200, (n, 2))
    goal = rng.uniform(0, 1200, (n, 2))
    runs = []
    for forget in (True, False):
        if not forget:
            monkeypatch.setattr(OlsrEngine, "_forget", lambda self, t: None)
        p = OlsrProvider(n, seed=9)
        p.reset(np.c_[start, np.zeros(n)])
        tables = []
        for k in range(1, steps + 1):
            xy = start + (goal - start) * k / steps
            snap = p.advance(k * 0.25, np.c_[xy, np.zeros(n)])
            tables.append(snap.hop_matrix())
        runs.append((np.array(tables), len(p.engine.topology)))
    (kept, small), (full, large) = runs
    np.testing.assert_array_equal(kept, full)
    assert small < large and (kept >= 3).sum() > 0


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("deselect", [False, True])
def test_a_relay_forwards_by_its_selectors_when_the_copy_arrives(seed, deselect):
    # ns-3 ForwardDefault looks the sender up in the MPR-selector set when the copy arrives
    # (FindMprSelectorTuple), not when the TC was built: HELLOs received during a flood change
    # who relays it. Line a-b-c-d: c relays b's TCs to d because b selected c as MPR.
    d = 3
    line = np.array([[0.0, 0, 0], [300.0, 0, 0], [600.0, 0, 0], [900.0, 0, 0]])
    p = OlsrProvider(4, seed=seed)
    p.reset(line)
    p.advance(25.0, line)  # b's TC of t = 25 is built, not yet sent (jitter)
    e = p.engine
    assert e.tc_message(B) == [A, C]
    if deselect:  # c stops counting b as a selector before the copy reaches it
        e.selectors.keep(e.selectors.keys != C * 4 + B)
    p.advance(26.0, line)
    # d holds b's TC of 25 s only if c relayed it
    round_at_d = e.topology.get("round", np.array([d * 4 + B]))[0]
    assert (round_at_d == e._last_tc) is not deselect
