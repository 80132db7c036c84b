"""``swarmgames reproduce comms-ns3``: built-in routed delivery against UDP packets in ns-3.

The recorded ns-3 traces (:data:`~swarmgames.experiments.record_ns3.SCENARIOS`: the same
positions as ``tests/data/ns3``, regenerated from their fixed seeds) are replayed through a
live :class:`~swarmgames.network.ns3_backend.Ns3Provider`. Every second from ``warmup_s`` on
(a control period), both communication models deliver the robots' state messages (their
positions, D = 3) over the *same* ns-3 routing tables at the same positions:

* ``routed``: :class:`~swarmgames.comms.RoutedComms`, the built-in flooding (links in the
  tables and within radio range, ``hop_delay_s`` + airtime per hop, no loss);
* ``ns3``: :class:`~swarmgames.comms.ns3_comms.Ns3Comms`, the same flooding as UDP broadcasts
  in ns-3 (802.11a DCF, collisions, OLSR's own traffic).

For every sender s and every member r of its N_s(h), at the distance d = Hops(s, r) of s's own
table, the message counts as delivered when r holds it at the decision
(``decide_after_s`` after it was sent); its age on arrival is its arrival minus its
timestamp. Per trace, model, ns-3 run and d: the delivery ratio and the mean age on arrival;
:meth:`DeliveryComparison.aggregate` gives their mean and spread over the runs.

:func:`compare_control_traffic` holds the built-in OLSR model's count of its control traffic
(:mod:`swarmgames.network.olsr.traffic`, with TCs on, as ns-3 always sends them) against the
packets ns-3's OLSR sends on the same trace
(:class:`~swarmgames.network.ns3_olsr_traffic.Ns3OlsrTraffic`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from swarmgames.comms import RoutedComms
from swarmgames.comms.ns3_comms import Ns3Comms
from swarmgames.errors import ConfigError
from swarmgames.experiments.comms_replay import delivered_age
from swarmgames.network.ns3_backend import Ns3Provider
from swarmgames.network.ns3_olsr_traffic import Ns3OlsrTraffic
from swarmgames.network.olsr.provider import OlsrProvider
from swarmgames.network.olsr.wire import UDP_IP_HEADER
from swarmgames.network.parameters import OlsrParameters
from swarmgames.network.trace import PositionTrace

__all__ = [
    "DEFAULT_TRACES",
    "ControlTrafficComparison",
    "DeliveryComparison",
    "compare_control_traffic",
    "compare_delivery",
]

#: The recorded traces compared by default.
DEFAULT_TRACES = ("static_20", "waypoint_20")
#: Columns that identify a row of :attr:`DeliveryComparison.frame`.
KEYS = ("trace", "model", "run", "hops")
#: The measured columns.
_VALUES = ("pairs", "delivered", "delivery_ratio", "mean_age_ms", "bytes_per_robot")


@dataclass(frozen=True, eq=False)
class DeliveryComparison:
    """Delivery of the two models, per trace, model, ns-3 run and hop distance.

    Attributes
    ----------
    frame : DataFrame
        Columns ``trace, model, run, hops, pairs`` (sender-member pairs over the stages),
        ``delivered`` (of those, held at the decision), ``delivery_ratio``,
        ``mean_age_ms`` (age on arrival of the delivered ones) and ``bytes_per_robot``
        (payload sent and forwarded per robot and stage, the same in every ``hops`` row).
    """

    frame: pd.DataFrame

    def aggregate(self) -> pd.DataFrame:
        """Per trace, model and hop distance: mean, standard deviation and n over the runs
        of the delivery ratio, the mean age on arrival and the bytes per robot and stage."""
        grp = self.frame.groupby(["trace", "model", "hops"], sort=True)
        out = grp[["delivery_ratio", "mean_age_ms", "bytes_per_robot"]].agg(["mean", "std"])
        out.columns = [f"{a}_{b}" for a, b in out.columns]
        out["runs"] = grp["run"].nunique()
        out["pairs"] = grp["pairs"].sum()
        return out.reset_index()

    def plot(self) -> Figure:
        """Delivery ratio and mean age on arrival against the hop distance, per trace and
        model (mean ± standard deviation over the runs)."""
        agg = self.aggregate()
        fig = Figure(figsize=(10, 3.8), layout="constrained")
        axs = fig.subplots(1, 2)
        for (trace, model), rows in agg.groupby(["trace", "model"], sort=True):
            for ax, name in ((axs[0], "delivery_ratio"), (axs[1], "mean_age_ms")):
                ax.errorbar(
                    rows["hops"],
                    rows[f"{name}_mean"],
                    yerr=rows[f"{name}_std"].fillna(0.0),
                    marker="o" if model == "ns3" else "s",
                    capsize=3,
                    label=f"{trace}, {model}",
                )
        for ax in axs:
            ax.set_xticks(sorted(agg["hops"].unique()))
        axs[0].set(xlabel="hops from the sender", ylabel="delivered by the decision")
        axs[1].set(xlabel="hops from the sender", ylabel="age on arrival (ms)")
        axs[0].legend(fontsize=8)
        return fig

    def write(self, folder) -> list:
        """Write ``delivery.csv`` (every run), ``delivery_aggregate.csv`` and
        ``delivery.png`` into a RunFolder."""
        return [
            folder.write_csv("delivery.csv", self.frame),
            folder.write_csv("delivery_aggregate.csv", self.aggregate()),
            folder.save_figure("delivery.png", self.plot()),
        ]


def _trace(name: str) -> PositionTrace:
    from swarmgames.experiments.record_ns3 import SCENARIOS

    if name not in SCENARIOS:
        raise ConfigError(f"traces: {name!r} is not a recorded trace (one of {sorted(SCENARIOS)})")
    return PositionTrace.from_frame(SCENARIOS[name].positions(), source=name)


def _checked(traces: Sequence[str], runs: Sequence[int]) -> tuple[list[str], list[int]]:
    traces, runs = list(traces), [int(r) for r in runs]
    if not traces or not runs or min(runs) < 1:
        raise ConfigError(f"traces and runs (>= 1) must not be empty (got {traces}, {runs})")
    return traces, runs


def _follow(net, trace: PositionTrace, until: float) -> None:
    """Step ``net`` through the trace's motion up to ``until``."""
    for tt in trace.times[(trace.times > net.time) & (trace.times < until)]:
        net.step(float(tt), trace.at(tt))
    net.step(float(until), trace.at(until))


