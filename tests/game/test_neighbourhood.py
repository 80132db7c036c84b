"""The owner's neighbourhood term ψ (``PotentialCapabilities.neighbourhood``).

ψ enters the owner's unary row only, ``U[b, 0, a] += α_a ψ[b, a]``
(:func:`~swarmgames.game.potentials.evaluate_payoffs`), so the payoff of a pure profile is
eq. 1 plus ``α_a ψ(x_0)``, and the owners' rows of the global and ex-post regret hold it too.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np
import pytest

from swarmgames.errors import PayoffError
from swarmgames.game import (
    DisplacementActions,
    Inertia,
    MeanFieldSolver,
    OwnerPayoffs,
    PotentialCapabilities,
    StageProblem,
    check_potentials,
    evaluate_payoffs,
    local_games,
    solve,
)
from swarmgames.game.equilibrium import enumerate_payoffs, owner_payoffs
from tests.game.helpers import disk_snapshot

MODEL = DisplacementActions.headings(2.0, 4)  # stay, +x, +y, -x, -y
GOAL = np.array([-100.0, 0.0])


@dataclass(frozen=True, eq=False)
class KeepALink:
    """A goal to the west (unary), a repulsion between next positions (pairwise) and, as
    ψ, a cost ``penalty`` on every owner action after which no other member's state lies
    within ``range_m`` of the owner: "keep at least one link", which is no sum over pairs."""

    range_m: float = 10.0
    penalty: float = 50.0
    owner_rows: bool = False

    @property
    def capabilities(self) -> PotentialCapabilities:
        return PotentialCapabilities(neighbourhood=True, owner_rows=self.owner_rows)

    def unary(self, batch):
        return -np.linalg.norm(np.asarray(batch.next_states)[..., :2] - GOAL, axis=-1)

    def owner_unary(self, batch):
        return self.unary(batch)[:, 0]

    def pairwise(self, batch):
        nxt = np.asarray(batch.next_states)[..., :2]
        d = np.linalg.norm(nxt[:, :, None, :, None] - nxt[:, None, :, None, :], axis=-1)
        return -np.exp(-d)

    def neighbourhood(self, batch):
        own = np.asarray(batch.next_states)[:, 0, :, :2]  # (B, A, 2)
        others = np.asarray(batch.states)[:, :, :2]  # (B, K, 2)
        d = np.linalg.norm(own[:, :, None, :] - others[:, None, :, :], axis=-1)  # (B, A, K)
        near = (d <= self.range_m) & np.asarray(batch.mask)[:, None, :]
        near[:, :, 0] = False  # the owner itself is no link
        return np.where(near.any(axis=2), 0.0, -self.penalty)


def _line(gap: float = 9.0, n: int = 3):
    pos = np.array([[gap * i, 0.0] for i in range(n)])
    return pos, local_games(disk_snapshot(pos, 10.0), 1, pos, MODEL)


def test_payoff_table_is_eq1_plus_the_owner_term_by_brute_force():
    pot, (alpha_a, alpha_b) = KeepALink(), (2.0, 0.5)
    _, batch = _line()
    pay = evaluate_payoffs(batch, pot, alpha_a, alpha_b)
    u, p, psi = pot.unary(batch), pot.pairwise(batch), pot.neighbourhood(batch)
    for b in range(batch.n_games):
        grid, actions = enumerate_payoffs(pay, b)
        valid = np.flatnonzero(batch.mask[b])
        for idx in itertools.product(*(range(len(a)) for a in actions)):
            x = [int(actions[i][j]) for i, j in enumerate(idx)]
            want = alpha_a * sum(u[b, k, x[i]] for i, k in enumerate(valid))
            want += alpha_a * psi[b, x[0]]  # the owner is variable 0
            want += alpha_b * sum(
                p[b, k, m, x[i], x[j]]
                for (i, k), (j, m) in itertools.permutations(enumerate(valid), 2)
            )
            assert grid[idx] == pytest.approx(want, rel=1e-12, abs=1e-12)


def test_the_term_enters_the_owner_row_only():
    _, batch = _line()
    with_psi = evaluate_payoffs(batch, KeepALink(), 1.0, 0.001)
    without = evaluate_payoffs(batch, KeepALink(penalty=0.0), 1.0, 0.001)
    np.testing.assert_array_equal(with_psi.unary[:, 1:], without.unary[:, 1:])
    np.testing.assert_array_equal(with_psi.pair, without.pair)
    assert np.any(with_psi.unary[:, 0] != without.unary[:, 0])


@pytest.mark.parametrize("owner_rows", [False, True])
@pytest.mark.parametrize("wrap", [False, True])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_owner_rows_hold_the_term_bit_for_bit(owner_rows, wrap, dtype):
    # The global and ex-post regret read the owners' rows (owner_payoffs): with the owners'
    # unary alone or from the whole evaluation, the term is the same.
    pot = KeepALink(owner_rows=owner_rows)
    pot = Inertia(pot, 0.25) if wrap else pot
    _, batch = _line(n=4)
    whole = OwnerPayoffs.of(evaluate_payoffs(batch, pot, 1.5, 0.01, dtype=dtype))
    rows = owner_payoffs(batch, pot, 1.5, 0.01, dtype=dtype)
    np.testing.assert_array_equal(rows.unary, whole.unary)
    np.testing.assert_array_equal(rows.pair, whole.pair)


def test_keep_a_link_makes_an_isolated_risk_owner_keep_a_neighbour():
    # Robot 0 is pulled west, away from its only neighbour 9 m east (range 10 m): moving
    # west (action 3) ends 11 m from it. With the term it takes the best move that keeps
    # the link.
    pos = np.array([[0.0, 0.0], [9.0, 0.0]])
    snap = disk_snapshot(pos, 10.0)
    solver = MeanFieldSolver()
    free = solve(StageProblem.ideal(snap, 1, pos, MODEL, KeepALink(penalty=0.0), solver))
    kept = solve(StageProblem.ideal(snap, 1, pos, MODEL, KeepALink(), solver))
    assert free.actions[0] == 3
    nxt = kept.next_states[0]
    assert np.linalg.norm(nxt - pos[1]) <= 10.0
    assert kept.actions[0] != 3
    # The measurements score the same term: the owner's move is a best response.
    assert kept.global_regret[0] == pytest.approx(0.0, abs=1e-12)
    assert kept.local_regret[0] == pytest.approx(0.0, abs=1e-12)


class _Bad(KeepALink):
    def __init__(self, out) -> None:
        super().__init__()
        object.__setattr__(self, "out", out)

    def neighbourhood(self, batch):
        return self.out(batch)


def test_a_term_of_the_wrong_shape_is_an_error():
    _, batch = _line()
    bad = _Bad(lambda b: np.zeros((b.n_games, b.n_actions + 1)))
    with pytest.raises(ValueError, match=r"neighbourhood term must have shape \(3, 5\)"):
        evaluate_payoffs(batch, bad)
    with pytest.raises(ValueError, match="neighbourhood term must have shape"):
        check_potentials(bad, batch)


def test_a_non_finite_term_names_the_owner_and_action():
    _, batch = _line()

    def nan_at(b):
        out = np.zeros((b.n_games, b.n_actions))
        out[1, 2] = np.nan
        return out

    with pytest.raises(PayoffError, match=r"neighbourhood term is not finite \(nan\) for "
                       r"local game of robot 1 \(game 1\), variable 0.*action 2"):  # fmt: skip
        evaluate_payoffs(batch, _Bad(nan_at))
    with pytest.raises(PayoffError, match="neighbourhood term is not finite"):
        owner_payoffs(batch, _Bad(nan_at))


def test_a_non_finite_term_at_an_invalid_action_is_ignored():
    _, batch = _line()
    amask = np.asarray(batch.action_mask).copy()
    amask[0, 0, 4] = False
    batch = replace(batch, action_mask=amask)

    def nan_at_invalid(b):
        out = np.zeros((b.n_games, b.n_actions))
        out[0, 4] = np.nan
        return out

    pay = evaluate_payoffs(batch, _Bad(nan_at_invalid))
    assert pay.unary[0, 0, 4] == 0.0


def test_a_term_mixing_games_is_caught():
    _, batch = _line(n=4)
    leaky = _Bad(lambda b: np.broadcast_to(np.arange(b.n_games, dtype=float)[:, None],
                                           (b.n_games, b.n_actions)))  # fmt: skip
    with pytest.raises(ValueError, match="unary or neighbourhood of a game depends"):
        check_potentials(leaky, batch)


def test_a_declared_term_without_its_method_is_refused():
    class Undeclared:
        capabilities = PotentialCapabilities(neighbourhood=True)

        def unary(self, batch):
            return np.zeros(batch.action_mask.shape)

        def pairwise(self, batch):
            return None

    _, batch = _line()
    with pytest.raises(TypeError, match="callable neighbourhood"):
        evaluate_payoffs(batch, Undeclared())
