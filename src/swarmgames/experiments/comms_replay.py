"""``swarmgames comms replay``: what a communication model delivers on a position trace.

A position trace is replayed through a network provider (the built-in OLSR model, ns-3, or a
recording's tables). From ``warmup_s`` on, every whole second (a control period), every robot
sends its state message (its position, D = 3) and the communication model delivers it; the
robots decide ``comms.decide_after_s`` after the stage time. For every sender s and every
member r of s's own N_s(h), at the distance d = Hops(s, r) of s's table, the message counts as
delivered when r holds it at the decision; its age on arrival is its arrival time minus its
timestamp, both simulated. :class:`DeliveryCounter` sums these by d over the trace:
``hops, pairs, delivered, ratio, mean_age_ms``, the columns of ``delivery.csv``.

These are the conventions of ``swarmgames reproduce comms-ns3``: the ns-3 run number of a
replay with seed S is S + 1.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from swarmgames.errors import Ns3CrashError

__all__ = [
    "DELIVERY_COLUMNS",
    "CommsReplay",
    "DeliveryCounter",
    "delivered_age",
    "replay_comms",
    "replay_delivery",
    "replay_recording",
]

#: The columns of ``delivery.csv``, one row per hop distance.
DELIVERY_COLUMNS = ("hops", "pairs", "delivered", "ratio", "mean_age_ms")


def delivered_age(table, t: float, sender, member, decide: float) -> np.ndarray:
    """Age on arrival of s's message of time ``t`` at each member (NaN: not held by
    ``decide``)."""
    now = (table.stamp == t) & (table.arrival <= decide + 1e-12)
    key = table.owner[now] * table.n_robots + table.sender[now]
    arrival = table.arrival[now]
    want = member * table.n_robots + sender
    age = np.full(want.size, np.nan)
    if key.size == 0:
        return age
    order = np.argsort(key)
    pos = np.minimum(np.searchsorted(key[order], want), key.size - 1)
    found = key[order][pos] == want
    age[found] = arrival[order][pos[found]] - t
    return age


class DeliveryCounter:
    """Sums, by hop distance, the sender-member pairs of each stage and what was delivered.

    Parameters
    ----------
    hops : int
        h: members up to this distance in the sender's own table count.
    decide_after_s : float
        The decision's delay after the stage time, seconds.
    """

    def __init__(self, hops: int, decide_after_s: float) -> None:
        self.hops = int(hops)
        self.decide_after_s = float(decide_after_s)
        self._sums: dict[int, list[float]] = {}

    def add(self, t: float, snapshot, table) -> None:
        """Count the stage at ``t``: its tables ``snapshot`` and the belief ``table`` after
        the exchange."""
        dist = np.asarray(snapshot.hops, dtype=np.int64)
        keep = dist <= self.hops
        sender = np.asarray(snapshot.owner, dtype=np.int64)[keep]
        member = np.asarray(snapshot.dest, dtype=np.int64)[keep]
        dist = dist[keep]
        age = delivered_age(table, t, sender, member, t + self.decide_after_s)
        ok = np.isfinite(age)
        pairs = np.bincount(dist, minlength=self.hops + 1)
        got = np.bincount(dist[ok], minlength=self.hops + 1)
        ages = np.bincount(dist[ok], weights=age[ok], minlength=self.hops + 1)
        for d in np.flatnonzero(pairs):
            acc = self._sums.setdefault(int(d), [0, 0, 0.0])
            acc[0] += int(pairs[d])
            acc[1] += int(got[d])
            acc[2] += float(ages[d])

    def frame(self) -> pd.DataFrame:
        """One row per hop distance: ``hops, pairs, delivered, ratio, mean_age_ms``."""
        rows = [
            (d, p, g, g / p if p else np.nan, 1e3 * a / g if g else np.nan)
            for d, (p, g, a) in sorted(self._sums.items())
        ]
        return pd.DataFrame(rows, columns=list(DELIVERY_COLUMNS))


@dataclass(frozen=True, eq=False)
class CommsReplay:
    """What a communication model delivered on a trace.

    Attributes
    ----------
    delivery : DataFrame
        One row per hop distance: ``hops, pairs, delivered, ratio, mean_age_ms`` (the columns
        of ``delivery.csv``).
    stages : DataFrame
        One row per stage: ``t``, ``bytes_per_robot`` (payload sent and relayed per robot),
        ``channel_load`` (the busiest robot's, :func:`~swarmgames.comms.load.offered_load`).
    comms, backend : str
        The communication model and the network backend.
    failure : str or None
        Why the replay stopped before the trace's end (ns-3 aborted: the one-line
        :class:`~swarmgames.errors.Ns3CrashError`), with the stages completed until then;
        None for a replay that reached its end.
    """

    delivery: pd.DataFrame
    stages: pd.DataFrame
    comms: str
    backend: str
    failure: str | None = None

    def plot(self) -> Figure:
        """Delivery by the decision and mean age on arrival against the hop distance."""
        fig = Figure(figsize=(8, 3.4), layout="constrained")
        ax_d, ax_a = fig.subplots(1, 2)
        d = self.delivery
        label = f"{self.comms} on {self.backend}"
        ax_d.plot(d["hops"], 100 * d["ratio"], "o-", label=label)
        ax_a.plot(d["hops"], d["mean_age_ms"], "o-", label=label)
        ax_d.set(xlabel="hops from the sender", ylabel="delivered by the decision (%)",
                 ylim=(0, 105))  # fmt: skip
        ax_a.set(xlabel="hops from the sender", ylabel="age on arrival (ms)")
        ax_a.set_ylim(bottom=0)
        for ax in (ax_d, ax_a):
            ax.set_xticks(d["hops"].tolist())
            ax.grid(alpha=0.3)
        ax_d.legend(loc="lower left")
        return fig

    def write(self, folder) -> list:
        """Write ``delivery.csv``, ``stages.csv`` and ``delivery.png`` into a RunFolder."""
        return [
            folder.write_csv("delivery.csv", self.delivery),
            folder.write_csv("stages.csv", self.stages),
            folder.save_figure("delivery.png", self.plot()),
        ]


def _stage_times(trace, warmup_s: float, period_s: float) -> np.ndarray:
    """Every whole control period from ``warmup_s`` to the trace's end."""
    return np.arange(float(warmup_s), float(trace.end), float(period_s))


