"""Record ns-3 OLSR routing tables on reference traces (the project's ns-3 test data).

Each scenario writes a folder ``<out>/<name>/`` with ``positions.csv`` (``t,node,x,y,z``; a row
holds from ``t`` until the node's next row), ``hops.csv`` (``t,node,dest,hops``; reachable
destinations only, every ``sample`` seconds) and ``meta.json``. The recordings let the built-in
OLSR model be checked against ns-3 on machines without ns-3.

Scenarios (seeded, so the positions are reproduced exactly; ns-3's own jitter draws depend on
its run number, recorded in ``meta.json``):

* ``static_7``, ``static_20``, ``static_50``: uniform random layouts in a square sized so that
  routes of several hops exist; 40 s, tables every 5 s.
* ``waypoint_20``: 20 UAVs flying random waypoints (speed 5-15 m/s, pauses 0-2 s) over
  1 km x 1 km at 30 m altitude for 150 s; positions every 0.5 s, tables every 1 s.
* ``hex_expand``: 7 UAVs, a centre and a ring of 6 whose radius holds at 100 m for 10 s, grows
  at 5 m/s to 500 m, shrinks back to 100 m and holds (180 s); positions every 0.1 s, tables
  every 0.5 s (docs/reference.md section 4).
* ``waypoint_20_fine``: the flight of ``waypoint_20`` with positions every 0.1 s (to 0.1 m),
  tables every 1 s, ten ns-3 runs (run numbers 1-10), stored like the ``fast_*`` folders.
* ``fast_20``, ``fast_30``, ``fast_40``: 20, 30 and 40 UAVs flying random waypoints at
  15-30 m/s (pauses 0-2 s) for 150 s over squares of 1000, 1225 and 1415 m (the density of
  ``waypoint_20``, routes of up to 6-7 hops); positions every 0.1 s (to 0.1 m),
  tables every 1 s, ten ns-3 runs each (run numbers 1-10). These folders hold xz-compressed
  ``positions.csv.xz`` and ``hops.csv.xz``, the latter with a leading ``run`` column; they
  measure the built-in OLSR model against ns-3's run-to-run spread (docs/ns3.md).

Usage::

    python -m swarmgames.experiments.record_ns3 --out tests/data/ns3/
    python -m swarmgames.experiments.record_ns3 --out DIR --only waypoint_20 --run 2
    python -m swarmgames.experiments.record_ns3 --out DIR --only fast_20 --run 1 2 3

References
----------
.. [1] docs/reference.md section 4 (measured ns-3 behaviour and the ``hex_expand`` recording).
.. [2] T. Camp, J. Boleng, V. Davies, "A survey of mobility models for ad hoc network
   research", WCMC 2002: the random waypoint model.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from swarmgames.experiments.replay import replay
from swarmgames.network.trace import PositionTrace

__all__ = [
    "SCENARIOS",
    "Scenario",
    "hex_expand",
    "main",
    "random_waypoint",
    "record",
    "static_layout",
]

#: Compression of the ``.csv.xz`` files. LZMA's large dictionary finds the repetition between
#: consecutive tables (about 5 times smaller than gzip here), and its output has no time stamp.
_XZ = {"method": "xz", "preset": 9}


def _frame(times: np.ndarray, pos: np.ndarray, decimals: int = 4) -> pd.DataFrame:
    t_count, n = pos.shape[:2]
    return pd.DataFrame(
        {
            "t": np.repeat(np.round(times, 6), n),
            "node": np.tile(np.arange(n), t_count),
            "x": np.round(pos[..., 0].ravel(), decimals),
            "y": np.round(pos[..., 1].ravel(), decimals),
            "z": np.round(pos[..., 2].ravel(), decimals),
        }
    )


def static_layout(n: int, side_m: float, duration_s: float, seed: int) -> pd.DataFrame:
    """``n`` robots uniform in a ``side_m`` square at 30 m altitude, still for ``duration_s``."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0.0, side_m, size=(n, 2))
    pos = np.column_stack([xy, np.full(n, 30.0)])
    return _frame(np.array([0.0, duration_s]), np.stack([pos, pos]))


