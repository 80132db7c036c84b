"""Layers point only down (STYLE.md, layout): every import in every module, at the top or
inside a function, reaches only its own layer or the layers below it. The snapshot type the
network returns and the game consumes needs nothing but numpy and scipy. No module outside
the missions package names a particular mission: the others reach a mission through the
registry and the protocol only, as they reach a plug-in's."""

from __future__ import annotations

import ast
import importlib
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
    "swarmgames.lazy",
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
MAY_IMPORT["swarmgames.bench"] = (*ABOVE_SIM, "swarmgames.experiments", "swarmgames.env")


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


#: The missions package's shared infrastructure, which every layer may use: the protocol, the
#: registry, the conformance check and what every mission shares (motion models, geometry).
MISSION_INFRASTRUCTURE = tuple(
    f"swarmgames.missions.{m}"
    for m in ("protocol", "registry", "conformance", "motion", "geometry")
)
#: Layers that may name a particular mission, and which: the benchmarks time the coverage
#: mission's own kernels (its signal window, bench/suite.py).
MAY_NAME_MISSION = {"swarmgames.bench": ("swarmgames.missions.coverage",)}


def _module_name(path: Path, root: Path) -> str:
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(("swarmgames", *parts[: -1 if parts[-1] == "__init__" else None]))


def _home(name: str) -> str:
    """The module that ``name`` (``package.module`` or ``package.attribute``) comes from: the
    module itself, or where the attribute is defined (a re-export's home)."""
    try:
        return importlib.import_module(name).__name__
    except ModuleNotFoundError:
        package, _, attr = name.rpartition(".")
        return getattr(getattr(importlib.import_module(package), attr), "__module__", package)


def mission_imports(path: Path, root: Path = SRC) -> set[str]:
    """The particular missions' modules that the module at ``path`` imports, at the top or
    inside a function, directly (``swarmgames.missions.coverage.lloyd``), as a submodule or a
    re-export of the package (``from swarmgames.missions import coverage``, ``... import
    CoveragePotentials``) or relatively; ``root`` is the folder of the swarmgames package."""
    here = _module_name(path, root)
    package = here if path.name == "__init__.py" else here.rpartition(".")[0]
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(filter(None, [*up, base]))
            names |= {base} | {f"{base}.{a.name}" for a in node.names if a.name != "*"}
    inside = {n for n in names if n.startswith("swarmgames.missions.")}
    homes = {_home(n) for n in inside}
    return {
        m
        for m in homes
        if m.startswith("swarmgames.missions.") and not m.startswith(MISSION_INFRASTRUCTURE)
    }


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


OUTSIDE_MISSIONS = sorted(
    p
    for p in SRC.rglob("*.py")
    if _module_name(p, SRC).split(".")[:2] != ["swarmgames", "missions"]
)


@pytest.mark.parametrize("path", OUTSIDE_MISSIONS, ids=lambda p: str(p.relative_to(SRC)))
def test_no_module_outside_the_missions_names_a_mission(path):
    allowed = MAY_NAME_MISSION.get(_layer(path), ())
    leaks = {m for m in mission_imports(path) if not m.startswith(allowed)}
    assert not leaks, f"{path.relative_to(SRC)} imports the missions {sorted(leaks)}"


@pytest.mark.parametrize(
    ("source", "leaks"),
    [
        ("from swarmgames.missions.coverage.lloyd import lloyd_actions", {"coverage.lloyd"}),
        ("import swarmgames.missions.rendezvous", {"rendezvous"}),
        ("def f():\n    from swarmgames.missions import flocking", {"flocking"}),
        ("from swarmgames.missions import CoveragePotentials", {"coverage.potentials"}),
        ("from ..missions.coverage import roi", {"coverage", "coverage.roi"}),
        ("from ..missions import get_mission, Mission, HeadingActions", set()),
        ("from swarmgames.missions.protocol import SWARM_HEAD", set()),
        ("from swarmgames.missions.geometry import CROWDING_CHUNK_ELEMS", set()),
        ("import swarmgames.missions", set()),
    ],
)
def test_the_mission_check_flags_a_mission_import(tmp_path, source, leaks):
    # A module of the sim layer, written where the check looks: what does it catch?
    module = tmp_path / "sim" / "leaky.py"
    module.parent.mkdir()
    module.write_text(source + "\n", encoding="utf-8")
    found = mission_imports(module, root=tmp_path)
    assert found == {f"swarmgames.missions.{m}" for m in leaks}
