"""Configuration validation: every bad value is reported with its field path, rule and value."""

from __future__ import annotations

import sys

import pytest

from swarmgames.config import (
    ScenarioConfig,
    builtin_scenarios,
    load_config,
    parse_config,
    resolve_scenario,
    to_toml,
)
from swarmgames.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib


def test_defaults_follow_the_paper_and_ns3():
    cfg = ScenarioConfig()
    # Paper section III: h = 2, alpha_a = 1, alpha_b = 0.001.
    assert (cfg.network.hops, cfg.game.alpha_a, cfg.game.alpha_b) == (2, 1.0, 0.001)
    # docs/reference.md section 2: ns-3 WifiPhy 16.0206 dBm, Friis at 5.15 GHz, -82 dBm gate.
    assert cfg.network.radio.tx_power_dbm == 16.0206
    assert cfg.network.radio.frequency_hz == 5.15e9
    assert cfg.network.radio.rx_threshold_dbm == -82.0
    # RFC 3626 section 18.2 / ns-3: HELLO 2 s, TC 5 s, holds 6 s / 15 s.
    olsr = cfg.network.olsr
    assert (olsr.hello_interval_s, olsr.tc_interval_s) == (2.0, 5.0)
    assert (olsr.neighbour_hold_s, olsr.topology_hold_s) == (6.0, 15.0)


def test_toml_round_trip_is_lossless():
    cfg = ScenarioConfig()
    assert parse_config(tomllib.loads(to_toml(cfg))) == cfg


def test_unknown_key_names_the_field_path():
    with pytest.raises(ConfigError, match=r"network\.olsr\.hello_intervall: is not a known field"):
        parse_config({"network": {"olsr": {"hello_intervall": 2.0}}})


def test_unknown_top_level_section():
    with pytest.raises(ConfigError, match=r"^invalid configuration: swarms: is not a known field"):
        parse_config({"swarms": {}})


def test_wrong_type_names_field_and_value():
    with pytest.raises(ConfigError, match=r"swarm\.n_robots: .*valid integer \(got '7'\)"):
        parse_config({"swarm": {"n_robots": "7"}})


def test_wrong_type_is_not_coerced():
    # A float where an int is required is an error, not a silent truncation.
    with pytest.raises(ConfigError, match=r"swarm\.n_robots"):
        parse_config({"swarm": {"n_robots": 7.5}})
    with pytest.raises(ConfigError, match=r"game\.virtual_mean"):
        parse_config({"game": {"virtual_mean": 1}})


@pytest.mark.parametrize(
    ("given", "name"),
    [(True, "eq3"), (False, "off"), ("eq3", "eq3"), ("outside", "outside"), ("exact", "exact")],
)
def test_virtual_mean_names_a_variant_and_the_old_switch_still_parses(given, name):
    cfg = parse_config({"game": {"virtual_mean": given}})
    assert cfg.game.virtual_mean == name
    # config show prints the variant's name, which reads back as the same configuration.
    assert f'virtual_mean = "{name}"' in to_toml(cfg)
    assert parse_config(tomllib.loads(to_toml(cfg))) == cfg


@pytest.mark.parametrize("bad", [1, 0, "on", "True", "EQ3", 1.0, [True]])
def test_virtual_mean_refuses_other_values_naming_field_rule_and_value(bad):
    with pytest.raises(ConfigError) as err:
        parse_config({"game": {"virtual_mean": bad}})
    msg = str(err.value)
    assert "game.virtual_mean: must be one of 'eq3', 'outside', 'exact', 'off', true" in msg
    assert f"(got {bad!r})" in msg


def test_out_of_range_names_rule_and_value():
    with pytest.raises(ConfigError, match=r"game\.beta: must be > 0(\.0)? \(got -1\.0\)"):
        parse_config({"game": {"beta": -1.0}})
    with pytest.raises(ConfigError, match=r"network\.hops: must be >= 1 \(got 0\)"):
        parse_config({"network": {"hops": 0}})


def test_cross_field_rule():
    with pytest.raises(ConfigError, match=r"neighbour_hold_s must be > hello_interval_s"):
        parse_config({"network": {"olsr": {"neighbour_hold_s": 1.0}}})


