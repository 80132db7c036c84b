"""Benchmarks of the communication layer: one exchange's share of a stage, and the shared
channel against ns-3's packets on the same trace."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

__all__ = ["channel_vs_ns3", "exchange_record"]


def exchange_record(sb, model: str, stage_s: float, repeats: int, seed: int) -> dict[str, Any]:
    """One exchange of ``model`` (compose, deliver, merge the belief tables, build the
    inboxes) on the stage benchmark's swarm ``sb``, median of ``repeats`` after one untimed
    exchange that fills the belief tables, and its share of a stage (``stage_s``)."""
    from swarmgames.sim.providers import comms_from_config

    cfg = sb.config.with_overrides({"comms.model": model})
    comms = comms_from_config(cfg, sb.states.shape[1], sb.provider)
    rng = np.random.default_rng(seed)
    comms.exchange(sb.time, sb.snapshot, sb.states, rng)
    samples = []
    for k in range(max(1, repeats)):
        t0 = time.perf_counter()
        comms.exchange(sb.time + k + 1.0, sb.snapshot, sb.states, rng)
        samples.append(time.perf_counter() - t0)
    med = float(np.median(samples))
    return {
        "benchmark": f"{model}_comms",
        "n_robots": sb.n_robots,
        "median_s": med,
        "share_of_stage": med / stage_s if stage_s > 0 else float("nan"),
        "repeats": max(1, repeats),
        "unit": "per control period",
    }


def channel_vs_ns3(trace: str = "static_40_dense", stages: int = 5, seed: int = 0) -> dict:
    """The shared channel (``csma``) against UDP packets in ns-3 (``ns3``), one exchange each
    per stage of a recorded channel trace, on the same live ns-3 tables and positions, after
    one untimed exchange that compiles the channel; the ratio of their total times."""
    from swarmgames.comms import CsmaComms
    from swarmgames.comms.ns3_comms import Ns3Comms
    from swarmgames.experiments.channel_record import TRACES
    from swarmgames.network.ns3_import import ns3_available
    from swarmgames.network.ns3_process import shared_process
    from swarmgames.network.trace import PositionTrace

    rec: dict[str, Any] = {"benchmark": "csma_vs_ns3", "trace": trace, "stages": stages}
    if not ns3_available():
        rec["skipped"] = "ns-3 not installed"
        return rec
    from swarmgames.network.ns3_backend import Ns3Provider

    shared_process()  # the ns-3 process and its import are not compared
    path = PositionTrace.from_frame(TRACES[trace].positions(), source=trace)
    n = path.n_robots
    rng = np.random.default_rng(seed)
    spent = {"csma": 0.0, "ns3": 0.0}
    with Ns3Provider(n, run=1) as net:
        models = {
            "csma": CsmaComms(n, 3, 2, tc_interval_s=5.0),
            "ns3": Ns3Comms(n, 3, 2, net, 0.04),
        }
        net.reset(path.at(path.start), path.start)
        first = net.advance(20.0, path.at(20.0))
        CsmaComms(n, 3, 2).exchange(19.0, first, path.at(20.0), rng)  # compiled, not timed
        for k in range(stages):
            t = 20.0 + k
            snap = net.advance(t, path.at(t))
            for name, comms in models.items():
                t0 = time.perf_counter()
                comms.exchange(t, snap, path.at(t), rng)
                spent[name] += time.perf_counter() - t0
    rec.update(
        n_robots=n,
        csma_s=spent["csma"] / stages,
        ns3_s=spent["ns3"] / stages,
        median_s=spent["csma"] / stages,
        ratio=spent["ns3"] / spent["csma"],
        csma_per_ns3=spent["csma"] / spent["ns3"],
    )
    return rec
