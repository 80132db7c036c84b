"""Tests of backend comparison and recorded tables; none needs ns-3 (the recorded ns-3 runs in
tests/data/ns3 stand in for it)."""

from __future__ import annotations

import json
import os

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.errors import ConfigError, InputDataError, RunFolderError
from swarmgames.experiments.compare import compare
from swarmgames.network.oracle import OracleProvider
from swarmgames.network.recorded import RecordedProvider, read_recording
from swarmgames.topology import TopologySnapshot

DATA = os.path.join(os.path.dirname(__file__), "..", "data", "ns3")


class Scripted:
    """Provider whose tables at time t are ``matrices[round(t)]`` (the last one after the end);
    hop 0 = no route."""

    def __init__(self, matrices: list[np.ndarray], name: str = "scripted") -> None:
        self.matrices = matrices
        self.name = name
        self._time = 0.0

    @property
    def time(self) -> float:
        return self._time

    def _snap(self) -> TopologySnapshot:
        m = self.matrices[min(round(self._time), len(self.matrices) - 1)]
        return TopologySnapshot.from_hop_matrix(self._time, m)

    def reset(self, positions, start_time=0.0):
        self._time = start_time
        return self._snap()

    def advance(self, to_time, positions):
        self._time = to_time
        return self._snap()


def still_trace(n: int, duration: float) -> pd.DataFrame:
    return pd.DataFrame(
        {"t": [0.0] * n, "node": range(n), "x": np.arange(n) * 10.0, "y": 0.0, "z": 0.0}
    ).pipe(lambda f: pd.concat([f, f.assign(t=duration)], ignore_index=True))


# -- agreement arithmetic ----------------------------------------------------------------------


def test_agreement_counts_entries_either_backend_routes():
    a = np.array([[0, 1, 2], [1, 0, 1], [2, 1, 0]])
    b = np.array([[0, 1, 0], [1, 0, 1], [3, 1, 0]])
    result = compare(still_trace(3, 1.0), [Scripted([a], "a"), Scripted([b], "b")], 1.0)
    # 6 entries routed by a; b misses 0->2 and says 3 hops for 2->0: 4 of 6 agree. Within 2
    # hops: the same 6 entries (a routes all within 2), 4 agree.
    assert result.agreement("b") == pytest.approx(4 / 6)
    assert result.agreement("b", within_2_hops=True) == pytest.approx(4 / 6)
    conf = result.confusion.set_index(["hops_reference", "hops_backend"])["count"]
    # two samples (0 s and 1 s) of the same tables
    assert conf[(2, 0)] == 2
    assert conf[(2, 3)] == 2
    assert conf[(1, 1)] == 8


def test_by_hops_splits_agreement_by_route_length():
    n = 4
    ref = np.array([[0, 1, 2, 3], [1, 0, 1, 2], [2, 1, 0, 1], [3, 2, 1, 0]])
    other = ref.copy()
    other[0, 3], other[3, 0], other[1, 3] = 4, -1, -1  # longer, lost, lost
    result = compare(still_trace(n, 1.0), [Scripted([ref], "a"), Scripted([other], "b")], 1.0)
    rows = result.by_hops("b").set_index("hops")
    # two samples (t = 0, 1) of: 6 one-hop, 4 two-hop, 2 three-hop routes in the reference
    assert rows.loc["1"].tolist()[:4] == [12, 12, 12, 12]
    assert rows.loc["2"].tolist()[:4] == [8, 6, 8, 6]
    assert rows.loc["3"].tolist()[:4] == [4, 0, 4, 0]
    assert rows.loc["4"].tolist()[:4] == [0, 2, 2, 0]
    assert rows.loc["5+", "agreement"] == 1.0 and rows.loc["5+", "entries"] == 0
    assert rows.loc["all", "agreement"] == pytest.approx(result.agreement("b"))
    summary = result.summary()["agreement"]["b"]["by_hops"]
    assert summary["3"] == {"agreement": 0.0, "entries": 4, "routes_reference": 4,
                            "routes_backend": 0}  # fmt: skip


def test_within_two_hops_ignores_far_disagreements():
    a = np.array([[0, 1, 3], [1, 0, 0], [3, 0, 0]])
    b = np.array([[0, 1, 4], [1, 0, 0], [4, 0, 0]])
    result = compare(still_trace(3, 1.0), [Scripted([a], "a"), Scripted([b], "b")], 1.0)
    assert result.agreement("b") == pytest.approx(2 / 4)
    assert result.agreement("b", within_2_hops=True) == 1.0


def test_confusion_accounts_for_every_ordered_pair():
    rec = read_recording(os.path.join(DATA, "hex_expand"))
    result = compare(rec.positions, [rec.provider("ns3"), OracleProvider(rec.n_robots)], 0.5)
    n = rec.n_robots
    assert result.confusion["count"].sum() == result.sample_times.size * n * (n - 1)


