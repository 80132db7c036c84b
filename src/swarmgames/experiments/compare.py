"""Compare neighbourhood providers on the same positions trace.

Every backend replays the same trace; at each sample time its routing tables are read, and each
backend after the first (the *reference*) is compared with the reference entry by entry.

Agreement at a sample time is measured over the *entries*: the ordered pairs (node, dest) that
at least one of the two backends can route (pairs that neither can reach are agreed on trivially
and left out, so a partitioned swarm does not inflate the score). An entry agrees when both
backends give the same hop count:

.. math::

    A(t) = \\frac{|\\{(i, j) : h^a_{ij}(t) = h^b_{ij}(t)\\}|}{|\\{(i, j) : h^a_{ij}(t) > 0
    \\lor h^b_{ij}(t) > 0\\}|},

with :math:`h = 0` for "no route". The *within 2 hops* agreement restricts both counts to the
entries that at least one backend puts within 2 hops: the entries that decide the paper's
neighbourhoods :math:`N_i(2)`. Overall figures pool the entries of every sample time at or after
``warmup_s``.

References
----------
.. [1] docs/reference.md section 4: after settling ns-3 routes equal BFS on the 368.84 m disk graph;
   on moving swarms ns-3 agrees with itself across seeds on about 97 % of entries (99.3 % within
   2 hops).
"""

from __future__ import annotations

import difflib
import math
import time as _time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from swarmgames.config import NetworkConfig
from swarmgames.errors import ConfigError, SwarmgamesError
from swarmgames.experiments.replay import replay
from swarmgames.network.factory import BACKENDS
from swarmgames.network.propagation import new_shadowing_key
from swarmgames.network.provider import NeighbourhoodProvider
from swarmgames.network.trace import PositionTrace, read_positions
from swarmgames.rng import as_generator
from swarmgames.sim.providers import provider_from_config

__all__ = ["HOP_ROWS", "CompareResult", "compare", "counts_by_hops"]

#: Rows of the per-hop-count breakdown: routes of 1, 2, 3, 4 and 5 or more hops, then all.
HOP_ROWS = ("1", "2", "3", "4", "5+", "all")


