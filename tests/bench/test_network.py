"""The network benchmarks return plain records (timing is reported, never asserted)."""

import numpy as np

from swarmgames.bench.network import (
    bench_olsr_advance,
    bench_oracle,
    bench_replay,
    random_swarm,
)
from swarmgames.network.links import link_graph


def test_bench_records_are_plain_dicts():
    rec = bench_olsr_advance(20, sim_seconds=6.0, seed=1)
    assert rec["benchmark"] == "olsr_advance" and rec["n_robots"] == 20
    assert rec["wall_s"] >= 0 and rec["routes"] > 0
    assert set(bench_oracle(20)) == {"benchmark", "n_robots", "routes", "wall_s"}
    hello = bench_olsr_advance(20, sim_seconds=6.0, hello_only=True, seed=1)
    assert hello["hello_only"] is True
    rep = bench_replay(10, sim_seconds=3.0, backend="oracle")
    assert rep["benchmark"] == "replay" and rep["rows"] > 0


def test_random_swarm_density():
    # Expected neighbours within R of a uniform square layout: N * pi R^2 / side^2 (edges aside).
    pos = random_swarm(2000, mean_degree=10.0, seed=0)
    assert 7.0 < link_graph(pos).degree().mean() < 10.5
    assert np.all(pos[:, 2] == 0)
