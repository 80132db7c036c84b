"""ns-3 in a child process: an abort inside ns-3 is one line, and costs no completed work.

The abort is simulated by a stand-in for the ns-3 process (``fake_ns3_worker``) that writes
what ns-3 3.44 wrote when it aborted in ``PhyEntity::StartReceivePreamble`` and ends itself
as ``std::terminate`` does; the real abort is reproduced at the end (needs ns-3).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from swarmgames.cli import cli
from swarmgames.errors import Ns3CrashError
from swarmgames.network import ns3_process
from swarmgames.network.ns3_process import Ns3ProcessDied, parse_abort

ROOT = Path(__file__).resolve().parents[2]
#: ns-3 3.44's own lines (static_80_sparse, run 4: docs/ns3.md, "Known ns-3 faults").
NS3_ABORT = (
    'NS_ASSERT failed, cond="!m_wifiPhy->m_currentEvent", +34.052927252s 10 '
    "file=/gcl-builds/src/wifi/model/phy-entity.cc, line=490\n"
    "NS_FATAL, terminating\n"
    "terminate called without an active exception\n"
    " *** Break *** abort\n"
)
REASON = 'NS_ASSERT failed, cond="!m_wifiPhy->m_currentEvent", file=phy-entity.cc, line=490'


@pytest.fixture
def fake_ns3(monkeypatch):
    """ns-3 providers of this test talk to the stand-in, which aborts at 14.5 s of its clock."""
    monkeypatch.setattr(ns3_process, "WORKER_MODULE", "tests.network.fake_ns3_worker")
    monkeypatch.setattr(ns3_process, "_shared", [])
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    monkeypatch.setenv("PYTHONPATH", path)
    monkeypatch.setenv("SWARMGAMES_FAKE_NS3_ABORT_S", "14.5")
    yield ns3_process
    for process in ns3_process._shared:
        process.close()


def test_ns3s_abort_line_is_parsed_into_reason_time_and_node():
    assert parse_abort(NS3_ABORT, -6) == (REASON, 34.052927252, 10)
    fatal = 'msg="Channel width 20 MHz not allowed", +0.000000000s -1 file=/b/src/wifi/a.cc, line=7'
    assert parse_abort(fatal, -6) == (
        'msg="Channel width 20 MHz not allowed", file=a.cc, line=7',
        0.0,
        -1,
    )


@pytest.mark.parametrize(
    ("code", "how"), [(-signal.SIGSEGV, "killed by SIGSEGV"), (3, "exit code 3")]
)
def test_a_death_without_ns3s_line_says_how_the_process_ended(code, how):
    reason, t, node = parse_abort("Failed to materialize symbols: x\nsomething else\n", code)
    assert how in reason and t is None and node is None


def test_a_long_reason_is_cut():
    reason, _, _ = parse_abort(f'NS_ASSERT failed, cond="{"x" * 5000}"', -6)
    assert len(reason) <= 300 and reason.endswith("…")


def test_provider_reports_the_abort_in_one_line_and_the_next_scenario_runs(fake_ns3):
    from swarmgames.network.ns3_backend import Ns3Provider

    pos = np.array([[0.0, 0, 0], [100, 0, 0], [200, 0, 0]])
    net = Ns3Provider(3, run=4)
    net.reset(pos, start_time=5.0)  # the run's clock is 5 s ahead of ns-3's
    assert net.advance(19.0, pos).n_entries == 6
    first = net._process.pid
    with pytest.raises(Ns3CrashError) as info:
        net.advance(25.0, pos)
    err = info.value
    assert str(err) == (
        f"ns-3 aborted in its run 4 at t = 19.25 s, node 10: {REASON} "
        '(docs/ns3.md, "Known ns-3 faults")'
    )
    assert (err.run, err.time, err.reason) == (4, 19.25, REASON)
    assert err.exit_code == -signal.SIGABRT
    with pytest.raises(RuntimeError, match="reset"):  # this provider's scenario is gone
        net.advance(26.0, pos)
    other = Ns3Provider(3, run=1)  # a fresh ns-3 process
    assert other.reset(pos).n_robots == 3
    assert other._process.pid != first and other._process.alive


def test_the_processs_own_lines_are_passed_on_without_cppyys_chatter(fake_ns3, monkeypatch, capsys):
    monkeypatch.setenv("SWARMGAMES_FAKE_NS3_SAY", "a word from ns-3")
    process = ns3_process.Ns3Process()  # its first request imports ns-3, which says so
    process.close()
    assert capsys.readouterr().err == "a word from ns-3\n"


def test_a_dead_process_refuses_every_later_request(fake_ns3):
    process = ns3_process.Ns3Process()
    process.call("build", np.zeros((2, 3)), {}, {}, 1, None)
    with pytest.raises(Ns3ProcessDied) as first:
        process.call("step", 1, 20 * 10**9, None)
    with pytest.raises(Ns3ProcessDied) as again:
        process.call("now", 1)
    assert again.value is first.value and not process.alive
    process.close()


def test_a_run_whose_ns3_aborts_exits_1_with_one_line_and_keeps_its_stages(fake_ns3, tmp_path):
    out = tmp_path / "run"
    args = ["run", "--out", str(out), "--no-progress", "--set", "swarm.n_robots=4"]
    res = CliRunner().invoke(cli, [*args, "--set", "network.backend='ns3'"])
    assert res.exit_code == 1, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("Error: ns-3 aborted in its run ")
    assert "at t = 14.25 s, node 10: NS_ASSERT failed" in lines[0]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "failed"
    assert "ns-3 aborted" in manifest["error"]
    assert manifest["stages_completed"] == 4  # t = 10 ... 13 s; the 5th runs ns-3 to 15 s
    trajectory = (out / "trajectory.csv").read_text().splitlines()
    assert len(trajectory) == 1 + 4 * 4  # the header and 4 stages of 4 robots
    # The completed stages give their summary and figures; ns-3 cannot be continued.
    res = CliRunner().invoke(cli, ["run", "--resume", str(out), "--no-progress"])
    assert res.exit_code == 1 and "cannot be resumed" in res.stderr.lower().replace("\n", " ")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stages"] == 4


def test_the_ns3_process_ends_with_its_parent(tmp_path):
    if not ns3_process.ns3_available():
        pytest.skip("ns-3 not installed")
    script = (
        "from swarmgames.network.ns3_process import shared_process\n"
        "import sys, time\n"
        "print(shared_process().pid, flush=True)\n"
        "time.sleep(600)\n"
    )
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    child = int(parent.stdout.readline())
    parent.kill()
    parent.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            break
        if (
            Path(f"/proc/{child}/stat").exists()
            and " Z " in Path(f"/proc/{child}/stat").read_text()
        ):
            break  # a zombie: ended, waiting for init to reap it
        time.sleep(0.2)
    else:
        os.kill(child, signal.SIGKILL)
        pytest.fail("the ns-3 process outlived its parent")


@pytest.mark.ns3
def test_the_real_ns3_abort_on_a_channel_trace_is_reported_and_survived():
    # docs/ns3.md, "Known ns-3 faults": ns-3 3.44 aborts in run 4 of static_80_sparse at
    # ns-3's 34.05 s, at every attempt.
    from swarmgames.comms.ns3_comms import Ns3Comms
    from swarmgames.experiments.channel_record import TRACES
    from swarmgames.network.ns3_backend import Ns3Provider
    from swarmgames.network.trace import PositionTrace

    try:
        ns3_process.shared_process()
    except Exception as exc:
        pytest.skip(str(exc))
    trace = PositionTrace.from_frame(TRACES["static_80_sparse"].positions())
    rng = np.random.default_rng([0, 4])
    net = Ns3Provider(trace.n_robots, run=4)
    comms = Ns3Comms(trace.n_robots, 3, 2, net, 0.04, decide_after_s=0.1)
    net.reset(trace.at(trace.start), trace.start)
    with pytest.raises(Ns3CrashError) as info:
        for t in np.arange(20.0, 40.0):
            snap = net.advance(float(t), trace.at(t))
            comms.exchange(float(t), snap, trace.at(t), rng)
    err = info.value
    assert err.run == 4 and err.reason == REASON
    assert err.time == pytest.approx(34.052927252 + trace.start)
    assert "\n" not in str(err)
    again = Ns3Provider(3, run=1)  # the next scenario gets a fresh ns-3 process
    pos = np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]])
    again.reset(pos)
    assert again.advance(30.0, pos).hop_matrix()[0].tolist() == [0, 1, 2]


def _static_trace(tmp_path: Path, seconds: float) -> Path:
    rows = [(t, i, 100.0 * i, 0.0, 30.0) for t in (0.0, seconds) for i in range(4)]
    path = tmp_path / "static.csv"
    pd.DataFrame(rows, columns=["t", "node", "x", "y", "z"]).to_csv(path, index=False)
    return path


@pytest.fixture
def abort_once(fake_ns3, monkeypatch, tmp_path):
    """Only the first ns-3 run of the test aborts (at 14.5 s of ns-3's clock)."""
    monkeypatch.setenv("SWARMGAMES_FAKE_NS3_ONCE", str(tmp_path / "aborted"))


def test_network_replay_reports_the_aborted_run_and_replays_the_others(abort_once, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(
        cli,
        ["network", "replay", "--positions", str(_static_trace(tmp_path, 20.0)),
         "--backend", "ns3", "--seed", "0", "--seed", "1", "--sample-every", "1",
         "--out", str(out), "--no-progress"],
    )  # fmt: skip
    assert res.exit_code == 1, res.output
    err = res.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("failed: seed 0: ns-3 aborted in its run ")
    runs = pd.read_csv(out / "runs.csv")
    assert runs["status"].tolist() == ["failed", "complete"]
    assert runs["folder"].tolist() == ["seed-0", "seed-1"]
    kept = pd.read_csv(out / "seed-0" / "summary.csv")["t"]
    assert kept.tolist() == [float(t) for t in range(15)]  # the samples before the abort
    assert pd.read_csv(out / "seed-1" / "summary.csv")["t"].max() == 20.0


def test_comms_replay_keeps_the_stages_before_the_abort_and_goes_on(
    abort_once, tmp_path, monkeypatch
):
    monkeypatch.setenv("SWARMGAMES_FAKE_NS3_ABORT_S", "22.5")  # stages from 20 s
    out = tmp_path / "out"
    res = CliRunner().invoke(
        cli,
        ["comms", "replay", "--positions", str(_static_trace(tmp_path, 24.0)),
         "--backend", "ns3", "--seed", "3", "--seed", "4", "--out", str(out),
         "--no-progress"],
    )  # fmt: skip
    assert res.exit_code == 1, res.output
    assert "failed: seed 3: ns-3 aborted in its run 4 at t = 22.25 s" in res.stderr
    assert pd.read_csv(out / "seed-3" / "stages.csv")["t"].tolist() == [20.0, 21.0, 22.0]
    assert pd.read_csv(out / "seed-4" / "stages.csv")["t"].tolist() == [20.0, 21.0, 22.0, 23.0]
    assert pd.read_csv(out / "runs.csv")["status"].tolist() == ["failed", "complete"]


def test_network_compare_leaves_out_the_backend_whose_ns3_aborted(abort_once, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(
        cli,
        ["network", "compare", "--positions", str(_static_trace(tmp_path, 20.0)),
         "--backends", "olsr,ns3,ns3", "--sample-every", "1", "--out", str(out)],
    )  # fmt: skip
    assert res.exit_code == 1, res.output
    assert "failed: ns3: ns-3 aborted in its run " in res.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["backends"] == ["olsr", "ns3#2"]
    assert list(summary["failed"]) == ["ns3"]
