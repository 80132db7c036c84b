"""The coverage mission's link keeping against a hand computation and its guarantee.

The reference is the midpoint-disc rule of H. Ando, Y. Oasa, I. Suzuki and M. Yamashita,
IEEE Trans. Robotics and Automation 15(5), 1999: a robot that stays within the disc of radius
D / 2 around the midpoint of a link keeps the pair within D of each other whatever the other
robot does, if the other does the same. Here D = max(R - 2 s, d), R the radio's range
(368.84 m for ns-3's Friis defaults, docs/reference.md section 2), s the longest move and d the
pair's distance now; only relative neighbour links (G. T. Toussaint, Pattern Recognition
12(4), 1980: no third robot closer to both ends) are kept.
"""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.config import parse_config
from swarmgames.errors import ConfigError
from swarmgames.game import local_games
from swarmgames.missions.coverage.mission import build
from swarmgames.missions.coverage.potentials import KEEP_COST_DB_PER_M
from tests.game.helpers import disk_snapshot


def _mission(n=3, **cov):
    cov = {"link_term": "keep", "move_cost_db": 0.0, "separation_cost_db": 0.0, **cov}
    return build(parse_config({"swarm": {"n_robots": n}, "coverage": cov}))


def _games(mission, xy, hops=1):
    states = np.array([[x, y, 50.0] for x, y in xy])
    snap = disk_snapshot(states[:, :2], 1e4)
    return local_games(snap, hops, states, mission.action_model, virtual_mean="off")


def test_a_robot_pays_for_every_metre_outside_the_midpoint_disc_of_a_link():
    mission = _mission(n=2)
    keep = mission.potentials.link_keep
    assert keep.range_m == pytest.approx(368.84, abs=0.01)
    batch = _games(mission, [(0.0, 0.0), (340.0, 0.0)])
    nxt = np.asarray(batch.next_states)[..., :3]
    states = np.asarray(batch.states)[..., :3]
    s = float(np.linalg.norm(nxt - states[:, :, None], axis=-1).max())
    radius = max(keep.range_m - 2.0 * s, 340.0) / 2.0
    out = keep.outside_m(batch)
    for b in range(2):
        mid = (states[b, 0] + states[b, 1]) / 2.0
        for k in range(2):
            for a in range(nxt.shape[2]):
                want = max(0.0, float(np.linalg.norm(nxt[b, k, a] - mid)) - radius)
                assert out[b, k, a] == pytest.approx(want, abs=1e-9)
    assert out[0, 0, 0] == 0.0  # staying put is always inside
    assert out.max() > 0.0  # flying away from the neighbour is not
    np.testing.assert_array_equal(keep.outside_m(batch, owner_only=True), out[:, 0])


def test_only_relative_neighbour_links_near_the_range_are_kept():
    mission = _mission()
    keep = mission.potentials.link_keep
    # Robots 0 and 1 are 350 m apart, and robot 2 is 180 m from both: it is a witness, so
    # the link 0-1 need not be kept (0-2 and 2-1 keep the three together), and the links to
    # robot 2 are far from the range: no move can leave their discs.
    assert not np.any(keep.outside_m(_games(mission, [(0, 0), (350, 0), (175, 50)])))
    # Without the witness (robot 2 far off, unlinked), the link 0-1 is kept.
    assert np.any(keep.outside_m(_games(mission, [(0, 0), (350, 0), (2000, 0)])))


@pytest.mark.parametrize(
    "xy",
    [
        [(0.0, 0.0)],  # one robot
        [(0.0, 0.0), (0.0, 0.0)],  # co-located: the disc has radius D / 2 around them
        [(0.0, 0.0), (2000.0, 0.0)],  # isolated: no link to keep
    ],
)
def test_degenerate_swarms_keep_nothing(xy):
    mission = _mission(n=len(xy))
    out = mission.potentials.link_keep.outside_m(_games(mission, xy))
    assert out.shape[:2] == (len(xy), len(xy)) and not np.any(out)


def test_the_values_do_not_depend_on_the_chunking_or_the_batch():
    mission = _mission(n=30)
    rng = np.random.default_rng(5)
    # A winding chain of links near the range, each a relative neighbour link.
    xy = np.column_stack([345.0 * np.arange(30), rng.uniform(-60.0, 60.0, 30)])
    batch = _games(mission, xy, hops=2)
    keep = mission.potentials.link_keep
    whole = keep.outside_m(batch)
    assert whole.max() > 0.0
    np.testing.assert_array_equal(keep.outside_m(batch, max_elems=1), whole)
    np.testing.assert_array_equal(keep.outside_m(batch, owner_only=True, max_elems=7), whole[:, 0])


def test_two_robots_inside_their_discs_stay_linked_whatever_they_choose():
    mission = _mission(n=2)
    keep = mission.potentials.link_keep
    rng = np.random.default_rng(7)
    for d in rng.uniform(300.0, 368.0, 25):
        theta = rng.uniform(0, 2 * np.pi)
        xy = [(0.0, 0.0), (d * np.cos(theta), d * np.sin(theta))]
        batch = _games(mission, xy)
        out = keep.outside_m(batch)
        nxt = np.asarray(batch.next_states)[0, :, :, :3]  # robot 0's game: variables 0, 1
        ok0, ok1 = np.flatnonzero(out[0, 0] == 0.0), np.flatnonzero(out[0, 1] == 0.0)
        gaps = np.linalg.norm(nxt[0, ok0][:, None] - nxt[1, ok1][None], axis=-1)
        assert gaps.max() <= max(d, keep.range_m) + 1e-9


def test_the_unary_charges_the_hard_cost_and_the_pairwise_term_is_the_crowding_alone():
    mission = _mission(n=2, separation_cost_db=0.1)
    pot = mission.potentials
    batch = _games(mission, [(0.0, 0.0), (340.0, 0.0)])
    off = _mission(n=2, separation_cost_db=0.1, link_term="off").potentials
    want = off.unary(batch) - KEEP_COST_DB_PER_M * pot.roi.mass * pot.link_keep.outside_m(batch)
    np.testing.assert_allclose(pot.unary(batch), want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(pot.owner_unary(batch), want[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(pot.pair_table(batch), off.pair_table(batch))


def test_a_seeded_run_keeps_the_relative_neighbour_link_that_the_ablation_loses():
    import swarmgames
    from swarmgames.config import resolve_scenario
    from swarmgames.experiments.coverage_scale import run_connectivity, trajectory_stages
    from swarmgames.network.parameters import RadioParameters
    from swarmgames.network.propagation import PropagationModel

    def connectivity(link_term):
        config = resolve_scenario(
            "coverage-large",
            (
                "swarm.n_robots=100",
                "sim.duration_s=30.0",
                "coverage.area_per_robot_m2=120000",
                f"coverage.link_term={link_term}",
            ),
        )
        result = swarmgames.run(config, progress=False, figures=False)
        model = PropagationModel(RadioParameters(**config.network.radio.model_dump()))
        return run_connectivity(trajectory_stages(result.trajectory), model)

    off, keep = connectivity("off"), connectivity("keep")
    assert off["spanning_links_lost"] >= 1  # seed 0: the ablation loses one
    assert keep["links_lost"] > 0  # the swarm moved and left links behind
    assert keep["spanning_links_lost"] == 0 and keep["splits"] == 0


def test_the_configuration_names_link_keeping():
    assert parse_config({"coverage": {"link_term": "keep"}}).mission.link_term == "keep"
    with pytest.raises(ConfigError, match="link_term"):
        parse_config({"coverage": {"link_term": "hold"}})
