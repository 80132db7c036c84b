"""The network layer points only down: it never imports the configuration or a higher layer,
and the snapshot type it returns needs nothing but numpy and scipy (STYLE.md, layout)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import swarmgames

SRC = Path(swarmgames.__file__).parent
#: What the network layer may import from swarmgames besides itself.
BELOW = ("swarmgames.errors", "swarmgames.rng", "swarmgames.topology")


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.add(node.module)
    return names


@pytest.mark.parametrize(
    "path", sorted((SRC / "network").rglob("*.py")), ids=lambda p: str(p.relative_to(SRC))
)
def test_network_modules_import_only_lower_layers(path):
    ours = {m for m in _imports(path) if m.split(".")[0] == "swarmgames"}
    above = {m for m in ours if not m.startswith(("swarmgames.network", *BELOW))}
    assert not above, f"{path.name} imports {sorted(above)}"


def test_topology_needs_only_numpy_and_scipy():
    # Module-level imports: networkx is imported inside the optional to_networkx export only.
    tree = ast.parse((SRC / "topology.py").read_text(encoding="utf-8"))
    names = {a.name for n in tree.body if isinstance(n, ast.Import) for a in n.names}
    names |= {n.module for n in tree.body if isinstance(n, ast.ImportFrom)}
    assert {m.split(".")[0] for m in names} <= {"__future__", "dataclasses", "numpy", "scipy"}
