"""Best-response refinement ends at a pure NE whose local regret is exactly 0.

Monderer and Shapley (1996), "Potential Games": a finite exact potential game has the finite
improvement property, so best-response dynamics from any profile stop at a pure Nash
equilibrium. Every player of a local game is scored by the same M_i (paper eq. 1, Fernando
et al. 2022, section II.C), so the local game is such a game.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.game import (
    GamePayoffs,
    StageProblem,
    evaluate_payoffs,
    exact_profiles,
    local_regret,
    make_solver,
    mean_field,
    profile_payoff,
    solve,
)
from swarmgames.game.capabilities import PairSourceCapabilities
from swarmgames.game.equilibrium import _fields
from swarmgames.game.refine import _field_row, refine_profiles
from tests.game.helpers import MODEL, POT, disk_snapshot, random_games, swarm


@dataclass(frozen=True, eq=False)
class TransposedSource:
    """A PairSource serving a held table whose ``at`` is a transposed view (the layout of
    the coverage source), recording the largest table it was asked for."""

    capabilities = PairSourceCapabilities()

    w: np.ndarray
    served: list = field(default_factory=list)

    def table(self, games):
        self.served.append(len(games))
        return self.w[np.asarray(games)].copy()

    def at(self, profile):
        b, k, a = self.w.shape[:3]
        # out[b, l, k * A + a] = W[b, k, a, l, x_l], returned as (B, K, A, K).
        out = np.empty((b, k, k * a), dtype=self.w.dtype)
        got = np.take_along_axis(self.w, profile[:, None, None, :, None], axis=4)[..., 0]
        out[...] = got.transpose(0, 3, 1, 2).reshape(b, k, k * a)
        return out.reshape(b, k, k, a).transpose(0, 2, 3, 1)

    def select(self, games):
        return TransposedSource(self.w[games], self.served)


def _payoffs(seed, dtype, source, b=30, k=6, a=5, alpha_b=1.0):
    batch, pot = random_games(seed, b, k, a)
    held = evaluate_payoffs(batch, pot, 1.0, alpha_b, dtype=dtype)
    if not source:
        return held
    return GamePayoffs(
        held.unary, None, held.action_mask, held.mask, held.owner, held.members,
        TransposedSource(np.asarray(held.pair)),
    )  # fmt: skip


def _random_profile(pay, seed):
    keys = np.random.default_rng(seed).random(pay.action_mask.shape)
    return np.where(pay.mask, np.where(pay.action_mask, keys, -1.0).argmax(axis=2), 0)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    dtype=st.sampled_from(["float64", "float32"]),
    source=st.booleans(),
    k=st.integers(1, 9),
)
def test_refinement_ends_at_a_pure_ne_with_local_regret_exactly_zero(seed, dtype, source, k):
    pay = _payoffs(seed, dtype, source, k=k)
    start = _random_profile(pay, seed)
    ref = refine_profiles(pay, start)
    assert ref.converged.all()
    assert np.all(local_regret(pay, ref.profile) == 0.0)  # exactly, not within a tolerance
    # Every switch raises the potential M (to the rounding of the tables).
    tol = 1e-9 if dtype == "float64" else 1e-3
    assert np.all(profile_payoff(pay, ref.profile) >= profile_payoff(pay, start) - tol)
    moved = (ref.profile != np.where(pay.mask, start, 0)).any(axis=1)
    assert np.array_equal(moved, ref.moves > 0)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), source=st.booleans())
def test_refinement_of_the_mean_field_profile(seed, source):
    pay = _payoffs(seed, "float32", source, alpha_b=2.0)
    res = mean_field(_payoffs(seed, "float32", False, alpha_b=2.0), beta=2.0, engine="blas")
    start = np.where(pay.mask, np.where(pay.action_mask, res.marginals, -1.0).argmax(axis=2), 0)
    ref = refine_profiles(pay, start)
    assert np.all(local_regret(pay, ref.profile) == 0.0)
    already = local_regret(pay, start) == 0.0
    assert np.array_equal(ref.moves == 0, already)
    assert np.all(ref.sweeps[already] == 1)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), source=st.booleans())
def test_refinement_of_a_nash_equilibrium_changes_nothing(seed, source):
    pay = _payoffs(seed, "float64", source, k=4, a=3)
    ne = exact_profiles(_payoffs(seed, "float64", False, k=4, a=3))  # the maximum of M is a NE
    ref = refine_profiles(pay, ne)
    assert np.array_equal(ref.profile, ne)
    assert np.all(ref.moves == 0) and np.all(ref.sweeps == 1) and ref.converged.all()
    again = refine_profiles(pay, refine_profiles(pay, _random_profile(pay, seed)).profile)
    assert np.all(again.moves == 0)


def test_with_a_source_the_refinement_builds_tables_of_chunks_only(monkeypatch):
    import swarmgames.game.meanfield as mf

    monkeypatch.setattr(mf, "SOURCE_CHUNK_ELEMS", 3 * (6 * 5) ** 2)  # three games a chunk
    pay = _payoffs(7, "float32", True, b=40, alpha_b=3.0)
    ref = refine_profiles(pay, _random_profile(pay, 7))
    assert np.all(local_regret(pay, ref.profile) == 0.0)
    served = pay.pair_source.served
    assert served and max(served) <= 3


@pytest.mark.parametrize("source", [False, True])
def test_games_the_first_round_leaves_are_finished_with_the_stopping_test_arithmetic(
    source, monkeypatch
):
    # Should the compiled round round a near-tie otherwise than the stopping test, the games
    # it leaves gaining are swept again with the test's own fields: here it does nothing.
    import swarmgames.game.refine as refine

    def idle(payoffs, x, games, budget):
        return np.ones(len(games), np.int64), np.zeros(len(games), np.int64)

    monkeypatch.setattr(refine, "_compiled", idle)
    monkeypatch.setattr(refine, "_chunked_sweeps", idle)
    pay = _payoffs(11, "float32", source, alpha_b=2.0)
    ref = refine_profiles(pay, _random_profile(pay, 11))
    assert ref.converged.all() and np.all(local_regret(pay, ref.profile) == 0.0)
    assert np.all(ref.sweeps[ref.moves > 0] >= 2)


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("source", [False, True])
def test_a_variable_field_is_the_stopping_test_field_bit_for_bit(dtype, source):
    pay = _payoffs(3, dtype, source, k=9)
    x = _random_profile(pay, 3)
    full = _fields(pay, x)
    for k in range(pay.shape[1]):
        assert np.array_equal(_field_row(pay, x, k), full[:, k])


def test_refinement_honours_max_iter_and_checks_its_inputs():
    pay = _payoffs(1, "float64", False, b=50, k=6, a=4, alpha_b=5.0)
    start = _random_profile(pay, 1)
    ref = refine_profiles(pay, start, max_iter=1)
    assert not ref.converged.all() and np.all(ref.sweeps[~ref.converged] == 1)
    with pytest.raises(ValueError, match=r"max_iter must be an integer >= 1 \(got 0\)"):
        refine_profiles(pay, start, max_iter=0)
    with pytest.raises(ValueError, match=r"profile must have shape \(50, 6\)"):
        refine_profiles(pay, start[:, :2])


def test_isolated_robot_and_single_action_games():
    # One variable: its best response is the unary argmax; one action: nothing to change.
    pay = _payoffs(4, "float64", False, b=5, k=1, a=4)
    ref = refine_profiles(pay, np.zeros((5, 1), dtype=int) + _random_profile(pay, 4))
    assert np.array_equal(
        ref.profile[:, 0], np.where(pay.action_mask[:, 0], pay.unary[:, 0], -np.inf).argmax(1)
    )
    one = _payoffs(5, "float64", False, b=5, k=3, a=1)
    assert np.all(refine_profiles(one, np.zeros((5, 3), dtype=int)).moves == 0)


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_a_refined_stage_has_local_regret_exactly_zero(dtype):
    pos, snap = swarm(20, 3)
    solver = make_solver("mean_field", alpha_b=0.5, beta=1.0, dtype=dtype)
    plain = solve(StageProblem.ideal(snap, 2, pos, MODEL, POT, solver), 0)
    out = solve(StageProblem.ideal(snap, 2, pos, MODEL, POT, solver, refine="best_response"), 0)
    assert np.all(out.local_regret == 0.0)
    assert np.array_equal(out.refine_moves == 0, plain.local_regret == 0.0)
    assert np.all(out.refine_sweeps >= 1) and out.refine_s > 0
    assert np.all(plain.refine_sweeps == 0) and plain.refine_s == 0.0
    # The owner plays its refined action (no two robots coincide here).
    kept = solve(
        StageProblem.ideal(
            snap, 2, pos, MODEL, POT, solver, refine="best_response", keep_games=True
        ),
        0,
    )
    assert np.array_equal(kept.actions, kept.solution.profile[:, 0])
    with pytest.raises(ValueError, match=r"refine must be one of 'none', 'best_response'"):
        solve(StageProblem.ideal(snap, 2, pos, MODEL, POT, solver, refine="nash"))


def test_a_refined_centralised_stage_plays_a_pure_ne_of_the_swarm_game():
    pos, snap = swarm(8, 1)
    solver = make_solver("mean_field", alpha_b=0.5, beta=1.0)
    out = solve(
        StageProblem.ideal(
            snap,
            1,
            pos,
            MODEL,
            POT,
            solver,
            centralised=True,
            refine="best_response",
            keep_games=True,
        )
    )
    pay = solver.evaluate(out.batch, POT)
    assert np.all(local_regret(pay, out.solution.profile) == 0.0)
    assert np.array_equal(out.actions, out.solution.profile[0])


def test_refinement_on_the_fused_coverage_source():
    # The coverage potentials serve float32 tables on demand (CoveragePairs, docs/bench.md):
    # the refined stage still has local regret exactly 0, and no table is materialised.
    from swarmgames.config import resolve_scenario
    from swarmgames.sim.runner import build_mission

    cfg = resolve_scenario(
        "coverage",
        ["swarm.n_robots=30", "game.dtype='float32'", "coverage.signal_floor_dbm=-100.0"],
    )
    mission = build_mission(cfg)
    states = mission.initial_states(30, np.random.default_rng(0))
    snap = disk_snapshot(states[:, :2], 368.84)
    solver = make_solver("mean_field", alpha_b=cfg.game.alpha_b, dtype="float32", beta=5.0)
    out = solve(
        StageProblem.ideal(
            snap,
            2,
            states,
            mission.action_model,
            mission.potentials,
            solver,
            refine="best_response",
            keep_games=True,
        ),
        0,
    )
    pay = solver.evaluate(out.batch, mission.potentials)
    assert pay.pair_source is not None and pay.pair is None
    assert np.all(out.local_regret == 0.0)