def test_warmup_leaves_early_samples_out():
    empty = np.zeros((2, 2), dtype=int)
    linked = np.array([[0, 1], [1, 0]])
    a = Scripted([linked], "a")
    b = Scripted([empty, linked], "b")
    trace = still_trace(2, 4.0)
    # samples at 0, 1, 2, 3, 4 s: b misses both entries at 0 s only
    assert compare(trace, [a, b], 1.0).agreement("b") == pytest.approx(8 / 10)
    assert compare(trace, [a, b], 1.0, warmup_s=1.0).agreement("b") == 1.0


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 6))
def test_agreement_is_symmetric(seed, n):
    rng = np.random.default_rng(seed)

    def tables():
        m = rng.integers(0, 4, size=(n, n))
        np.fill_diagonal(m, 0)
        return [m]

    ta, tb = tables(), tables()
    trace = still_trace(n, 1.0)
    ab = compare(trace, [Scripted(ta, "a"), Scripted(tb, "b")], 1.0)
    ba = compare(trace, [Scripted(tb, "b"), Scripted(ta, "a")], 1.0)
    assert ab.agreement("b") == pytest.approx(ba.agreement("a"))
    assert ab.agreement("b", True) == pytest.approx(ba.agreement("a", True))
    assert 0.0 <= ab.agreement("b") <= 1.0


def test_a_backend_agrees_with_itself():
    rec = read_recording(os.path.join(DATA, "waypoint_20"))
    result = compare(rec.positions, [OracleProvider(20), OracleProvider(20)], 1.0)
    assert result.backends == ("oracle", "oracle#2")
    assert result.agreement() == 1.0
    assert set(result.wall_time_s) == {"oracle", "oracle#2"}


# -- recorded ns-3 runs ------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["static_7", "static_20", "static_50"])
def test_recorded_ns3_equals_bfs_on_static_layouts_after_30s(name):
    # docs/reference.md section 4: settled ns-3 routes equal BFS on the 368.84 m disk graph
    rec = read_recording(os.path.join(DATA, name))
    result = compare(
        rec.positions,
        [rec.provider("ns3"), OracleProvider(rec.n_robots)],
        rec.sample_every,
        warmup_s=30,
    )
    assert result.agreement() == 1.0
    assert result.per_time.loc[result.per_time["t"] >= 30, "entries"].gt(0).all()


@pytest.mark.parametrize("name", ["waypoint_20", "hex_expand"])
def test_instant_bfs_lags_recorded_ns3_on_moving_traces(name):
    # ns-3's tables lag the geometry by 2-6 s (docs/reference.md section 4), so instantaneous BFS
    # disagrees with them on a sizeable share of entries: measured 81 % (waypoint_20, 1 s
    # samples) and 89 % (hex_expand) agreement with the recorded ns-3 runs.
    rec = read_recording(os.path.join(DATA, name))
    result = compare(
        rec.positions, [rec.provider("ns3"), OracleProvider(rec.n_robots)], rec.sample_every
    )
    assert 0.6 < result.agreement() < 0.95


def test_recorded_provider_serves_last_sample_at_or_before_t():
    hops = pd.DataFrame({"t": [1.0, 1.0, 3.0], "node": [0, 1, 0], "dest": [1, 0, 1], "hops": 1})
    rec = RecordedProvider(hops, n_robots=2, sample_every=1.0)
    rec.reset(np.zeros((2, 3)))
    assert rec.advance(0.5, None).n_entries == 0
    assert rec.advance(1.7, None).n_entries == 2
    assert rec.advance(2.0, None).n_entries == 0  # sample at 2 s had empty tables
    assert rec.advance(3.2, None).n_entries == 1
    with pytest.raises(ValueError, match="to_time must be >="):
        rec.advance(1.0, None)


def test_recorded_provider_rejects_bad_rows():
    hops = pd.DataFrame({"t": [1.0], "node": [0], "dest": [5], "hops": [1]})
    with pytest.raises(InputDataError, match="hops row 2"):
        RecordedProvider(hops, n_robots=2, sample_every=1.0)


def test_read_recording_needs_all_files(tmp_path):
    with pytest.raises(InputDataError, match=r"no positions\.csv"):
        read_recording(tmp_path)


def _two_run_folder(folder, suffix, compression):
    positions = pd.DataFrame({"t": [0.0, 0.0], "node": [0, 1], "x": [0.0, 100.0], "y": 0.0,
                              "z": 0.0})  # fmt: skip
    hops = pd.DataFrame({"run": [3, 3, 7], "t": [1.0, 1.0, 1.0], "node": [0, 1, 0],
                         "dest": [1, 0, 1], "hops": [1, 1, 2]})  # fmt: skip
    folder.mkdir()
    positions.to_csv(folder / f"positions{suffix}", index=False, compression=compression)
    hops.to_csv(folder / f"hops{suffix}", index=False, compression=compression)
    (folder / "meta.json").write_text(json.dumps({"sample": 1.0, "runs": [3, 7]}))
    return positions, hops


@pytest.mark.parametrize("suffix", [".csv", ".csv.xz", ".csv.gz"])
def test_read_recording_reads_plain_xz_and_gzip_files(tmp_path, suffix):
    positions, hops = _two_run_folder(tmp_path / "rec", suffix, "infer")
    rec = read_recording(tmp_path / "rec")
    pd.testing.assert_frame_equal(rec.positions, positions)
    pd.testing.assert_frame_equal(rec.hops, hops)


