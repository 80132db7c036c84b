"""Positions traces: parsing and every kind of bad input (issue: bad input names the row)."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.errors import InputDataError
from swarmgames.network.trace import PositionTrace, read_positions

GOOD = "t,node,x,y,z\n0,0,0,0,0\n0,1,100,0,0\n1.5,1,200,0,0\n"


def _write(tmp_path, text):
    p = tmp_path / "positions.csv"
    p.write_text(text)
    return p


def test_reads_piecewise_constant_trace(tmp_path):
    tr = read_positions(_write(tmp_path, GOOD))
    assert tr.n_robots == 2 and tr.times.tolist() == [0.0, 1.5]
    assert tr.at(1.0)[1].tolist() == [100.0, 0.0, 0.0]
    assert tr.at(1.5)[1].tolist() == [200.0, 0.0, 0.0]
    assert tr.at(9.0)[0].tolist() == [0.0, 0.0, 0.0]  # node 0 holds its only row
    assert not tr.positions.flags.writeable


def test_reads_recorded_ns3_trace():
    tr = read_positions(
        Path(__file__).resolve().parents[1] / "data" / "ns3" / "hex_expand" / "positions.csv"
    )
    assert tr.n_robots == 7 and tr.end == 180.0


@pytest.mark.parametrize(
    "text, match",
    [
        ("t,node,x,y,z\n0,0,nan,0,0\n", r"line 2, column x: must be a finite number"),
        ("t,node,x,y,z\n0,0,0,inf,0\n", r"line 2, column y: must be a finite number"),
        ("t,node,x,y,z\n0,0,0,0,abc\n", r"line 2, column z: must be a finite number"),
        ("t,node,x,y\n0,0,0,0\n", r"missing column\(s\) z"),
        ("t,node,x,y,z\n", r"no rows"),
        ("t,node,x,y,z\n-1,0,0,0,0\n", r"line 2, column t: must be >= 0"),
        ("t,node,x,y,z\n0,0,0,0,0\n0,0,1,0,0\n", r"line 3: duplicate row for node 0 at t = 0"),
        (
            "t,node,x,y,z\n0,0,0,0,0\n2,0,1,0,0\n1,0,2,0,0\n",
            r"line 4, column t: times of node 0 must increase",
        ),
        ("t,node,x,y,z\n0,0,0,0,0\n1,1,0,0,0\n", r"node 1 has no row at the start time"),
        ("t,node,x,y,z\n0,0,0,0,0\n0,2,0,0,0\n", r"node 1 has no row"),
        ("t,node,x,y,z\n0,1.5,0,0,0\n", r"line 2, column node: must be an integer"),
        ("t,node,x,y,z\n0,-1,0,0,0\n", r"line 2, column node: must be an integer >= 0"),
    ],
)
def test_bad_input_names_the_row(tmp_path, text, match):
    with pytest.raises(InputDataError, match=match):
        read_positions(_write(tmp_path, text))


def test_missing_file():
    with pytest.raises(InputDataError, match="positions file not found"):
        read_positions("/nonexistent/positions.csv")


def test_empty_file(tmp_path):
    with pytest.raises(InputDataError, match="empty file; expected a header t,node,x,y,z"):
        read_positions(_write(tmp_path, ""))


def test_single_robot_trace(tmp_path):
    tr = read_positions(_write(tmp_path, "t,node,x,y,z\n0,0,1,2,3\n"))
    assert tr.n_robots == 1 and np.array_equal(tr.at(0.0), [[1.0, 2.0, 3.0]])


@settings(max_examples=40, deadline=None)
@given(
    rows=st.lists(
        st.tuples(st.integers(0, 3), st.integers(1, 40), st.floats(-1e4, 1e4)),
        min_size=1,
        max_size=30,
    ),
    query=st.floats(0, 5),
)
def test_position_at_is_the_nodes_latest_row(rows, query):
    # A node's row holds from its t until its next row (issue: trace semantics).
    n = max(r[0] for r in rows) + 1
    data = {(node, 0.0): (0.0, 0.0) for node in range(n)}  # every node present at t = 0
    for node, tick, x in rows:
        data[(node, tick / 10)] = (x, -x)
    frame = pd.DataFrame(
        [(t, node, x, y, 1.0) for (node, t), (x, y) in data.items()],
        columns=["t", "node", "x", "y", "z"],
    ).sample(frac=1.0, random_state=0)  # row order across nodes does not matter
    frame = frame.sort_values("t", kind="stable")
    tr = PositionTrace.from_frame(frame)
    got = tr.at(query)
    for node in range(n):
        t_last = max(t for (k, t) in data if k == node and t <= query)
        assert got[node].tolist() == [*data[(node, t_last)], 1.0]


# Bounds checked before any array is sized by a value of the file (issue 13: a node id of
# 10^9 or a row at t = 10^12 asked for gigabytes).


def test_huge_node_id_names_the_column_the_value_and_the_bound(tmp_path):
    text = "t,node,x,y,z\n0,0,0,0,0\n0,1000000000,0,0,0\n"
    with pytest.raises(
        InputDataError, match=r"line 3, column node: must be < 100000, .*\(got 1000000000\)"
    ):
        read_positions(_write(tmp_path, text))


def test_large_node_id_with_gaps_is_found_without_an_id_sized_array(tmp_path):
    text = "t,node,x,y,z\n0,0,0,0,0\n0,99999,0,0,0\n"
    with pytest.raises(InputDataError, match=r"numbered 0\.\.99999 without gaps \(node 1 has"):
        read_positions(_write(tmp_path, text))


def test_far_future_time_names_the_column_the_value_and_the_bound(tmp_path):
    text = "t,node,x,y,z\n0,0,0,0,0\n1e12,0,1,0,0\n"
    with pytest.raises(
        InputDataError, match=r"line 3, column t: must be <= 1e\+06 s, .*\(got 1000000000000\.0\)"
    ):
        read_positions(_write(tmp_path, text))


def test_dense_positions_over_the_limit_are_refused(tmp_path, monkeypatch):
    import swarmgames.network.trace as trace

    monkeypatch.setattr(trace, "MAX_TRACE_VALUES", 5)  # 2 times x 2 nodes x 3 = 12 values
    with pytest.raises(InputDataError, match=r"2 distinct times x 2 nodes would hold .* GiB"):
        read_positions(_write(tmp_path, GOOD))


def test_non_utf8_file_is_one_line(tmp_path):
    p = tmp_path / "positions.csv"
    p.write_bytes(b"t,node,x,y,z\n0,0,0,0,0\n0,1,\xff,0,0\n")
    with pytest.raises(InputDataError, match=r"not UTF-8 text \(byte 0xff\)") as info:
        read_positions(p)
    assert "\n" not in str(info.value)


def test_folder_is_one_line(tmp_path):
    with pytest.raises(InputDataError, match=r"cannot read positions file .*: it is a folder"):
        read_positions(tmp_path)


def test_unreadable_file_is_one_line(tmp_path, monkeypatch):
    # chmod 000 does not stop root; the error it would raise does the same here.
    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(pd, "read_csv", refuse)
    with pytest.raises(InputDataError, match=r"cannot read positions file .*: Permission denied"):
        read_positions(_write(tmp_path, GOOD))
