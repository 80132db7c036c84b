"""``swarmgames comms replay``: delivery by hop on a user's trace, from the CLI and Python."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from swarmgames.cli import cli
from swarmgames.config import ScenarioConfig
from swarmgames.errors import ChannelOverloadWarning, ConfigError
from swarmgames.experiments.comms_replay import DELIVERY_COLUMNS, replay_comms
from swarmgames.network.trace import PositionTrace
from swarmgames.sim import run


def _static(tmp_path: Path, n: int, side: float, seconds: float = 24.0) -> Path:
    rng = np.random.default_rng(n)
    xy = rng.uniform(0, side, (n, 2))
    rows = [(t, i, x, y, 30.0) for t in (0.0, seconds) for i, (x, y) in enumerate(xy)]
    path = tmp_path / f"static_{n}.csv"
    pd.DataFrame(rows, columns=["t", "node", "x", "y", "z"]).to_csv(path, index=False)
    return path


def test_the_cli_writes_delivery_by_hop_and_prints_a_summary(tmp_path):
    trace = _static(tmp_path, 15, 900.0)
    res = CliRunner().invoke(
        cli,
        ["comms", "replay", "--positions", str(trace), "--out", str(tmp_path / "out"),
         "--seed", "3", "--no-progress"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    delivery = pd.read_csv(tmp_path / "out" / "delivery.csv")
    assert list(delivery.columns) == list(DELIVERY_COLUMNS)
    assert delivery["hops"].tolist() == [1, 2]
    assert (delivery["delivered"] <= delivery["pairs"]).all()
    assert np.allclose(delivery["ratio"], delivery["delivered"] / delivery["pairs"])
    assert (tmp_path / "out" / "delivery.png").is_file()
    assert "csma on olsr: 15 robots, 4 stages" in res.output


def test_routed_delivers_every_settled_member_and_csma_less_in_a_crowd(tmp_path):
    trace = PositionTrace.from_frame(pd.read_csv(_static(tmp_path, 40, 600.0)))
    base = ScenarioConfig()
    routed = replay_comms(trace, config=base.with_overrides({"comms.model": "routed"}))
    csma = replay_comms(trace, config=base)
    assert routed.delivery["ratio"].min() == 1.0
    assert (csma.delivery["ratio"] < routed.delivery["ratio"]).all()
    # The age on arrival is simulated: at least one airtime, at most the decision.
    assert (csma.delivery["mean_age_ms"] > 0.1).all()
    assert (csma.delivery["mean_age_ms"] < 100.0).all()
    assert (csma.stages["channel_load"] > 0).all()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--comms", "ideal"], "ideal"),
        (["--hops", "0"], "--hops"),
        (["--set", "comms.jitter_s=-1"], "comms.jitter_s"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, args, message):
    trace = _static(tmp_path, 5, 500.0)
    res = CliRunner().invoke(
        cli, ["comms", "replay", "--positions", str(trace), "--out", str(tmp_path / "o"), *args]
    )
    assert res.exit_code == 2, res.output
    assert message in res.output and "Traceback" not in res.output


def test_a_trace_that_ends_before_the_first_stage_is_refused(tmp_path):
    trace = PositionTrace.from_frame(pd.read_csv(_static(tmp_path, 5, 500.0, seconds=10.0)))
    with pytest.raises(ConfigError, match="beyond the first stage"):
        replay_comms(trace)
    bad = tmp_path / "bad.csv"
    bad.write_text("t,node,x,y,z\n0,0,0,0,0\n0,1,nan,0,0\n")
    res = CliRunner().invoke(
        cli, ["comms", "replay", "--positions", str(bad), "--out", str(tmp_path / "o")]
    )
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert not (tmp_path / "o").exists()


def test_a_run_records_its_channel_load_and_warns_once_when_it_cannot_fit(tmp_path):
    # 30 UAVs in the default take-off disc with a 5 ms decision window: the messages of a
    # stage need more airtime than the window holds.
    cfg = ScenarioConfig().with_overrides(
        {
            "swarm.n_robots": 30,
            "sim.duration_s": 3.0,
            "sim.animation": False,
            "comms.decide_after_s": 0.005,
        }
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run(cfg, out=tmp_path / "run", progress=False)
    overload = [w for w in caught if issubclass(w.category, ChannelOverloadWarning)]
    assert len(overload) == 1
    assert "comms.decide_after_s" in str(overload[0].message)
    swarm = pd.read_csv(tmp_path / "run" / "swarm.csv")
    assert (swarm["channel_load"] > 1).all()
    assert result.summary["max_channel_load"] == pytest.approx(swarm["channel_load"].max())
    metrics = pd.read_csv(tmp_path / "run" / "metrics.csv")
    assert np.isclose(metrics.groupby("t")["channel_load"].max().to_numpy(),
                      swarm["channel_load"].to_numpy()).all()  # fmt: skip


@pytest.mark.ns3
def test_replay_through_ns3_with_ns3_packets_from_the_cli(tmp_path):
    from swarmgames.network import ns3_process

    try:
        ns3_process.shared_process()
    except Exception as exc:
        pytest.skip(str(exc))
    trace = _static(tmp_path, 6, 500.0, seconds=22.0)
    res = CliRunner().invoke(
        cli,
        ["comms", "replay", "--positions", str(trace), "--out", str(tmp_path / "out"),
         "--backend", "ns3", "--comms", "ns3", "--seed", "0", "--no-progress"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    delivery = pd.read_csv(tmp_path / "out" / "delivery.csv")
    assert list(delivery.columns) == list(DELIVERY_COLUMNS)
    assert (delivery["pairs"] > 0).all() and (delivery["ratio"] <= 1.0).all()
    assert "ns3 on ns3: 6 robots, 2 stages" in res.output
