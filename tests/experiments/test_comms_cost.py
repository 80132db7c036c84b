"""Bytes of three coordination schemes: by hand on a line, and against the simulated flood."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from swarmgames.comms import flood, message_bytes
from swarmgames.errors import ConfigError
from swarmgames.experiments.comms_cost import (
    ACTION_BYTES,
    centralised_bytes,
    comms_cost,
    flood_all_bytes,
)
from swarmgames.runfolder import RunFolder
from swarmgames.topology import TopologySnapshot


def _line_snapshot(n):
    idx = np.arange(n)
    return TopologySnapshot.from_hop_matrix(0.0, np.abs(idx[:, None] - idx[None, :]))


def test_centralised_bytes_on_a_line_by_hand():
    # Robots 0 - 1 - 2 - 3 - 4, controller 2 (nearest the centroid). Robot 1 sends its state
    # and relays 0's (2 x 39 bytes: 15 + 8 x 3) and relays 0's action (14); the controller
    # sends the 4 actions; the ends send their state only.
    states = np.column_stack([np.arange(5) * 100.0, np.zeros(5), np.full(5, 30.0)])
    got = centralised_bytes(_line_snapshot(5), states)
    up = 15 + 8 * 3
    assert got.tolist() == [up, 2 * up + ACTION_BYTES, 4 * ACTION_BYTES, 2 * up + ACTION_BYTES, up]


def test_flooding_the_whole_swarm_equals_the_simulated_flood():
    rng = np.random.default_rng(0)
    n = 40
    pos = rng.uniform(0, 1500, (n, 2))
    d = np.linalg.norm(pos[:, None] - pos[None], axis=-1)
    adj = (d <= 368.84) & (d > 0)
    hops = np.where(adj, 1, 0)
    snap = TopologySnapshot.from_hop_matrix(0.0, hops)
    sizes = message_bytes(3, rng.integers(1, 9, n))
    simulated = flood(sp.csr_array(adj.astype(int)), n, sizes)
    np.testing.assert_array_equal(
        flood_all_bytes(snap, sizes), simulated.bytes_sent + simulated.bytes_forwarded
    )


def test_comms_cost_runs_and_writes(tmp_path):
    res = comms_cost(sizes=(10, 50), seeds=(0, 1))
    agg = res.aggregate()
    assert len(res.frame) == 2 * 2 * 3 and (agg["mean_bytes_n"] == 2).all()
    assert (agg["mean_bytes_mean"] > 0).all()
    names = {f.name for f in res.write(RunFolder(tmp_path / "c"))}
    assert names == {"comms_cost.csv", "comms_cost_aggregate.csv", "comms_cost.png"}
    with pytest.raises(ConfigError, match="sizes must be"):
        comms_cost(sizes=(1,))
