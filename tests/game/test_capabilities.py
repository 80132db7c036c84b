"""Declared capabilities: validation at the boundary, and what wrappers and solvers declare."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.game import (
    FunctionPotentials,
    Inertia,
    PotentialCapabilities,
    SolverCapabilities,
    TablePotentials,
    capabilities_of,
    evaluate_payoffs,
    make_solver,
)
from swarmgames.game.capabilities import PairSourceCapabilities, pair_source_capabilities
from swarmgames.missions.flocking import FlockingPotentials
from tests.game.helpers import random_games

PLAIN = FunctionPotentials(lambda s: -np.linalg.norm(s, axis=-1))


class _Plain:
    def unary(self, batch):
        return np.zeros(batch.action_mask.shape)

    def pairwise(self, batch):
        return None


def test_built_in_helpers_declare_no_optional_form():
    assert capabilities_of(PLAIN) == PotentialCapabilities()
    _, table = random_games(0, 2, 2, 2)
    assert capabilities_of(table) == PotentialCapabilities()
    assert isinstance(table, TablePotentials)


def test_undeclared_potentials_are_refused_with_the_rule():
    batch, _ = random_games(0, 2, 2, 2)
    with pytest.raises(TypeError, match="potentials must declare capabilities: a "
                       "PotentialCapabilities attribute \\(got NoneType on _Plain\\)"):  # fmt: skip
        evaluate_payoffs(batch, _Plain())


@pytest.mark.parametrize(
    ("caps", "match"),
    [
        ({"pair_table": True}, "pair_table = True, so it must have a callable pair_table"),
        ({"pair_source": True}, "callable pair_source"),
        ({"owner_rows": True}, "callable owner_unary"),
        ({"held_sharing": True}, "callable held_sharing_min"),
        ({"memory": True}, "callable stage_bytes"),
    ],
)  # fmt: skip
def test_a_declared_form_needs_its_method(caps, match):
    class Claims(_Plain):
        capabilities = PotentialCapabilities(**caps)

    with pytest.raises(TypeError, match=match):
        capabilities_of(Claims())


def test_fields_must_be_booleans():
    class Vague(_Plain):
        capabilities = PotentialCapabilities(pair_table=1)

    with pytest.raises(TypeError, match=r"capabilities\.pair_table must be a bool \(got 1"):
        capabilities_of(Vague())


def test_pair_sources_declare_their_optional_methods():
    class Source:
        capabilities = PairSourceCapabilities(at_sums=True)

    with pytest.raises(TypeError, match=r"pair source declares capabilities\.at_sums = True"):
        pair_source_capabilities(Source())
    with pytest.raises(TypeError, match="pair source must declare capabilities"):
        pair_source_capabilities(object())


def test_inertia_declares_what_it_forwards():
    flock = FlockingPotentials((0.5, 0.0), 0.2, 0.5, 0.5)
    # Owner rows need the wrapped pair table's owner rows, which flocking lacks.
    assert capabilities_of(Inertia(flock, 0.1)) == PotentialCapabilities(pair_table=True)
    assert capabilities_of(Inertia(PLAIN, 0.1)) == PotentialCapabilities(owner_rows=True)
    with pytest.raises(TypeError, match="potentials must declare capabilities"):
        capabilities_of(Inertia(_Plain(), 0.1))


def test_solver_capabilities():
    assert make_solver("exact").capabilities(PLAIN) == SolverCapabilities()
    sampling = make_solver("mean_field", action_choice="sample")
    assert sampling.capabilities(PLAIN) == SolverCapabilities(samples_actions=True, draws=True)
    assert make_solver("random").capabilities(PLAIN) == SolverCapabilities(draws=True)
    with pytest.raises(TypeError, match="potentials must declare capabilities"):
        make_solver("mean_field").capabilities(_Plain())