def _member_rows(snapshot, hops: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sender, member, distance) of every member of every robot's N_s(h), itself excluded."""
    keep = np.asarray(snapshot.hops) <= hops
    return (
        np.asarray(snapshot.owner, dtype=np.int64)[keep],
        np.asarray(snapshot.dest, dtype=np.int64)[keep],
        np.asarray(snapshot.hops, dtype=np.int64)[keep],
    )


def compare_delivery(
    traces: Sequence[str] = DEFAULT_TRACES,
    runs: Sequence[int] = (1, 2, 3),
    *,
    hops: int = 2,
    warmup_s: float = 20.0,
    jitter_s: float = 0.04,
    hop_delay_s: float = 0.002,
    decide_after_s: float = 0.1,
    seed: int = 0,
) -> DeliveryComparison:
    """Replay each trace once per ns-3 run and compare the two models (module docstring).

    Parameters
    ----------
    traces : sequence of str
        Names of recorded traces (:data:`~swarmgames.experiments.record_ns3.SCENARIOS`).
    runs : sequence of int
        ns-3 run numbers (``RngSeedManager.SetRun``), >= 1: the spread of the results.
    hops : int
        h, the neighbourhood radius and the flooding's TTL.
    warmup_s : float
        First stage time (OLSR has settled its 2-hop tables by then), seconds.
    jitter_s, decide_after_s : float
        Of the ``ns3`` model (:class:`~swarmgames.comms.ns3_comms.Ns3Comms`), seconds.
    hop_delay_s : float
        Of the ``routed`` model, seconds.
    seed : int
        Seed of the jitter and of the routed model's draws (one Generator per run).

    Returns
    -------
    DeliveryComparison

    Raises
    ------
    ConfigError
        An unknown trace, no trace or run, or a run number < 1.
    BackendUnavailableError
        Without the ns-3 package.
    """
    traces, runs = _checked(traces, runs)
    rows = []
    for name in traces:
        trace = _trace(name)
        n = trace.n_robots
        stages = np.arange(warmup_s, trace.end, 1.0)
        for run in runs:
            rng = np.random.default_rng([seed, run])
            net = Ns3Provider(n, run=run)
            beliefs = {"decide_after_s": decide_after_s}
            models = {
                "routed": RoutedComms(n, 3, hops, hop_delay_s=hop_delay_s, **beliefs),
                "ns3": Ns3Comms(n, 3, hops, net, jitter_s, **beliefs),
            }
            net.reset(trace.at(trace.start), trace.start)
            sums = {m: {"bytes": 0.0} for m in models}
            per_hop = {m: {} for m in models}
            for t in stages:
                _follow(net, trace, float(t))
                pos = trace.at(t)
                snap = net.snapshot()
                sender, member, dist = _member_rows(snap, hops)
                for model, comms in models.items():
                    _, stats = comms.exchange(float(t), snap, pos, rng)
                    sums[model]["bytes"] += float(np.mean(stats.bytes_sent + stats.bytes_forwarded))
                    age = delivered_age(
                        comms.table, float(t), sender, member, float(t) + decide_after_s
                    )
                    for d in np.unique(dist):
                        at = dist == d
                        acc = per_hop[model].setdefault(int(d), [0, 0, 0.0])
                        acc[0] += int(at.sum())
                        ok = np.isfinite(age[at])
                        acc[1] += int(ok.sum())
                        acc[2] += float(age[at][ok].sum())
            net.close()
            for model, by_d in per_hop.items():
                for d, (pairs, got, age_sum) in sorted(by_d.items()):
                    rows.append(
                        {
                            "trace": name,
                            "model": model,
                            "run": run,
                            "hops": d,
                            "pairs": pairs,
                            "delivered": got,
                            "delivery_ratio": got / pairs if pairs else np.nan,
                            "mean_age_ms": 1e3 * age_sum / got if got else np.nan,
                            "bytes_per_robot": sums[model]["bytes"] / max(len(stages), 1),
                        }
                    )
    return DeliveryComparison(pd.DataFrame(rows, columns=[*KEYS, *_VALUES]))


