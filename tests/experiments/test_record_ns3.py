"""Tests of the ns-3 recording scenarios (the positions part needs no ns-3)."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.experiments.record_ns3 import (
    SCENARIOS,
    hex_expand,
    main,
    random_waypoint,
    static_layout,
)
from swarmgames.network.recorded import read_recording

DATA = os.path.join(os.path.dirname(__file__), "..", "data", "ns3")


def test_hexagon_trace_equals_the_recorded_ns3_run():
    # tests/data/ns3/hex_expand (docs/reference.md section 4): ring radius 100 m -> 500 m -> 100 m
    committed = pd.read_csv(os.path.join(DATA, "hex_expand", "positions.csv"))
    pd.testing.assert_frame_equal(hex_expand(180.0, 0.1), committed, check_dtype=False)


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_committed_positions_are_what_the_scenarios_generate(name):
    committed = read_recording(os.path.join(DATA, name)).positions
    pd.testing.assert_frame_equal(SCENARIOS[name].positions(), committed, check_dtype=False)


@pytest.mark.parametrize("name", ["waypoint_20_fine", "fast_20", "fast_30", "fast_40"])
def test_multi_run_recordings_hold_ten_ns3_runs_with_their_command(name):
    rec = read_recording(os.path.join(DATA, name))
    assert rec.runs == tuple(range(1, 11)) == SCENARIOS[name].runs
    assert rec.meta["runs"] == list(range(1, 11)) and "run" not in rec.meta
    assert rec.meta["command"].endswith(f"--only {name} --run 1 2 3 4 5 6 7 8 9 10")
    assert rec.meta["dt"] == 0.1 and rec.sample_every == 1.0 and rec.meta["t_end"] == 150.0
    assert list(rec.hops.columns) == ["run", "t", "node", "dest", "hops"]
    # every run has tables at every sample time from 3 s on (first links at 2.3-2.5 s,
    # docs/reference.md section 4)
    times = rec.hops.groupby("run")["t"].unique()
    assert all(set(t) == set(np.arange(3.0, 151.0)) for t in times)


def test_fine_waypoint_20_is_the_waypoint_20_flight_every_0_1_s():
    coarse = SCENARIOS["waypoint_20"].positions()
    fine = SCENARIOS["waypoint_20_fine"].positions()
    common = fine[np.isin(fine["t"], coarse["t"].unique())].reset_index(drop=True)
    assert len(common) == len(coarse) and fine["t"].nunique() == 1501
    np.testing.assert_allclose(common[["x", "y"]], coarse[["x", "y"]], atol=0.05)  # 0.1 m


@pytest.mark.parametrize(("name", "n", "side"), [("fast_20", 20, 1000.0), ("fast_40", 40, 1415.0)])
def test_fast_waypoints_fly_15_to_30_m_s_in_their_square(name, n, side):
    frame = SCENARIOS[name].positions()
    xy = frame[["x", "y"]].to_numpy().reshape(-1, n, 2)
    assert xy.min() >= 0 and xy.max() <= side
    speed = np.linalg.norm(np.diff(xy, axis=0), axis=2) / 0.1
    assert speed.max() <= 30.0 + 1.5  # 0.1 m rounding of the positions over 0.1 s
    moving = speed[speed > 1.0]
    assert np.quantile(moving, 0.05) > 14.0


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 8))
def test_waypoint_uavs_stay_in_the_square_within_the_speed_limit(seed, n):
    frame = random_waypoint(n, 500.0, 30.0, 0.5, seed=seed, speed_m_s=(5.0, 15.0))
    xy = frame[["x", "y"]].to_numpy()
    assert (xy >= 0).all() and (xy <= 500.0).all()
    pos = xy.reshape(-1, n, 2)
    speed = np.linalg.norm(np.diff(pos, axis=0), axis=2) / 0.5
    assert speed.max() <= 15.0 + 1e-3  # 4-decimal rounding of the positions
    assert (frame["z"] == 30.0).all()


def test_static_layout_holds_still_and_is_seeded():
    a, b = static_layout(5, 100.0, 40.0, seed=3), static_layout(5, 100.0, 40.0, seed=3)
    pd.testing.assert_frame_equal(a, b)
    np.testing.assert_array_equal(a["t"].unique(), [0.0, 40.0])
    first, last = a[a["t"] == 0.0], a[a["t"] == 40.0]
    np.testing.assert_array_equal(first[["x", "y"]].to_numpy(), last[["x", "y"]].to_numpy())


@pytest.mark.parametrize("runs", [["0"], ["1", "-2"]])
def test_bad_run_number_is_a_usage_error(runs, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--out", "unused", "--run", *runs])
    assert exc.value.code == 2
    assert "--run must be >= 1" in capsys.readouterr().err