def random_waypoint(
    n: int,
    side_m: float,
    duration_s: float,
    dt: float,
    seed: int,
    speed_m_s: tuple[float, float] = (5.0, 15.0),
    pause_s: tuple[float, float] = (0.0, 2.0),
    decimals: int = 4,
) -> pd.DataFrame:
    """Random-waypoint flight of ``n`` UAVs in a ``side_m`` square, sampled every ``dt`` s.

    Each UAV flies straight to a uniform random waypoint at a uniform random speed, pauses for a
    uniform random time, and repeats (Camp et al. 2002). Positions are rounded to ``decimals``
    decimal places of a metre.
    """
    rng = np.random.default_rng(seed)
    times = np.round(np.arange(0.0, duration_s + dt / 2, dt), 9)
    pos = np.empty((times.size, n, 3))
    pos[..., 2] = 30.0
    for i in range(n):  # legs per UAV are sequential by nature
        knots_t, knots_xy = [0.0], [rng.uniform(0, side_m, 2)]
        while knots_t[-1] < duration_s:
            goal = rng.uniform(0, side_m, 2)
            leg = np.linalg.norm(goal - knots_xy[-1]) / rng.uniform(*speed_m_s)
            knots_t.append(knots_t[-1] + leg)
            knots_xy.append(goal)
            knots_t.append(knots_t[-1] + rng.uniform(*pause_s))
            knots_xy.append(goal)
        kt, kxy = np.array(knots_t), np.array(knots_xy)
        pos[:, i, 0] = np.interp(times, kt, kxy[:, 0])
        pos[:, i, 1] = np.interp(times, kt, kxy[:, 1])
    return _frame(times, pos, decimals)


def hex_expand(duration_s: float = 180.0, dt: float = 0.1) -> pd.DataFrame:
    """Centre plus a ring of 6 whose radius is 100 m until 10 s, grows at 5 m/s to 500 m at
    90 s, shrinks back to 100 m at 170 s and holds until ``duration_s``."""
    times = np.round(np.arange(0.0, duration_s + dt / 2, dt), 9)
    radius = np.interp(times, [0, 10, 90, 170, max(duration_s, 170)], [100, 100, 500, 100, 100])
    angle = np.deg2rad(60.0 * np.arange(6))
    pos = np.zeros((times.size, 7, 3))
    pos[:, 1:, 0] = radius[:, None] * np.cos(angle)
    pos[:, 1:, 1] = radius[:, None] * np.sin(angle)
    return _frame(times, pos)


@dataclass(frozen=True)
class Scenario:
    """A recording scenario.

    Attributes
    ----------
    positions : callable
        Returns the ``t,node,x,y,z`` frame of the trace (seeded: the same frame every call).
    sample : float
        Sampling period of the tables, seconds.
    runs : tuple of int, default (1,)
        ns-3 run numbers recorded by default. With more than one, ``hops`` gets a leading
        ``run`` column.
    compressed : bool, default False
        Write xz-compressed ``positions.csv.xz`` and ``hops.csv.xz`` instead of plain CSV.
    """

    positions: Callable[[], pd.DataFrame]
    sample: float
    runs: tuple[int, ...] = (1,)
    compressed: bool = False


def _fast(n: int, side_m: float, seed: int) -> Scenario:
    def positions() -> pd.DataFrame:
        return random_waypoint(n, side_m, 150.0, 0.1, seed, (15.0, 30.0), (0.0, 2.0), decimals=1)

    return Scenario(positions, 1.0, runs=tuple(range(1, 11)), compressed=True)


def _fine_waypoint_20() -> pd.DataFrame:
    # The waypoint_20 flight (its seed draws the same legs) sampled every 0.1 s.
    return random_waypoint(20, 1000.0, 150.0, 0.1, seed=2005, decimals=1)


