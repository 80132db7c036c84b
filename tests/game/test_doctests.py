"""Run the examples in the game modules' docstrings."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ["actions", "local", "potentials", "virtual"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(f"swarmgames.game.{name}")
    result = doctest.testmod(module)
    assert result.attempted > 0 and result.failed == 0
