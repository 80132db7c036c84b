"""Payoffs whose pairwise table comes from a PairSource give the results of the held table."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from swarmgames.game import evaluate_payoffs, mean_field
from swarmgames.game.baselines import best_response
from swarmgames.game.capabilities import PairSourceCapabilities
from swarmgames.game.equilibrium import (
    enumerate_payoffs,
    global_regret,
    local_regret,
    profile_payoff,
)
from swarmgames.game.potentials import GamePayoffs, PairSource
from tests.game.helpers import random_games


@dataclass(frozen=True, eq=False)
class HeldSource:
    """A PairSource serving a held table (what any source must be equivalent to)."""

    capabilities = PairSourceCapabilities()

    w: np.ndarray

    def table(self, games):
        return self.w[np.asarray(games)].copy()

    def at(self, profile):
        return np.take_along_axis(self.w, profile[:, None, None, :, None], axis=4)[..., 0]

    def select(self, games):
        return HeldSource(self.w[games])


def _both(seed, dtype=np.float64, prefix=True):
    batch, pot = random_games(seed, 40, 5, 4)
    held = evaluate_payoffs(batch, pot, 1.0, 0.5, dtype=dtype)
    if not prefix:  # valid variables that are not a prefix: the compiled engine reorders
        keep = held.mask.copy()
        keep[:, 1] &= np.arange(40) % 2 == 0
        held = GamePayoffs(
            np.where(keep[..., None], held.unary, 0.0), held.pair * keep[:, :, None, None, None]
            * keep[:, None, None, :, None], held.action_mask & keep[..., None], keep,
            held.owner, held.members,
        )  # fmt: skip
    lazy = GamePayoffs(
        held.unary, None, held.action_mask, held.mask, held.owner, held.members,
        HeldSource(np.asarray(held.pair)),
    )  # fmt: skip
    return held, lazy


def test_a_source_conforms_to_the_protocol():
    _, lazy = _both(0)
    assert isinstance(lazy.pair_source, PairSource)
    assert lazy.has_pair and lazy.pair is None


@pytest.mark.parametrize("engine", ["compiled", "blas", "sequential"])
@pytest.mark.parametrize("prefix", [True, False])
def test_mean_field_is_bit_identical_with_a_source(engine, prefix, monkeypatch):
    import swarmgames.game.meanfield as mf

    monkeypatch.setattr(mf, "SOURCE_CHUNK_ELEMS", 1)  # chunks of the fewest games
    held, lazy = _both(1, np.float32, prefix)
    a = mean_field(held, 5.0, engine=engine)
    b = mean_field(lazy, 5.0, engine=engine)
    assert np.array_equal(a.marginals, b.marginals)
    assert np.array_equal(a.iterations, b.iterations)


def test_measurements_and_baselines_are_identical_with_a_source():
    held, lazy = _both(2)
    rng = np.random.default_rng(0)
    # A random valid action of every variable.
    x = np.argmax(np.where(held.action_mask, rng.random(held.action_mask.shape), -1.0), axis=2)
    assert np.array_equal(profile_payoff(held, x), profile_payoff(lazy, x))
    assert np.array_equal(local_regret(held, x), local_regret(lazy, x))
    joint = rng.integers(0, 4, 200)
    members = np.where(held.mask, np.arange(5)[None, :] + 100, -1)
    h2 = GamePayoffs(held.unary, held.pair, np.ones_like(held.action_mask) & held.mask[..., None],
                     held.mask, members[:, 0], members)  # fmt: skip
    l2 = GamePayoffs(h2.unary, None, h2.action_mask, h2.mask, h2.owner, h2.members,
                     lazy.pair_source)  # fmt: skip
    assert np.array_equal(global_regret(h2, joint), global_regret(l2, joint))
    assert np.array_equal(enumerate_payoffs(held, 3)[0], enumerate_payoffs(lazy, 3)[0])
    assert np.array_equal(best_response(held)[0], best_response(lazy)[0])
    sub = lazy.select(np.arange(40)[::3])
    assert np.array_equal(sub.pair_table(), held.select(np.arange(40)[::3]).pair)