def replay_delivery(
    trace,
    provider,
    comms,
    *,
    hops: int,
    decide_after_s: float,
    rng: np.random.Generator,
    warmup_s: float = 20.0,
    period_s: float = 1.0,
    progress: Callable[[float, float], None] | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame, str | None]:
    """Replay ``trace`` through ``provider`` and let ``comms`` deliver a state message from
    every robot each control period from ``warmup_s`` on (module docstring).

    Returns
    -------
    (delivery, stages) : DataFrames
        See :class:`CommsReplay`: of the stages completed.
    failure : str or None
        The one-line :class:`~swarmgames.errors.Ns3CrashError` if ns-3 aborted, else None.
    """
    counter = DeliveryCounter(hops, decide_after_s)
    stages = _stage_times(trace, warmup_s, period_s)
    comms.reset()
    provider.reset(trace.at(trace.start), trace.start)
    rows = []
    moves = trace.times
    now = trace.start
    failure = None
    try:
        for t in stages:
            for tt in moves[(moves > now) & (moves < t)]:
                provider.advance(float(tt), trace.at(tt))
            snap = provider.advance(float(t), trace.at(t))
            now = float(t)
            _, stats = comms.exchange(float(t), snap, trace.at(t), rng)
            counter.add(float(t), snap, comms.table)
            load = stats.channel_load[np.isfinite(stats.channel_load)]
            rows.append(
                {
                    "t": float(t),
                    "bytes_per_robot": float(np.mean(stats.bytes_sent + stats.bytes_forwarded)),
                    "channel_load": float(load.max()) if load.size else float("nan"),
                }
            )
            if progress is not None:
                progress(float(t), float(stages[-1]))
    except Ns3CrashError as exc:  # keep the stages completed
        failure = str(exc)
    columns = ["t", "bytes_per_robot", "channel_load"]
    return counter.frame(), pd.DataFrame(rows, columns=columns), failure


