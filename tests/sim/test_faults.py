"""Faults: crashes, dead radios, jamming and GPS error, as the other robots can learn of them."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.config import parse_config
from swarmgames.errors import ConfigError
from swarmgames.sim import run
from swarmgames.sim.faults import FAR_AWAY_M, Faults


def _cfg(faults=None, comms=None, n=6, duration=30.0):
    return parse_config(
        {
            "swarm": {"n_robots": n, "start_radius_m": 150.0},
            "sim": {"duration_s": duration, "warmup_s": 10.0, "animation": False},
            "comms": {"model": "routed", **(comms or {})},
            "faults": faults or {},
        }
    )


def _frames(res):
    m = res.to_frame("metrics")
    n = int(m["robot"].max()) + 1
    return m, n


def test_a_crashed_robot_stops_falls_silent_and_is_forgotten():
    # Robot 2 crashes at 15 s. It holds its position; its measures are NaN; it sends nothing;
    # the others drop its state after max_age_s (3 s) and OLSR forgets it after the neighbour
    # hold time (6 s, docs/reference.md section 3).
    res = run(_cfg({"crash": [[15.0, 2]]}), progress=False)
    m, n = _frames(res)
    tr = res.to_frame("trajectory")
    xy = tr[tr["robot"] == 2][["x", "y"]].to_numpy()
    times = tr[tr["robot"] == 2]["t"].to_numpy()
    assert np.ptp(xy[times >= 15.0], axis=0).max() == 0.0
    dead = m[(m["robot"] == 2) & (m["t"] >= 15.0)]
    assert not dead["alive"].any() and dead["payoff"].isna().all()
    assert (dead["messages_sent"] == 0).all() and (dead["bytes_received"] == 0).all()
    others = m[(m["robot"] != 2) & (m["t"] >= 15.0 + 3.0 + 1.0)]
    # The routed games no longer hold robot 2: every other robot's neighbour count is at
    # most the n - 2 others.
    assert (others["neighbours"] <= n - 2).all()
    late = res.to_frame()
    assert (late[late["t"] >= 15.0]["alive_robots"] == n - 1).all()
    assert res.summary["robots_failed"] == 1


def test_the_expost_regret_is_measured_against_where_a_crashed_robot_stays(monkeypatch):
    # The ex-post regret scores every robot against the states its neighbours reached: a
    # crashed robot reaches none but the one it holds, whatever its decision said.
    from swarmgames.sim.controllers import GameController

    seen = []
    measure = GameController.expost_regret

    def spy(self, problem, actions, next_states):
        seen.append((np.array(problem.states), np.array(next_states)))
        return measure(self, problem, actions, next_states)

    monkeypatch.setattr(GameController, "expost_regret", spy)
    res = run(_cfg({"crash": [[15.0, 2]]}, duration=12.0), progress=False)
    assert len(seen) == 7  # the stages from 15 s to 21 s
    for states, reached in seen:
        np.testing.assert_array_equal(
            reached[2], np.r_[states[2, :3], np.zeros(len(states[2]) - 3)]
        )
    m, _ = _frames(res)
    after = m[m["t"] >= 15.0]
    assert after[after["robot"] == 2]["expost_regret"].isna().all()
    alive = after[after["robot"] != 2]["expost_regret"]
    assert np.isfinite(alive).all() and (alive >= 0).all()


def test_the_mission_counts_what_is_alive_where_it_is():
    from swarmgames.sim import build_mission

    cfg = _cfg({"crash": [[12.0, 0], [12.0, 1]]}, duration=4.0)
    res = run(cfg, progress=False)
    mission = build_mission(cfg)
    tr = res.to_frame("trajectory")
    last = tr[tr["t"] == 13.0].sort_values("robot")[["x", "y", "z"]].to_numpy()
    alive = np.arange(6) >= 2
    assert res.to_frame()["coverage"].iloc[-1] == pytest.approx(
        mission.swarm_metrics(last[alive], None, 13.0)["coverage"]
    )


def test_a_dead_radio_flies_on_deaf_and_mute():
    res = run(_cfg({"radio_failure": [[12.0, 3]]}), progress=False)
    m, _ = _frames(res)
    deaf = m[(m["robot"] == 3) & (m["t"] >= 12.0)]
    assert deaf["alive"].all() and not deaf["radio"].any()
    assert (deaf["messages_sent"] == 0).all() and (deaf["bytes_received"] == 0).all()
    # It plays on with what it heard before 12 s until that is max_age_s (3 s) old, then
    # alone; while its own table still lists the others (their hold times) it holds none.
    assert (deaf[deaf["t"] < 14.0]["neighbours"] > 0).all()
    assert (deaf[deaf["t"] >= 14.0]["neighbours"] == 0).all()
    assert (deaf[deaf["t"] == 14.0]["fresh_fraction"] == 0).all()
    assert res.summary["robots_failed"] == 0 and res.summary["robots_without_radio"] == 1


def test_random_crashes_are_seeded():
    cfg = _cfg({"crash_rate_per_s": 0.02}, n=8)
    a = Faults.from_config(cfg.faults, 8, np.random.default_rng(5))
    b = Faults.from_config(cfg.faults, 8, np.random.default_rng(5))
    np.testing.assert_array_equal(a.crash_s, b.crash_s)
    assert np.all(np.isfinite(a.crash_s))
    r1 = run(cfg, progress=False).to_frame("metrics")["alive"]
    r2 = run(cfg, progress=False).to_frame("metrics")["alive"]
    assert r1.equals(r2)


def test_the_jammed_disc_silences_who_is_inside_while_it_lasts():
    f = Faults.none(3)
    f = Faults(f.crash_s, f.radio_s, (0.0, 0.0), 100.0, 5.0, 10.0)
    pos = np.array([[0.0, 0, 30], [50.0, 0, 30], [500.0, 0, 30]])
    assert f.radio(4.0, pos).tolist() == [True, True, True]
    assert f.radio(6.0, pos).tolist() == [False, False, True]
    assert f.radio(10.0, pos).tolist() == [True, True, True]
    net = f.network_positions(pos, f.radio(6.0, pos))
    assert net[0, 0] >= FAR_AWAY_M and net[1, 0] - net[0, 0] == pytest.approx(1e4)


def test_gps_error_perturbs_only_what_robots_report():
    ok = run(_cfg(duration=6.0), progress=False)
    noisy = run(_cfg({"gps_error_m": 20.0}, duration=6.0), progress=False)
    a, b = ok.to_frame("trajectory"), noisy.to_frame("trajectory")
    start = a["t"] == 10.0
    assert a[start][["x", "y"]].equals(b[start][["x", "y"]])  # the same take-off
    assert not a.equals(b)  # decisions on reported positions differ


@pytest.mark.parametrize(
    ("faults", "match"),
    [
        ({"crash": [[5.0, 9]]}, r"faults\.crash: every \[t_s, robot\] needs"),
        ({"radio_failure": [[-1.0, 0]]}, r"faults\.radio_failure"),
        ({"jam_radius_m": 50.0}, r"faults\.jam_radius_m > 0 needs faults\.jam_center_m"),
    ],
)
def test_bad_fault_schedules_are_rejected(faults, match):
    with pytest.raises(ConfigError, match=match):
        _cfg(faults)
