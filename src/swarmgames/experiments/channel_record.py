"""Recordings of ns-3's delivery of the state messages, the reference of the built-in channel.

``python -m swarmgames.experiments.channel_record --out tests/data/channel`` replays each
trace of :data:`TRACES` through a live :class:`~swarmgames.network.ns3_backend.Ns3Provider`
once per ns-3 run, and from ``warmup_s`` on, every second, floods every robot's state message
(D = 3) as UDP broadcasts in ns-3 (:class:`~swarmgames.comms.ns3_comms.Ns3Comms`, 40 ms
jitter, h = 2, the decision 0.1 s after the stage time): the conventions of
``swarmgames reproduce comms-ns3``. It writes, per trace, a recording folder
(:mod:`swarmgames.network.recorded`'s format) that a machine without ns-3 replays:

* ``positions.csv`` — the trace;
* ``hops.csv.xz`` — ns-3's routing tables at every stage time, per run (``run,t,node,dest,
  hops``), taken while the state messages were on the air (their frames change the tables);
* ``delivery.csv`` — ns-3's delivery per run and hop distance: ``run,hops,pairs,delivered,
  ratio,mean_age_ms`` (:func:`~swarmgames.experiments.comms_replay.delivery_by_hop`);
* ``meta.json`` — what was recorded, with which ns-3, and the command.

The built-in models replay the recorded tables at the same positions
(:func:`~swarmgames.experiments.comms_replay.replay_recording`), and
``tests/comms/test_channel_fidelity.py`` holds the default channel model against these
recordings.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from swarmgames.experiments.comms_replay import DeliveryCounter
from swarmgames.experiments.record_ns3 import SCENARIOS, random_waypoint, static_layout
from swarmgames.network.trace import PositionTrace

__all__ = ["TRACES", "ChannelTrace", "main", "record"]

#: xz keeps the repeated tables small and writes no time stamp.
_XZ = {"method": "xz", "preset": 9}


@dataclass(frozen=True)
class ChannelTrace:
    """A trace to record: its positions (seeded) and the ns-3 runs recorded."""

    positions: Callable[[], pd.DataFrame]
    runs: tuple[int, ...] = (1, 2, 3, 4, 5)


#: The recorded traces: 20 to 80 UAVs, 5 to 17 one-hop neighbours, static and moving.
TRACES: dict[str, ChannelTrace] = {
    "static_20": ChannelTrace(SCENARIOS["static_20"].positions),
    "static_80_sparse": ChannelTrace(lambda: static_layout(80, 2400.0, 35.0, seed=8024)),
    "static_40_dense": ChannelTrace(lambda: static_layout(40, 1200.0, 35.0, seed=4012)),
    "static_80_dense": ChannelTrace(lambda: static_layout(80, 1200.0, 35.0, seed=8012)),
    "waypoint_20": ChannelTrace(lambda: random_waypoint(20, 1000.0, 60.0, 0.5, seed=2005)),
    "waypoint_50_dense": ChannelTrace(lambda: random_waypoint(50, 1200.0, 50.0, 0.5, seed=5012)),
}


def _follow(net, trace: PositionTrace, until: float) -> None:
    """Step ``net`` through the trace's motion up to ``until``."""
    for tt in trace.times[(trace.times > net.time) & (trace.times < until)]:
        net.step(float(tt), trace.at(tt))
    net.step(float(until), trace.at(until))


