"""Generated invalid-configuration suite: every field of every section rejects bad values.

In the spirit of scikit-learn's invalid-parameter checks: the cases are derived from the
schema itself (pydantic's field annotations and constraints), so a field added later is
covered without editing this file. For every field of ``ScenarioConfig``'s sections and of the
built-in missions' sections: a value of the wrong type, a value just outside each declared
bound, NaN and the infinities for floats, and a misspelt key. Each must raise a
:class:`ConfigError` from ``parse_config`` whose message names the field's dotted path; through
the CLI, each field's wrong type exits 2 with that one line and no traceback.
"""

from __future__ import annotations

import math
import types
import typing
from typing import Any, Literal

import annotated_types as at
import pytest
from click.testing import CliRunner
from pydantic import BaseModel

from swarmgames.cli import cli
from swarmgames.config import ScenarioConfig, parse_config
from swarmgames.config.io import toml_literal
from swarmgames.errors import ConfigError
from swarmgames.missions import get_mission

MISSIONS = ("coverage", "rendezvous", "flocking")


def _leaves(model: type[BaseModel], prefix: str = ""):
    """``(dotted path, FieldInfo)`` of every scalar field, descending into sections."""
    for name, info in model.model_fields.items():
        if name == "mission":
            continue  # the mission's table, walked from each mission's section below
        ann = info.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            yield from _leaves(ann, f"{prefix}{name}.")
        else:
            yield f"{prefix}{name}", info


def _fields():
    """``(mission, dotted path, FieldInfo)``: the scenario's fields, then each mission's."""
    for path, info in _leaves(ScenarioConfig):
        yield "coverage", path, info
    for mission in MISSIONS:
        for path, info in _leaves(get_mission(mission).config, f"{mission}."):
            yield mission, path, info


FIELDS = list(_fields())


def _members(ann: Any) -> list[Any]:
    """The alternatives of a union (``float | None``, ``bool | Literal['auto']``)."""
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        return [a for a in typing.get_args(ann) if a is not type(None)]
    return [ann]


def _wrong_types(ann: Any) -> list[Any]:
    """Values no alternative of ``ann`` accepts without coercion."""
    members = _members(ann)
    literals = [v for m in members if typing.get_origin(m) is Literal for v in typing.get_args(m)]
    wrong: list[Any] = []
    for m in members:
        origin = typing.get_origin(m)
        if m is float:
            wrong += ["1.0", True]
        elif m is int:
            wrong += [1.5, "7", True]
        elif m is bool:
            wrong += [1, "true"]
        elif m is str:
            wrong += [5, ["a"]]
        elif origin is tuple:
            n = len(typing.get_args(m))
            wrong += ["(0, 0)", [0.0] * (n + 1), ["a"] * n]
        elif origin is Literal:
            wrong += [True, 3.5] if all(isinstance(v, int) for v in literals) else [5, "nope"]

    # A value one alternative rejects may be another's (True is fine in bool | 'auto').
    def accepted(w: Any) -> bool:
        exact = any(type(w) is type(v) and w == v for v in literals)
        return exact or any(isinstance(m, type) and type(w) is m for m in members)

    return [w for w in wrong if not accepted(w)]


def _out_of_range(info: Any) -> list[Any]:
    """One value beyond each declared bound (and length) of the field."""
    is_int = info.annotation is int
    step = 1 if is_int else 1e-9
    out: list[Any] = []
    for m in info.metadata:
        if isinstance(m, at.Gt):
            out.append(m.gt)
        elif isinstance(m, at.Ge):
            out.append(m.ge - step if is_int else m.ge - max(abs(m.ge) * 1e-9, 1e-9))
        elif isinstance(m, at.Lt):
            out.append(m.lt)
        elif isinstance(m, at.Le):
            out.append(m.le + step if is_int else m.le + max(abs(m.le) * 1e-9, 1e-9))
        elif isinstance(m, at.MinLen):
            out.append("" if m.min_length == 1 else "a" * (m.min_length - 1))
        elif isinstance(m, at.MaxLen):
            out.append("a" * (m.max_length + 1))
    if getattr(info.annotation, "__name__", "") == "str" and any(
        getattr(m, "pattern", None) for m in info.metadata
    ):
        out += ["..", "a b"]
    return out


