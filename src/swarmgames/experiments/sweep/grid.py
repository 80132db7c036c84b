"""The grid of a sweep: the levels of each overridden field, their combinations with the seeds,
every combination validated, and the run folder each one gets.

A factor is a dotted configuration path with one or more levels (``swarm.n_robots`` at 5 and
10). The grid is the Cartesian product of the factors' levels (the first factor varies
slowest); with ``zip`` the i-th levels of every factor go together instead. Every combination
runs once per seed.

On the command line a factor is ``--set path=v1,v2,...``: the text after ``=`` is split at the
commas that are outside brackets, braces and quotes, and each piece is read as ``--set`` reads
a value (a TOML literal, else a bare word as a string, :func:`~swarmgames.config.io.parse_value`).
So ``faults.crash=[[5.0,1]],[]`` has two levels (one crash, none), and a string with a comma
is quoted: ``name='a,b'``.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from swarmgames.config import ScenarioConfig
from swarmgames.config.io import apply_overrides, parse_value, toml_literal
from swarmgames.errors import ConfigError

__all__ = [
    "Factor",
    "SweepPlan",
    "SweepPoint",
    "factors_from_assignments",
    "factors_from_mapping",
    "folder_name",
    "plan_sweep",
    "split_levels",
    "study_levels",
]

#: Longest readable part of a run folder's name (the hash that follows keeps it unique).
MAX_SLUG = 96
_UNSAFE = re.compile(r"[^A-Za-z0-9._=-]+")
_CLOSE = {"[": "]", "{": "}"}


def _frozen(value: Any, path: str) -> Any:
    """``value`` with every list a tuple (levels are immutable and hashable)."""
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v, path) for v in value)
    if isinstance(value, dict):
        raise ConfigError(
            f"{path}: a table cannot be a level of a sweep; sweep its fields one by one "
            f"(got {value!r})"
        )
    return value


@dataclass(frozen=True)
class Factor:
    """One overridden field of a sweep and its levels.

    Attributes
    ----------
    path : str
        Dotted configuration path, as ``--set`` takes it (``"swarm.n_robots"``).
    levels : tuple
        The values it takes, in order (lists as tuples); the first is the baseline of the
        paired differences.
    """

    path: str
    levels: tuple[Any, ...]


@dataclass(frozen=True)
class SweepPoint:
    """One run of a sweep.

    Attributes
    ----------
    values : tuple of (str, value)
        The level of every factor, in the factors' order.
    seed : int
    config : ScenarioConfig
        The validated configuration of the run.
    folder : str
        The run folder's name inside the sweep's ``runs/`` (:func:`folder_name`).
    """

    values: tuple[tuple[str, Any], ...]
    seed: int
    config: ScenarioConfig
    folder: str

    @property
    def label(self) -> str:
        """``path=value, ..., seed=s``, values as TOML literals."""
        return ", ".join([*(f"{p}={toml_literal(v)}" for p, v in self.values), f"seed={self.seed}"])


@dataclass(frozen=True)
class SweepPlan:
    """A validated sweep: the base scenario, its factors and seeds, and every run.

    Attributes
    ----------
    base : ScenarioConfig
    factors : tuple of Factor
    seeds : tuple of int
    zip : bool
        Whether the factors' levels were zipped rather than crossed.
    points : tuple of SweepPoint
        Every run, combination by combination (grid order), the seeds innermost.
    """

    base: ScenarioConfig
    factors: tuple[Factor, ...]
    seeds: tuple[int, ...]
    zip: bool
    points: tuple[SweepPoint, ...]


def split_levels(text: str) -> list[str]:
    """Split ``text`` at the commas outside brackets, braces and quotes.

    Raises
    ------
    ConfigError
        Unbalanced brackets or quotes, or an empty piece.

    Examples
    --------
    >>> split_levels("5,10")
    ['5', '10']
    >>> split_levels("[[5.0,1]],[],'a,b'")
    ['[[5.0,1]]', '[]', "'a,b'"]
    """
    pieces, expected, quote, start, i = [], [], "", 0, 0
    while i < len(text):
        c = text[i]
        if quote:
            if quote == '"' and c == "\\":
                i += 1  # an escaped character inside a basic string
            elif c == quote:
                quote = ""
        elif c in "\"'":
            quote = c
        elif c in _CLOSE:
            expected.append(_CLOSE[c])
        elif c in "]}":
            if not expected or expected.pop() != c:
                raise ConfigError(f"unbalanced {c!r} at character {i + 1} (got {text!r})")
        elif c == "," and not expected:
            pieces.append(text[start:i])
            start = i + 1
        i += 1
    if quote or expected:
        what = f"quote {quote}" if quote else f"{expected[-1]!r}"
        raise ConfigError(f"missing closing {what} (got {text!r})")
    pieces.append(text[start:])
    if any(not p.strip() for p in pieces):
        raise ConfigError(f"every comma-separated value must be non-empty (got {text!r})")
    return pieces


def _factor(path: str, levels: Sequence[Any], what: str) -> Factor:
    if path == "seed":
        raise ConfigError(f"seed: the seeds of a sweep are given by --seeds / seeds= (got {what})")
    frozen = tuple(_frozen(v, path) for v in levels)
    if not frozen:
        raise ConfigError(f"{path}: needs at least one value (got {what})")
    return Factor(path, frozen)


def study_levels(values: Sequence[Any], what: str) -> tuple[Any, ...]:
    """The levels of a study's axis (its sizes, seeds or variants) as a tuple; ``what``
    names the axis in the one-line error.

    Raises
    ------
    ConfigError
        No level, or a level given twice.
    """
    values = tuple(values)
    if not values or len(set(values)) != len(values):
        raise ConfigError(f"{what}: must be a non-empty list without repeats (got {values!r})")
    return values


def _first_repeat(items: Sequence[Any]) -> Any:
    """The first item equal to an earlier one, or None."""
    seen: set = set()
    for item in items:
        if item in seen:
            return item
        seen.add(item)
    return None


def factors_from_assignments(assignments: Sequence[str]) -> dict[str, tuple[Any, ...]]:
    """The factors of ``--set path=v1,v2,...`` assignments (see the module notes).

    Raises
    ------
    ConfigError
        An assignment without ``=``, a path given twice, unbalanced brackets or quotes, an
        empty value; the message names the path and the assignment.

    Examples
    --------
    >>> factors_from_assignments(["swarm.n_robots=5,10", "faults.crash=[[5.0,1]],[]"])
    {'swarm.n_robots': (5, 10), 'faults.crash': (((5.0, 1),), ())}
    """
    out: dict[str, tuple[Any, ...]] = {}
    for assignment in assignments:
        path, sep, text = assignment.partition("=")
        path = path.strip()
        if not sep or not path:
            raise ConfigError(f"--set must look like section.field=v1,v2,... (got {assignment!r})")
        if path in out:
            raise ConfigError(f"{path}: is given by two --set options (got {assignment!r})")
        try:
            pieces = split_levels(text)
        except ConfigError as exc:
            raise ConfigError(f"{path}: {exc}") from None
        out[path] = _factor(path, [parse_value(p) for p in pieces], repr(assignment)).levels
    return out


def factors_from_mapping(overrides: Mapping[str, Sequence[Any]] | None) -> tuple[Factor, ...]:
    """Validate ``{path: [level, ...]}`` into factors.

    Raises
    ------
    ConfigError
        A path that is not a non-empty string, or ``seed``; levels that are not a list or
        tuple, or none.
    """
    if overrides is None:
        return ()
    if not isinstance(overrides, Mapping):
        raise ConfigError(
            f"overrides must be a dict of dotted paths to lists of values "
            f"(got {type(overrides).__name__})"
        )
    factors = []
    for path, levels in overrides.items():
        if not (isinstance(path, str) and path.strip()):
            raise ConfigError(f"override paths must be non-empty strings (got {path!r})")
        if not isinstance(levels, (list, tuple)):
            raise ConfigError(
                f"{path}: must be a list of the values to sweep, e.g. [{levels!r}] (got {levels!r})"
            )
        factors.append(_factor(path.strip(), levels, repr(list(levels))))
    return tuple(factors)


def _seeds(seeds: Sequence[int]) -> tuple[int, ...]:
    if isinstance(seeds, (str, bytes)) or not isinstance(seeds, Sequence):
        raise ConfigError(f"seeds must be a list of integers >= 0 (got {seeds!r})")
    bad = [s for s in seeds if isinstance(s, bool) or not isinstance(s, int) or s < 0]
    if not seeds or bad:
        raise ConfigError(f"seeds must be a non-empty list of integers >= 0 (got {list(seeds)!r})")
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"seeds must not repeat (got {list(seeds)!r})")
    return tuple(int(s) for s in seeds)


def _combinations(factors: tuple[Factor, ...], zipped: bool) -> list[tuple[Any, ...]]:
    """The combinations of the factors' levels; a repeated one (which would run twice into
    one folder) is an error."""
    if not zipped:
        for f in factors:
            repeat = _first_repeat(f.levels)
            if repeat is not None:
                levels = ", ".join(toml_literal(v) for v in f.levels)
                raise ConfigError(
                    f"{f.path}: value {toml_literal(repeat)} is given twice (got {levels})"
                )
        return list(itertools.product(*(f.levels for f in factors)))
    lengths = {len(f.levels) for f in factors} - {1}
    if len(lengths) > 1:
        counts = ", ".join(f"{f.path}: {len(f.levels)}" for f in factors)
        raise ConfigError(
            f"--zip pairs the i-th values of every factor, so each must have the same number "
            f"of values or just one (got {counts})"
        )
    n = max(lengths, default=1)
    combos = [tuple(f.levels[i if len(f.levels) > 1 else 0] for f in factors) for i in range(n)]
    repeat = _first_repeat(combos)
    if repeat is not None:
        label = ", ".join(
            f"{f.path}={toml_literal(v)}" for f, v in zip(factors, repeat, strict=True)
        )
        raise ConfigError(f"--zip: the combination {label} is given twice")
    return combos


def folder_name(values: Sequence[tuple[str, Any]], seed: int) -> str:
    """The run folder's name of a combination and seed: readable, safe and unique.

    ``path=value__...__seed=s`` (strings bare, other values as TOML literals) with every
    character but letters, digits, ``. _ = -`` replaced by ``_`` and cut at :data:`MAX_SLUG`
    characters, then ``-`` and 10 hex digits of the SHA-256 of the exact values. The paths are
    sorted, so the order of the ``--set`` options does not matter. The name has no ``/`` and
    never starts with a dot: it stays inside ``runs/``.

    Examples
    --------
    >>> folder_name([("swarm.n_robots", 5)], 0)
    'swarm.n_robots=5__seed=0-25b5f1c16f'
    """
    items = sorted((p, toml_literal(v)) for p, v in values)
    readable = sorted((p, v if isinstance(v, str) else toml_literal(v)) for p, v in values)
    text = "__".join([*(f"{p}={v}" for p, v in readable), f"seed={seed}"])
    slug = _UNSAFE.sub("_", text)[:MAX_SLUG].lstrip("._-") or "run"
    digest = hashlib.sha256(json.dumps([items, seed]).encode("utf-8")).hexdigest()[:10]
    return f"{slug}-{digest}"


def plan_sweep(
    base: ScenarioConfig,
    factors: tuple[Factor, ...],
    seeds: Sequence[int],
    zipped: bool = False,
) -> SweepPlan:
    """Expand and validate a sweep: every combination goes through the configuration schema
    before anything runs.

    Parameters
    ----------
    base : ScenarioConfig
        The scenario every run starts from.
    factors : tuple of Factor
    seeds : sequence of int
        Distinct seeds >= 0; each combination runs once per seed.
    zipped : bool
        Zip the factors' levels (the i-th of each together; a factor with one level goes
        with every combination) instead of crossing them.

    Returns
    -------
    SweepPlan

    Raises
    ------
    ConfigError
        Bad seeds, a repeated level (a repeated combination under ``zipped``), levels of
        unequal numbers under ``zipped``, or combinations the schema rejects: one line per
        distinct problem, naming the combination, the field, the rule and the value.
    """
    seeds = _seeds(seeds)
    problems: dict[str, str] = {}
    points = []
    for combo in _combinations(factors, zipped):
        values = tuple((f.path, v) for f, v in zip(factors, combo, strict=True))
        label = ", ".join(f"{p}={toml_literal(v)}" for p, v in values) or "the base scenario"
        try:
            config = apply_overrides(base, dict(values), source=f"sweep point {label}")
        except ConfigError as exc:
            for line in exc.errors:
                problems.setdefault(line, label)
            continue
        # The seed is checked above (an int >= 0 is all the schema asks of it).
        points += [
            SweepPoint(values, s, config.model_copy(update={"seed": s}), folder_name(values, s))
            for s in seeds
        ]
    if len(problems) == 1:
        ((line, label),) = problems.items()
        raise ConfigError(f"invalid configuration in sweep point {label}: {line}", [line])
    if problems:
        lines = [f"{label}: {line}" for line, label in problems.items()]
        raise ConfigError(f"invalid sweep: {len(lines)} problems\n  " + "\n  ".join(lines), lines)
    return SweepPlan(base, factors, seeds, bool(zipped), tuple(points))
