"""Games that hold the same variables in another order are solved on one shared table.

The reference is each game solved on its own table (Algorithm 1 of M. Fernando et al., ICRA
2022 workshop, as :mod:`swarmgames.game.meanfield_compiled` runs it): on a shared table the
compiled engine must give the same marginals and sweeps bit for bit, and the stage the same
decisions, while computing the tables of the first game of each group only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from swarmgames.game import FunctionPotentials, evaluate_payoffs, make_solver, mean_field
from swarmgames.game.capabilities import PairSourceCapabilities
from swarmgames.game.memory import stage_memory
from swarmgames.game.potentials import GamePayoffs, PairSource
from swarmgames.game.stage import size_groups
from tests.game.helpers import random_games


@dataclass(frozen=True, eq=False)
class SharingSource:
    """A held table served on demand, ranking every game's variables and naming the games
    whose ranked tables are equal; ``asked`` records the games whose ranked tables the
    engine computed."""

    capabilities = PairSourceCapabilities(shared=True)
    w: np.ndarray
    head: np.ndarray
    rank: np.ndarray
    asked: list

    def table(self, games):
        return self.w[np.asarray(games)].copy()

    def at(self, profile):
        return np.take_along_axis(self.w, profile[:, None, None, :, None], axis=4)[..., 0]

    def select(self, games):
        games = np.arange(self.head.size)[games]
        head = self.head[games]
        first = {int(h): i for i, h in reversed(list(enumerate(head)))}
        sub = np.array([first[int(h)] for h in head], dtype=np.int64)
        return SharingSource(self.w[games], sub, self.rank[games], self.asked)

    def shared(self):
        return self.head, self.rank

    def ranked_table(self, games):
        self.asked.extend(np.asarray(games).tolist())
        out = np.empty_like(self.w[games])
        for i, g in enumerate(games):
            order = np.argsort(self.rank[g])
            out[i] = self.w[g][order][:, :, order]
        return out


def _permuted(seed, dtype, prefix=True, identity=False):
    """Held payoffs of 12 random games and 24 more that are their variables reordered
    (shuffled valid variables, padding kept at the end), and the same on demand, ranked
    (a random canonical order of every group, or ``identity``: each game its own order and
    its own table)."""
    rng = np.random.default_rng(seed)
    batch, pot = random_games(seed, 12, 6, 4)
    base = evaluate_payoffs(batch, pot, 1.0, 0.5, dtype=dtype)
    b, k, _ = base.shape
    heads = np.concatenate([np.arange(b), rng.integers(0, b, 2 * b)])
    # perm[g, k] is the head's variable that variable k of game g is.
    perm = np.tile(np.arange(k), (heads.size, 1))
    canon = np.tile(np.arange(k), (b, 1))  # the rank of every variable of the heads
    for g in range(heads.size):
        nv = int(base.mask[heads[g]].sum())
        if g >= b:
            perm[g, :nv] = rng.permutation(nv)
        else:
            canon[g, :nv] = rng.permutation(nv)
    rank = canon[heads[:, None], perm]
    rows = heads[:, None]
    unary, amask = base.unary[rows, perm], base.action_mask[rows, perm]
    mask, members = base.mask[rows, perm], base.members[rows, perm]
    w = base.pair[rows, perm]  # (G, K, A, K, A), variables k then l reordered
    w = np.take_along_axis(w, perm[:, None, None, :, None], axis=3)
    if not prefix:  # every game loses its head's variable 1: a hole the engine reorders
        keep = mask & (perm != 1)
        unary, amask = np.where(keep[..., None], unary, 0.0), amask & keep[..., None]
        w = w * keep[:, :, None, None, None] * keep[:, None, None, :, None]
        # The ranks of the valid variables stay 0 .. n_valid - 1 (the lost one ranks last).
        lost = np.take_along_axis(rank, np.argmax(perm == 1, axis=1)[:, None], axis=1)
        rank = np.where(rank > lost, rank - 1, rank)
        rank = np.where(keep | (perm != 1), rank, k - 1)
        mask = keep
    if identity:
        heads, rank = np.arange(heads.size), np.tile(np.arange(k), (heads.size, 1))
    owner = members[:, 0].astype(np.int32)
    held = GamePayoffs(unary.astype(dtype), w.astype(dtype), amask, mask, owner, members)
    source = SharingSource(np.asarray(held.pair), heads, rank, [])
    lazy = GamePayoffs(held.unary, None, amask, mask, owner, members, source)
    return held, lazy, source


def test_a_sharing_source_conforms_to_the_protocol():
    _, lazy, _ = _permuted(0, np.float32)
    assert isinstance(lazy.pair_source, PairSource)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("prefix", [True, False])
def test_games_on_shared_ranked_tables_agree_with_their_own_tables(dtype, prefix):
    held, lazy, source = _permuted(1, dtype, prefix)
    own = mean_field(held, 5.0, engine="compiled")
    shared = mean_field(lazy, 5.0, engine="compiled")
    # The same sweeps in the same order; only the pair sums run in rank order.
    tol = 2e-5 if dtype == np.float32 else 1e-12
    np.testing.assert_allclose(shared.marginals, own.marginals, atol=tol)
    assert sorted(source.asked) == list(range(12))  # the heads' tables only


def test_a_games_results_do_not_depend_on_the_games_sharing_its_table():
    _, lazy, _ = _permuted(2, np.float32)
    together = mean_field(lazy, 5.0, engine="compiled")
    for g in range(lazy.shape[0]):
        alone = mean_field(lazy.select([g]), 5.0, engine="compiled")
        assert np.array_equal(alone.marginals[0], together.marginals[g])
        assert alone.iterations[0] == together.iterations[g]


def test_identity_ranks_give_the_own_tables_results_bit_for_bit():
    held, lazy, source = _permuted(3, np.float32, identity=True)
    own = mean_field(held, 5.0, engine="compiled")
    shared = mean_field(lazy, 5.0, engine="compiled")
    assert np.array_equal(own.marginals, shared.marginals)
    assert np.array_equal(own.iterations, shared.iterations)
    assert sorted(source.asked) == list(range(36))


def test_chunks_of_heads_take_every_game_of_their_heads(monkeypatch):
    import swarmgames.game.meanfield as mf
    import swarmgames.game.meanfield_compiled as mfc

    _, lazy, _ = _permuted(4, np.float32)
    whole = mean_field(lazy, 5.0, engine="compiled")
    monkeypatch.setattr(mf, "SOURCE_CHUNK_ELEMS", 1)
    monkeypatch.setattr(mfc, "PARALLEL_MIN_GAMES", 1)  # one head per chunk
    _, lazy, source = _permuted(4, np.float32)
    chunked = mean_field(lazy, 5.0, engine="compiled")
    assert np.array_equal(whole.marginals, chunked.marginals)
    assert sorted(source.asked) == list(range(12))


def test_solve_batch_rejects_nothing_and_defaults_to_own_tables():
    from swarmgames.game.meanfield_compiled import solve_batch

    held, _, _ = _permuted(3, np.float32)
    logits = np.where(held.action_mask, held.unary * np.float32(5.0), -np.inf)
    nv = held.mask.sum(axis=1)
    a = solve_batch(logits, np.asarray(held.pair), nv, 5.0, 1e-6, 200)
    b = solve_batch(
        logits, np.asarray(held.pair), nv, 5.0, 1e-6, 200,
        table=np.arange(nv.size), perm=np.tile(np.arange(held.shape[1]), (nv.size, 1)),
    )  # fmt: skip
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_on_demand_batches_are_bounded_by_the_measured_rows_not_the_tables():
    sizes = np.full(300, 300)
    held = size_groups(sizes, 0, 9)
    lazy = size_groups(sizes, 0, 9, on_demand=True)
    assert max(g.size for g in held) == 3  # 25 M entries / (300² 9²)
    assert max(g.size for g in lazy) == 30  # 25 M entries / (300² 9)
    assert sorted(np.concatenate(lazy).tolist()) == list(range(300))


def test_batches_of_games_sharing_a_held_table_are_bounded_by_their_tables():
    """``size_groups(shared=...)``: a batch holds one table per label and every game's rows
    at a profile; each batch stays within the budget however the labels fall."""
    from swarmgames.game.stage import MAX_PAIR_ELEMS

    sizes = np.full(300, 300)
    table, rows = 300**2 * 81, 300**2 * 9
    one = size_groups(sizes, 0, 9, shared=np.zeros(300, np.int64))
    # Two buckets of 150 games, each in batches of at most 21: one table and 21 rows.
    assert (MAX_PAIR_ELEMS - table) // rows == 21
    assert len(one) == 2 * 8 and max(g.size for g in one) <= 21
    assert sorted(np.concatenate(one).tolist()) == list(range(300))
    rng = np.random.default_rng(0)
    for labels in (rng.integers(0, 2, 300), rng.integers(0, 5, 300), np.arange(300)):
        for g in size_groups(sizes, 0, 9, shared=labels):
            assert min(np.unique(labels[g]).size, g.size) * table + g.size * rows <= max(
                MAX_PAIR_ELEMS, table + rows
            )
    # A robot with a table of its own (-1) keeps its bucket (robots 0-149) on the tables'
    # budget; the other bucket shares.
    mixed = np.zeros(300, np.int64)
    mixed[7] = -1
    batches = size_groups(sizes, 0, 9, shared=mixed)
    assert max(g.size for g in batches if g.max() < 150) == 3
    assert max(g.size for g in batches if g.min() >= 150) == 19


def test_sharing_labels_name_equal_neighbourhoods_of_large_games():
    from swarmgames.game.local import broadcast
    from swarmgames.game.stage import sharing_labels
    from swarmgames.network import TopologySnapshot

    # Robots 0-3 all within one hop of each other; 4-5 a pair; 6 alone.
    hop = np.full((7, 7), -1)
    hop[:4, :4] = 1
    hop[4:6, 4:6] = 1
    np.fill_diagonal(hop, 0)
    msgs = broadcast(TopologySnapshot.from_hop_matrix(0.0, hop), 1, np.zeros((7, 3)))
    labels = sharing_labels(msgs, 9, 18)  # games of at least 2 robots x 9 actions
    assert len(set(labels[:4].tolist())) == 1 and len(set(labels[4:6].tolist())) == 1
    assert labels[0] != labels[4] and labels[6] == -1
    assert np.all(sharing_labels(msgs, 9, 10**6) == -1)


def _dense_default_stage(monkeypatch, share: bool):
    """One stage of the default scenario (float64) with 40 UAVs within range, its games
    shared from 100 entries and batches of at most 1 M table entries (old rule: 7 games)."""
    import swarmgames.game.stage as stage
    from swarmgames.bench.stage import StageBench
    from swarmgames.config import resolve_scenario
    from swarmgames.game import held

    monkeypatch.setattr(held, "HELD_SHARE_MIN", 100)
    monkeypatch.setattr(stage, "MAX_PAIR_ELEMS", 1_000_000)
    plain = stage.size_groups
    seen = []

    def sized(*args, **kwargs):
        out = plain(*args[:3], 1_000_000, **kwargs)
        seen.append(max(g.size for g in out))
        return out

    monkeypatch.setattr(stage, "size_groups", sized)
    if not share:  # the solver declares no held sharing
        from dataclasses import replace

        from swarmgames.game.solvers import MeanFieldSolver

        declared = MeanFieldSolver.capabilities
        monkeypatch.setattr(
            MeanFieldSolver,
            "capabilities",
            lambda self, pot: replace(declared(self, pot), held_sharing_min=None),
        )
    cfg = resolve_scenario("coverage", ["swarm.n_robots=40", "swarm.start_max_neighbours=0"])
    sb = StageBench(40, config=cfg, seed=3)
    sb.controller.global_regret = True
    sb.step()
    return sb.controller.decide(sb.problem(), np.random.default_rng(0)), seen


def test_equal_held_games_batched_by_their_table_give_the_same_stage(monkeypatch):
    """Batching the equal games of a dense swarm by their one table changes no result: the
    actions, payoffs, local, global and ex-post regrets of a stage are those of the batches
    of distinct games, bit for bit (the ex-post games, never equal, keep those batches)."""
    with monkeypatch.context() as m:
        shared, seen_shared = _dense_default_stage(m, True)
    with monkeypatch.context() as m:
        plain, seen_plain = _dense_default_stage(m, False)
    assert max(seen_plain) == 7 and max(seen_shared) == 40  # one batch of 40 equal games
    for name in ("actions", "payoff", "local_regret", "global_regret", "expost_regret"):
        assert np.array_equal(getattr(shared, name), getattr(plain, name)), name
    assert np.all(np.isfinite(shared.global_regret)) and np.all(np.isfinite(shared.expost_regret))


def held_sharing(solver, potentials):
    return solver.capabilities(potentials).held_sharing_min


def pair_on_demand(solver, potentials):
    return solver.capabilities(potentials).pairs_on_demand


def test_which_solvers_solve_equal_held_games_on_one_table():
    from swarmgames.config import parse_config
    from swarmgames.game.held import HELD_SHARE_MIN
    from swarmgames.missions.coverage.mission import build

    pot = build(parse_config({"swarm": {"n_robots": 4}})).potentials
    assert held_sharing(make_solver("mean_field", dtype="float64", engine="compiled"), pot) == (
        HELD_SHARE_MIN
    )
    assert held_sharing(make_solver("mean_field", dtype="float32", engine="compiled"), pot) is None
    assert held_sharing(make_solver("mean_field", dtype="float64", engine="blas"), pot) is None
    assert held_sharing(make_solver("best_response", dtype="float64"), pot) is None
    plain = FunctionPotentials(lambda s: s[..., 0])  # declares no held sharing
    assert (
        held_sharing(make_solver("mean_field", dtype="float64", engine="compiled"), plain) is None
    )
    with pytest.raises(TypeError, match="potentials must declare capabilities"):
        held_sharing(make_solver("mean_field", dtype="float64"), object())


def test_which_solvers_compute_the_coverage_tables_on_demand():
    from swarmgames.config import parse_config
    from swarmgames.missions.coverage.mission import build

    pot = build(parse_config({"swarm": {"n_robots": 4}})).potentials
    on = make_solver("mean_field", dtype="float32", engine="compiled")
    assert pair_on_demand(on, pot)
    assert not pair_on_demand(make_solver("mean_field", dtype="float64"), pot)
    assert not pair_on_demand(make_solver("mean_field", dtype="float32", engine="blas"), pot)
    assert not pair_on_demand(make_solver("mean_field", dtype="float32", alpha_b=0.0), pot)
    assert not pair_on_demand(make_solver("best_response", dtype="float32"), pot)
    assert not pair_on_demand(on, FunctionPotentials(lambda s: s[..., 0]))  # no pair source
    with pytest.raises(TypeError, match="potentials must declare capabilities"):
        pair_on_demand(on, object())


def test_the_memory_estimate_follows_the_on_demand_batches():
    held = stage_memory(300, 300, 9, itemsize=4)
    lazy = stage_memory(300, 300, 9, itemsize=4, pair_on_demand=True)
    assert (held.batch_games, lazy.batch_games) == (3, 30)
    # Eight tables of one chunk (58 M entries) and the rows of 30 games at a profile.
    parts = dict(lazy.parts)
    assert parts["pairwise tables of one batch"] == 8 * 2700**2 * 4
    assert lazy.total_gib < 2.0


def test_the_memory_estimate_follows_the_batches_of_equal_held_games():
    """Games that may share a held table are batched 21 at a time at K = 300 (one table):
    the estimate counts that batch, its table and weighted copy and the rows of 21 games,
    when it is the larger; small games keep the batches of distinct games."""
    distinct = stage_memory(300, 300, 9)
    equal = stage_memory(300, 300, 9, held_sharing=1024)
    assert (distinct.batch_games, equal.batch_games) == (3, 21)
    assert dict(equal.parts)["pairwise tables of one batch"] == 2 * 2700**2 * 8
    assert equal.total_gib < 0.5
    small = stage_memory(300, 10, 9, held_sharing=1024)  # 90 entries: below the threshold
    assert small.batch_games == stage_memory(300, 10, 9).batch_games


def test_refinement_on_shared_ranked_tables_ends_at_a_pure_ne_whatever_the_batch():
    """Best-response dynamics end at a pure NE of each (potential) game (D. Monderer and
    L. S. Shapley, 1996): on the ranked tables too, and alike for a game alone."""
    from swarmgames.game.equilibrium import local_regret
    from swarmgames.game.refine import refine_profiles

    held, lazy, source = _permuted(5, np.float32)
    rng = np.random.default_rng(5)
    start = np.argmax(np.where(held.action_mask, rng.random(held.action_mask.shape), -1), 2)
    together = refine_profiles(lazy, start)
    assert together.converged.all()
    assert np.all(local_regret(held, together.profile) == 0.0)
    assert source.asked and set(source.asked) <= set(range(12))  # the heads' tables only
    for g in range(lazy.shape[0]):
        alone = refine_profiles(lazy.select([g]), start[[g]])
        assert np.array_equal(alone.profile[0], together.profile[g])


def test_games_in_step_give_the_same_results_on_any_number_of_threads():
    """The games of a group are split into one task per thread; each game's arithmetic is
    its own, so the split changes nothing."""
    import numba

    _, lazy, _ = _permuted(6, np.float32)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = mean_field(lazy, 5.0, engine="compiled")
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = mean_field(lazy, 5.0, engine="compiled")
    finally:
        numba.set_num_threads(before)
    assert np.array_equal(one.marginals, many.marginals)
    assert np.array_equal(one.iterations, many.iterations)
