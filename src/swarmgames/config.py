"""Validated configuration of a swarmgames scenario.

Every field is typed, carries its unit in its description, has a default and declares its
constraints (pydantic v2). Unknown keys are rejected. Errors are collected into one
:class:`~swarmgames.errors.ConfigError` whose message names each field path, the rule broken and
the value given, e.g. ``game.beta: must be > 0 (got -1.0)``.

Scenario files are TOML with one table per section::

    name = "coverage"
    seed = 7

    [swarm]
    n_robots = 7

    [game]
    alpha_b = 0.001

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203).
.. [2] RFC 3626, "Optimized Link State Routing Protocol (OLSR)", sections 6-10 and 18.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any, Literal

import tomli_w
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from swarmgames.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

__all__ = [
    "CoverageConfig",
    "GameConfig",
    "NetworkConfig",
    "OlsrConfig",
    "RadioConfig",
    "ScenarioConfig",
    "SimConfig",
    "SwarmConfig",
    "builtin_scenarios",
    "format_validation_error",
    "load_config",
    "parse_config",
    "resolve_scenario",
    "to_toml",
]


class _Section(BaseModel):
    """Base of every configuration section: immutable, strict about unknown keys."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


#: 802.11a minimum receiver sensitivity (dBm) per OFDM rate (Mbit/s), IEEE 802.11-2016
#: Table 17-18; ns-3's preamble-detection gate is -82 dBm at 6 Mbit/s.
SENSITIVITY_80211A_DBM: dict[int, float] = {
    6: -82.0,
    9: -81.0,
    12: -79.0,
    18: -77.0,
    24: -74.0,
    36: -70.0,
    48: -66.0,
    54: -65.0,
}


class RadioConfig(_Section):
    """Radio propagation and reception (ns-3 3.44 defaults)."""

    tx_power_dbm: float = Field(
        16.0206, ge=-30, le=60, description="Transmit power, dBm (ns-3 WifiPhy default, 40 mW)."
    )
    loss_model: Literal["friis", "log_distance"] = Field(
        "friis", description="Path-loss model: 'friis' or 'log_distance'."
    )
    frequency_hz: float = Field(
        5.15e9, gt=0, description="Carrier frequency for Friis, Hz (ns-3 Friis default)."
    )
    system_loss: float = Field(1.0, ge=1.0, description="Friis system loss L, linear (>= 1).")
    min_loss_db: float = Field(0.0, ge=0, description="Friis minimum loss, dB.")
    exponent: float = Field(3.0, gt=0, description="Log-distance path-loss exponent n.")
    reference_distance_m: float = Field(
        1.0, gt=0, description="Log-distance reference distance d0, metres."
    )
    reference_loss_db: float = Field(
        46.6777, description="Log-distance loss at the reference distance, dB."
    )
    shadowing_sigma_db: float = Field(
        0.0, ge=0, description="Log-normal shadowing standard deviation, dB (0 = off)."
    )
    nakagami_m: float | None = Field(
        None, ge=0.5, description="Nakagami-m fading shape (1 = Rayleigh); omit for no fading."
    )
    rx_threshold_dbm: float = Field(
        -82.0, le=0, description="Reception threshold, dBm (-82 = 802.11a 6 Mbit/s broadcast)."
    )


class OlsrConfig(_Section):
    """OLSR timing (RFC 3626 section 18, ns-3 defaults)."""

    hello_interval_s: float = Field(2.0, gt=0, description="HELLO emission interval, seconds.")
    tc_interval_s: float = Field(5.0, gt=0, description="TC emission interval, seconds.")
    max_jitter_s: float = Field(
        0.5, ge=0, description="Upper bound of the uniform message jitter, seconds."
    )
    neighbour_hold_s: float = Field(
        6.0, gt=0, description="Neighbour/link hold time (3 x HELLO interval), seconds."
    )
    topology_hold_s: float = Field(
        15.0, gt=0, description="Topology hold time (3 x TC interval), seconds."
    )
    duplicate_hold_s: float = Field(30.0, gt=0, description="Duplicate-set hold time, seconds.")
    willingness: Literal[0, 1, 3, 6, 7] = Field(
        3, description="Willingness to relay: 0 never, 3 default, 7 always."
    )
    hello_only: bool | Literal["auto"] = Field(
        "auto",
        description=(
            "Skip TC messages. 'auto' skips them when the game needs only h <= 2 hops, where "
            "TCs cannot change N_i(h)."
        ),
    )

    @model_validator(mode="after")
    def _holds_cover_intervals(self) -> OlsrConfig:
        if self.neighbour_hold_s <= self.hello_interval_s:
            raise ValueError(
                "neighbour_hold_s must be > hello_interval_s "
                f"(got {self.neighbour_hold_s} <= {self.hello_interval_s})"
            )
        if self.topology_hold_s <= self.tc_interval_s:
            raise ValueError(
                "topology_hold_s must be > tc_interval_s "
                f"(got {self.topology_hold_s} <= {self.tc_interval_s})"
            )
        return self


