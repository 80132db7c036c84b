"""Where a model's routing tables fall within ns-3's own run-to-run spread, per hop count.

A recording of several ns-3 runs of one trace (``tests/data/ns3/fast_*``: ten runs each) shows
how much ns-3 varies with nothing but its random jitter. :func:`fidelity` replays the same trace
through a model (the built-in ``olsr`` provider, over several seeds) and asks, for the routes of
1, 2, 3, 4 and 5 or more hops and for all routes together:

* **routes**: how many (sample time, node, dest) routes of that length the tables hold, pooled
  over the samples after the warm-up. The model's median over its seeds is placed among the
  ns-3 runs' counts (its percentile there) and compared with their median (``excess``, the
  relative difference: +2 % means the model keeps 2 % more such routes than ns-3 does).
* **agreement**: the share of entries of that length, in either table of a pair, on which both
  tables give the same hop count (:meth:`.compare.CompareResult.by_hops`). The model is paired
  with every ns-3 run, ns-3 with itself (every pair of distinct runs); the model's median is
  placed in the distribution of ns-3's pairwise agreements.

A percentile is a mid-rank: ``100 * (#below + #equal / 2) / #values``, so a model that draws
from ns-3's distribution sits near 50 on average.

References
----------
.. [1] docs/ns3.md, "Fidelity beyond 2 hops": the recordings and the measured percentiles.
.. [2] RFC 3626 section 10: routes of 3 or more hops come from TC messages.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from swarmgames.config import NetworkConfig
from swarmgames.experiments.compare import HOP_ROWS, counts_by_hops
from swarmgames.experiments.replay import replay
from swarmgames.network.recorded import Recording, read_recording
from swarmgames.network.trace import PositionTrace

__all__ = ["CLASSES", "FidelityResult", "fidelity", "hop_tensor", "main", "pair_counts"]

#: Row labels: routes of 1, 2, 3, 4 and 5 or more hops, then all routes.
CLASSES = HOP_ROWS


def hop_tensor(hops: pd.DataFrame, n_robots: int, samples: np.ndarray) -> np.ndarray:
    """Hop counts of a ``t, node, dest, hops`` table as an array of shape (S, N, N).

    ``out[k, i, j]`` is node ``i``'s hop count to ``j`` at ``samples[k]`` (0: no route). Rows at
    other times are left out.
    """
    keys = np.round(np.asarray(samples, dtype=float) * 1e6).astype(np.int64)
    t = np.round(hops["t"].to_numpy(dtype=float) * 1e6).astype(np.int64)
    k = np.searchsorted(keys, t)
    hit = k < keys.size
    hit[hit] = keys[k[hit]] == t[hit]
    out = np.zeros((keys.size, n_robots, n_robots), dtype=np.int16)
    node = hops["node"].to_numpy(dtype=np.int64)[hit]
    dest = hops["dest"].to_numpy(dtype=np.int64)[hit]
    out[k[hit], node, dest] = hops["hops"].to_numpy(dtype=np.int16)[hit]
    return out


def pair_counts(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per row of :data:`CLASSES`: routes in ``a``, routes in ``b``, entries (in either) and
    entries on which both agree, for two hop tensors of equal shape. Shape (6, 4), int64
    (:func:`~swarmgames.experiments.compare.counts_by_hops` of their confusion matrix)."""
    top = int(max(a.max(initial=0), b.max(initial=0))) + 1
    cells = np.bincount((a.astype(np.int64) * top + b).ravel(), minlength=top * top)
    ha, hb = np.divmod(np.arange(top * top), top)
    return counts_by_hops(ha, hb, cells)


def _percentile(value: float, values: np.ndarray) -> float:
    """Mid-rank percentile of ``value`` among ``values``."""
    below = np.sum(values < value - 1e-12)
    equal = np.sum(np.abs(values - value) <= 1e-12)
    return float(100.0 * (below + equal / 2) / values.size)


