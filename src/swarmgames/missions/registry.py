"""Missions by name: the built-in ones, and plug-ins from other packages' entry points.

A mission is registered as a :class:`MissionEntry`: its name, its configuration section (a
:class:`~swarmgames.section.Section` subclass: the ``[name]`` table of a scenario file) and a
``build(config)`` function that turns a validated
:class:`~swarmgames.config.schema.ScenarioConfig` into a
:class:`~swarmgames.missions.protocol.Mission`.

A third-party package makes its mission available to every swarmgames command by declaring
an entry point in the group ``swarmgames.missions`` whose object is its entry::

    # pyproject.toml of the package "swarm-dispersal"
    [project.entry-points."swarmgames.missions"]
    dispersal = "swarm_dispersal:ENTRY"

after which ``scenario = "dispersal"`` and a ``[dispersal]`` table work in any scenario file.
Entry points are read once, on the first look-up; :func:`register_mission` adds one from
Python (a notebook, a test).
"""

from __future__ import annotations

import difflib
import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from swarmgames.errors import ConfigError
from swarmgames.names import CONTROLLERS
from swarmgames.section import Section

__all__ = [
    "ENTRY_POINT_GROUP",
    "MissionEntry",
    "broken_plugins",
    "get_mission",
    "mission_names",
    "register_mission",
    "unregister_mission",
]

#: Entry-point group through which other packages register missions.
ENTRY_POINT_GROUP = "swarmgames.missions"

#: Built-in missions: name -> "module:attribute" of their entry (imported on first use).
_BUILTIN = {
    "coverage": "swarmgames.missions.coverage.mission:ENTRY",
    "rendezvous": "swarmgames.missions.rendezvous:ENTRY",
    "flocking": "swarmgames.missions.flocking:ENTRY",
}


@dataclass(frozen=True)
class MissionEntry:
    """A mission as the registry knows it.

    Parameters
    ----------
    name : str
        Registry name: the value of ``scenario`` and the name of the mission's table.
    config : type of Section
        The mission's configuration section; every field needs a default.
    build : callable ``(ScenarioConfig) -> Mission``
        Builds the mission from a whole validated scenario (its own section is
        ``config.mission``; the swarm, game and sim sections are there too).
    description : str
        One line for ``swarmgames config list``.
    baselines : tuple of str, default ()
        Names of the baseline controllers the built mission offers (its ``baselines`` hook,
        :mod:`swarmgames.missions.protocol`): the values of ``sim.controller`` besides
        ``"game"`` and ``"mpc"`` that a configuration of this mission accepts. Python
        identifiers, none of them ``"game"`` or ``"mpc"``.
    """

    name: str
    config: type[Section]
    build: Callable[[Any], Any]
    description: str = ""
    baselines: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not (isinstance(self.name, str) and self.name.isidentifier()):
            raise ValueError(f"mission name must be a Python identifier (got {self.name!r})")
        if not (isinstance(self.config, type) and issubclass(self.config, Section)):
            raise TypeError(
                f"mission {self.name!r}: config must be a subclass of swarmgames.section.Section "
                f"(got {self.config!r})"
            )
        if not callable(self.build):
            raise TypeError(f"mission {self.name!r}: build must be callable (got {self.build!r})")
        names = self.baselines
        if not (
            isinstance(names, tuple)
            and all(isinstance(b, str) and b.isidentifier() for b in names)
            and not set(names) & set(CONTROLLERS)
        ):
            raise ValueError(
                f"mission {self.name!r}: baselines must be a tuple of Python identifiers, none "
                f"of them {' or '.join(map(repr, CONTROLLERS))} (got {names!r})"
            )


_registry: dict[str, MissionEntry] = {}
#: Plug-ins that could not be loaded: their name and why, in one line.
_broken: dict[str, str] = {}
_loaded = False


def _resolve(target: str) -> Any:
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def _load() -> None:
    """Register the built-in missions and those of installed packages (once)."""
    global _loaded
    if _loaded:
        return
    _loaded = True
    for name, target in _BUILTIN.items():
        _registry.setdefault(name, _resolve(target))
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            _registry[ep.name] = _plugin(ep)
        except ConfigError as exc:  # a broken plug-in must not break the other missions
            _broken[ep.name] = str(exc)


def _plugin(ep) -> MissionEntry:
    """The entry of the mission plug-in ``ep`` (an entry point), checked.

    Raises
    ------
    ConfigError
        It cannot be imported or is not a valid entry (one line).
    """
    try:
        entry = ep.load()
    except Exception as exc:  # any error of a plug-in's import is the plug-in's
        why = " ".join(f"{type(exc).__name__}: {exc}".split())[:200]
        raise ConfigError(
            f"cannot load mission plug-in {ep.name!r} ({ep.value}) from entry point group "
            f"{ENTRY_POINT_GROUP!r}: {why}"
        ) from None
    if not isinstance(entry, MissionEntry):
        raise ConfigError(
            f"mission plug-in {ep.name!r} ({ep.value}) must be a swarmgames.missions."
            f"MissionEntry (got {type(entry).__name__})"
        )
    if entry.name != ep.name:
        raise ConfigError(
            f"mission plug-in {ep.value}: entry point name {ep.name!r} differs from the "
            f"entry's name {entry.name!r}"
        )
    if entry.name in _registry and _registry[entry.name] is not entry:
        raise ConfigError(
            f"mission plug-in {ep.value} registers {entry.name!r}, which is already taken"
        )
    return entry


def broken_plugins() -> dict[str, str]:
    """The installed mission plug-ins that could not be loaded: name to the reason, one line
    each (the other missions work without them).

    Examples
    --------
    >>> isinstance(broken_plugins(), dict)
    True
    """
    _load()
    return dict(_broken)


def register_mission(entry: MissionEntry, *, replace: bool = False) -> MissionEntry:
    """Register ``entry`` under its name and return it.

    Raises
    ------
    ValueError
        The name is taken and ``replace`` is false.
    """
    if not isinstance(entry, MissionEntry):
        raise TypeError(f"entry must be a MissionEntry (got {type(entry).__name__})")
    _load()
    if entry.name in _registry and not replace and _registry[entry.name] is not entry:
        raise ValueError(f"mission {entry.name!r} is already registered (pass replace=True)")
    _registry[entry.name] = entry
    return entry


def unregister_mission(name: str) -> None:
    """Remove a mission registered from Python (for tests and notebooks)."""
    _load()
    if name in _BUILTIN:
        raise ValueError(f"mission {name!r} is built in and cannot be removed")
    _registry.pop(name, None)


def mission_names() -> tuple[str, ...]:
    """Names of every registered mission, sorted."""
    _load()
    return tuple(sorted(_registry))


def get_mission(name: str) -> MissionEntry:
    """The entry of mission ``name``.

    Raises
    ------
    ConfigError
        Unknown name; the message lists the registered missions and close matches.

    Examples
    --------
    >>> get_mission("coverage").config.__name__
    'CoverageConfig'
    """
    _load()
    try:
        return _registry[name]
    except (KeyError, TypeError):
        if isinstance(name, str) and name in _broken:
            raise ConfigError(_broken[name]) from None
        names = mission_names()
        close = difflib.get_close_matches(str(name), names, n=3)
        hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
        raise ConfigError(
            f"unknown mission {name!r}{hint} (registered: {', '.join(names)})"
        ) from None
