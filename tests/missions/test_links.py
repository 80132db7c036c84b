"""The coverage mission's link term at risk against a hand computation.

The reference is the definition in swarmgames.missions.coverage.links (the rendezvous
mission's link-budget shortfall, charged for what a move adds to it): for a pair linked now,
the growth of the shortfall of the mean received power (ns-3's log-distance or Friis model)
below the reception threshold plus the margin costs ``link_cost_db * roi.mass / alpha_b`` per
dB in the symmetrised table; a pair not linked now, or a move that keeps the margin or does
not weaken the link, costs nothing.
"""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.config import parse_config
from swarmgames.errors import ConfigError
from swarmgames.game import local_games
from swarmgames.game.potentials import evaluate_payoffs
from swarmgames.missions.coverage.links import LinkRisk
from swarmgames.missions.coverage.mission import build
from swarmgames.network.parameters import RadioParameters
from swarmgames.network.propagation import PropagationModel
from tests.game.helpers import disk_snapshot


def _mission(**cov):
    cov = {"link_term": "at_risk", "move_cost_db": 0.0, "separation_cost_db": 0.0, **cov}
    return build(parse_config({"swarm": {"n_robots": 3}, "coverage": cov}))


def _games(mission, xs, hops=1):
    states = np.array([[x, 0.0, 50.0] for x in xs])
    snap = disk_snapshot(states[:, :2], 1e4)
    return states, local_games(snap, hops, states, mission.action_model, virtual_mean="off")


def test_a_pair_near_its_range_pays_its_shortfall_and_others_nothing():
    mission = _mission()
    pot = mission.potentials
    risk = pot.link_risk
    assert risk.range_m == pytest.approx(368.84, abs=0.01)
    # Robot 1 is 350 m from robot 0 (linked, within 3 dB of the threshold); robot 2 is 100 m
    # from robot 0 (linked with margin: a 20 m move cannot use it up) and 450 m from robot 1.
    _, batch = _games(mission, [0.0, 350.0, -100.0])
    table = pot.pair_table(batch)
    nxt = np.asarray(batch.next_states)[..., :3]
    b = 0  # robot 0's game: variables 0, 1, 2 are robots 0, 1, 2
    power = PropagationModel(RadioParameters()).mean_rx_power
    scale = pot.link_cost_db * pot.roi.mass / pot.alpha_b
    for a in range(nxt.shape[2]):
        for c in range(nxt.shape[2]):
            d = np.linalg.norm(nxt[b, 0, a] - nxt[b, 1, c])
            now = max(0.0, -82.0 + 3.0 - float(power(350.0)))
            want = -scale * max(0.0, max(0.0, -82.0 + 3.0 - float(power(d))) - now)
            assert table[b, 0, a, 1, c] == pytest.approx(want, rel=1e-12, abs=1e-9)
    assert np.all(table[b, 0, :, 2, :] == 0.0)  # margin to spare
    assert np.all(table[b, 1, :, 2, :] == 0.0)  # not linked now: no pull to make a link
    assert table[b, 0, 0, 1, 0] == 0.0  # staying 350 m apart: short, but no shorter
    assert table.min() < 0.0


def test_the_table_forms_agree():
    mission = _mission()
    pot = mission.potentials
    _, batch = _games(mission, [0.0, 340.0, 690.0], hops=2)
    table = pot.pair_table(batch)
    k = batch.n_vars
    valid = np.asarray(batch.action_mask)
    ok = valid[:, :, :, None, None] & valid[:, None, None, :, :]
    ok &= ~np.eye(k, dtype=bool)[None, :, None, :, None]
    pw = pot.pairwise(batch)
    sym = pw.transpose(0, 1, 3, 2, 4) + pw.transpose(0, 2, 4, 1, 3)
    np.testing.assert_allclose(sym[ok], table[ok], rtol=1e-12)
    owner = pot.owner_pair_table(batch)
    assert np.array_equal(owner[ok[:, 0]], table[:, 0][ok[:, 0]])
    np.testing.assert_allclose(
        pot.pair_table(batch, np.float32)[ok], table[ok], rtol=1e-6, atol=1e-3
    )
    assert not pot.pair_on_demand(np.float32)  # the float32 table is computed, not on demand
    # Each game alone gives the same table bit for bit (a pair's entries depend on it alone).
    for g in range(batch.n_games):
        alone = pot.pair_table(batch.select([g]))[0]
        assert np.array_equal(alone[ok[g]], table[g][ok[g]])


