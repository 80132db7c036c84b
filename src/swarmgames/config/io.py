"""Reading and writing scenarios: TOML files, built-in presets, ``--set`` overrides.

Scenario files are TOML with one table per section; the mission's parameters are the table
named by ``scenario``::

    name = "coverage"
    scenario = "coverage"
    seed = 7

    [swarm]
    n_robots = 7

    [coverage]
    move_cost_db = 0.0

Values are never coerced: validation runs in pydantic's strict JSON mode (``"7"`` is not an
int, ``1`` is not a bool), yet TOML arrays are accepted where a tuple is declared. Every
problem becomes one line ``<field.path>: <rule> (got <value>)`` of one
:class:`~swarmgames.errors.ConfigError`.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import tomli_w
from pydantic import BaseModel, ValidationError

from swarmgames.config.schema import ScenarioConfig
from swarmgames.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

__all__ = [
    "apply_overrides",
    "builtin_scenarios",
    "format_validation_error",
    "load_config",
    "parse_config",
    "parse_value",
    "resolve_scenario",
    "set_path",
    "to_data",
    "to_toml",
    "toml_literal",
]


#: Largest scenario file read, bytes (scenarios are a few kilobytes).
MAX_TOML_BYTES = 1 << 20
#: Deepest nesting of tables and arrays in a scenario.
MAX_TOML_DEPTH = 32
#: Problems listed in one error (the rest are counted).
MAX_PROBLEMS = 20
#: Characters of a value echoed in an error.
MAX_ECHO = 200


def shown(value: Any) -> str:
    """``repr(value)``, cut to about :data:`MAX_ECHO` characters.

    Examples
    --------
    >>> shown("x" * 1000)[-25:]
    "...' (1002 characters)"
    """
    text = repr(value)
    if len(text) <= MAX_ECHO:
        return text
    return f"{text[:MAX_ECHO]}...{text[-1]} ({len(text)} characters)"


def _depth(data: Any) -> int:
    """Nesting depth of tables and arrays (0 for a scalar), without recursion."""
    deepest, stack = 0, [(data, 0)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict):
            node = list(node.values())
        if isinstance(node, list):
            deepest = max(deepest, depth + 1)
            if depth + 1 <= MAX_TOML_DEPTH:
                stack.extend((child, depth + 1) for child in node)
    return deepest


def _parse_toml(text: str, source: str) -> dict[str, Any]:
    """The data of a scenario's TOML text, within the size and depth limits.

    Raises
    ------
    ConfigError
        Not TOML, larger than :data:`MAX_TOML_BYTES` or nested deeper than
        :data:`MAX_TOML_DEPTH` (one line).
    """
    size = len(text.encode("utf-8"))
    if size > MAX_TOML_BYTES:
        raise ConfigError(
            f"{source}: a scenario file must be at most {MAX_TOML_BYTES} bytes (got {size})"
        )
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source} is not valid TOML: {str(exc)[:MAX_ECHO]}") from None
    except RecursionError:
        data = None
    if data is None or _depth(data) > MAX_TOML_DEPTH:
        raise ConfigError(
            f"{source}: tables and arrays may nest at most {MAX_TOML_DEPTH} deep (got deeper)"
        )
    return data


def _rule(err: dict[str, Any]) -> str:
    kind, ctx = err["type"], err.get("ctx") or {}
    bounds = {
        "greater_than": ">",
        "greater_than_equal": ">=",
        "less_than": "<",
        "less_than_equal": "<=",
    }
    if kind in bounds:
        return f"must be {bounds[kind]} {next(iter(ctx.values()))}"
    if kind == "finite_number":
        return "must be a finite number"
    if kind == "extra_forbidden":
        return "is not a known field"
    if kind == "missing":
        return "is required"
    if kind == "value_error":
        return str(ctx.get("error", err["msg"]))
    return err["msg"][0].lower() + err["msg"][1:]


def _known_fields(model: type[BaseModel] | None, loc: list[Any]) -> list[str]:
    """The field names of the section at ``loc`` inside ``model`` ([] where unknown)."""
    for part in loc:
        info = model.model_fields.get(str(part)) if model is not None else None
        model = info.annotation if info is not None else None
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            return []
    return list(model.model_fields) if model is not None else []


def _did_you_mean(name: str, known: list[str]) -> str:
    import difflib

    close = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def _error_lines(
    exc: ValidationError,
    mission: str | None = None,
    model: type[BaseModel] | None = None,
) -> list[str]:
    """One line per problem, for the first :data:`MAX_PROBLEMS` (then a line counting the
    rest); a path into ``mission`` is shown under the mission's name. An unknown key of
    ``model`` (or of its sections) gets the closest known field suggested."""
    lines = []
    errors = exc.errors()
    for err in errors[:MAX_PROBLEMS]:
        loc = list(err["loc"])
        rule = _rule(err)
        if err["type"] == "extra_forbidden" and loc:
            known = _known_fields(model, loc[:-1])
            if model is ScenarioConfig and len(loc) == 1:
                known = [k for k in known if k != "mission"] + ([mission] if mission else [])
            rule += _did_you_mean(str(loc[-1]), known)
        if mission and loc and loc[0] == "mission":
            loc[0] = mission
        path = ".".join(str(p) for p in loc)[:MAX_ECHO]
        if err["type"] == "value_error" and "(got" in rule:
            lines.append(f"{path}: {rule[: 2 * MAX_ECHO]}" if path else rule[: 2 * MAX_ECHO])
        else:
            lines.append(f"{path}: {rule[:MAX_ECHO]} (got {shown(err['input'])})")
    if len(errors) > MAX_PROBLEMS:
        lines.append(f"... and {len(errors) - MAX_PROBLEMS} more problems")
    return lines


def _config_error(lines: list[str], source: str | None) -> ConfigError:
    where = f" in {source}" if source else ""
    problems = [line for line in lines if not line.startswith("... and ")]
    hidden = sum(int(line.split()[2]) for line in lines if line.startswith("... and "))
    hidden += max(0, len(problems) - MAX_PROBLEMS)
    problems = problems[:MAX_PROBLEMS]
    total = len(problems) + hidden
    lines = problems + ([f"... and {hidden} more problems"] if hidden else [])
    head = f"invalid configuration{where}: " + (lines[0] if total == 1 else f"{total} problems")
    msg = head if total == 1 else head + "\n  " + "\n  ".join(lines)
    return ConfigError(msg, lines)


def format_validation_error(exc: ValidationError, source: str | None = None) -> ConfigError:
    """Turn a pydantic ``ValidationError`` into a :class:`ConfigError` with one line per problem:
    ``<field.path>: <rule> (got <value>)``."""
    return _config_error(_error_lines(exc), source)


def _json(data: Any) -> str:
    return json.dumps(data, default=lambda o: o.item() if hasattr(o, "item") else str(o))


def parse_config(data: dict[str, Any] | None = None, source: str | None = None) -> ScenarioConfig:
    """Validate a mapping (as read from TOML) into a :class:`ScenarioConfig`.

    The mission's table is validated by the mission's own section class first, so that its
    problems are reported with their paths (``coverage.grid_cell_m: ...``) together with those
    of the other sections.

    Raises
    ------
    ConfigError
        On an unknown key, a wrong type or an out-of-range value; the message names the field
        path, the rule and the value.
    """
    from swarmgames.missions.registry import get_mission, mission_names

    if _depth(data) > MAX_TOML_DEPTH:
        where = f"{source}: " if source else ""
        raise ConfigError(f"{where}tables and arrays may nest at most {MAX_TOML_DEPTH} deep")
    data = dict(data or {})
    name = data.get("scenario", "coverage")
    lines: list[str] = []
    if isinstance(name, str):
        for other in mission_names():
            if other != name and other in data:
                lines.append(
                    f"{other}: is the section of mission {other!r}, but scenario = {name!r}"
                )
                data.pop(other)
        if "mission" in data:
            lines.append(f"mission: is not a known field; give the mission's table as [{name}]")
            data.pop("mission")
    if isinstance(name, str) and name in data and not isinstance(data[name], dict):
        lines.append(f"{name}: must be a table of the mission's fields (got {data.pop(name)!r})")
    if isinstance(name, str) and isinstance(data.get(name), dict):
        try:
            section = get_mission(name).config
        except ConfigError:
            section = None  # reported by the scenario field below
        if section is not None:
            table = data.pop(name)
            try:
                section.model_validate_json(_json(table), strict=True)
                data["mission"] = table
            except ValidationError as exc:
                lines += [f"{name}.{line}" for line in _error_lines(exc, model=section)]
    try:
        # JSON mode in strict mode: no silent coercion ("7" is not an int), yet TOML arrays
        # are accepted where a tuple is declared.
        config = ScenarioConfig.model_validate_json(_json(data), strict=True)
    except ValidationError as exc:
        lines += _error_lines(exc, name if isinstance(name, str) else None, ScenarioConfig)
    if lines:
        raise _config_error(lines, source)
    return config


def load_config(path: str | Path) -> ScenarioConfig:
    """Read and validate a TOML scenario file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "s.toml"
    >>> _ = p.write_text("[swarm]\\nn_robots = 5\\n")
    >>> load_config(p).swarm.n_robots
    5
    """
    path = Path(path)
    return parse_config(_parse_toml(_read_file(path), str(path)), source=str(path))


def _read_file(path: Path) -> str:
    """The text of a scenario file; one ConfigError line for whatever stops reading it."""
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"configuration file not found: {path}") from None
    except IsADirectoryError:
        raise ConfigError(f"cannot read configuration file {path}: it is a folder") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"cannot read configuration file {path}: not UTF-8 text (byte "
            f"{exc.object[exc.start]:#04x} at offset {exc.start}); TOML files are UTF-8"
        ) from None
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        raise ConfigError(f"cannot read configuration file {path}: {why}") from None


def builtin_scenarios() -> list[str]:
    """Names of the scenario files shipped with swarmgames (``presets/*.toml``)."""
    from importlib import resources

    files = resources.files("swarmgames.presets").iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))


def scenario_description(name: str) -> str:
    """The one-line description of the built-in scenario ``name``: the first comment line of
    its preset file."""
    first = _builtin_text(name).splitlines()[0]
    return first.removeprefix("#").strip() if first.startswith("#") else ""


def _builtin_text(name: str) -> str:
    from importlib import resources

    return (resources.files("swarmgames.presets") / f"{name}.toml").read_text(encoding="utf-8")


def parse_value(raw: str) -> Any:
    """The value of a ``--set`` assignment: a TOML literal, or else the text itself as a
    string (a bare word: ``backend=oracle``).

    Examples
    --------
    >>> parse_value("20"), parse_value("[[5.0, 1]]"), parse_value("oracle"), parse_value("'7'")
    (20, [[5.0, 1]], 'oracle', '7')
    """
    raw = raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        return raw
    except RecursionError:
        raise ConfigError(
            f"override value: arrays may nest at most {MAX_TOML_DEPTH} deep (got deeper)"
        ) from None
    if _depth(value) > MAX_TOML_DEPTH:
        raise ConfigError(
            f"override value: arrays may nest at most {MAX_TOML_DEPTH} deep (got deeper)"
        )
    return value


def set_path(data: dict[str, Any], assignment: str) -> None:
    """Apply one ``--set`` assignment ``"section.field=value"`` (a TOML value; a bare word is
    a string, see :func:`parse_value`) to the raw scenario data ``data`` in place."""
    key, sep, raw = assignment.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(f"override must look like section.field=value (got {assignment!r})")
    _set_value(data, key, parse_value(raw), assignment)


def _set_value(data: dict[str, Any], key: str, value: Any, what: str) -> None:
    *parents, leaf = key.split(".")
    node = data
    for part in parents:
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            raise ConfigError(f"override {key}: {part} is not a section (got {what!r})")
        node = child
    node[leaf] = value


def resolve_scenario(
    scenario: str | Path | None = None, overrides: list[str] | tuple[str, ...] = ()
) -> ScenarioConfig:
    """Resolve a scenario given as a built-in name or a TOML file path, then apply overrides.

    Parameters
    ----------
    scenario : str or Path, optional
        A built-in name (see :func:`builtin_scenarios`), a path to a TOML file, or ``None`` for
        the default scenario ``"coverage"``.
    overrides : sequence of str
        Assignments ``"section.field=value"`` with TOML values, e.g. ``"swarm.n_robots=20"``.

    Raises
    ------
    ConfigError
        Unknown scenario name (with close matches), unreadable file, or invalid values.
    """
    import difflib

    scenario = "coverage" if scenario is None else scenario
    path = Path(scenario)
    if path.suffix == ".toml" or path.exists():
        source, text = str(path), _read_file(path)
    else:
        names = builtin_scenarios()
        if str(scenario) not in names:
            close = difflib.get_close_matches(str(scenario), names, n=3)
            hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
            raise ConfigError(
                f"unknown scenario {str(scenario)!r}{hint} (built-in: {', '.join(names)}; "
                "or give a path to a .toml file)"
            )
        source, text = f"built-in scenario {scenario!r}", _builtin_text(str(scenario))
    data = _parse_toml(text, source)
    for assignment in overrides:
        set_path(data, assignment)
    return parse_config(data, source=source)


def _constraints(info: Any) -> str:
    rules = []
    for m in info.metadata:
        for attr, sym in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            v = getattr(m, attr, None)
            if v is not None:
                rules.append(f"{sym} {v}")
    return f" [{', '.join(rules)}]" if rules else ""


def toml_literal(value: Any) -> str:
    """One-line TOML literal of a configuration value (arrays stay on one line): what
    :func:`parse_value` reads back.

    Examples
    --------
    >>> toml_literal([[5.0, 1]]), toml_literal("oracle"), toml_literal(True)
    ('[[5.0, 1]]', '"oracle"', 'true')
    """
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    return tomli_w.dumps({"v": value})[4:].strip()


def _toml_lines(
    model: BaseModel, prefix: str, annotated: bool, derived: tuple[str, ...] = ()
) -> list[str]:
    lines: list[str] = []
    subsections = []
    below = model.derived_fields() if isinstance(model, ScenarioConfig) else {}
    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        if isinstance(value, BaseModel):
            # The mission's section is written as the table named by the scenario.
            table = (
                model.scenario if isinstance(model, ScenarioConfig) and name == "mission" else name
            )
            subsections.append((table, value, below.get(name, ())))
            continue
        if annotated:
            lines.append(f"# {info.description}{_constraints(info)}")
        if name in derived:  # derived at validation: written, it would be given twice
            if annotated:
                lines.append(f"# {name} = {toml_literal(value)}   (derived)")
        elif value is None:
            if annotated:
                lines.append(f"# {name} =   (unset)")
        else:
            lines.append(f"{name} = {toml_literal(value)}")
    for name, value, fields in subsections:
        lines += ["", f"[{prefix}{name}]"]
        if annotated:
            lines.append("# " + (type(value).__doc__ or "").strip().splitlines()[0])
        lines += _toml_lines(value, f"{prefix}{name}.", annotated, fields)
    return lines


def to_toml(config: ScenarioConfig, annotated: bool = False) -> str:
    """Serialise a configuration to TOML.

    Parameters
    ----------
    config : ScenarioConfig
        The configuration.
    annotated : bool, default False
        Precede every field with a comment giving its description, unit and allowed range.

    Notes
    -----
    Fields left at ``None`` are omitted (commented out when annotated), which reads back as the
    same ``None`` default, so ``parse_config(tomllib.loads(to_toml(c))) == c``. So are the
    fields derived at validation (:meth:`ScenarioConfig.derived_fields`, such as the ROI of
    ``coverage.area_per_robot_m2``), which reading back derives again.
    """
    return "\n".join(_toml_lines(config, "", annotated)) + "\n"


def to_data(config: ScenarioConfig) -> dict[str, Any]:
    """The configuration as plain data, the mission's section under its table name: what
    :func:`parse_config` reads back into an equal configuration (the fields derived at
    validation left out, see :func:`to_toml`)."""
    data = config.model_dump(mode="json")
    for section, fields in config.derived_fields().items():
        for name in fields:
            data[section].pop(name)
    data[config.scenario] = data.pop("mission")
    return data


def apply_overrides(
    config: ScenarioConfig, overrides: dict[str, Any], source: str = "overrides"
) -> ScenarioConfig:
    """``config`` with the fields at the dotted paths of ``overrides`` replaced, re-validated
    (see :meth:`ScenarioConfig.with_overrides`); an error names ``source``."""
    if not isinstance(overrides, dict):
        raise TypeError(
            f"overrides must be a dict of dotted paths (got {type(overrides).__name__})"
        )
    data = to_data(config)
    for key, value in overrides.items():
        if not (isinstance(key, str) and key.strip()):
            raise ConfigError(f"override paths must be non-empty strings (got {key!r})")
        if isinstance(value, tuple):
            value = list(value)
        _set_value(data, key.strip(), value, f"{key}={value!r}")
    return parse_config(data, source=source)