def counts_by_hops(hops_a: np.ndarray, hops_b: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Per-hop-count counts of a confusion matrix between two tables.

    Parameters
    ----------
    hops_a, hops_b, count : ndarray of int, shape (K,)
        ``count[k]`` entries have ``hops_a[k]`` hops in table a and ``hops_b[k]`` in table b
        (0: no route).

    Returns
    -------
    ndarray of int64, shape (6, 4)
        Per row of :data:`HOP_ROWS`: routes in a, routes in b, entries (routed by either with
        that hop count) and entries on which both agree (same hop count, so ``a = 3, b = 4``
        counts against rows 3 and 4, and ``a = 5, b = 6`` against row 5+).
    """
    a, b = np.asarray(hops_a), np.asarray(hops_b)
    w = np.asarray(count, dtype=np.int64)
    ca, cb, same = np.minimum(a, 5), np.minimum(b, 5), a == b
    out = np.zeros((len(HOP_ROWS), 4), dtype=np.int64)
    for row, c in enumerate(range(1, 6)):
        in_a, in_b = ca == c, cb == c
        either = in_a | in_b
        out[row] = w[in_a].sum(), w[in_b].sum(), w[either].sum(), w[either & same].sum()
    either = (a > 0) | (b > 0)
    out[-1] = w[a > 0].sum(), w[b > 0].sum(), w[either].sum(), w[either & same].sum()
    return out


def _check_name(name: str) -> None:
    if name not in BACKENDS:
        close = difflib.get_close_matches(name, BACKENDS, n=2)
        hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
        raise ConfigError(f"backend must be one of {', '.join(BACKENDS)} (got {name!r}){hint}")


@dataclass(frozen=True, eq=False)
class CompareResult:
    """Outcome of :func:`compare`.

    Attributes
    ----------
    backends : tuple of str
        Labels of the backends, reference first (repeated names get ``#2``, ``#3``...).
    n_robots : int
        Number of robots.
    sample_times : ndarray, shape (S,)
        Sample times, seconds.
    start_time : float
        Start of the trace, seconds.
    warmup_s : float
        Samples before ``start_time + warmup_s`` are left out of the overall figures.
    hops : dict of str to DataFrame
        Every backend's tables, rows ``t, node, dest, hops``.
    per_time : DataFrame
        One row per compared backend and sample time: ``backend, t, entries, agree,
        agreement, entries_2hop, agree_2hop, agreement_2hop``.
    confusion : DataFrame
        ``backend, hops_reference, hops_backend, count`` pooled over the overall samples;
        hop count 0 means "no route".
    wall_time_s : dict of str to float
        Wall-clock time of each backend's replay, seconds (building the provider, which for
        ns-3 includes importing it, is not counted).
    failed : dict of str to str
        Backends left out because their replay stopped (ns-3 aborted), with the reason; the
        others are compared as if they had not been asked for.
    """

    backends: tuple[str, ...]
    n_robots: int
    sample_times: np.ndarray
    start_time: float
    warmup_s: float
    hops: dict[str, pd.DataFrame]
    per_time: pd.DataFrame
    confusion: pd.DataFrame
    wall_time_s: dict[str, float] = field(default_factory=dict)
    failed: dict[str, str] = field(default_factory=dict)

    def to_frame(self) -> pd.DataFrame:
        """Per-time agreement (a copy of :attr:`per_time`)."""
        return self.per_time.copy()

    @property
    def reference(self) -> str:
        """Label of the reference backend."""
        return self.backends[0]

    def agreement(self, backend: str | None = None, within_2_hops: bool = False) -> float:
        """Overall agreement of ``backend`` (default: the second) with the reference."""
        backend = self.backends[1] if backend is None else backend
        rows = self.per_time[(self.per_time["backend"] == backend) & self._kept()]
        a, e = ("agree_2hop", "entries_2hop") if within_2_hops else ("agree", "entries")
        total = int(rows[e].sum())
        return float(rows[a].sum() / total) if total else 1.0

    def by_hops(self, backend: str | None = None) -> pd.DataFrame:
        """Agreement of ``backend`` (default: the second) with the reference per hop count,
        pooled over the overall samples.

        Returns
        -------
        DataFrame
            One row per :data:`HOP_ROWS` entry: ``hops``, ``routes_reference`` and
            ``routes_backend`` (routes of that length in each table), ``entries`` (in either),
            ``agree`` and ``agreement`` (``agree / entries``; 1 where there are none).
        """
        backend = self.backends[1] if backend is None else backend
        c = self.confusion[self.confusion["backend"] == backend]
        counts = counts_by_hops(
            c["hops_reference"].to_numpy(), c["hops_backend"].to_numpy(), c["count"].to_numpy()
        )
        frame = pd.DataFrame(
            counts, columns=["routes_reference", "routes_backend", "entries", "agree"]
        )
        frame.insert(0, "hops", HOP_ROWS)
        frame["agreement"] = np.where(
            frame["entries"] > 0, frame["agree"] / frame["entries"].clip(lower=1), 1.0
        )
        return frame

    def _kept(self) -> pd.Series:
        return self.per_time["t"] >= self.start_time + self.warmup_s - 1e-9

    def summary(self) -> dict[str, Any]:
        """Overall figures as a JSON-ready dict."""
        return {
            "reference": self.reference,
            "backends": list(self.backends),
            "n_robots": self.n_robots,
            "n_samples": int(self.sample_times.size),
            "sample_every_s": float(np.diff(self.sample_times[:2])[0])
            if self.sample_times.size > 1
            else None,
            "warmup_s": self.warmup_s,
            "wall_time_s": dict(self.wall_time_s),
            "failed": dict(self.failed),
            "agreement": {
                b: {
                    "overall": self.agreement(b),
                    "within_2_hops": self.agreement(b, within_2_hops=True),
                    "entries": int(self.per_time.loc[self._is(b), "entries"].sum()),
                    "entries_2hop": int(self.per_time.loc[self._is(b), "entries_2hop"].sum()),
                    "by_hops": {
                        r.hops: {
                            "agreement": float(r.agreement),
                            "entries": int(r.entries),
                            "routes_reference": int(r.routes_reference),
                            "routes_backend": int(r.routes_backend),
                        }
                        for r in self.by_hops(b).itertuples()
                    },
                }
                for b in self.backends[1:]
            },
        }

    def _is(self, b: str) -> pd.Series:
        return (self.per_time["backend"] == b) & self._kept()

    def plot(self):
        """Figure: agreement against time (left) and the confusion matrix of the first compared
        backend (right)."""
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig, (ax, cx) = plt.subplots(1, 2, figsize=(11, 4), width_ratios=[1.6, 1])
        for b in self.backends[1:]:
            d = self.per_time[self.per_time["backend"] == b]
            ax.plot(d["t"], 100 * d["agreement"], label=f"{b}: all entries")
            ax.plot(d["t"], 100 * d["agreement_2hop"], "--", label=f"{b}: within 2 hops")
        ax.set_xlabel("time (s)")
        ax.set_ylabel(f"agreement with {self.reference} (%)")
        ax.set_ylim(-2, 102)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        if len(self.backends) > 1:
            b = self.backends[1]
            c = self.confusion[self.confusion["backend"] == b]
            m = c.pivot_table(
                index="hops_reference", columns="hops_backend", values="count", fill_value=0
            )
            im = cx.imshow(np.log10(1 + m.to_numpy()), cmap="viridis", origin="lower")
            cx.set_xticks(range(m.shape[1]), [str(x) for x in m.columns])
            cx.set_yticks(range(m.shape[0]), [str(x) for x in m.index])
            cx.set_xlabel(f"hops, {b} (0 = no route)")
            cx.set_ylabel(f"hops, {self.reference} (0 = no route)")
            fig.colorbar(im, ax=cx, label="log10(1 + entries)")
        fig.tight_layout()
        return fig

    def write(self, run_folder: Any) -> list[Path]:
        """Write ``per_time.csv``, ``confusion.csv``, ``hops_<backend>.csv``, ``agreement.png``
        and ``summary.json`` into ``run_folder`` (a :class:`~swarmgames.runfolder.RunFolder` or
        a path to a new or empty folder)."""
        from swarmgames.runfolder import RunFolder

        run = RunFolder.of(run_folder)
        files = [
            run.write_csv("per_time.csv", self.per_time),
            run.write_csv("confusion.csv", self.confusion),
        ]
        for b, frame in self.hops.items():
            safe = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in b)
            files.append(run.write_csv(f"hops_{safe}.csv", frame))

        files.append(run.save_figure("agreement.png", self.plot()))
        files.append(run.write_json("summary.json", self.summary()))
        return files


def _labels(names: Sequence[str]) -> tuple[str, ...]:
    seen: dict[str, int] = {}
    out = []
    for name in names:
        seen[name] = seen.get(name, 0) + 1
        out.append(name if seen[name] == 1 else f"{name}#{seen[name]}")
    return tuple(out)


def _pair(ref: pd.DataFrame, other: pd.DataFrame, samples: np.ndarray, n: int):
    m = ref.merge(other, on=["t", "node", "dest"], how="outer", suffixes=("_a", "_b"))
    a = m["hops_a"].fillna(0).to_numpy(dtype=np.int64)
    b = m["hops_b"].fillna(0).to_numpy(dtype=np.int64)
    agree = a == b
    near = ((a >= 1) & (a <= 2)) | ((b >= 1) & (b <= 2))
    g = pd.DataFrame({"t": m["t"], "agree": agree, "near": near, "agree_2hop": agree & near})
    per = g.groupby("t").agg(
        entries=("agree", "size"),
        agree=("agree", "sum"),
        entries_2hop=("near", "sum"),
        agree_2hop=("agree_2hop", "sum"),
    )
    per = per.reindex(samples, fill_value=0).rename_axis("t").reset_index()
    return per, m["t"].to_numpy(), a, b


def compare(
    trace: PositionTrace | pd.DataFrame | str | Path,
    backends: Sequence[str | NeighbourhoodProvider],
    sample_every: float = 0.5,
    *,
    config: NetworkConfig | None = None,
    seed: int | np.random.Generator | None = None,
    warmup_s: float = 0.0,
) -> CompareResult:
    """Run every backend on the same positions trace and compare their routing tables.

    Parameters
    ----------
    trace : PositionTrace, DataFrame or path
        Positions trace (``t, node, x, y, z``; a row holds from ``t`` until the node's next row).
    backends : sequence of str or NeighbourhoodProvider
        At least two; names (``olsr``, ``oracle``, ``disk``, ``knn``, ``ns3``) are built from
        ``config`` by :func:`~swarmgames.sim.providers.provider_from_config`. The
        first is the reference the others are compared with. Backends run one after the other,
        so two ns-3 providers (two seeds) can be compared in one process.
    sample_every : float, default 0.5
        Sampling period of the routing tables, seconds.
    config : NetworkConfig, optional
        Radio and OLSR settings for backends given by name.
    seed : int, Generator or None
        Seeds of the backends given by name (one independent stream each).
    warmup_s : float, default 0.0
        Leave samples earlier than ``warmup_s`` after the start out of the overall figures
        (e.g. 30 s to compare settled tables).

    Returns
    -------
    CompareResult
        A backend whose replay stopped (ns-3 aborted) is left out and listed in ``failed``.

    Raises
    ------
    ValueError
        If fewer than two backends are given or ``sample_every`` / ``warmup_s`` is invalid.
    SwarmgamesError
        If fewer than two backends are left once those that failed are left out.
    ConfigError
        For an unknown backend name (the message suggests close matches).
    BackendUnavailableError
        For ``"ns3"`` without the optional ``ns3`` package.
    InputDataError
        If the trace is malformed.

    Examples
    --------
    >>> import pandas as pd
    >>> trace = pd.DataFrame({"t": [0.0, 0.0, 10.0, 10.0], "node": [0, 1, 0, 1],
    ...                       "x": [0.0, 300.0, 0.0, 300.0], "y": 0.0, "z": 0.0})
    >>> result = compare(trace, ["oracle", "olsr"], sample_every=1.0, seed=0, warmup_s=5.0)
    >>> result.agreement()
    1.0
    """
    if len(backends) < 2:
        raise ValueError(f"backends must name at least two backends (got {len(backends)})")
    if not (math.isfinite(sample_every) and sample_every > 0):
        raise ValueError(f"sample_every must be > 0 (got {sample_every})")
    if not (math.isfinite(warmup_s) and warmup_s >= 0):
        raise ValueError(f"warmup_s must be >= 0 (got {warmup_s})")
    for b in backends:
        if isinstance(b, str):
            _check_name(b)
    if isinstance(trace, (str, Path)):
        trace = read_positions(trace)
    elif isinstance(trace, pd.DataFrame):
        trace = PositionTrace.from_frame(trace)
    if sample_every > trace.end - trace.start:
        raise ValueError(
            f"sample_every must be at most the trace duration {trace.end - trace.start:g} s "
            f"(got {sample_every})"
        )
    if warmup_s > trace.end - trace.start:
        raise ConfigError(
            f"warmup_s must leave samples to compare: at most the trace duration "
            f"{trace.end - trace.start:g} s (got {warmup_s:g})"
        )
    rng = as_generator(seed)
    # One static shadowing field for every backend: they are compared on the same channel.
    shadowed = (config or NetworkConfig()).radio.shadowing_sigma_db > 0
    channel = new_shadowing_key(rng) if shadowed else None
    labels = _labels([b if isinstance(b, str) else b.name for b in backends])
    hops: dict[str, pd.DataFrame] = {}
    wall: dict[str, float] = {}
    failed: dict[str, str] = {}
    for label, backend in zip(labels, backends, strict=True):
        if isinstance(backend, str):
            cfg = (config or NetworkConfig()).model_copy(update={"backend": backend})
            child = np.random.default_rng(rng.integers(2**63))
            # OLSR with TCs, as replay builds it, so that routes of any length are compared.
            backend = provider_from_config(
                cfg, trace.n_robots, child, full_tables=True, shadowing_key=channel
            )
        start = _time.perf_counter()
        result = replay(trace, backend, sample_every)
        if result.failure is not None:
            failed[label] = result.failure
            continue
        wall[label] = _time.perf_counter() - start
        hops[label] = result.hops
        samples = result.summary["t"].to_numpy(dtype=float)
    labels = tuple(label for label in labels if label not in failed)
    if len(labels) < 2:
        raise SwarmgamesError(
            "fewer than two backends left to compare: "
            + "; ".join(f"{k}: {v}" for k, v in failed.items())
        )

    t0 = float(trace.times[0])
    per_rows, conf_rows = [], []
    n = trace.n_robots
    for label in labels[1:]:
        per, t, a, b = _pair(hops[labels[0]], hops[label], samples, n)
        per.insert(0, "backend", label)
        per_rows.append(per)
        keep = t >= t0 + warmup_s - 1e-9
        c = pd.crosstab(a[keep], b[keep]).stack()
        c.index.names = ["hops_reference", "hops_backend"]
        c = c[c > 0].rename("count").reset_index()
        # Pairs that neither backend routes, so the matrix accounts for every ordered pair.
        n_kept = int(np.sum(samples >= t0 + warmup_s - 1e-9))
        both_none = n_kept * n * (n - 1) - int(keep.sum())
        if both_none:
            c = pd.concat(
                [
                    pd.DataFrame(
                        {"hops_reference": [0], "hops_backend": [0], "count": [both_none]}
                    ),
                    c,
                ]
            )
        c.insert(0, "backend", label)
        conf_rows.append(c)
    per_time = pd.concat(per_rows, ignore_index=True)
    for x, e in (("agreement", "entries"), ("agreement_2hop", "entries_2hop")):
        a = "agree" if x == "agreement" else "agree_2hop"
        per_time[x] = np.where(per_time[e] > 0, per_time[a] / per_time[e].clip(lower=1), 1.0)
    confusion = pd.concat(conf_rows, ignore_index=True).astype(
        {"hops_reference": int, "hops_backend": int, "count": int}
    )
    return CompareResult(
        labels, n, samples, t0, float(warmup_s), hops, per_time, confusion, wall, failed
    )
