"""The mission protocol: conformance checks, the registry and its entry points, run(mission=)."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from pydantic import Field

import swarmgames
from swarmgames.config import ScenarioConfig, parse_config, resolve_scenario, to_toml
from swarmgames.errors import ConfigError
from swarmgames.game import FunctionPotentials, PotentialCapabilities
from swarmgames.missions import (
    ENTRY_POINT_GROUP,
    HeadingActions,
    Mission,
    MissionEntry,
    check_mission,
    get_mission,
    mission_names,
    register_mission,
    unregister_mission,
)
from swarmgames.missions import registry as registry_module
from swarmgames.missions.conformance import MissionCheckError
from swarmgames.section import Section
from swarmgames.sim import build_mission, run

from ..sim.conftest import DiskOracle

GOAL = np.array([100.0, 0.0])


@dataclass(frozen=True, eq=False)
class GoalMission:
    """Fly to a goal: written here as a user would, outside swarmgames."""

    potentials: object = FunctionPotentials(lambda s: -np.linalg.norm(s[..., :2] - GOAL, axis=-1))
    action_model: object = HeadingActions(10.0, 4)
    name: str = "goal"
    state_dim: int = 3

    def initial_states(self, n_robots, rng):
        return np.c_[rng.uniform(-50, 50, (n_robots, 2)), np.full(n_robots, 30.0)]

    def swarm_metrics(self, states, previous, t):
        return {"goal_distance_m": float(np.linalg.norm(states[:, :2] - GOAL, axis=1).mean())}

    def robot_metrics(self, states, t):
        return {"goal_distance_m": np.linalg.norm(states[:, :2] - GOAL, axis=1)}

    def summary(self, times, swarm):
        return {"goal_distance_end_m": float(swarm["goal_distance_m"][-1])}


def test_every_registered_mission_conforms():
    # Each built-in mission has a preset of its name (flocking needs its acceleration set).
    for name in mission_names():
        config = resolve_scenario(name)
        mission = build_mission(config)
        assert isinstance(mission, Mission)
        check_mission(mission)


def test_a_user_mission_runs_with_every_output(tmp_path):
    cfg = parse_config({"swarm": {"n_robots": 4}, "sim": {"duration_s": 12.0, "warmup_s": 2.0}})
    mission = GoalMission()
    check_mission(mission)
    res = run(cfg, out=tmp_path / "r", progress=False, provider=DiskOracle(), mission=mission)
    sw = res.to_frame()
    assert sw["goal_distance_m"].iloc[-1] < sw["goal_distance_m"].iloc[0] - 50.0
    assert "coverage" not in sw  # nothing of the configured coverage mission ran
    assert "goal_distance_m" in res.to_frame("metrics")
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["mission"] == "goal" and summary["goal_distance_end_m"] < 60.0
    for f in ("trajectory.csv", "metrics.csv", "swarm.csv", "timeseries.png", "paths.png"):
        assert (tmp_path / "r" / f).stat().st_size > 0
    assert (tmp_path / "r" / "animation.gif").read_bytes()[:3] == b"GIF"


def test_run_refuses_an_object_that_is_no_mission():
    with pytest.raises(TypeError, match="check_mission"):
        run(ScenarioConfig(), progress=False, mission=object())


def _broken(**changes):
    return dataclasses.replace(GoalMission(), **changes)


class _Global(GoalMission):
    def initial_states(self, n_robots, rng):
        return np.c_[np.random.uniform(-50, 50, (n_robots, 2)), np.full(n_robots, 30.0)]  # noqa: NPY002


class _WrongShape(GoalMission):
    def initial_states(self, n_robots, rng):
        return np.zeros((n_robots, 2))


class _BadMetrics(GoalMission):
    def swarm_metrics(self, states, previous, t):
        return {"mean_payoff": 1.0, "bad": float("nan"), "flag": True}


class _BadHooks(GoalMission):
    def robot_metrics(self, states, t):
        return {"d": np.zeros(2)}

    def summary(self, times, swarm):
        return {"when": object()}

    def extent(self):
        return (1.0, 0.0, 0.0, 1.0)


def _raises(states):
    raise RuntimeError("no plan")


class _BadBaselines(GoalMission):
    @property
    def baselines(self):
        return {
            "game": lambda s: np.zeros(len(s), dtype=int),
            "short": lambda s: np.zeros(2, dtype=int),
            "real": lambda s: np.zeros(len(s)),
            "far": lambda s: np.full(len(s), 99),
            "stuck": _raises,
            "moving": lambda s: np.zeros(s.__iadd__(1.0).shape[0], dtype=int),
            "noop": 3,
        }


class _Undeclared:
    """Potentials without a ``capabilities`` declaration."""

    def unary(self, batch):
        return np.zeros(np.shape(batch.action_mask))

    def pairwise(self, batch):
        return None


class _BadNeighbourhood(_Undeclared):
    """A declared neighbourhood term of the wrong shape."""

    capabilities = PotentialCapabilities(neighbourhood=True)

    def neighbourhood(self, batch):
        return np.zeros(np.shape(batch.action_mask))  # (B, K, A), not (B, A)


@pytest.mark.parametrize(
    ("mission", "problems"),
    [
        (_broken(name=""), ["name must be a non-empty string"]),
        (
            _broken(potentials=_Undeclared()),
            ["potentials must declare capabilities: a PotentialCapabilities attribute"],
        ),
        (
            _broken(potentials=_BadNeighbourhood()),
            ["potentials.neighbourhood must return shape (4, 5)"],
        ),
        (_broken(state_dim=2), ["state_dim must be an integer >= 3"]),
        (_WrongShape(), ["initial_states must return shape (4, 3)"]),
        (_Global(), ["global random state", "not reproducible"]),
        (
            _BadMetrics(),
            [
                "'mean_payoff' is a column the simulation writes itself",
                "swarm_metrics (first stage)['bad'] must be a finite real number",
                "['flag'] must be a finite real number",
            ],
        ),
        (
            _BadHooks(),
            [
                "robot_metrics['d'] must be a numeric array of shape (4,)",
                "summary must return JSON-serialisable values",
                "extent() must be (xmin, xmax, ymin, ymax)",
            ],
        ),
        (
            _broken(potentials=FunctionPotentials(lambda s: np.full(s.shape[:-1], np.nan))),
            ["unary potential is not finite"],
        ),
        (
            _BadBaselines(),
            [
                "baseline names must be Python identifiers, none of them 'game' or 'mpc' "
                "(got 'game')",
                "baselines['short'](states) must return an integer array of shape (4,) "
                "(got int64 (2,))",
                "baselines['real'](states) must return an integer array of shape (4,)",
                "baselines['far'](states) must return action indices in [0, 5)",
                "baselines['stuck'](states) raised RuntimeError: no plan",
                "baselines['moving'](states) changed the states it was given",
                "baselines['noop'] must be callable (got int)",
            ],
        ),
    ],
)
def test_check_mission_names_every_problem(mission, problems):
    with pytest.raises(MissionCheckError) as info:
        check_mission(mission)
    text = str(info.value)
    for problem in problems:
        assert problem in text, text


def test_a_small_global_draw_is_caught_wherever_the_global_generator_stands():
    """A draw inside the Mersenne Twister's current block leaves its key unchanged; the
    check compares the position too, whatever earlier code drew."""
    saved = np.random.get_state()  # noqa: NPY002
    try:
        np.random.seed(0)  # noqa: NPY002
        np.random.random(10)  # noqa: NPY002 - mid-block: the next small draw keeps the key
        with pytest.raises(MissionCheckError, match="global random state"):
            check_mission(_Global())
    finally:
        np.random.set_state(saved)  # noqa: NPY002


def test_check_mission_reports_missing_attributes_at_once():
    class Half:
        name = "half"

    with pytest.raises(MissionCheckError) as info:
        check_mission(Half())
    assert len(info.value.problems) == 5  # every required attribute but the name
    assert "missing required attribute 'initial_states'" in str(info.value)


# --------------------------------------------------------------------------- baselines


def _toward_goal(states):
    """Every robot's heading nearest the bearing to the goal (HeadingActions(10, 4): stay,
    then east, north, west, south)."""
    bearing = np.arctan2(*(GOAL - states[:, :2]).T[::-1])
    return (np.round(bearing / (np.pi / 2)).astype(np.int64) % 4) + 1


class BaselineGoalMission(GoalMission):
    @property
    def baselines(self):
        return {"straight": _toward_goal}


def test_a_mission_baseline_runs_by_name_and_is_measured_like_the_game(tmp_path):
    entry = MissionEntry(
        "goalb", GoalConfig, lambda config: BaselineGoalMission(), baselines=("straight",)
    )
    register_mission(entry, replace=True)
    try:
        check_mission(BaselineGoalMission())
        cfg = parse_config(
            {
                "scenario": "goalb",
                "swarm": {"n_robots": 3},
                "sim": {"controller": "straight", "duration_s": 5.0, "animation": False},
            }
        )
        res = run(cfg, progress=False, provider=DiskOracle())
        with pytest.raises(ConfigError, match=r"it offers: 'straight'\) \(got 'lloyd'\)"):
            cfg.with_overrides({"sim.controller": "lloyd"})
    finally:
        unregister_mission("goalb")
    sw, m = res.to_frame(), res.to_frame("metrics")
    assert res.summary["controller"] == "straight"
    assert sw["goal_distance_m"].iloc[-1] < sw["goal_distance_m"].iloc[0] - 30.0
    assert (m["iterations"] == 1).all() and m["converged"].all()
    assert np.isfinite(m[["payoff", "local_regret", "global_regret"]]).all().all()


@pytest.mark.parametrize("baselines", [("game",), ("two words",), ["straight"], ("mpc", "x")])
def test_an_entry_refuses_bad_baseline_names(baselines):
    with pytest.raises(ValueError, match=r"baselines must be a tuple of Python identifiers"):
        MissionEntry("x", GoalConfig, _build, baselines=baselines)


# --------------------------------------------------------------------------- the registry


class GoalConfig(Section):
    """Fly to a goal."""

    goal_x_m: float = Field(100.0, gt=-1e6, lt=1e6, description="Goal x, metres.")


def _build(config):
    return GoalMission()


GOAL_ENTRY = MissionEntry("goal", GoalConfig, _build, "fly to a goal")


@pytest.fixture
def goal_registered():
    register_mission(GOAL_ENTRY, replace=True)
    yield GOAL_ENTRY
    unregister_mission("goal")


def test_a_registered_mission_has_its_own_validated_section(goal_registered):
    cfg = parse_config({"scenario": "goal", "goal": {"goal_x_m": 5.0}})
    assert isinstance(cfg.mission, GoalConfig) and cfg.mission.goal_x_m == 5.0
    assert "[goal]\ngoal_x_m = 5.0" in to_toml(cfg)
    assert parse_config(__import__("tomllib").loads(to_toml(cfg))) == cfg
    with pytest.raises(ConfigError, match=r"goal\.goal_x_m: must be > -1000000"):
        parse_config({"scenario": "goal", "goal": {"goal_x_m": -1e9}})
    with pytest.raises(ConfigError, match=r"goal\.speed: is not a known field"):
        parse_config({"scenario": "goal", "goal": {"speed": 1.0}})
    with pytest.raises(ConfigError, match=r"coverage: is the section of mission 'coverage'"):
        parse_config({"scenario": "goal", "coverage": {"grid_cell_m": 5.0}})
    assert cfg.with_overrides({"goal.goal_x_m": 7.0}).mission.goal_x_m == 7.0


def test_unknown_mission_names_close_matches():
    with pytest.raises(ConfigError, match=r"unknown mission 'coverag'; did you mean 'coverage'"):
        get_mission("coverag")
    with pytest.raises(ConfigError, match=r"scenario: unknown mission 'nope'"):
        resolve_scenario(None, ["scenario='nope'"])


def test_register_refuses_a_taken_name_and_bad_entries(goal_registered):
    with pytest.raises(ValueError, match="already registered"):
        register_mission(MissionEntry("goal", GoalConfig, _build))
    with pytest.raises(ValueError, match="built in"):
        unregister_mission("coverage")
    with pytest.raises(TypeError, match=r"subclass of swarmgames\.section\.Section"):
        MissionEntry("x", dict, _build)
    with pytest.raises(ValueError, match="Python identifier"):
        MissionEntry("two words", GoalConfig, _build)


class _EntryPoint:
    """What importlib.metadata.entry_points returns, for a fake installed plug-in."""

    def __init__(self, name, value, obj):
        self.name, self.value, self.obj = name, value, obj

    def load(self):
        if isinstance(self.obj, Exception):
            raise self.obj
        return self.obj


@pytest.fixture
def fresh_registry(monkeypatch):
    monkeypatch.setattr(registry_module, "_registry", {})
    monkeypatch.setattr(registry_module, "_broken", {})
    monkeypatch.setattr(registry_module, "_loaded", False)

    def install(*points):
        import importlib.metadata

        real = importlib.metadata.entry_points

        def entry_points(group=None, **kwargs):
            if group != ENTRY_POINT_GROUP:  # other libraries' plug-ins (numba's)
                return real(**kwargs) if group is None else real(group=group, **kwargs)
            return list(points)

        monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)

    return install


def test_a_plugin_registers_through_its_entry_point(fresh_registry, tmp_path):
    fresh_registry(_EntryPoint("goal", "swarm_goal:ENTRY", GOAL_ENTRY))
    assert "goal" in mission_names() and "coverage" in mission_names()
    cfg = parse_config({"scenario": "goal", "swarm": {"n_robots": 3}, "sim": {"duration_s": 4.0}})
    res = run(cfg, progress=False, provider=DiskOracle())
    assert res.summary["mission"] == "goal"


@pytest.mark.parametrize(
    ("point", "match"),
    [
        (_EntryPoint("goal", "swarm_goal:ENTRY", ImportError("no numpy")), "cannot load"),
        (_EntryPoint("goal", "swarm_goal:ENTRY", object()), "must be a swarmgames"),
        (_EntryPoint("other", "swarm_goal:ENTRY", GOAL_ENTRY), "differs from the entry's name"),
        (
            _EntryPoint("coverage", "x:E", MissionEntry("coverage", GoalConfig, _build)),
            "already taken",
        ),
    ],
)
def test_a_broken_plugin_is_named_and_the_others_still_work(fresh_registry, point, match):
    fresh_registry(point)
    assert "coverage" in mission_names() and "rendezvous" in mission_names()
    assert get_mission("coverage").name == "coverage"
    (why,) = registry_module.broken_plugins().values()
    assert re.search(match, why) and "\n" not in why
    if point.name != "coverage":
        assert point.name not in mission_names()
        with pytest.raises(ConfigError, match=match):
            get_mission(point.name)


def test_missions_list_and_run_report_a_plugin_that_cannot_be_imported(fresh_registry, tmp_path):
    from click.testing import CliRunner

    from swarmgames.cli import cli

    long = "x" * 5000
    fresh_registry(_EntryPoint("goal", "swarm_goal:ENTRY", RuntimeError(f"boom\n{long}")))
    res = CliRunner().invoke(cli, ["missions", "list"])
    assert res.exit_code == 0 and "coverage" in res.output and "Traceback" not in res.output
    (line,) = [x for x in res.output.splitlines() if "plug-in" in x]
    assert "cannot load mission plug-in 'goal'" in line and "RuntimeError: boom" in line
    assert len(line) < 400
    args = ["run", "--out", str(tmp_path / "r"), "--no-progress", "--set", "swarm.n_robots=3"]
    args += ["--set", "sim.duration_s=2", "--set", "sim.animation=false"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert "cannot load mission plug-in 'goal'" in res.output


def test_top_level_exports_the_mission_api():
    assert swarmgames.Mission is Mission and swarmgames.check_mission is check_mission


def test_game_layer_imports_without_the_network_config_or_pandas():
    code = (
        "import sys, swarmgames.game; "
        "bad = [m for m in ('pydantic', 'pandas', 'swarmgames.network', "
        "'swarmgames.network.olsr.engine', 'swarmgames.config', 'swarmgames.missions') "
        "if m in sys.modules]; print(bad)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


PLUGIN = '''
import numpy as np
from pydantic import Field

from swarmgames.game import FunctionPotentials, PotentialCapabilities
from swarmgames.missions import HeadingActions, MissionEntry, TakeOff
from swarmgames.section import Section


class HoverConfig(Section):
    """Hover where you took off."""

    weight: float = Field(1.0, gt=0, description="Weight of the distance to home, per metre.")


class Hover:
    name, state_dim = "hover", 3

    def __init__(self, config):
        self.action_model = HeadingActions(config.swarm.step_m, config.swarm.n_headings)
        w = config.mission.weight
        self.potentials = FunctionPotentials(lambda s: -w * np.linalg.norm(s[..., :2], axis=-1))
        self.takeoff = TakeOff.of(config.swarm)

    def initial_states(self, n, rng):
        return self.takeoff.states(n, rng)

    def swarm_metrics(self, states, previous, t):
        return {"home_distance_m": float(np.linalg.norm(states[:, :2], axis=1).mean())}


ENTRY = MissionEntry("hover", HoverConfig, Hover, "hover at home")
'''


def test_an_installed_plugin_is_found_by_every_command(tmp_path):
    # A real installed distribution, not a mock: a module and its .dist-info with an
    # entry_points.txt on the path, discovered by importlib.metadata in a fresh process.
    (tmp_path / "swarm_hover.py").write_text(PLUGIN)
    info = tmp_path / "swarm_hover-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: swarm-hover\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[{ENTRY_POINT_GROUP}]\nhover = swarm_hover:ENTRY\n")
    scenario = tmp_path / "hover.toml"
    scenario.write_text(
        'name = "hover"\nscenario = "hover"\n[swarm]\nn_robots = 3\nstart_center_m = [100.0, 0.0]'
        "\n[sim]\nduration_s = 6.0\nanimation = false\n[hover]\nweight = 2.0\n"
    )
    # The plug-in's folder first, then the swarmgames under test (not whichever is installed).
    tree = str(Path(swarmgames.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), tree])}

    def cli(*args):
        return subprocess.run(
            [sys.executable, "-m", "swarmgames", *args],
            capture_output=True,
            text=True,
            env=env,
            cwd=tmp_path,
            timeout=300,
        )

    listed = cli("missions", "list")
    assert listed.returncode == 0 and "hover" in listed.stdout, listed.stderr
    assert cli("missions", "check", "hover").returncode == 0
    bad = tmp_path / "bad.toml"
    bad.write_text('scenario = "hover"\n[hover]\nweight = -1.0\n')
    checked = cli("config", "check", str(bad))
    assert checked.returncode == 2 and "hover.weight: must be > 0" in checked.stderr
    ran = cli("run", str(scenario), "--out", str(tmp_path / "out"), "--no-progress")
    assert ran.returncode == 0, ran.stderr
    swarm = (tmp_path / "out" / "swarm.csv").read_text().splitlines()
    assert "home_distance_m" in swarm[0]
    first, last = (float(r.split(",")[2]) for r in (swarm[1], swarm[-1]))
    assert last < first


# --------------------------------------------------------------------------- time


class _OldMetrics(GoalMission):
    """Metrics hooks written without the stage time."""

    def swarm_metrics(self, states, previous):
        return {"goal_distance_m": 0.0}

    def robot_metrics(self, states):
        return {"goal_distance_m": np.zeros(len(states))}


def test_check_mission_names_a_metrics_hook_without_the_stage_time():
    with pytest.raises(MissionCheckError) as info:
        check_mission(_OldMetrics())
    problems = info.value.problems
    assert len(problems) == 2, problems  # one line per hook, and no TypeError of the calls
    assert problems[0].startswith(
        "swarm_metrics must take the stage time: swarm_metrics(states, previous, t)"
    )
    assert "(got swarm_metrics(states, previous))" in problems[0]
    assert problems[1].startswith(
        "robot_metrics must take the stage time: robot_metrics(states, t)"
    )


class _Clock:
    """A unary that reads the stage time: finite up to ``limit_s``, NaN after."""

    capabilities = PotentialCapabilities()

    def __init__(self, limit_s):
        self.limit_s = limit_s

    def unary(self, batch):
        value = 0.0 if batch.t <= self.limit_s else np.nan
        return np.full(batch.action_mask.shape, value - batch.t)

    def pairwise(self, batch):
        return None


class _TimedMetrics(GoalMission):
    """Records the stage times its metrics hooks are given."""

    def __init__(self, potentials):
        object.__setattr__(self, "potentials", potentials)
        object.__setattr__(self, "seen", [])

    def swarm_metrics(self, states, previous, t):
        self.seen.append(t)
        return {"goal_distance_m": 0.0}

    def robot_metrics(self, states, t):
        self.seen.append(t)
        return {"goal_distance_m": np.zeros(len(states))}


def test_check_mission_gives_the_metrics_two_stage_times_and_passes_a_timed_mission():
    mission = _TimedMetrics(_Clock(limit_s=1e9))
    check_mission(mission)
    assert len(set(mission.seen)) == 2  # two stages, two times


def test_check_mission_evaluates_the_potentials_at_a_later_stage_time():
    # Finite at t = 0 (the other checks), not finite at the later times.
    with pytest.raises(MissionCheckError) as info:
        check_mission(_TimedMetrics(_Clock(limit_s=1.0)))
    (first, second) = info.value.problems
    assert first.startswith("potentials at stage time t = 10 s:"), first
    assert second.startswith("potentials at stage time t = 250 s:"), second
    assert "unary potential is not finite" in first


def test_a_run_refuses_undeclared_potentials_in_one_line():
    # A plug-in whose potentials do not declare their capabilities is a usage error naming
    # the mission, not a TypeError from inside the stage (docs/game.md, the Potentials
    # contract).
    from swarmgames.config import ScenarioConfig
    from swarmgames.errors import ConfigError
    from swarmgames.sim.controllers import make_controller

    mission = GoalMission(potentials=_Undeclared())
    with pytest.raises(ConfigError, match=r"^mission 'goal': potentials must declare"):
        make_controller(ScenarioConfig(), mission)