@dataclass(frozen=True, eq=False)
class FidelityResult:
    """Outcome of :func:`fidelity`.

    Attributes
    ----------
    name : str
        Label of the recording.
    model : str
        Label of the model.
    runs : tuple of int
        ns-3 run numbers.
    seeds : tuple of int
        Seeds of the model.
    routes_ns3 : ndarray, shape (R, 6)
        Routes per ns-3 run and row of :data:`CLASSES`.
    routes_model : ndarray, shape (M, 6)
        Routes per model seed and row.
    agreement_ns3 : ndarray, shape (R * (R - 1) / 2, 6)
        Agreement of every pair of distinct ns-3 runs, per row.
    agreement_model : ndarray, shape (M * R, 6)
        Agreement of every (model seed, ns-3 run) pair, per row.
    """

    name: str
    model: str
    runs: tuple[int, ...]
    seeds: tuple[int, ...]
    routes_ns3: np.ndarray
    routes_model: np.ndarray
    agreement_ns3: np.ndarray
    agreement_model: np.ndarray

    def to_frame(self) -> pd.DataFrame:
        """One row per hop count (``1`` ... ``5+``, ``all``): ``ns3_routes`` and
        ``model_routes`` (medians), ``excess`` (model / ns-3 - 1), ``routes_percentile``,
        ``ns3_agreement`` and ``model_agreement`` (medians), ``agreement_percentile`` and the
        range of ns-3's pairwise agreement (``ns3_agreement_min``, ``ns3_agreement_max``)."""
        rows = []
        for c, label in enumerate(CLASSES):
            r3, rm = self.routes_ns3[:, c], self.routes_model[:, c]
            a3, am = self.agreement_ns3[:, c], self.agreement_model[:, c]
            med3, medm = float(np.median(r3)), float(np.median(rm))
            rows.append(
                {
                    "hops": label,
                    "ns3_routes": med3,
                    "model_routes": medm,
                    "excess": medm / med3 - 1.0 if med3 else float("nan"),
                    "routes_percentile": _percentile(medm, r3),
                    "ns3_agreement": float(np.median(a3)),
                    "model_agreement": float(np.median(am)),
                    "agreement_percentile": _percentile(float(np.median(am)), a3),
                    "ns3_agreement_min": float(a3.min()),
                    "ns3_agreement_max": float(a3.max()),
                }
            )
        return pd.DataFrame(rows)

    def to_markdown(self) -> str:
        """The table of :meth:`to_frame` in Markdown, percentages to one decimal place."""
        f = self.to_frame()
        lines = [
            f"{self.name}: {self.model} (seeds {self.seeds[0]}-{self.seeds[-1]}) against ns-3 "
            f"(runs {self.runs[0]}-{self.runs[-1]})",
            "",
            "| hops | ns-3 routes | model routes | excess | routes pct | ns-3 agreement "
            "(range) | model agreement | agreement pct |",
            "| --- | --- | --- | --- | --- | --- | --- | --- |",
        ]
        for r in f.itertuples():
            lines.append(
                f"| {r.hops} | {r.ns3_routes:.0f} | {r.model_routes:.0f} | {100 * r.excess:+.1f} % "
                f"| {r.routes_percentile:.0f} | {100 * r.ns3_agreement:.1f} % "
                f"({100 * r.ns3_agreement_min:.1f}-{100 * r.ns3_agreement_max:.1f}) "
                f"| {100 * r.model_agreement:.1f} % | {r.agreement_percentile:.0f} |"
            )
        return "\n".join(lines)


def _agreement(counts: np.ndarray) -> np.ndarray:
    entries, agree = counts[:, 2], counts[:, 3]
    return np.where(entries > 0, agree / np.maximum(entries, 1), 1.0)


def fidelity(
    recording: Recording | str | Path,
    model: str = "olsr",
    seeds: Sequence[int] = tuple(range(10)),
    *,
    warmup_s: float = 30.0,
    config: NetworkConfig | None = None,
) -> FidelityResult:
    """Place a model's routing tables within the run-to-run spread of recorded ns-3 runs.

    Parameters
    ----------
    recording : Recording or path
        A recording of at least two ns-3 runs of one trace (a ``run`` column in ``hops``).
    model : str, default "olsr"
        Backend name, replayed with full routing tables (see
        :func:`~swarmgames.experiments.replay.replay`).
    seeds : sequence of int, default 0-9
        Seeds of the model's replays.
    warmup_s : float, default 30.0
        Samples before this time after the start are left out (OLSR start-up).
    config : NetworkConfig, optional
        Radio and OLSR settings of the model (default: ns-3's, as recorded).

    Returns
    -------
    FidelityResult

    Raises
    ------
    ValueError
        If the recording holds fewer than two runs or ``seeds`` is empty.
    """
    rec = recording if isinstance(recording, Recording) else read_recording(recording)
    name = str(rec.meta.get("kind", "recording"))
    runs = rec.runs
    if len(runs) < 2:
        raise ValueError(f"recording must hold at least two ns-3 runs (got {len(runs)})")
    seeds = tuple(int(s) for s in seeds)
    if not seeds:
        raise ValueError("seeds must name at least one seed (got none)")
    trace = PositionTrace.from_frame(rec.positions)
    n, every = rec.n_robots, rec.sample_every
    count = int(np.floor((trace.end - trace.start) / every + 1e-9)) + 1
    samples = np.round(trace.start + np.arange(count) * every, 9)
    samples = samples[samples >= trace.start + warmup_s - 1e-9]
    ns3 = [hop_tensor(rec.run_hops(k), n, samples) for k in runs]
    ours = [
        hop_tensor(replay(trace, model, every, seed=s, config=config).hops, n, samples)
        for s in seeds
    ]
    pairs = [pair_counts(ns3[i], ns3[j]) for i in range(len(ns3)) for j in range(i + 1, len(ns3))]
    cross = [pair_counts(ns3[j], m) for m in ours for j in range(len(ns3))]
    return FidelityResult(
        name=name,
        model=model,
        runs=runs,
        seeds=seeds,
        routes_ns3=np.array([pair_counts(h, h)[:, 0] for h in ns3]),
        routes_model=np.array([c[:, 1] for c in cross[:: len(ns3)]]),
        agreement_ns3=np.array([_agreement(p) for p in pairs]),
        agreement_model=np.array([_agreement(c) for c in cross]),
    )


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point: print the table of every recording given; exit status 0."""
    parser = argparse.ArgumentParser(
        prog="python -m swarmgames.experiments.fidelity", description=__doc__.split("\n")[0]
    )
    parser.add_argument("recordings", nargs="+", type=Path, help="recording folders")
    parser.add_argument("--model", default="olsr", help="backend to place (default olsr)")
    parser.add_argument("--seeds", type=int, default=10, help="model seeds 0..K-1 (default 10)")
    parser.add_argument("--warmup", type=float, default=30.0, help="warm-up, s (default 30)")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error(f"--seeds must be >= 1 (got {args.seeds})")
    for folder in args.recordings:
        result = fidelity(folder, args.model, range(args.seeds), warmup_s=args.warmup)
        print(result.to_markdown() + "\n", file=sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
