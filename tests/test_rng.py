"""The one seed normaliser, :func:`swarmgames.rng.as_generator`."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.rng import as_generator


def test_generator_is_passed_through():
    rng = np.random.default_rng(3)
    assert as_generator(rng) is rng


@pytest.mark.parametrize("seed", [0, 7, np.int64(7)])
def test_int_seed_matches_default_rng(seed):
    assert as_generator(seed).integers(2**62) == np.random.default_rng(seed).integers(2**62)


def test_none_gives_a_fresh_generator():
    assert isinstance(as_generator(None), np.random.Generator)


@pytest.mark.parametrize("seed", [True, 1.5, "x", np.random.SeedSequence(1)])
def test_other_types_are_rejected(seed):
    with pytest.raises(TypeError, match=r"seed must be an int, a numpy Generator or None \(got "):
        as_generator(seed)