class NetworkConfig(_Section):
    """How each robot's neighbourhood N_i(h) is obtained."""

    backend: Literal["olsr", "oracle", "disk", "knn", "ns3"] = Field(
        "olsr",
        description=(
            "Neighbourhood provider: 'olsr' (built-in RFC 3626 model), 'oracle' (instant "
            "shortest paths), 'disk' (fixed radius), 'knn' (k nearest), 'ns3' (ns-3 simulator)."
        ),
    )
    hops: int = Field(2, ge=1, le=64, description="Neighbourhood radius h, hops (paper: 2).")
    disk_radius_m: float = Field(368.84, gt=0, description="Radius of the 'disk' baseline, metres.")
    knn_k: int = Field(4, ge=1, description="Number of neighbours of the 'knn' baseline.")
    radio: RadioConfig = Field(default_factory=RadioConfig)
    olsr: OlsrConfig = Field(default_factory=OlsrConfig)


class GameConfig(_Section):
    """Stage graphical game and its solver (paper section II.B-C, Algorithm 1)."""

    alpha_a: float = Field(1.0, ge=0, description="Weight of the unary potentials (paper: 1).")
    alpha_b: float = Field(
        0.001, ge=0, description="Weight of the pairwise potentials (paper: 0.001)."
    )
    solver: Literal[
        "mean_field", "no_virtual_mean", "best_response", "exact", "centralised", "random"
    ] = Field(
        "mean_field",
        description=(
            "Local-game solver: mean_field (Algorithm 1), no_virtual_mean (the same without "
            "eq. 3), best_response, exact (enumeration), centralised (one swarm-wide "
            "mean-field game), random."
        ),
    )
    virtual_mean: bool = Field(
        True, description="Replace neighbours with outside neighbours by virtual means (eq. 3)."
    )
    beta: float = Field(
        50.0, gt=0, description="Inverse temperature of Q_j(x) ∝ exp(beta · E[M_i | x]), 1/payoff."
    )
    delta: float = Field(1e-6, gt=0, description="KL(Q_old || Q) stopping threshold, nats.")
    max_iter: int = Field(200, ge=1, description="Maximum mean-field sweeps.")
    action_choice: Literal["argmax", "sample"] = Field(
        "argmax", description="How a robot picks its action from its own marginal."
    )
    precision: Literal["float64", "float32"] = Field(
        "float64",
        description="Floating-point precision of the payoff tables and marginals (float32 "
        "halves the memory of the pairwise table, B K^2 A^2 values).",
    )
    engine: Literal["auto", "compiled", "blas", "sequential"] = Field(
        "auto",
        description="Mean-field engine: compiled (Numba kernel, all cores), blas or sequential "
        "(numpy); auto = compiled when Numba is installed. They agree to rounding.",
    )
    exact_max_profiles: int = Field(
        1_000_000,
        ge=1,
        description="Largest number of joint profiles the exact solver enumerates per game.",
    )
    buckets: int = Field(
        0,
        ge=0,
        le=1024,
        description="Local games are solved in this many batches of similar neighbourhood "
        "size (less padding); 0 = automatic (one per 128 robots, at most 8).",
    )


