"""Command-line behaviour: exit codes 0 (ok), 1 (failed / not available), 2 (usage)."""

from __future__ import annotations

import subprocess
import sys

import pytest
from click.testing import CliRunner

from swarmgames.cli import cli


@pytest.fixture
def runner():
    return CliRunner()


def test_help_lists_every_subcommand(runner):
    res = runner.invoke(cli, ["--help"])
    assert res.exit_code == 0
    for cmd in ("run", "reproduce", "network", "bench", "config"):
        assert cmd in res.output


def test_mistyped_subcommand_suggests_close_match(runner):
    res = runner.invoke(cli, ["rnu"])
    assert res.exit_code == 2
    assert "Did you mean 'run'?" in res.output


def test_config_show_prints_resolved_toml(runner):
    res = runner.invoke(cli, ["config", "show"])
    assert res.exit_code == 0
    assert "[network.olsr]" in res.output and "hello_interval_s = 2.0" in res.output


def test_config_check_valid_and_invalid(runner, tmp_path):
    good = tmp_path / "good.toml"
    good.write_text("[swarm]\nn_robots = 5\n")
    res = runner.invoke(cli, ["config", "check", str(good)])
    assert res.exit_code == 0 and "valid" in res.output

    bad = tmp_path / "bad.toml"
    bad.write_text("[swarm]\nn_robots = -5\n")
    res = runner.invoke(cli, ["config", "check", str(bad)])
    assert res.exit_code == 2
    assert "swarm.n_robots: must be >= 1 (got -5)" in res.output
    assert "Traceback" not in res.output


def test_unknown_scenario_exits_2_with_suggestion(runner):
    res = runner.invoke(cli, ["config", "show", "coverag"])
    assert res.exit_code == 2
    assert "did you mean 'coverage'" in res.output


def test_bad_option_value_exits_2(runner, tmp_path):
    res = runner.invoke(cli, ["reproduce", "fig9"])
    assert res.exit_code == 2


def test_console_entry_point_via_python_m():
    res = subprocess.run(
        [sys.executable, "-m", "swarmgames", "config", "check", "/nonexistent/x.toml"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 2
    assert "configuration file not found" in res.stderr
    assert "Traceback" not in res.stderr


@pytest.mark.parametrize(
    ("error", "code"),
    [
        ("ConfigError", 2),
        ("InputDataError", 2),
        ("RunFolderError", 2),
        ("NotAvailableError", 1),
        ("BackendUnavailableError", 1),
        ("ConvergenceError", 1),
    ],
)
def test_errors_map_to_documented_exit_codes(runner, error, code):
    import click

    import swarmgames.errors as errors
    from swarmgames.cli import _guarded

    exc_type = getattr(errors, error)

    @click.command()
    @_guarded
    def failing() -> None:
        if error == "ConvergenceError":
            raise exc_type("did not converge", iterations=3, residual=0.5)
        raise exc_type("something is wrong")

    res = runner.invoke(failing, [])
    assert res.exit_code == code
    assert "Error:" in res.output and "Traceback" not in res.output
