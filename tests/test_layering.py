"""Layers point only down (STYLE.md, layout): every import in every module, at the top or
inside a function, reaches only its own layer or the layers below it. The snapshot type the
network returns and the game consumes needs nothing but numpy and scipy."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import swarmgames

SRC = Path(swarmgames.__file__).parent

#: Shared modules with no swarmgames layer below them.
BASE = (
    "swarmgames.allocator",
    "swarmgames.arrays",
    "swarmgames.errors",
    "swarmgames.labels",
    "swarmgames.lifetime",
    "swarmgames.names",
    "swarmgames.rng",
    "swarmgames.runfolder",
    "swarmgames.section",
    "swarmgames.topology",
)
#: Each layer and what it may import besides itself and BASE (the layering of the note in
#: the README's "Layout").
MAY_IMPORT = {
    "swarmgames.network": (),
    "swarmgames.game": (),
    "swarmgames.comms": ("swarmgames.game", "swarmgames.network"),
    "swarmgames.missions": ("swarmgames.game", "swarmgames.network"),
    "swarmgames.config": ("swarmgames.missions", "swarmgames.game", "swarmgames.network"),
    "swarmgames.sim": (
        "swarmgames.comms",
        "swarmgames.config",
        "swarmgames.missions",
        "swarmgames.game",
        "swarmgames.network",
    ),
}
ABOVE_SIM = ("swarmgames.sim", *MAY_IMPORT["swarmgames.sim"])
MAY_IMPORT["swarmgames.experiments"] = ABOVE_SIM
MAY_IMPORT["swarmgames.env"] = ABOVE_SIM
MAY_IMPORT["swarmgames.bench"] = (*ABOVE_SIM, "swarmgames.experiments")


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.add(node.module)
    return {m for m in names if m.split(".")[0] == "swarmgames"}


def _layer(path: Path) -> str:
    return "swarmgames." + path.relative_to(SRC).parts[0].removesuffix(".py")


MODULES = sorted(p for p in SRC.rglob("*.py") if _layer(p) in MAY_IMPORT or _layer(p) in BASE)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(SRC)))
def test_modules_import_only_lower_layers(path):
    layer = _layer(path)
    allowed = (*BASE,) if layer in BASE else (layer, *BASE, *MAY_IMPORT[layer])
    above = {m for m in _imports(path) if not m.startswith(allowed)}
    assert not above, f"{path.relative_to(SRC)} ({layer}) imports {sorted(above)}"


def test_base_modules_need_no_layer():
    for name in BASE:
        path = SRC / (name.removeprefix("swarmgames.") + ".py")
        assert not {m for m in _imports(path) if m not in BASE}, name


def test_topology_needs_only_numpy_and_scipy():
    # Module-level imports: networkx is imported inside the optional to_networkx export only.
    tree = ast.parse((SRC / "topology.py").read_text(encoding="utf-8"))
    names = {a.name for n in tree.body if isinstance(n, ast.Import) for a in n.names}
    names |= {n.module for n in tree.body if isinstance(n, ast.ImportFrom)}
    allowed = {"__future__", "dataclasses", "numpy", "scipy", "swarmgames.arrays"}
    assert {m if m.startswith("swarmgames") else m.split(".")[0] for m in names} <= allowed
