"""Replay a recorded positions trace through a neighbourhood provider.

``replay`` advances a provider through a :class:`~swarmgames.network.trace.PositionTrace` (each
node's row holds until its next row) and samples every robot's routing table every
``sample_every`` seconds. The result holds one row per reachable destination ``dest != node``
at each sample time (the format of ns-3 recordings, e.g. ``tests/data/ns3/hex_expand/hops.csv``)
and a per-time summary.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.sparse as sp
from scipy.sparse import csgraph

from swarmgames.config import NetworkConfig
from swarmgames.errors import Ns3CrashError
from swarmgames.network.provider import NeighbourhoodProvider
from swarmgames.network.trace import PositionTrace, read_positions
from swarmgames.sim.providers import provider_from_config
from swarmgames.topology import TopologySnapshot

__all__ = [
    "MAX_HOP_ROWS",
    "SUMMARY_COLUMNS",
    "ReplayResult",
    "check_sampling",
    "replay",
    "summarise",
]

#: The columns of a replay's per-sample summary (:func:`summarise`).
SUMMARY_COLUMNS = ["t", "mean_degree", "mean_hops", "max_hops", "components", "routes"]

#: Most rows of a replay's hop table (every sample's routes, about 1 GB with the snapshots).
MAX_HOP_ROWS = 50_000_000


def summarise(snap: TopologySnapshot) -> dict:
    """Per-time summary of a snapshot: mean 1-hop degree, mean hop count over routed pairs,
    number of connected components of the 1-hop graph (isolated robots count), routed pairs."""
    one = snap.hops == 1
    adj = sp.csr_array(
        (np.ones(int(one.sum()), dtype=bool), (snap.owner[one], snap.dest[one])),
        shape=(snap.n_robots, snap.n_robots),
    )
    n_comp = csgraph.connected_components(adj, directed=True, connection="weak")[0]
    return {
        "t": snap.time,
        "mean_degree": float(one.sum()) / snap.n_robots,
        "mean_hops": float(snap.hops.mean()) if snap.n_entries else float("nan"),
        "max_hops": int(snap.hops.max()) if snap.n_entries else 0,
        "components": int(n_comp),
        "routes": snap.n_entries,
    }


@dataclass(frozen=True, eq=False)
class ReplayResult:
    """Routing tables sampled along a trace.

    Attributes
    ----------
    hops : DataFrame
        Columns ``t, node, dest, hops``: one row per reachable ``dest != node`` per sample.
    summary : DataFrame
        Columns ``t, mean_degree, mean_hops, max_hops, components, routes``, one row per sample.
    backend : str
        Name of the provider.
    failure : str or None
        Why the replay stopped before the trace's end (ns-3 aborted: the one-line
        :class:`~swarmgames.errors.Ns3CrashError`), with the samples taken until then; None
        for a replay that reached its end.
    """

    hops: pd.DataFrame
    summary: pd.DataFrame
    backend: str
    failure: str | None = None

    def plot(self):
        """Figure with mean degree, mean hop count and number of components against time."""
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(3, 1, sharex=True, figsize=(7, 6))
        s = self.summary
        for ax, col, label in zip(
            axes,
            ("mean_degree", "mean_hops", "components"),
            ("mean 1-hop degree", "mean hop count", "components"),
            strict=True,
        ):
            ax.plot(s["t"], s[col], drawstyle="steps-post")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        axes[-1].set_xlabel("time (s)")
        axes[0].set_title(f"network replay ({self.backend})")
        fig.tight_layout()
        return fig

    def write(self, run_folder) -> list[Path]:
        """Write ``hops.csv``, ``summary.csv`` and ``replay.png`` into a
        :class:`~swarmgames.runfolder.RunFolder` (or a folder path, created if needed)."""

        from swarmgames.runfolder import RunFolder

        run = RunFolder.of(run_folder)
        paths = [run.write_csv("hops.csv", self.hops), run.write_csv("summary.csv", self.summary)]
        paths.append(run.save_figure("replay.png", self.plot()))
        return paths


def check_sampling(trace: PositionTrace, sample_every, end: float | None = None) -> int:
    """The number of samples of a replay, checked before anything is allocated.

    Every sample keeps up to ``N (N - 1)`` routes, so the samples times that may hold at most
    :data:`MAX_HOP_ROWS` rows.

    Raises
    ------
    ValueError
        ``sample_every`` is not a positive finite number, ``end`` is before the trace's start,
        or the replay could hold more than :data:`MAX_HOP_ROWS` rows (the message names
        ``sample_every`` and the numbers).
    """
    ok = isinstance(sample_every, (int, float)) and not isinstance(sample_every, bool)
    if not (ok and np.isfinite(sample_every) and sample_every > 0):
        raise ValueError(f"sample_every must be > 0 (got {sample_every})")
    stop = trace.end if end is None else float(end)
    if not np.isfinite(stop) or stop < trace.start:
        raise ValueError(f"end must be >= the trace start {trace.start} (got {end})")
    samples = int(np.floor((stop - trace.start) / sample_every + 1e-9)) + 1
    routes = trace.n_robots * max(trace.n_robots - 1, 1)
    if samples * routes > MAX_HOP_ROWS:
        raise ValueError(
            f"sample_every must give at most {MAX_HOP_ROWS:,} hop rows: {samples:,} samples "
            f"over {stop - trace.start:g} s of up to {routes:,} routes each "
            f"({trace.n_robots} robots) (got sample_every = {sample_every:g} s); sample less "
            "often"
        )
    return samples


def _sample_times(start: float, end: float, every: float) -> np.ndarray:
    k = np.arange(int(np.floor((end - start) / every + 1e-9)) + 1)
    return np.round(start + k * every, 9)


def replay(
    trace: PositionTrace | str | Path,
    provider: NeighbourhoodProvider | str = "olsr",
    sample_every: float = 0.5,
    seed: int | np.random.Generator | None = None,
    out=None,
    config: NetworkConfig | None = None,
    end: float | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> ReplayResult:
    """Run a provider along a positions trace and sample every robot's routing table.

    Parameters
    ----------
    trace : PositionTrace, str or Path
        The trace, or a ``t,node,x,y,z`` CSV file to read (see :func:`read_positions`).
    provider : NeighbourhoodProvider or str, default "olsr"
        A provider, or a backend name (``olsr``, ``oracle``, ``disk``, ``knn``, ``ns3``) built
        with ``config`` (OLSR then runs with TCs so that routes of any length appear).
    sample_every : float, default 0.5
        Sampling period, seconds (> 0). Samples at ``start + k * sample_every`` up to the last
        time of the trace.
    seed : int, Generator or None
        Seed of the provider (when built here).
    out : RunFolder, str or Path, optional
        If given, write ``hops.csv``, ``summary.csv`` and ``replay.png`` there.
    config : NetworkConfig, optional
        Backend parameters when ``provider`` is a name.
    end : float, optional
        Stop at this time instead of the trace's last time.
    progress : callable, optional
        Called as ``progress(t, end)`` after each sample (for a progress bar).

    Returns
    -------
    ReplayResult
        If ns-3 aborts, the samples taken until then, with the reason in ``failure`` (and
        written to ``out``).

    Raises
    ------
    InputDataError
        For a malformed trace (the message names the line and column).
    ValueError
        See :func:`check_sampling`.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"t": [0.0, 0.0], "node": [0, 1], "x": [0.0, 100.0],
    ...                    "y": [0.0, 0.0], "z": [0.0, 0.0]})
    >>> res = replay(PositionTrace.from_frame(df), "oracle", end=1.0)
    >>> res.hops.to_dict("list")["hops"]
    [1, 1, 1, 1, 1, 1]
    """
    if not isinstance(trace, PositionTrace):
        trace = read_positions(trace)
    check_sampling(trace, sample_every, end)
    stop = trace.end if end is None else float(end)
    if isinstance(provider, str):
        cfg = (config or NetworkConfig()).model_copy(update={"backend": provider})
        provider = provider_from_config(cfg, trace.n_robots, seed, full_tables=True)
    samples = _sample_times(trace.start, stop, float(sample_every))
    changes = trace.times[(trace.times > trace.start) & (trace.times <= stop)]
    breaks = np.union1d(samples, changes)
    step = getattr(provider, "step", None)
    snap = provider.reset(trace.at(trace.start), trace.start)
    sample_set = set(samples.tolist())
    frames, rows = [], []
    if trace.start in sample_set:
        frames.append(snap)
    failure = None
    try:
        for t in breaks[breaks > trace.start]:
            held = trace.at(np.nextafter(t, -np.inf))
            if float(t) in sample_set:
                (step or provider.advance)(float(t), held)
                # The row starting at t holds at t (zero-length step: no OLSR events happen).
                frames.append(provider.advance(float(t), trace.at(t)))
                if progress is not None:
                    progress(float(t), stop)
            elif step is not None:
                step(float(t), held)
            else:
                provider.advance(float(t), held)
    except Ns3CrashError as exc:  # keep the samples taken
        failure = str(exc)
    for s in frames:
        rows.append(summarise(s))
    hops = pd.DataFrame(
        {
            "t": np.concatenate([np.full(s.n_entries, s.time) for s in frames]),
            # Compact dtypes: a 1 000-robot replay holds about a million rows per sample.
            "node": np.concatenate([s.owner for s in frames]).astype(np.int32),
            "dest": np.concatenate([s.dest for s in frames]).astype(np.int32),
            "hops": np.concatenate([s.hops for s in frames]).astype(np.int16),
        }
    )
    result = ReplayResult(hops, pd.DataFrame(rows, columns=SUMMARY_COLUMNS), provider.name, failure)
    if out is not None:
        result.write(out)
    return result