class SwarmConfig(_Section):
    """The UAVs: number, take-off area, motion.

    Defaults where the paper is silent: 7 UAVs (the paper's largest swarm); flight at 30 m
    (a typical low-altitude survey height, well below the 368.84 m radio range, so altitude
    barely changes the links); all UAVs take off from one common disc of 25 m radius at the
    edge of the ROI, so the swarm starts as a single-hop clique and its links break and form as
    it spreads; 10 m moves per 1 s period (10 m/s, a small multirotor's cruise speed) along
    8 headings plus "stay" (a 3 x 3 "king's move" set, as the authors' grid controllers).
    """

    n_robots: int = Field(7, ge=1, le=100_000, description="Number of UAVs.")
    altitude_m: float = Field(30.0, ge=0, description="Flight altitude above ground, metres.")
    start_center_m: tuple[float, float] = Field(
        (-300.0, 0.0), description="Centre of the common take-off area (x, y), metres."
    )
    start_radius_m: float = Field(
        25.0, ge=0, description="Radius of the take-off disc, metres (uniform start positions)."
    )
    step_m: float = Field(
        10.0, gt=0, description="Distance flown by one move action per control period, metres."
    )
    n_headings: int = Field(
        8, ge=1, le=64, description="Number of headings of the move actions (plus 'stay')."
    )
    action_set: Literal["headings", "acceleration"] = Field(
        "headings",
        description=(
            "'headings': stay + n_headings moves of step_m; 'acceleration': (2 accel_levels "
            "+ 1)^2 acceleration labels rolled forward over one period (the authors' flocking "
            "controller), speed capped at max_speed_m_s."
        ),
    )
    accel_step_m_s2: float = Field(
        0.25, gt=0, description="Grid step of the acceleration labels, m/s^2."
    )
    accel_levels: int = Field(
        2, ge=1, le=10, description="Acceleration levels on each side of zero (2: +-0.5 m/s^2)."
    )
    max_speed_m_s: float = Field(
        15.0, gt=0, description="Speed limit; step_m / control_period_s may not exceed it, m/s."
    )
    arena_margin_m: float = Field(
        50.0,
        ge=0,
        description=(
            "Margin of the arena box around the ROI and the take-off area; moves leaving the "
            "arena are invalid, metres."
        ),
    )


class CoverageConfig(_Section):
    """Communication-aware coverage mission (paper section III, eqs. 4-5).

    Defaults where the paper is silent: an isotropic Gaussian ROI with sigma = 250 m (its 95 %
    ellipse has a 612 m radius, so 7 UAVs spread over it sit farther apart than one radio range
    of 368.84 m end to end and the network is multi-hop); a 20 m integration grid (about 2 900
    cells: payoff differences between 10 m moves are resolved while a stage stays fast); the
    signal model uses ns-3's log-distance defaults (T0 = 16.0206 dBm, L0 = 46.6777 dB at 1 m,
    n = 3), the exponent the authors' scripts used.
    """

    roi_mean_m: tuple[float, float] = Field(
        (0.0, 0.0), description="Mean of the Gaussian region of interest (x, y), metres."
    )
    roi_cov_m2: tuple[tuple[float, float], tuple[float, float]] = Field(
        ((62500.0, 0.0), (0.0, 62500.0)),
        description="Covariance of the Gaussian region of interest, square metres.",
    )
    confidence: float = Field(
        0.95, gt=0, lt=1, description="Probability mass of the ROI concentration ellipse."
    )
    grid_cell_m: float = Field(20.0, gt=0, description="ROI integration grid cell size, metres.")
    t0_dbm: float = Field(16.0206, description="Signal model transmit power T0, dBm.")
    l0_db: float = Field(46.6777, description="Signal model reference loss L0, dB.")
    path_exponent: float = Field(3.0, gt=0, description="Signal model exponent n.")
    reference_distance_m: float = Field(
        1.0,
        gt=0,
        description="Signal model reference distance d0; shorter distances are clamped, metres.",
    )
    softness_db: float = Field(
        1.0,
        ge=0,
        description=(
            "Temperature of the smooth maximum tau*ln(e^(a/tau) + e^(b/tau)) used for eq. 4's "
            "max; not in the paper (0 = the hard max), dB."
        ),
    )
    separation_m: float = Field(
        50.0,
        ge=0,
        description=(
            "Distance below which a robot's next position is penalised for crowding another "
            "robot (not in the paper; 0 = off), metres."
        ),
    )
    separation_cost_db: float = Field(
        0.1,
        ge=0,
        description=(
            "Weight of the crowding penalty, dB of expected ROI signal at zero distance "
            "(not in the paper; 0 = off), dB."
        ),
    )
    separation_mode: Literal["pairwise", "unary"] = Field(
        "pairwise",
        description=(
            "How the crowding penalty sees the other robots: 'pairwise' = a pairwise potential "
            "on both robots' next positions (the local game predicts both moves), 'unary' = "
            "the robot's next position against the others' current positions (each assumes "
            "the others stay; co-located robots can then oscillate in lockstep); no unit."
        ),
    )
    move_cost_db: float = Field(
        0.01,
        ge=0,
        description=(
            "Cost of one move in the unary potential, dB of expected ROI signal; not in the "
            "paper (0 = eq. 4 exactly); a small cost lets the swarm settle, dB."
        ),
    )

    signal_floor_dbm: float | None = Field(
        None,
        description=(
            "Level below which a signal no longer counts in eq. 4 (signals are clamped to it), "
            "so a UAV's unary is integrated only over the grid cells within the radius where "
            "its signal reaches the floor; for large swarms (None = the whole ROI, the paper), "
            "dBm."
        ),
    )

    workers: int = Field(
        1,
        ge=1,
        le=64,
        description=(
            "Threads integrating the unary under a signal floor (numpy releases the GIL; the "
            "result does not depend on it)."
        ),
    )

    @model_validator(mode="after")
    def _covariance_positive_definite(self) -> CoverageConfig:
        (a, b), (c, d) = self.roi_cov_m2
        if b != c or a <= 0 or a * d - b * c <= 0:
            raise ValueError(
                f"roi_cov_m2 must be symmetric positive definite (got {self.roi_cov_m2})"
            )
        return self


