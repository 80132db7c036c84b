"""Providers' ``state()``/``restore()``: snapshot, advance, restore, advance again gives the
same tables (what resumed runs and planners rely on)."""

import pickle

import numpy as np
import pytest

from swarmgames.network import (
    DiskProvider,
    KnnProvider,
    NetworkState,
    OlsrParameters,
    OlsrProvider,
    OracleProvider,
    RadioParameters,
)
from swarmgames.network.recorded import read_recording

from ..conftest import DATA

FADING = RadioParameters(shadowing_sigma_db=4.0, nakagami_m=1.0)


def _walk(n, steps, seed=0):
    """Positions of ``n`` robots drifting over 800 m x 800 m, one row per step."""
    rng = np.random.default_rng(seed)
    start = np.c_[rng.uniform(0, 800, (n, 2)), np.zeros(n)]
    drift = np.c_[rng.normal(0, 8, (steps, n, 2)), np.zeros((steps, n, 1))]
    return start + np.cumsum(drift, axis=0)


def _tables(snap):
    return (snap.owner.tolist(), snap.dest.tolist(), snap.hops.tolist(), snap.next_hop.tolist())


PROVIDERS = {
    "olsr": lambda n: OlsrProvider(n, seed=3),
    "olsr-fading": lambda n: OlsrProvider(n, radio=FADING, seed=3),
    "olsr-hello-only": lambda n: OlsrProvider(n, hello_only=True, seed=3),
    "olsr-fast-tc": lambda n: OlsrProvider(
        n, olsr=OlsrParameters(hello_interval_s=1.0, tc_interval_s=2.0, max_jitter_s=0.25), seed=3
    ),
    "oracle": lambda n: OracleProvider(n, seed=3),
    "oracle-fading": lambda n: OracleProvider(n, radio=FADING, seed=3),
    "disk": lambda n: DiskProvider(n, radius=250.0),
    "knn": lambda n: KnnProvider(n, k=3),
}


@pytest.mark.parametrize("kind", PROVIDERS)
def test_restore_replays_the_same_tables(kind):
    n, steps = 20, 12
    walk = _walk(n, steps)
    p = PROVIDERS[kind](n)
    p.reset(walk[0])
    for k in range(1, 5):
        p.advance(2.0 * k, walk[k])
    saved = p.state()
    first = [_tables(p.advance(2.0 * k, walk[k])) for k in range(5, steps)]
    assert p.time == pytest.approx(2.0 * (steps - 1))
    # Restored twice (the state is not consumed) and through pickle (a checkpoint file).
    for state in (saved, pickle.loads(pickle.dumps(saved))):
        p.restore(state)
        assert p.time == pytest.approx(8.0)
        again = [_tables(p.advance(2.0 * k, walk[k])) for k in range(5, steps)]
        assert again == first
    # A fresh provider built the same way continues identically from the state.
    q = PROVIDERS[kind](n)
    q.restore(saved)
    assert [_tables(q.advance(2.0 * k, walk[k])) for k in range(5, steps)] == first


def test_olsr_state_is_independent_of_the_provider():
    walk = _walk(12, 6)
    p = OlsrProvider(12, seed=1)
    p.reset(walk[0])
    p.advance(5.0, walk[1])
    saved = p.state()
    copy = pickle.dumps(saved)
    p.advance(30.0, walk[2])  # the provider moves on; the state does not
    assert pickle.dumps(saved) == copy
    assert isinstance(saved, NetworkState) and saved.time == 5.0 and saved.provider == "olsr"


def test_olsr_control_traffic_counters_are_part_of_the_state():
    walk = _walk(10, 3)
    p = OlsrProvider(10, seed=2)
    p.reset(walk[0])
    p.advance(6.0, walk[1])
    saved = p.state()
    p.advance(12.0, walk[2])
    a = p.control_traffic()
    p.restore(saved)
    p.advance(12.0, walk[2])
    b = p.control_traffic()
    assert a.bytes.tolist() == b.bytes.tolist() and a.messages.tolist() == b.messages.tolist()


def test_state_before_reset_restores_an_unstarted_provider():
    p = OlsrProvider(4, seed=0)
    empty = p.state()
    line = np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0], [900, 0, 0]])
    p.reset(line)
    p.restore(empty)
    with pytest.raises(RuntimeError, match="reset"):
        p.snapshot()


@pytest.mark.parametrize(
    "other",
    [lambda: OlsrProvider(5, seed=0), lambda: OracleProvider(4), lambda: DiskProvider(5)],
    ids=["more-robots", "another-provider", "disk"],
)
def test_restore_refuses_a_state_of_another_network(other):
    p = OlsrProvider(4, seed=0)
    p.reset(np.zeros((4, 3)) + np.arange(4)[:, None] * 100)
    with pytest.raises(ValueError, match="this state is of a 'olsr' network of 4 robots"):
        other().restore(p.state())
    with pytest.raises(TypeError, match="NetworkState"):
        p.restore({"time": 0.0})


def test_recorded_replay_restores_its_time():
    rec = read_recording(DATA / "ns3" / "static_7")
    p = rec.provider()
    pos = np.zeros((rec.n_robots, 3))
    p.reset(pos)
    p.advance(5.0, pos)
    saved = p.state()
    a = _tables(p.advance(9.0, pos))
    p.restore(saved)
    assert p.time == 5.0 and _tables(p.advance(9.0, pos)) == a


def test_conformance_catches_a_restore_that_forgets():
    from swarmgames.network.conformance import ProviderConformanceError, check_provider

    class Forgetful(OlsrProvider):
        def restore(self, state):  # keeps the time, forgets the tables
            self._time = state.time

    check_provider(OlsrProvider(6, seed=0))
    with pytest.raises(ProviderConformanceError, match="after restore"):
        check_provider(Forgetful(6, seed=0))
