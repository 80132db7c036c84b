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

DATA = os.path.join(os.path.dirname(__file__), "..", "data", "ns3")


def test_hexagon_trace_equals_the_recorded_ns3_run():
    # tests/data/ns3/hex_expand (docs/reference.md section 4): ring radius 100 m -> 500 m -> 100 m
    committed = pd.read_csv(os.path.join(DATA, "hex_expand", "positions.csv"))
    pd.testing.assert_frame_equal(hex_expand(180.0, 0.1), committed, check_dtype=False)


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_committed_positions_are_what_the_scenarios_generate(name):
    factory, _ = SCENARIOS[name]
    committed = pd.read_csv(os.path.join(DATA, name, "positions.csv"))
    pd.testing.assert_frame_equal(factory(), committed, check_dtype=False)


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


def test_bad_run_number_is_a_usage_error():
    with pytest.raises(SystemExit) as exc:
        main(["--out", "unused", "--run", "0"])
    assert exc.value.code == 2