def test_a_virtual_mean_carries_no_link():
    mission = _mission()
    states, _ = _games(mission, [0.0, 350.0, 700.0])
    virtual = local_games(disk_snapshot(states[:, :2], 400.0), 1, states, mission.action_model)
    assert np.asarray(virtual.is_virtual).any()
    table = mission.potentials.pair_table(virtual)
    v = np.asarray(virtual.is_virtual)
    assert np.all(table[v[:, :, None, None, None] & np.ones(table.shape, bool)] == 0.0)


def test_the_payoff_charges_a_move_that_weakens_a_link():
    mission = _mission()
    _, batch = _games(mission, [0.0, 340.0, -100.0])
    pay = evaluate_payoffs(batch, mission.potentials, 1.0, 0.001)
    pair = np.asarray(pay.pair)[0]  # robot 0's game, weighted by alpha_b
    nxt = np.asarray(batch.next_states)[0, :, :, 0]
    away = int(np.argmin(nxt[0]))  # robot 0's move farthest from robot 1 (to -x)
    toward = int(np.argmax(nxt[0]))
    assert pair[0, away, 1, 0] < pair[0, 0, 1, 0] == pair[0, toward, 1, 0] == 0.0


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"coverage": {"link_term": "at_risk"}, "game": {"alpha_b": 0.0},
          "coverage_sep": True}, "game.alpha_b must be > 0 for the link term at risk"),
        ({"coverage": {"link_term": "nearby"}}, "link_term"),
        ({"coverage": {"link_term": "at_risk", "link_cost_db": 0.0}}, "link_cost_db"),
        ({"coverage": {"link_term": "at_risk", "link_margin_db": -1.0}}, "link_margin_db"),
    ],
)  # fmt: skip
def test_bad_link_settings_are_one_line(fields, message):
    data = {k: v for k, v in fields.items() if k != "coverage_sep"}
    if fields.get("coverage_sep"):
        data["coverage"] = {**data["coverage"], "separation_cost_db": 0.0}
    with pytest.raises((ConfigError, ValueError), match=message):
        build(parse_config({"swarm": {"n_robots": 3}, **data}))


def test_link_risk_rejects_a_negative_margin():
    with pytest.raises(ValueError, match="link margin must be >= 0 dB"):
        LinkRisk(RadioParameters(), -1.0)


def test_without_a_link_term_the_pairwise_term_is_the_crowding_alone():
    off = _mission(link_term="off", separation_cost_db=0.1)
    sig = _mission(link_term="signal", separation_cost_db=0.1)
    bare = _mission(link_term="off")
    _, batch = _games(off, [0.0, 30.0, 340.0])
    table = off.potentials.pair_table(batch)
    assert np.all(bare.potentials.pair_table(batch) == 0.0)
    assert table.min() < 0.0  # robots 0 and 1 are 30 m apart: crowded
    # The crowding part of eq. 6's table, entry by entry.
    crowd = sig.potentials.pair_table(batch) - _mission(link_term="signal").potentials.pair_table(
        batch
    )
    valid = np.asarray(batch.action_mask)
    ok = valid[:, :, :, None, None] & valid[:, None, None, :, :]
    ok &= ~np.eye(batch.n_vars, dtype=bool)[None, :, None, :, None]
    np.testing.assert_allclose(table[ok], crowd[ok], atol=1e-9)
    owner = off.potentials.owner_pair_table(batch)
    assert np.array_equal(owner[ok[:, 0]], table[:, 0][ok[:, 0]])