def record_run(
    trace: PositionTrace,
    run: int,
    *,
    hops: int = 2,
    warmup_s: float = 20.0,
    jitter_s: float = 0.04,
    decide_after_s: float = 0.1,
    seed: int = 0,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """One ns-3 run of ``trace``: its tables at the stage times and its delivery by hop."""
    from swarmgames.comms.ns3_comms import Ns3Comms
    from swarmgames.network.ns3_backend import Ns3Provider

    n = trace.n_robots
    rng = np.random.default_rng([seed, run])
    counter = DeliveryCounter(hops, decide_after_s)
    tables = []
    with Ns3Provider(n, run=run) as net:
        comms = Ns3Comms(n, 3, hops, net, jitter_s, decide_after_s=decide_after_s)
        net.reset(trace.at(trace.start), trace.start)
        for t in np.arange(warmup_s, trace.end, 1.0):
            _follow(net, trace, float(t))
            snap = net.snapshot()
            comms.exchange(float(t), snap, trace.at(t), rng)
            counter.add(float(t), snap, comms.table)
            tables.append(
                pd.DataFrame(
                    {
                        "t": float(t),
                        "node": np.asarray(snap.owner),
                        "dest": np.asarray(snap.dest),
                        "hops": np.asarray(snap.hops),
                    }
                )
            )
    return pd.concat(tables, ignore_index=True), counter.frame()


def record(name: str, out: Path, runs: tuple[int, ...] | None = None) -> Path:
    """Record trace ``name`` of :data:`TRACES` into ``out/name`` (module docstring).

    Each ns-3 run goes in a child process of its own: ns-3 aborts the whole process on some
    layouts (docs/ns3.md, "Known ns-3 faults"), and such a run is left out and listed in
    ``meta.json`` as ``failed_runs``, with the other runs kept.
    """
    spec = TRACES[name]
    runs = spec.runs if runs is None else runs
    positions = spec.positions()
    trace = PositionTrace.from_frame(positions, source=name)
    folder = out / name
    folder.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    tables, delivery, failed = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for run in runs:
            part = Path(tmp) / f"run{run}"
            child = ["--out", str(part), "--only", name, "--run", str(run), "--one"]
            done = subprocess.run(
                [sys.executable, "-m", "swarmgames.experiments.channel_record", *child],
                check=False,
            )
            if done.returncode != 0:
                failed.append({"run": run, "exit_code": done.returncode})
                print(f"{name} run {run}: ns-3 failed (exit {done.returncode})", file=sys.stderr)
                continue
            tables.append(pd.read_csv(part / "hops.csv"))
            delivery.append(pd.read_csv(part / "delivery.csv"))
            print(f"{name} run {run}: {time.perf_counter() - start:.0f} s", file=sys.stderr)
    wall = time.perf_counter() - start
    if not tables:
        raise RuntimeError(f"{name}: every ns-3 run failed ({failed})")
    positions.to_csv(folder / "positions.csv", index=False)
    pd.concat(tables).to_csv(folder / "hops.csv.xz", index=False, compression=_XZ)
    pd.concat(delivery).to_csv(folder / "delivery.csv", index=False, float_format="%.6g")
    from importlib.metadata import version

    meta = {
        "kind": name,
        "t_end": float(trace.times[-1]),
        "sample": 1.0,
        "runs": [r for r in runs if r not in {f["run"] for f in failed}],
        "failed_runs": failed,
        "warmup_s": 20.0,
        "hops": 2,
        "jitter_s": 0.04,
        "decide_after_s": 0.1,
        "state_dim": 3,
        "ns3": version("ns3"),
        "standard": "802.11a",
        "rate": "OfdmRate6Mbps",
        "loss": "Friis 5.15 GHz",
        "olsr": "ns-3 defaults",
        "ns3_wall_s": round(wall, 1),
        "command": f"python -m swarmgames.experiments.channel_record --out {out} --only {name}",
    }
    (folder / "meta.json").write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    return folder


def _record_one(name: str, out: Path, run: int) -> None:
    """One run into ``out`` (the child process of :func:`record`)."""
    trace = PositionTrace.from_frame(TRACES[name].positions(), source=name)
    hops, got = record_run(trace, run)
    out.mkdir(parents=True, exist_ok=True)
    hops.assign(run=run)[["run", *hops.columns]].to_csv(out / "hops.csv", index=False)
    got.assign(run=run)[["run", *got.columns]].to_csv(out / "delivery.csv", index=False)


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m swarmgames.experiments.channel_record", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--out", type=Path, required=True, help="folder to write recordings into")
    parser.add_argument("--only", nargs="+", choices=sorted(TRACES), help="these traces only")
    parser.add_argument("--run", type=int, nargs="+", help="ns-3 run numbers (default 1-5)")
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if any(k < 1 for k in args.run or ()):
        parser.error("--run must be >= 1")
    if args.one:
        _record_one(args.only[0], args.out, args.run[0])
        return 0
    for name in args.only or list(TRACES):
        folder = record(name, args.out, None if args.run is None else tuple(args.run))
        print(f"recorded {name} -> {folder}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
