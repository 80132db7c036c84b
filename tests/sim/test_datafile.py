"""Data-only storage of a run's state (swarmgames.sim.datafile): exact round trips, and
nothing but data read back."""

import io
import json

import numpy as np
import pytest

from swarmgames.config import parse_config
from swarmgames.sim import build_mission
from swarmgames.sim.datafile import dumps, frame, loads, split_frames
from swarmgames.sim.loop import LoopState
from swarmgames.sim.runner import build_loop

# Every stateful part: OLSR with TC floods (h = 3), routed messages with bursty loss and
# fading, GPS error and a crash.
STATEFUL = {
    "name": "stateful",
    "swarm": {"n_robots": 5},
    "sim": {"duration_s": 6.0, "warmup_s": 3.0, "animation": False},
    "network": {"hops": 3, "radio": {"nakagami_m": 2.0}},
    "comms": {"model": "routed", "loss_model": "gilbert_elliott", "loss_rate": 0.1},
    "faults": {"crash": [[4.0, 2]], "gps_error_m": 1.0},
}


def _same(a, b, where="value"):
    assert type(a) is type(b), where
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    elif hasattr(a, "__dict__"):
        _same(vars(a), vars(b), where)
    elif isinstance(a, float) and np.isnan(a):
        assert np.isnan(b), where
    else:
        assert a == b, where


def test_a_loop_state_and_a_stage_record_come_back_exactly():
    cfg = parse_config(STATEFUL)
    states, loop, _ = build_loop(cfg, build_mission(cfg), None)
    loop.start(states)
    records = [loop.step() for _ in range(3)]
    state = loop.state()
    back = loads(dumps(state))
    assert isinstance(back, LoopState)
    _same(vars(state), vars(back))
    for rec in records:
        _same(vars(rec), vars(loads(dumps(rec))))


def test_the_state_read_back_continues_the_run_bit_for_bit():
    cfg = parse_config(STATEFUL)
    mission = build_mission(cfg)
    states, loop, _ = build_loop(cfg, mission, None)
    loop.start(states)
    loop.step()
    saved = dumps(loop.state())
    ahead = [loop.step() for _ in range(3)]
    _, fresh, _ = build_loop(cfg, mission, None)
    fresh.restore(loads(saved))
    for a, b in zip(ahead, [fresh.step() for _ in range(3)], strict=True):
        np.testing.assert_array_equal(a.after, b.after)
        np.testing.assert_array_equal(a.actions, b.actions)


@pytest.mark.parametrize(
    "value",
    [
        None,
        True,
        3,
        2**127 + 5,  # a PCG64 state
        -0.0,
        float("nan"),
        float("inf"),
        "τ",
        np.float32(1.5),
        np.int64(-7),
        np.bool_(True),
        {1: (2, [3.0]), "a": {"b": None}},
        np.arange(6, dtype=np.int16).reshape(2, 3),
        np.zeros((0, 4)),
    ],
)
def test_values_keep_their_type_and_bits(value):
    _same({"v": value}, loads(dumps({"v": value})))


def _archive(tree, arrays=None, data=b""):
    """An archive of :func:`dumps`'s layout with the given content."""
    head = json.dumps({"tree": tree, "arrays": arrays or {}}).encode()
    buf = io.BytesIO()
    np.savez(
        buf,
        tree=np.frombuffer(head, dtype=np.uint8),
        data=np.frombuffer(data, dtype=np.uint8),
    )
    return buf.getvalue()


def test_objects_that_are_not_data_are_refused_both_ways():
    with pytest.raises(TypeError, match="cannot be stored"):
        dumps({"f": len})
    with pytest.raises(TypeError, match="Python objects"):
        dumps(np.array([object()], dtype=object))
    with pytest.raises(ValueError, match="class that is not stored"):
        loads(_archive({"$object": "Popen", "fields": {}}))
    with pytest.raises(ValueError, match=r"has dtype '\|O'"):
        loads(_archive({"$array": "a0"}, {"a0": ["|O", [1], 0, 8]}, b"\0" * 8))
    with pytest.raises(ValueError, match="does not fit the data"):
        loads(_archive({"$array": "a0"}, {"a0": ["<f8", [4], 0, 32]}, b"\0" * 8))
    buf = io.BytesIO()
    np.savez(buf, tree=np.frombuffer(b"{}", dtype=np.uint8), data=np.array([None], dtype=object))
    with pytest.raises(ValueError, match="not a swarmgames data file"):
        loads(buf.getvalue())
    with pytest.raises(ValueError, match="not a swarmgames data file"):
        loads(b"\x80\x04K\x01.")  # a pickle


def test_frames_split_and_a_cut_last_frame_is_left_out():
    data = frame(b"abc") + frame(b"") + frame(b"xyz")
    assert list(split_frames(data)) == [b"abc", b"", b"xyz"]
    assert list(split_frames(data[:-1], strict=False)) == [b"abc", b""]
    with pytest.raises(ValueError, match="cut short"):
        list(split_frames(data[:-1]))
    with pytest.raises(ValueError, match="no frame"):
        list(split_frames(b"junk" + data))