def replay_comms(
    trace,
    *,
    backend: str = "olsr",
    config=None,
    hops: int = 2,
    seed: int = 0,
    warmup_s: float = 20.0,
    progress: Callable[[float, float], None] | None = None,
) -> CommsReplay:
    """What ``config.comms.model`` delivers on ``trace`` (``swarmgames comms replay``).

    Parameters
    ----------
    trace : PositionTrace
    backend : {"olsr", "ns3", "oracle", "disk", "knn"}
        The network whose tables route the messages; ns-3 runs with run number ``seed + 1``.
    config : ScenarioConfig, optional
        Radio, OLSR and comms settings (default: the default scenario's).
    hops : int
        h: the neighbourhood radius and the flood's TTL.
    seed : int
        Seed of the provider's and the model's draws.
    warmup_s : float
        First stage time, seconds (the tables have settled by then).
    progress : callable ``(t, t_last)``, optional

    Returns
    -------
    CommsReplay
        If ns-3 aborts, the stages completed until then, with the reason in ``failure``.

    Raises
    ------
    ConfigError
        A setting the scenario's validation refuses (e.g. ``comms.model = 'ns3'`` without
        the ns3 backend), or a trace that ends before ``warmup_s``.
    """
    from swarmgames.config import ScenarioConfig
    from swarmgames.errors import ConfigError
    from swarmgames.sim.providers import comms_from_config, provider_from_config

    base = ScenarioConfig() if config is None else config
    if base.comms.model == "ideal":
        raise ConfigError(
            "comms.model must be one that delivers into belief tables ('routed', 'csma', "
            "'ns3'): 'ideal' delivers every message at once (got 'ideal')"
        )
    if not trace.end > warmup_s:
        raise ConfigError(
            f"the trace must last beyond the first stage at {warmup_s:g} s (it ends at "
            f"{trace.end:g} s)"
        )
    cfg = base.with_overrides(
        {"swarm.n_robots": trace.n_robots, "network.hops": int(hops), "network.backend": backend}
    )
    rng = np.random.default_rng(seed)
    if backend == "ns3":
        from swarmgames.network.ns3_backend import Ns3Provider
        from swarmgames.network.parameters import OlsrParameters, RadioParameters

        provider = Ns3Provider(
            trace.n_robots,
            RadioParameters(**cfg.network.radio.model_dump()),
            OlsrParameters(**cfg.network.olsr.model_dump()),
            rng,
            run=seed + 1,
        )
    else:
        provider = provider_from_config(cfg.network, trace.n_robots, rng)
    comms = comms_from_config(cfg, 3, provider)
    try:
        delivery, stages, failure = replay_delivery(
            trace,
            provider,
            comms,
            hops=hops,
            decide_after_s=cfg.comms.decide_after_s,
            rng=np.random.default_rng([seed, 1]),
            warmup_s=warmup_s,
            period_s=cfg.sim.control_period_s,
            progress=progress,
        )
    finally:
        if backend == "ns3":  # the ns-3 simulator's nodes and sockets
            provider.close()
    return CommsReplay(delivery, stages, cfg.comms.model, backend, failure)


def replay_recording(folder, *, comms: str = "csma", seed: int = 0, overrides=()) -> pd.DataFrame:
    """Replay an ns-3 delivery recording (:mod:`swarmgames.experiments.channel_record`)
    through a built-in communication model, run by run, over the recorded tables.

    The OLSR frames on the channel are ns-3's: HELLOs and TCs. Returns one row per run and
    hop distance: ``run`` and the columns of ``delivery.csv``.
    """
    from swarmgames.config import ScenarioConfig
    from swarmgames.network.recorded import read_recording
    from swarmgames.network.trace import PositionTrace
    from swarmgames.sim.providers import comms_from_config

    rec = read_recording(folder)
    meta = rec.meta
    trace = PositionTrace.from_frame(rec.positions, source=str(folder))
    settings = {
        "swarm.n_robots": rec.n_robots,
        "network.hops": int(meta["hops"]),
        "network.olsr.hello_only": False,
        "comms.model": comms,
        "comms.decide_after_s": float(meta["decide_after_s"]),
    }
    if comms == "csma":  # the recording's jitter; the routed model has none
        settings["comms.jitter_s"] = float(meta["jitter_s"])
    cfg = ScenarioConfig().with_overrides({**settings, **dict(overrides)})
    frames = []
    for run in rec.runs:
        model = comms_from_config(cfg, int(meta["state_dim"]), None)
        delivery, _, _ = replay_delivery(
            trace,
            rec.provider(run=run),
            model,
            hops=int(meta["hops"]),
            decide_after_s=float(meta["decide_after_s"]),
            rng=np.random.default_rng([seed, run]),
            warmup_s=float(meta["warmup_s"]),
        )
        frames.append(delivery.assign(run=run))
    out = pd.concat(frames, ignore_index=True)
    return out[["run", *DELIVERY_COLUMNS]]