class SimConfig(_Section):
    """The stage loop.

    Defaults where the paper is silent: 90 s of mission (the default swarm crosses the ROI
    and settles well within it) after a 10 s network warm-up (OLSR needs two HELLO rounds,
    about 2.5 s in ns-3, before the first 1-hop routes exist).
    """

    control_period_s: float = Field(
        1.0, gt=0, description="Time between two stage games, seconds (paper: 1 Hz)."
    )
    duration_s: float = Field(90.0, gt=0, description="Simulated mission time, seconds.")
    warmup_s: float = Field(
        10.0, ge=0, description="Network time before the first stage (OLSR start-up), seconds."
    )
    controller: Literal["game", "lloyd"] = Field(
        "game",
        description=(
            "'game': every robot solves its local graphical game; 'lloyd': Lloyd/Voronoi "
            "coverage baseline (centralised positions, no game)."
        ),
    )
    global_regret: bool = Field(
        True,
        description=(
            "Measure every robot's stage-game regret (metrics.csv global_regret); with virtual "
            "means on it costs a second payoff evaluation per stage."
        ),
    )
    animation: bool = Field(True, description="Write animation.gif of the swarm over the ROI.")
    animation_frames: int = Field(
        60, ge=2, le=1000, description="Maximum number of frames of the animation."
    )


class ScenarioConfig(_Section):
    """A complete scenario: everything a run needs, and nothing it does not."""

    name: str = Field(
        "coverage",
        min_length=1,
        max_length=64,
        pattern=r"^[A-Za-z0-9_.-]+$",
        description="Scenario name; also the default run folder name.",
    )
    scenario: Literal["coverage"] = Field("coverage", description="Mission type.")
    seed: int = Field(0, ge=0, description="Seed of the run's numpy random Generator.")
    swarm: SwarmConfig = Field(default_factory=SwarmConfig)
    network: NetworkConfig = Field(default_factory=NetworkConfig)
    game: GameConfig = Field(default_factory=GameConfig)
    coverage: CoverageConfig = Field(default_factory=CoverageConfig)
    sim: SimConfig = Field(default_factory=SimConfig)


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
    if kind == "extra_forbidden":
        return "is not a known field"
    if kind == "missing":
        return "is required"
    if kind == "value_error":
        return str(ctx.get("error", err["msg"]))
    return err["msg"][0].lower() + err["msg"][1:]


