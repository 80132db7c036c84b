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

Usage::

    python -m swarmgames.experiments.record_ns3 --out tests/data/ns3/
    python -m swarmgames.experiments.record_ns3 --out DIR --only waypoint_20 --run 2

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
from pathlib import Path

import numpy as np
import pandas as pd

from swarmgames.experiments.replay import replay
from swarmgames.network.trace import PositionTrace

__all__ = ["SCENARIOS", "hex_expand", "main", "random_waypoint", "record", "static_layout"]


def _frame(times: np.ndarray, pos: np.ndarray) -> pd.DataFrame:
    t_count, n = pos.shape[:2]
    return pd.DataFrame(
        {
            "t": np.repeat(np.round(times, 6), n),
            "node": np.tile(np.arange(n), t_count),
            "x": np.round(pos[..., 0].ravel(), 4),
            "y": np.round(pos[..., 1].ravel(), 4),
            "z": np.round(pos[..., 2].ravel(), 4),
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
) -> pd.DataFrame:
    """Random-waypoint flight of ``n`` UAVs in a ``side_m`` square, sampled every ``dt`` s.

    Each UAV flies straight to a uniform random waypoint at a uniform random speed, pauses for a
    uniform random time, and repeats (Camp et al. 2002).
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
    return _frame(times, pos)


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


#: name -> (positions factory, sampling period of the tables in seconds)
SCENARIOS: dict[str, tuple[Callable[[], pd.DataFrame], float]] = {
    "static_7": (lambda: static_layout(7, 800.0, 40.0, seed=7), 5.0),
    "static_20": (lambda: static_layout(20, 1200.0, 40.0, seed=20), 5.0),
    "static_50": (lambda: static_layout(50, 1800.0, 40.0, seed=50), 5.0),
    "waypoint_20": (lambda: random_waypoint(20, 1000.0, 150.0, 0.5, seed=2005), 1.0),
    "hex_expand": (lambda: hex_expand(180.0, 0.1), 0.5),
}


def record(name: str, out: Path, run: int = 1) -> Path:
    """Record scenario ``name`` with ns-3 run number ``run`` into ``out/name``."""
    from swarmgames.network.ns3_backend import Ns3Provider

    factory, sample = SCENARIOS[name]
    positions = factory()
    trace = PositionTrace.from_frame(positions)
    provider = Ns3Provider(n_robots=trace.n_robots, run=run)
    start = time.perf_counter()
    hops = replay(trace, provider, sample).hops
    wall = time.perf_counter() - start
    provider.close()
    folder = out / name
    folder.mkdir(parents=True, exist_ok=True)
    positions.to_csv(folder / "positions.csv", index=False)
    hops.to_csv(folder / "hops.csv", index=False)
    from importlib.metadata import version

    meta = {
        "kind": name,
        "t_end": float(trace.times[-1]),
        "dt": float(np.min(np.diff(trace.times))),
        "sample": sample,
        "run": run,
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
        f"--run {run}",
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
    parser.add_argument("--run", type=int, default=1, help="ns-3 run number (default 1)")
    args = parser.parse_args(argv)
    if args.run < 1:
        parser.error(f"--run must be >= 1 (got {args.run})")
    for name in args.only or list(SCENARIOS):
        folder = record(name, args.out, args.run)
        print(f"recorded {name} -> {folder}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