def test_several_problems_reported_together():
    with pytest.raises(ConfigError, match="2 problems") as info:
        parse_config({"game": {"beta": 0.0, "delta": -1.0}})
    assert len(info.value.errors) == 2


def test_literal_choice_lists_allowed_values():
    with pytest.raises(ConfigError, match=r"network\.backend: .*'olsr'.*\(got 'olrs'\)"):
        parse_config({"network": {"backend": "olrs"}})


def test_covariance_must_be_positive_definite():
    with pytest.raises(ConfigError, match="symmetric positive definite"):
        parse_config({"coverage": {"roi_cov_m2": [[1.0, 2.0], [2.0, 1.0]]}})


def test_config_is_immutable():
    cfg = ScenarioConfig()
    with pytest.raises(ValueError, match="frozen"):
        cfg.seed = 3  # type: ignore[misc]


def test_load_config_reads_toml(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('name = "x"\n[swarm]\nn_robots = 12\n')
    cfg = load_config(f)
    assert (cfg.name, cfg.swarm.n_robots) == ("x", 12)


def test_load_config_errors_name_the_file(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[swarm\n")
    with pytest.raises(ConfigError, match=r"bad\.toml is not valid TOML"):
        load_config(bad)
    wrong = tmp_path / "wrong.toml"
    wrong.write_text("[swarm]\nn_robots = 0\n")
    with pytest.raises(ConfigError, match=r"in .*wrong\.toml: swarm\.n_robots: must be >= 1"):
        load_config(wrong)


@pytest.mark.parametrize("name", builtin_scenarios())
def test_builtin_scenarios_are_valid(name):
    assert resolve_scenario(name).name == name


def test_unknown_scenario_suggests_close_matches():
    with pytest.raises(ConfigError, match=r"did you mean 'coverage'"):
        resolve_scenario("coverag")


def test_overrides_are_typed_and_validated():
    cfg = resolve_scenario(None, ["swarm.n_robots=20", "network.backend=oracle"])
    assert (cfg.swarm.n_robots, cfg.network.backend) == (20, "oracle")
    with pytest.raises(ConfigError, match=r"swarm\.n_robots: must be >= 1"):
        resolve_scenario(None, ["swarm.n_robots=0"])
    with pytest.raises(ConfigError, match="override must look like"):
        resolve_scenario(None, ["swarm.n_robots"])


@pytest.mark.parametrize("annotated", [False, True])
def test_round_trip_with_optional_fields(annotated):
    cfg = parse_config({"network": {"radio": {"nakagami_m": 1.0}}, "seed": 9})
    text = to_toml(cfg, annotated=annotated)
    assert parse_config(tomllib.loads(text)) == cfg
    assert parse_config(tomllib.loads(to_toml(ScenarioConfig(), annotated=annotated))) == (
        ScenarioConfig()
    )


def test_annotated_toml_documents_units_and_ranges():
    text = to_toml(ScenarioConfig(), annotated=True)
    assert "# Transmit power, dBm (ns-3 WifiPhy default, 40 mW). [>= -30, <= 60]" in text
    assert "# nakagami_m =   (unset)" in text


@pytest.mark.parametrize("name", [".", "..", ".config", "../x", "a/b", "a\\b", ""])
def test_name_must_stay_inside_runs(name):
    with pytest.raises(ConfigError, match=r"name: must be a folder name inside runs/"):
        parse_config({"name": name})


@pytest.mark.parametrize("name", ["coverage", "run.1", "a..b", "_x", "fig2-n10"])
def test_ordinary_names_are_fine(name):
    assert parse_config({"name": name}).name == name


# ----------------------------------------------------------------------------- issue 13


@pytest.mark.parametrize("value", [True, False, 1.0, 3.0])
def test_willingness_is_never_coerced(value):
    # A Literal of ints takes true as 1 even in strict JSON mode; the schema refuses it.
    with pytest.raises(ConfigError, match=r"network\.olsr\.willingness: must be one of the int"):
        parse_config({"network": {"olsr": {"willingness": value}}})


@pytest.mark.parametrize("hello", [0.5, 0.25])
def test_jitter_must_stay_below_the_hello_interval(hello):
    # The default max_jitter_s = 0.5 made every run with hello_interval_s <= 0.5 crash in the
    # OLSR model with a traceback; the rule is now the schema's, so config check sees it.
    with pytest.raises(ConfigError, match=r"max_jitter_s must be < hello_interval_s"):
        parse_config({"network": {"olsr": {"hello_interval_s": hello}}})


def test_every_olsr_timing_the_schema_accepts_starts_the_model():
    from swarmgames.network.olsr.provider import OlsrProvider
    from swarmgames.network.parameters import OlsrParameters

    olsr = {"hello_interval_s": 0.5, "max_jitter_s": 0.125, "neighbour_hold_s": 1.5}
    cfg = parse_config({"network": {"olsr": olsr}}).network.olsr
    params = OlsrParameters(**{k: getattr(cfg, k) for k in olsr})
    assert OlsrProvider(3, olsr=params).olsr.hello_interval_s == 0.5


@pytest.mark.parametrize("field", ["warmup_s", "duration_s"])
def test_simulated_time_has_an_upper_bound(field):
    # sim.warmup_s = 1e12 ran for 90 s and more without a word.
    with pytest.raises(
        ConfigError, match=rf"sim\.{field}: must be <= 1000000\.0 \(got 1000000000000\.0\)"
    ):
        parse_config({"sim": {field: 1e12}})


def test_stage_count_has_an_upper_bound():
    data = {"swarm": {"step_m": 1e-6}, "sim": {"control_period_s": 1e-6}}
    with pytest.raises(ConfigError, match=r"must be <= 1e\+06 stages .*= 9e\+07"):
        parse_config(data)


@pytest.mark.parametrize("literal", ["nan", "inf", "-inf", "+inf"])
def test_toml_nan_and_inf_are_one_line_naming_the_field(tmp_path, literal):
    p = tmp_path / "s.toml"
    p.write_text(f"[network.radio]\ntx_power_dbm = {literal}\n")
    with pytest.raises(ConfigError, match=r"network\.radio\.tx_power_dbm: must be a finite"):
        load_config(p)
    with pytest.raises(ConfigError) as info:
        resolve_scenario(None, [f"network.radio.tx_power_dbm={literal}"])
    assert len(info.value.errors) == 1
    assert info.value.errors[0].startswith("network.radio.tx_power_dbm: must be a finite number")


def test_non_utf8_scenario_file_is_one_line(tmp_path):
    p = tmp_path / "s.toml"
    p.write_bytes(b'name = "caf\xe9"\n')
    for read in (load_config, resolve_scenario):
        with pytest.raises(ConfigError, match=r"not UTF-8 text \(byte 0xe9 at offset 11\)"):
            read(p)


def test_folder_as_scenario_file_is_one_line(tmp_path):
    d = tmp_path / "s.toml"
    d.mkdir()
    for read in (load_config, resolve_scenario):
        with pytest.raises(ConfigError, match=r"cannot read configuration file .*: it is a folder"):
            read(d)


def test_unreadable_scenario_file_is_one_line(tmp_path, monkeypatch):
    # chmod 000 does not stop root; the error it would raise does the same here.
    from pathlib import Path

    p = tmp_path / "s.toml"
    p.write_text("seed = 1\n")

    def refuse(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(Path, "read_text", refuse)
    for read in (load_config, resolve_scenario):
        with pytest.raises(ConfigError, match=r"cannot read configuration file .*: Permission"):
            read(p)


def test_unknown_field_suggests_the_closest():
    with pytest.raises(ConfigError) as info:
        parse_config(
            {"swarm": {"n_robot": 7}, "coverag": {}, "network": {"olsr": {"hello_intervall": 1}}}
        )
    assert sorted(info.value.errors) == [
        "coverag: is not a known field; did you mean 'coverage'? (got {})",
        "network.olsr.hello_intervall: is not a known field; did you mean "
        "'hello_interval_s'? (got 1)",
        "swarm.n_robot: is not a known field; did you mean 'n_robots'? (got 7)",
    ]


def test_mission_field_suggestion_and_no_suggestion_when_nothing_is_close():
    with pytest.raises(ConfigError, match=r"coverage\.grid_cel_m: .*did you mean 'grid_cell_m'\?"):
        parse_config({"coverage": {"grid_cel_m": 3.0}})
    with pytest.raises(ConfigError) as info:
        parse_config({"swarm": {"zzzz": 1}})
    assert info.value.errors == ["swarm.zzzz: is not a known field (got 1)"]


@pytest.mark.parametrize(
    ("scenario", "overrides", "match"),
    [
        ("coverage", ["game.alpha_b=0.0"], r"game\.alpha_b must be > 0 for the pairwise crowd"),
        ("coverage", ["coverage.grid_cell_m=700.0"], r"coverage\.grid_cell_m must be <= the"),
        ("coverage", ["coverage.grid_cell_m=0.1"], r"coverage\.grid_cell_m = 0\.1 m gives"),
        ("flocking", ["swarm.action_set='headings'", "swarm.step_m=1.0"], r"action_set must be 'a"),
        ("flocking", ["flocking.initial_speed_m_s=20.0"], r"flocking\.initial_speed_m_s must"),
        ("flocking", ["game.alpha_b=0.0"], r"needs game\.alpha_b > 0"),
        ("rendezvous", ["game.alpha_b=0.0"], r"rendezvous: the link term needs game\.alpha_b"),
    ],
)
def test_mission_rules_across_sections_are_the_schemas(scenario, overrides, match):
    # Regression: these were found only when the run built its mission, with the potentials'
    # own parameter names (cell_m, alpha_b), after config check had passed the file.
    with pytest.raises(ConfigError, match=match):
        resolve_scenario(scenario, overrides)


def test_config_check_applies_the_missions_rules(tmp_path):
    from click.testing import CliRunner

    from swarmgames.cli import cli

    path = tmp_path / "bad.toml"
    path.write_text("[game]\nalpha_b = 0.0\n[coverage]\ngrid_cell_m = 20.0\n")
    res = CliRunner().invoke(cli, ["config", "check", str(path)])
    assert res.exit_code == 2
    assert "game.alpha_b must be > 0 for the pairwise crowding penalty" in res.output


@pytest.mark.parametrize(
    ("model", "field", "value"),
    [
        ("ideal", "loss_rate", 0.4),
        ("ideal", "loss_model", "'gilbert_elliott'"),
        ("ideal", "ge_good_to_bad", 0.2),
        ("ideal", "ge_bad_to_good", 0.2),
        ("ideal", "ge_loss_bad", 0.5),
        ("ideal", "hop_delay_s", 0.01),
        ("routed", "jitter_s", 0.02),
        ("ideal", "jitter_s", 0.02),
        ("csma", "loss_model", "'gilbert_elliott'"),
        ("csma", "hop_delay_s", 0.01),
        ("csma", "ge_loss_bad", 0.5),
    ],
)
def test_a_comms_field_without_effect_under_the_model_is_an_error(model, field, value):
    # A setting that does nothing under comms.model would make a grid run one point twice.
    from swarmgames.config import resolve_scenario
    from swarmgames.errors import ConfigError

    with pytest.raises(ConfigError, match=rf"comms\.{field} has no effect with comms\.model = "):
        resolve_scenario("coverage", [f"comms.model='{model}'", f"comms.{field}={value}"])


def test_comms_fields_at_their_defaults_or_under_their_model_are_valid():
    from swarmgames.config import resolve_scenario

    resolve_scenario("coverage", ["comms.model='ideal'", "comms.loss_rate=0.0"])
    cfg = resolve_scenario(
        "coverage", ["comms.model='routed'", "comms.loss_rate=0.4", "comms.hop_delay_s=0.01"]
    )
    assert (cfg.comms.model, cfg.comms.loss_rate) == ("routed", 0.4)
    cfg = resolve_scenario("coverage", ["comms.loss_rate=0.1", "comms.jitter_s=0.02"])
    assert (cfg.comms.model, cfg.comms.jitter_s) == ("csma", 0.02)


def test_every_builtin_scenario_has_a_one_line_description():
    from swarmgames.config import builtin_scenarios
    from swarmgames.config.io import scenario_description

    for name in builtin_scenarios():
        text = scenario_description(name)
        assert 20 <= len(text) <= 96 and "\n" not in text, name