def test_a_recording_of_several_runs_serves_one_run_at_a_time(tmp_path):
    _two_run_folder(tmp_path / "rec", ".csv.xz", "xz")
    rec = read_recording(tmp_path / "rec")
    assert rec.runs == (3, 7)
    assert list(rec.run_hops(7).columns) == ["t", "node", "dest", "hops"]
    net = rec.provider("ns3 run 3", run=3)
    net.reset(np.zeros((2, 3)))
    assert net.advance(1.0, None).hop_matrix().tolist() == [[0, 1], [1, 0]]
    net = rec.provider(run=7)
    net.reset(np.zeros((2, 3)))
    assert net.advance(1.0, None).hop_matrix().tolist() == [[0, 2], [-1, 0]]  # -1: no route
    with pytest.raises(ValueError, match=r"run must be one of \[3, 7\] \(got None\)"):
        rec.provider()
    with pytest.raises(ValueError, match=r"run must be one of \[3, 7\] \(got 4\)"):
        rec.run_hops(4)


def test_a_single_run_recording_names_its_run_from_meta():
    rec = read_recording(os.path.join(DATA, "waypoint_20"))
    assert rec.runs == (1,)
    assert rec.run_hops() is rec.hops and rec.run_hops(1) is rec.hops
    with pytest.raises(ValueError, match=r"run must be one of \[1\] \(got 2\)"):
        rec.provider(run=2)


# -- errors and output -------------------------------------------------------------------------


def test_bad_arguments():
    trace = still_trace(2, 1.0)
    with pytest.raises(ValueError, match="at least two"):
        compare(trace, [OracleProvider(2)])
    with pytest.raises(ValueError, match=r"sample_every must be > 0 \(got 0"):
        compare(trace, [OracleProvider(2), OracleProvider(2)], 0.0)
    with pytest.raises(ValueError, match="at most the trace duration"):
        compare(trace, [OracleProvider(2), OracleProvider(2)], 5.0)
    with pytest.raises(ValueError, match="warmup_s must be >= 0"):
        compare(trace, [OracleProvider(2), OracleProvider(2)], warmup_s=-1.0)
    with pytest.raises(ConfigError, match=r"warmup_s must leave samples to compare.*got 5\)"):
        compare(trace, [OracleProvider(2), OracleProvider(2)], warmup_s=5.0)


def test_unknown_backend_name_suggests_close_match():
    with pytest.raises(ConfigError, match="did you mean 'olsr'"):
        compare(still_trace(2, 1.0), ["oracle", "olsrr"])


def test_write_puts_tables_plot_and_summary_in_run_folder(tmp_path):
    rec = read_recording(os.path.join(DATA, "hex_expand"))
    result = compare(rec.positions, [rec.provider("ns3"), OracleProvider(rec.n_robots)], 0.5)
    files = result.write(tmp_path / "cmp")
    names = {f.name for f in files}
    assert names == {
        "per_time.csv",
        "confusion.csv",
        "hops_ns3.csv",
        "hops_oracle.csv",
        "agreement.png",
        "summary.json",
    }
    summary = json.loads((tmp_path / "cmp" / "summary.json").read_text())
    assert summary["agreement"]["oracle"]["overall"] == pytest.approx(result.agreement())
    per_time = pd.read_csv(tmp_path / "cmp" / "per_time.csv")
    assert len(per_time) == result.sample_times.size == 361  # 0, 0.5, ..., 180 s
    with pytest.raises(RunFolderError):
        result.write(tmp_path / "cmp")


# -- the built-in OLSR model against recorded ns-3 runs ----------------------------------------


@pytest.mark.parametrize("name", ["static_7", "static_20", "static_50"])
def test_olsr_equals_recorded_ns3_on_static_layouts_after_30s(name):
    # issue acceptance: on static layouts, after 30 s, olsr and ns3 agree on 100 % of routes
    rec = read_recording(os.path.join(DATA, name))
    result = compare(rec.positions, [rec.provider("ns3"), "olsr"], rec.sample_every, seed=1,
                     warmup_s=30.0)  # fmt: skip
    assert result.agreement() == 1.0


@pytest.mark.parametrize("name", ["waypoint_20", "hex_expand"])
def test_olsr_tracks_recorded_ns3_on_moving_traces_like_ns3_tracks_itself(name):
    # Target: ns-3's own run-to-run agreement, about 97 % overall and 99 % within 2 hops
    # (docs/reference.md section 4 / issue 3). Measured here: waypoint_20 99.4 % / 99.98 %,
    # hex_expand 99.2 % (seed 1); ns-3 against itself (runs 1 and 2) gives 99.0 % / 99.9 %.
    rec = read_recording(os.path.join(DATA, name))
    result = compare(rec.positions, [rec.provider("ns3"), "olsr"], rec.sample_every, seed=1)
    assert result.agreement() >= 0.97
    assert result.agreement(within_2_hops=True) >= 0.99