@dataclass(frozen=True, eq=False)
class ControlTrafficComparison:
    """OLSR's control traffic per robot and second, built-in model against ns-3.

    Attributes
    ----------
    frame : DataFrame
        One row per trace, backend (``olsr``: the built-in count; ``ns3``: ns-3's packets)
        and run: ``hello_per_s``, ``tc_per_s`` (originated and relayed), ``packets_per_s``,
        ``bytes_per_s`` (OLSR packets: packet headers and messages), ``on_air_bytes_per_s``
        (with 28 bytes of UDP/IP per packet), ``hello_bytes`` (per HELLO message, without the
        packet header) and ``shared_packets`` (share of packets with more than one message).
    """

    frame: pd.DataFrame

    def aggregate(self) -> pd.DataFrame:
        """Mean and standard deviation over the runs, per trace and backend."""
        grp = self.frame.groupby(["trace", "backend"], sort=True)
        out = grp[list(_TRAFFIC)].agg(["mean", "std"])
        out.columns = [f"{a}_{b}" for a, b in out.columns]
        return out.reset_index()

    def write(self, folder) -> list:
        """Write ``olsr_traffic.csv`` and ``olsr_traffic_aggregate.csv`` into a RunFolder."""
        return [
            folder.write_csv("olsr_traffic.csv", self.frame),
            folder.write_csv("olsr_traffic_aggregate.csv", self.aggregate()),
        ]


_TRAFFIC = (
    "hello_per_s",
    "tc_per_s",
    "packets_per_s",
    "bytes_per_s",
    "on_air_bytes_per_s",
    "hello_bytes",
    "shared_packets",
)


def _traffic_row(trace: str, backend: str, run: int, n: int, seconds: float, **c) -> dict:
    per = n * seconds
    return {
        "trace": trace,
        "backend": backend,
        "run": run,
        "hello_per_s": c["hello"] / per,
        "tc_per_s": c["tc"] / per,
        "packets_per_s": c["packets"] / per,
        "bytes_per_s": c["bytes"] / per,
        "on_air_bytes_per_s": (c["bytes"] + UDP_IP_HEADER * c["packets"]) / per,
        "hello_bytes": c["hello_bytes"] / max(c["hello"], 1),
        "shared_packets": c["shared"] / max(c["packets"], 1),
    }


def compare_control_traffic(
    traces: Sequence[str] = DEFAULT_TRACES,
    runs: Sequence[int] = (1, 2, 3),
    *,
    warmup_s: float = 20.0,
    seed: int = 0,
) -> ControlTrafficComparison:
    """Count OLSR's control traffic from ``warmup_s`` to the end of each trace, with the
    built-in model (TCs on, seeded ``[seed, run]``) and with ns-3 (run number ``run``).

    The built-in model sends every message in a packet of its own, so its packets are its
    messages and its ``hello_bytes`` include the 4-byte packet header; ns-3's ``hello_bytes``
    are message bytes (its packets may be shared).

    Raises
    ------
    ConfigError
        An unknown trace, no trace or run, or a run number < 1.
    BackendUnavailableError
        Without the ns-3 package.
    """
    traces, runs = _checked(traces, runs)
    rows = []
    for name in traces:
        trace = _trace(name)
        n, seconds = trace.n_robots, trace.end - warmup_s
        for run in runs:
            rng = np.random.default_rng([seed, run])
            model = OlsrProvider(n, olsr=OlsrParameters(hello_only=False), seed=rng)
            model.reset(trace.at(trace.start), trace.start)
            _follow(model, trace, warmup_s)
            model.control_traffic()
            _follow(model, trace, trace.end)
            c = model.control_traffic()
            rows.append(
                _traffic_row(
                    name,
                    "olsr",
                    run,
                    n,
                    seconds,
                    hello=c.hello_sent.sum(),
                    tc=(c.tc_sent + c.tc_forwarded).sum(),
                    packets=c.messages.sum(),
                    bytes=c.bytes.sum(),
                    hello_bytes=c.hello_bytes.sum(),
                    shared=0,
                )
            )
            net = Ns3Provider(n, run=run)
            net.reset(trace.at(trace.start), trace.start)
            counter = Ns3OlsrTraffic(net)
            _follow(net, trace, warmup_s)
            counter.take()
            _follow(net, trace, trace.end)
            k = counter.take()
            net.close()
            rows.append(
                _traffic_row(
                    name,
                    "ns3",
                    run,
                    n,
                    seconds,
                    hello=k.hello_sent.sum(),
                    tc=(k.tc_sent + k.tc_forwarded).sum(),
                    packets=k.packets.sum(),
                    bytes=k.packet_bytes.sum(),
                    hello_bytes=k.hello_bytes.sum(),
                    shared=k.shared_packets.sum(),
                )
            )
    return ControlTrafficComparison(pd.DataFrame(rows))