def _non_finite(ann: Any) -> list[Any]:
    """NaN and the infinities wherever a float sits (nested in tuples too)."""

    def fill(a: Any, bad: float) -> Any:
        if a is float:
            return bad
        if typing.get_origin(a) is tuple:
            args = typing.get_args(a)
            return [fill(args[0], bad)] + [_valid(x) for x in args[1:]]
        return None

    values = []
    for m in _members(ann):
        for bad in (math.nan, math.inf, -math.inf):
            v = fill(m, bad)
            if v is not None:
                values.append(v)
    return values


def _valid(a: Any) -> Any:
    if a is float:
        return 1.0
    return [_valid(x) for x in typing.get_args(a)]


def _data(mission: str, path: str, value: Any) -> dict[str, Any]:
    data: dict[str, Any] = {"scenario": mission}
    *parents, leaf = path.split(".")
    node = data
    for part in parents:
        node = node.setdefault(part, {})
    node[leaf] = value
    return data


def _cases():
    for mission, path, info in FIELDS:
        kinds = (
            [("wrong type", v) for v in _wrong_types(info.annotation)]
            + [("out of range", v) for v in _out_of_range(info)]
            + [("non-finite", v) for v in _non_finite(info.annotation)]
        )
        for kind, value in kinds:
            yield pytest.param(mission, path, value, id=f"{path}-{kind}-{value!r}")


CASES = list(_cases())


def test_the_suite_covers_every_field_with_every_kind():
    assert len(FIELDS) > 80  # the schema and the three missions' sections
    by_field = {path: info for _, path, info in FIELDS}
    floats = [p for p, i in by_field.items() if float in _members(i.annotation)]
    assert "network.radio.tx_power_dbm" in floats and "coverage.signal_floor_dbm" in floats
    for path, info in by_field.items():
        assert _wrong_types(info.annotation), f"{path}: no wrong-type value derived"
    for path in floats:
        assert len(_non_finite(by_field[path].annotation)) == 3, path
    bounded = [p for p, i in by_field.items() if i.metadata]
    assert all(_out_of_range(by_field[p]) for p in bounded)


@pytest.mark.parametrize(("mission", "path", "value"), CASES)
def test_invalid_value_names_the_field(mission, path, value):
    with pytest.raises(ConfigError) as info:
        parse_config(_data(mission, path, value))
    assert path in str(info.value), str(info.value)


@pytest.mark.parametrize(
    ("mission", "path"), [pytest.param(m, p, id=p) for m, p, _ in FIELDS if "." in p]
)
def test_misspelt_field_gets_did_you_mean(mission, path):
    *parents, leaf = path.split(".")
    wrong = ".".join([*parents, leaf + "x"])
    with pytest.raises(ConfigError) as info:
        parse_config(_data(mission, wrong, 1))
    assert f"{wrong}: is not a known field; did you mean {leaf!r}?" in str(info.value)


@pytest.fixture(scope="module")
def runner():
    return CliRunner()


@pytest.mark.parametrize(
    ("mission", "path", "info"), [pytest.param(m, p, i, id=p) for m, p, i in FIELDS]
)
def test_cli_exits_2_with_one_line_naming_the_field(runner, mission, path, info):
    value = _wrong_types(info.annotation)[0]
    res = runner.invoke(cli, ["config", "show", mission, "--set", f"{path}={toml_literal(value)}"])
    assert res.exit_code == 2, res.output
    assert res.output.startswith("Error: ") and path in res.output
    assert len(res.output.strip().splitlines()) == 1 and "Traceback" not in res.output
