"""Oracle, disk and knn providers, the provider factory and the provider interface."""

import numpy as np
import pytest

from swarmgames.errors import BackendUnavailableError
from swarmgames.network import NeighbourhoodProvider
from swarmgames.network.baselines import DiskProvider, KnnProvider
from swarmgames.network.factory import make_provider
from swarmgames.network.links import link_graph
from swarmgames.network.olsr.provider import OlsrProvider
from swarmgames.network.oracle import OracleProvider, bfs_hops, sparse_bfs_routes
from swarmgames.network.parameters import OlsrParameters

LINE = np.c_[np.arange(4) * 300.0, np.zeros(4), np.zeros(4)]


@pytest.mark.parametrize("backend", ["olsr", "oracle", "disk", "knn"])
def test_factory_builds_conforming_providers(backend):
    p = make_provider(backend, 4, 0)
    assert isinstance(p, NeighbourhoodProvider)
    assert p.name == backend
    snap = p.reset(LINE, 1.0)
    assert p.time == 1.0 and snap.time == 1.0
    snap = p.advance(31.0, LINE)
    assert snap.n_robots == 4 and p.time == 31.0
    assert (snap.owner != snap.dest).all()


def test_factory_hello_only_auto_follows_h():
    # OlsrParameters.hello_only = 'auto': HELLO-only when h <= 2.
    assert make_provider("olsr", 3, hops=2).hello_only
    assert not make_provider("olsr", 3, hops=3).hello_only
    assert not make_provider("olsr", 3, hops=2, full_tables=True).hello_only
    assert not make_provider("olsr", 3, olsr=OlsrParameters(hello_only=False)).hello_only


def test_factory_oracle_keeps_what_n_i_h_needs():
    assert make_provider("oracle", 4, hops=2).reset(LINE).hops.max() == 2
    full = make_provider("oracle", 4, hops=2, full_tables=True)
    assert full.reset(LINE).hops.max() == 3


def test_ns3_backend_is_lazy_and_reports_absence():
    try:
        import swarmgames.network.ns3_backend  # noqa: F401
    except ImportError:
        with pytest.raises(BackendUnavailableError, match="ns3"):
            make_provider("ns3", 3)
    else:  # pragma: no cover - when the ns-3 backend is installed
        pytest.skip("ns-3 backend installed")


def test_oracle_equals_settled_olsr():
    # docs/reference.md section 4: settled OLSR == BFS; the oracle is that BFS.
    rng = np.random.default_rng(4)
    pos = np.c_[rng.uniform(0, 1500, (15, 2)), np.zeros(15)]
    o = OracleProvider(15).reset(pos)
    p = OlsrProvider(15, seed=1)
    p.reset(pos)
    s = p.advance(40.0, pos)
    assert np.array_equal(o.hop_matrix(), s.hop_matrix())


def test_oracle_next_hops_are_neighbours_one_hop_closer():
    snap = OracleProvider(4).reset(LINE)
    assert snap.hop_matrix()[0].tolist() == [0, 1, 2, 3]
    h = snap.hop_matrix()
    for o, d, k, x in zip(snap.owner, snap.dest, snap.hops, snap.next_hop, strict=True):
        assert h[o, x] == 1 and (x == d or h[x, d] == k - 1)


def test_oracle_max_hops():
    snap = OracleProvider(4, max_hops=2).reset(LINE)
    assert snap.hops.max() == 2


def test_disk_is_one_hop_within_radius():
    snap = DiskProvider(4, radius=350.0).reset(LINE)
    assert snap.degree().tolist() == [1, 2, 2, 1]
    assert snap.neighbourhood(0, 5).tolist() == [0, 1]  # same set for every h


def test_knn_is_k_nearest_and_handles_small_swarms():
    snap = KnnProvider(4, k=2).reset(LINE)
    assert snap.neighbourhood(0, 1).tolist() == [0, 1, 2]
    assert snap.degree().tolist() == [2, 2, 2, 2]
    assert KnnProvider(2, k=5).reset(LINE[:2]).degree().tolist() == [1, 1]
    assert KnnProvider(1, k=3).reset(LINE[:1]).n_entries == 0
    # Co-located robots: self is never its own neighbour.
    co = KnnProvider(3, k=1).reset(np.zeros((3, 3)))
    assert (co.owner != co.dest).all() and co.degree().tolist() == [1, 1, 1]


@pytest.mark.parametrize("cls", [OracleProvider, DiskProvider, KnnProvider])
def test_instant_providers_degenerate_cases(cls):
    p = cls(1)
    assert p.reset(np.zeros((1, 3))).n_entries == 0
    iso = cls(3).reset(np.array([[0.0, 0, 0], [100, 0, 0], [9000, 0, 0]]))
    if cls is not KnnProvider:
        assert iso.degree().tolist() == [1, 1, 0]


def test_bad_provider_arguments():
    with pytest.raises(ValueError, match="radius must be > 0"):
        DiskProvider(3, radius=-1.0)
    with pytest.raises(ValueError, match="k must be >= 1"):
        KnnProvider(3, k=0)
    with pytest.raises(ValueError, match="n_robots must be >= 1"):
        OracleProvider(0)
    with pytest.raises(ValueError, match=r"positions must have shape \(N, 3\)"):
        OracleProvider(2).reset(np.zeros(3))


def test_sparse_bfs_equals_dense_bfs():
    # Two implementations that must agree: csgraph BFS (dense) and level-by-level sparse BFS.
    rng = np.random.default_rng(8)
    pos = np.c_[rng.uniform(0, 2500, (80, 2)), np.zeros(80)]
    g = link_graph(pos)
    for h in (1, 2, 4, 50):
        hops, _ = bfs_hops(g.adjacency(), h)
        owner, dest, k, nxt = sparse_bfs_routes(g, h)
        dense = np.full(hops.shape, np.inf)
        dense[owner, dest] = k
        np.fill_diagonal(dense, 0)
        assert np.array_equal(dense, hops)
        # The next hop is a neighbour one hop closer.
        full, _ = bfs_hops(g.adjacency())
        assert np.all(full[owner, nxt] == 1)
        assert np.all(full[nxt, dest] == k - 1)