def format_validation_error(exc: ValidationError, source: str | None = None) -> ConfigError:
    """Turn a pydantic ``ValidationError`` into a :class:`ConfigError` with one line per problem:
    ``<field.path>: <rule> (got <value>)``."""
    lines = []
    for err in exc.errors():
        path = ".".join(str(p) for p in err["loc"])
        rule = _rule(err)
        if err["type"] == "value_error" and "(got" in rule:
            lines.append(f"{path}: {rule}" if path else rule)
        else:
            lines.append(f"{path}: {rule} (got {err['input']!r})")
    where = f" in {source}" if source else ""
    head = f"invalid configuration{where}: " + (
        lines[0] if len(lines) == 1 else f"{len(lines)} problems"
    )
    msg = head if len(lines) == 1 else head + "\n  " + "\n  ".join(lines)
    return ConfigError(msg, lines)


def parse_config(data: dict[str, Any] | None = None, source: str | None = None) -> ScenarioConfig:
    """Validate a mapping (as read from TOML) into a :class:`ScenarioConfig`.

    Raises
    ------
    ConfigError
        On an unknown key, a wrong type or an out-of-range value; the message names the field
        path, the rule and the value.
    """
    try:
        # JSON mode in strict mode: no silent coercion ("7" is not an int), yet TOML arrays
        # are accepted where a tuple is declared.
        return ScenarioConfig.model_validate_json(json.dumps(data or {}, default=str), strict=True)
    except ValidationError as exc:
        raise format_validation_error(exc, source) from None


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
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"configuration file not found: {path}") from None
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read configuration file {path}: {exc}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path} is not valid TOML: {exc}") from None
    return parse_config(data, source=str(path))


def builtin_scenarios() -> list[str]:
    """Names of the scenario files shipped with swarmgames (``presets/*.toml``)."""
    from importlib import resources

    files = resources.files("swarmgames.presets").iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))


def _builtin_text(name: str) -> str:
    from importlib import resources

    return (resources.files("swarmgames.presets") / f"{name}.toml").read_text(encoding="utf-8")


def _set_path(data: dict[str, Any], assignment: str) -> None:
    key, sep, raw = assignment.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(f"override must look like section.field=value (got {assignment!r})")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()  # a bare word is read as a string: backend=oracle
    *parents, leaf = key.split(".")
    node = data
    for part in parents:
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            raise ConfigError(f"override {key}: {part} is not a section (got {assignment!r})")
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
        if not path.is_file():
            raise ConfigError(f"configuration file not found: {path}")
        source, text = str(path), path.read_text(encoding="utf-8")
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
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source} is not valid TOML: {exc}") from None
    for assignment in overrides:
        _set_path(data, assignment)
    return parse_config(data, source=source)


def _constraints(info: Any) -> str:
    rules = []
    for m in info.metadata:
        for attr, sym in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            v = getattr(m, attr, None)
            if v is not None:
                rules.append(f"{sym} {v}")
    return f" [{', '.join(rules)}]" if rules else ""


def _toml_value(value: Any) -> str:
    """One-line TOML literal of a configuration value (arrays stay on one line)."""
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return tomli_w.dumps({"v": value})[4:].strip()


def _toml_lines(model: BaseModel, prefix: str, annotated: bool) -> list[str]:
    lines: list[str] = []
    subsections = []
    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        if isinstance(value, BaseModel):
            subsections.append((name, value))
            continue
        if annotated:
            lines.append(f"# {info.description}{_constraints(info)}")
        if value is None:
            if annotated:
                lines.append(f"# {name} =   (unset)")
        else:
            lines.append(f"{name} = {_toml_value(value)}")
    for name, value in subsections:
        lines += ["", f"[{prefix}{name}]"]
        if annotated:
            lines.append("# " + (type(value).__doc__ or "").strip().splitlines()[0])
        lines += _toml_lines(value, f"{prefix}{name}.", annotated)
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
    same ``None`` default, so ``parse_config(tomllib.loads(to_toml(c))) == c``.
    """
    return "\n".join(_toml_lines(config, "", annotated)) + "\n"
