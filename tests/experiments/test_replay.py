"""Trace replay, and agreement with the recorded ns-3 run ``tests/data/ns3/hex_expand``
(7-node hexagon expanding 100 -> 500 m and back over 180 s; ns-3 3.44, Friis, 802.11a,
6 Mbit/s; docs/reference.md section 4)."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from swarmgames.experiments.replay import replay
from swarmgames.network.baselines import DiskProvider
from swarmgames.network.trace import PositionTrace

DATA = Path(__file__).resolve().parents[1] / "data" / "ns3" / "hex_expand"


def agreement(ours: pd.DataFrame, ns3: pd.DataFrame) -> float:
    """Fraction of (t, node, dest) entries, present in either table, with equal hop counts."""
    ours = ours[ours["t"] >= ns3["t"].min()]
    m = ns3.merge(ours, on=["t", "node", "dest"], how="outer", suffixes=("_ns3", "_ours"))
    return float((m["hops_ns3"] == m["hops_ours"]).mean())


@pytest.fixture(scope="module")
def ns3_hops():
    return pd.read_csv(DATA / "hops.csv")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_olsr_matches_ns3_recording_at_its_own_run_to_run_level(seed, ns3_hops):
    # Issue / docs/reference.md section 4: ns-3 agrees with itself across seeds on ~97 % of
    # entries; instantaneous BFS reaches ~85 % on this trace.
    res = replay(DATA / "positions.csv", "olsr", seed=seed)
    assert agreement(res.hops, ns3_hops) >= 0.97


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_mismatch_is_in_the_reconnection_window(seed, ns3_hops):
    # docs/network.md: the only disagreements come right after the ring re-enters range on
    # contraction (116.3 s), while the jitter decides which link ends turn symmetric first;
    # the lost-link lag on expansion (63.8 s) and every settled table match ns-3 exactly.
    res = replay(DATA / "positions.csv", "olsr", seed=seed)
    ours = res.hops[res.hops["t"] >= ns3_hops["t"].min()]
    m = ns3_hops.merge(ours, on=["t", "node", "dest"], how="outer", suffixes=("_ns3", "_ours"))
    bad = m[m["hops_ns3"] != m["hops_ours"]]
    assert bad["t"].between(118.5, 122.0).all()
    # Never two different hop counts for the same entry: only presence differs.
    assert (bad["hops_ns3"].isna() | bad["hops_ours"].isna()).all()


def test_instant_bfs_lags_behind_ns3(ns3_hops):
    # The oracle has no protocol lag: it misses the ns-3 lag windows.
    res = replay(DATA / "positions.csv", "oracle")
    olsr = replay(DATA / "positions.csv", "olsr", seed=0)
    assert agreement(res.hops, ns3_hops) < agreement(olsr.hops, ns3_hops)
    assert agreement(res.hops, ns3_hops) < 0.95


def test_replay_outputs_and_files(tmp_path):
    df = pd.DataFrame(
        {
            "t": [0.0, 0.0, 0.0, 5.0],
            "node": [0, 1, 2, 2],
            "x": [0.0, 300.0, 600.0, 5000.0],
            "y": 0.0,
            "z": 0.0,
        }
    )
    seen = []
    res = replay(
        PositionTrace.from_frame(df),
        "oracle",
        sample_every=1.0,
        end=6.0,
        progress=lambda t, end: seen.append((t, end)),
    )
    assert seen[-1] == (6.0, 6.0)
    assert list(res.hops.columns) == ["t", "node", "dest", "hops"]
    assert (res.hops["node"] != res.hops["dest"]).all()
    s = res.summary.set_index("t")
    assert s.loc[0.0, "components"] == 1 and s.loc[0.0, "mean_hops"] == pytest.approx(8 / 6)
    # The row at t = 5 holds from t = 5: node 2 is gone at the 5 s sample.
    assert s.loc[5.0, "components"] == 2 and s.loc[5.0, "routes"] == 2
    assert s.loc[4.0, "routes"] == 6
    paths = res.write(tmp_path / "run")
    assert sorted(p.name for p in paths) == ["hops.csv", "replay.png", "summary.csv"]
    back = pd.read_csv(tmp_path / "run" / "hops.csv")
    assert back.shape == res.hops.shape


def test_replay_with_provider_object_and_out(tmp_path):
    df = pd.DataFrame({"t": [0.0, 0.0], "node": [0, 1], "x": [0.0, 50.0], "y": 0.0, "z": 0.0})
    res = replay(PositionTrace.from_frame(df), DiskProvider(2, 100.0), end=1.0, out=tmp_path / "o")
    assert res.backend == "disk" and len(res.hops) == 6
    assert (tmp_path / "o" / "summary.csv").exists()


def test_replay_single_robot():
    df = pd.DataFrame({"t": [0.0], "node": [0], "x": [0.0], "y": 0.0, "z": 0.0})
    res = replay(PositionTrace.from_frame(df), "olsr", end=3.0)
    assert res.hops.empty
    assert res.summary["components"].tolist() == [1] * 7
    assert np.isnan(res.summary["mean_hops"]).all()


@pytest.mark.parametrize("bad", [0.0, -0.5, float("nan"), float("inf")])
def test_bad_sample_interval(bad):
    with pytest.raises(ValueError, match="sample_every must be > 0"):
        replay(DATA / "positions.csv", "oracle", sample_every=bad)


def test_bad_end():
    with pytest.raises(ValueError, match="end must be >= the trace start"):
        replay(DATA / "positions.csv", "oracle", end=-1.0)


def test_sampling_is_bounded_by_the_rows_it_could_hold():
    from swarmgames.experiments.replay import MAX_HOP_ROWS, check_sampling
    from swarmgames.network.trace import read_positions

    trace = read_positions(DATA / "positions.csv")
    assert check_sampling(trace, 0.5) == int((trace.end - trace.start) / 0.5) + 1
    routes = trace.n_robots * (trace.n_robots - 1)
    finest = (trace.end - trace.start) / (MAX_HOP_ROWS // routes)
    with pytest.raises(ValueError, match=r"sample_every must give at most 50,000,000 hop rows"):
        check_sampling(trace, finest / 10)
    with pytest.raises(ValueError, match="sample_every must be > 0"):
        check_sampling(trace, True)
