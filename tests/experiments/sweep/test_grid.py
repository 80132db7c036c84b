"""The grid of a sweep: splitting ``--set`` values, crossing and zipping the factors,
validation of every combination before anything runs, and the run folders' names."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from swarmgames.config import ScenarioConfig, parse_config
from swarmgames.errors import ConfigError
from swarmgames.experiments.sweep.grid import (
    factors_from_assignments,
    factors_from_mapping,
    folder_name,
    plan_sweep,
    split_levels,
)

BASE = parse_config({"sim": {"duration_s": 4.0, "animation": False}})


@pytest.mark.parametrize(
    ("text", "pieces"),
    [
        ("5", ["5"]),
        ("5,10,20", ["5", "10", "20"]),
        ("[[5.0,1]]", ["[[5.0,1]]"]),  # one level: a list with a comma inside
        ("[[5.0,1]],[],[[5.0,1],[8.0,2]]", ["[[5.0,1]]", "[]", "[[5.0,1],[8.0,2]]"]),
        ("'a,b',c", ["'a,b'", "c"]),
        ('"x\\",y",z', ['"x\\",y"', "z"]),  # an escaped quote inside a basic string
        ("'say \"hi\", then',y", ["'say \"hi\", then'", "y"]),  # a literal string
        ("{a = 1, b = 2},3", ["{a = 1, b = 2}", "3"]),
    ],
)
def test_split_levels_keeps_commas_inside_brackets_and_quotes(text, pieces):
    assert split_levels(text) == pieces


@pytest.mark.parametrize(
    ("text", "rule"),
    [
        ("[[5.0,1]", "missing closing ']'"),
        ("[1,2]]", "unbalanced ']'"),
        ("[1,2}", "unbalanced '}'"),
        ("'a,b", "missing closing quote '"),
        ("5,,10", "must be non-empty"),
        ("5,", "must be non-empty"),
        ("", "must be non-empty"),
    ],
)
def test_split_levels_rejects_unbalanced_or_empty(text, rule):
    with pytest.raises(ConfigError, match=rule) as err:
        split_levels(text)
    assert repr(text) in str(err.value)


def test_assignments_are_read_as_set_reads_a_value():
    factors = factors_from_assignments(
        [
            "swarm.n_robots=5,10",
            "network.backend=olsr,'oracle'",
            "faults.crash=[[5.0,1]],[]",
            "game.virtual_mean=true",
        ]
    )
    assert factors == {
        "swarm.n_robots": (5, 10),
        "network.backend": ("olsr", "oracle"),  # a bare word and a TOML string alike
        "faults.crash": (((5.0, 1),), ()),
        "game.virtual_mean": (True,),
    }


@pytest.mark.parametrize(
    ("assignments", "message"),
    [
        (["swarm.n_robots"], "must look like section.field=v1,v2"),
        (["=5"], "must look like section.field=v1,v2"),
        (["swarm.n_robots=5", "swarm.n_robots=7"], "swarm.n_robots: is given by two --set"),
        (["seed=1,2"], "seed: the seeds of a sweep are given by --seeds"),
        (["faults.crash=[[5.0,1]"], "faults.crash: missing closing ']'"),
        (["swarm={n_robots=5}"], "swarm: a table cannot be a level"),
    ],
)
def test_bad_assignments_name_the_path(assignments, message):
    with pytest.raises(ConfigError, match=message):
        factors_from_assignments(assignments)


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        (
            {"swarm.n_robots": 5},
            r"swarm.n_robots: must be a list of the values to sweep, e.g. \[5\]",
        ),
        ({"network.backend": "oracle"}, "must be a list of the values"),
        ({"swarm.n_robots": []}, "needs at least one value"),
        ({"": [1]}, "override paths must be non-empty strings"),
        ({"seed": [1, 2]}, "seed: the seeds of a sweep"),
        ([("swarm.n_robots", [5])], "overrides must be a dict"),
    ],
)
def test_bad_mappings_are_rejected(overrides, message):
    with pytest.raises(ConfigError, match=message):
        factors_from_mapping(overrides)


def _plan(overrides, seeds=(0,), zipped=False):
    return plan_sweep(BASE, factors_from_mapping(overrides), seeds, zipped)


def test_the_grid_crosses_the_factors_first_slowest_seeds_innermost():
    plan = _plan({"swarm.n_robots": [3, 4], "game.beta": [1.0, 2.0, 3.0]}, seeds=[0, 7])
    got = [
        (dict(p.values)["swarm.n_robots"], dict(p.values)["game.beta"], p.seed) for p in plan.points
    ]
    want = [(n, b, s) for n in (3, 4) for b in (1.0, 2.0, 3.0) for s in (0, 7)]
    assert got == want
    for p in plan.points:  # every run's configuration has its levels and seed
        assert (p.config.swarm.n_robots, p.config.game.beta, p.config.seed) == (
            dict(p.values)["swarm.n_robots"],
            dict(p.values)["game.beta"],
            p.seed,
        )
        assert p.config.sim.duration_s == 4.0  # the base scenario's own fields stay
    assert len({p.folder for p in plan.points}) == len(plan.points)


def test_zip_pairs_the_levels_and_a_single_level_goes_with_every_pair():
    plan = _plan(
        {"swarm.n_robots": [3, 4, 5], "game.beta": [1.0, 2.0, 3.0], "network.backend": ["oracle"]},
        zipped=True,
    )
    got = [tuple(v for _, v in p.values) for p in plan.points]
    assert got == [(3, 1.0, "oracle"), (4, 2.0, "oracle"), (5, 3.0, "oracle")]


def test_a_repeated_level_is_an_error_but_zip_may_repeat_a_factors_value():
    with pytest.raises(
        ConfigError, match=r"swarm.n_robots: value 5 is given twice \(got 5, 7, 5\)"
    ):
        _plan({"swarm.n_robots": [5, 7, 5]})
    plan = _plan({"swarm.n_robots": [5, 7], "game.beta": [1.0, 1.0]}, zipped=True)
    assert [tuple(v for _, v in p.values) for p in plan.points] == [(5, 1.0), (7, 1.0)]
    with pytest.raises(
        ConfigError, match=r"--zip: the combination swarm\.n_robots=5, game\.beta=1\.0 is"
    ):
        _plan({"swarm.n_robots": [5, 5], "game.beta": [1.0, 1.0]}, zipped=True)


def test_zip_needs_the_same_number_of_levels():
    with pytest.raises(ConfigError, match=r"--zip .* \(got swarm.n_robots: 2, game.beta: 3\)"):
        _plan({"swarm.n_robots": [3, 4], "game.beta": [1.0, 2.0, 3.0]}, zipped=True)


def test_no_factor_is_the_base_scenario_over_the_seeds():
    plan = _plan({}, seeds=[0, 1, 2])
    assert [p.seed for p in plan.points] == [0, 1, 2]
    assert all(p.config.model_copy(update={"seed": 0}) == BASE for p in plan.points)


def test_a_bad_level_fails_before_anything_runs_naming_the_field():
    with pytest.raises(ConfigError) as err:
        _plan({"swarm.n_robots": [3, 0], "game.beta": [1.0, 2.0]}, seeds=[0, 1])
    # One problem, reported once although two combinations and two seeds have it.
    assert str(err.value) == (
        "invalid configuration in sweep point swarm.n_robots=0, game.beta=1.0: "
        "swarm.n_robots: must be >= 1 (got 0)"
    )


def test_every_distinct_problem_is_listed():
    with pytest.raises(ConfigError) as err:
        _plan({"swarm.n_robot": [3], "comms.loss_rate": [0.1, 2.0]})
    lines = err.value.errors
    assert len(lines) == 2, lines
    assert "swarm.n_robot: is not a known field; did you mean 'n_robots'?" in lines[0]
    assert lines[1].startswith("swarm.n_robot=3, comms.loss_rate=2.0: comms.loss_rate: must be <=")


def test_cross_field_rules_of_the_schema_apply_to_each_combination():
    with pytest.raises(ConfigError, match="max_jitter_s must be < hello_interval_s"):
        _plan({"network.olsr.hello_interval_s": [2.0, 0.5]})


@pytest.mark.parametrize("seeds", [[], [-1], [1, 1], [True], ["0"], "012", [1.5]], ids=repr)
def test_bad_seeds(seeds):
    with pytest.raises(ConfigError, match="seeds must"):
        _plan({}, seeds=seeds)


def test_folder_names_are_readable_and_independent_of_the_factor_order():
    a = folder_name([("swarm.n_robots", 5), ("network.backend", "oracle")], 3)
    b = folder_name([("network.backend", "oracle"), ("swarm.n_robots", 5)], 3)
    assert a == b
    assert a.startswith("network.backend=oracle__swarm.n_robots=5__seed=3-")
    assert folder_name([("faults.crash", ((5.0, 1),))], 0).startswith("faults.crash=_5.0_1_")
    # Same readable text, different values: the hash tells them apart.
    assert folder_name([("name", "a/b")], 0) != folder_name([("name", "a_b")], 0)


@given(
    st.lists(
        st.tuples(
            st.text(min_size=1, max_size=30), st.one_of(st.text(max_size=300), st.integers())
        ),
        max_size=4,
    ),
    st.integers(min_value=0, max_value=2**32),
)
def test_folder_names_never_leave_the_runs_folder(values, seed):
    name = folder_name(values, seed)
    assert "/" not in name and "\\" not in name and "\0" not in name
    assert not name.startswith(".") and name not in ("", ".", "..")
    assert len(name.encode()) <= 120  # well below the 255 bytes of a file name


def test_a_scenario_config_is_the_base():
    plan = plan_sweep(ScenarioConfig(), factors_from_mapping({"swarm.n_robots": [5]}), [0])
    assert plan.points[0].config.swarm.n_robots == 5