SCENARIOS: dict[str, Scenario] = {
    "static_7": Scenario(lambda: static_layout(7, 800.0, 40.0, seed=7), 5.0),
    "static_20": Scenario(lambda: static_layout(20, 1200.0, 40.0, seed=20), 5.0),
    "static_50": Scenario(lambda: static_layout(50, 1800.0, 40.0, seed=50), 5.0),
    "waypoint_20": Scenario(lambda: random_waypoint(20, 1000.0, 150.0, 0.5, seed=2005), 1.0),
    "hex_expand": Scenario(lambda: hex_expand(180.0, 0.1), 0.5),
    "waypoint_20_fine": Scenario(_fine_waypoint_20, 1.0, runs=tuple(range(1, 11)), compressed=True),
    "fast_20": _fast(20, 1000.0, seed=3020),
    "fast_30": _fast(30, 1225.0, seed=3030),
    "fast_40": _fast(40, 1415.0, seed=3040),
}


def record(name: str, out: Path, run: int | tuple[int, ...] | None = None) -> Path:
    """Record scenario ``name`` with ns-3 run number(s) ``run`` into ``out/name``.

    ``run`` defaults to the scenario's :attr:`Scenario.runs`. Several runs are replayed one
    after the other in this process (ns-3's streams are fixed per run, so the result does not
    depend on the order) and stored in one ``hops`` table with a leading ``run`` column.
    """
    from swarmgames.network.ns3_backend import Ns3Provider

    scenario = SCENARIOS[name]
    runs = scenario.runs if run is None else (run,) if isinstance(run, int) else tuple(run)
    positions = scenario.positions()
    trace = PositionTrace.from_frame(positions)
    start = time.perf_counter()
    tables = []
    for k in runs:
        with Ns3Provider(n_robots=trace.n_robots, run=k) as provider:
            hops = replay(trace, provider, scenario.sample).hops
        tables.append(hops.assign(run=k)[["run", *hops.columns]] if len(runs) > 1 else hops)
    wall = time.perf_counter() - start
    folder = out / name
    folder.mkdir(parents=True, exist_ok=True)
    ext, compression = (".csv.xz", _XZ) if scenario.compressed else (".csv", None)
    positions.to_csv(folder / f"positions{ext}", index=False, compression=compression)
    hops = pd.concat(tables, ignore_index=True)
    hops.to_csv(folder / f"hops{ext}", index=False, compression=compression)
    from importlib.metadata import version

    meta = {
        "kind": name,
        "t_end": float(trace.times[-1]),
        "dt": round(float(np.min(np.diff(trace.times))), 9),
        "sample": scenario.sample,
        **({"run": runs[0]} if len(runs) == 1 else {"runs": list(runs)}),
        "ns3": version("ns3"),
        "standard": "802.11a",
        "rate": "OfdmRate6Mbps",
        "loss": "Friis 5.15 GHz",
        "tx_dbm": 16.0206,
        "rx_gate_dbm": -82,
        "geometric_range_m": 368.84,
        "olsr": "ns-3 defaults",
        "ns3_wall_s": round(wall, 2),
        "command": f"python -m swarmgames.experiments.record_ns3 --out {out} --only {name} "
        f"--run {' '.join(map(str, runs))}",
    }
    (folder / "meta.json").write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    return folder


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m swarmgames.experiments.record_ns3", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--out", type=Path, required=True, help="folder to write recordings into")
    parser.add_argument(
        "--only", nargs="+", choices=sorted(SCENARIOS), help="record only these scenarios"
    )
    parser.add_argument(
        "--run",
        type=int,
        nargs="+",
        help="ns-3 run number(s) (default: the scenario's, 1 or 1-10 for the fast_* scenarios)",
    )
    args = parser.parse_args(argv)
    bad = [k for k in args.run or () if k < 1]
    if bad:
        parser.error(f"--run must be >= 1 (got {bad[0]})")
    for name in args.only or list(SCENARIOS):
        folder = record(name, args.out, None if args.run is None else tuple(args.run))
        print(f"recorded {name} -> {folder}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
