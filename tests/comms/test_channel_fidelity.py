"""The shared channel against ns-3's packets, on the committed recordings.

``tests/data/channel/<trace>/`` holds, per trace, ns-3 3.44's routing tables at every stage
time and its delivery by hop of the state messages as UDP broadcasts (five ns-3 runs each,
recorded by ``python -m swarmgames.experiments.channel_record``: 40 ms jitter, h = 2, the
decision 0.1 s after the stage time; 20 to 80 UAVs, 5 to 17 one-hop neighbours, static and
moving). The built-in ``csma`` model replays the same tables at the same positions
(:func:`~swarmgames.experiments.comms_replay.replay_recording`) and must deliver, at every
hop distance, within 3 points of ns-3's median at 1 hop and 6 points at 2 hops; it must
reproduce ns-3's fall with density; its age on arrival must lie within ns-3's spread over
its runs, widened by 2 ms (docs/comms.md, "Fidelity against ns-3").
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import pandas as pd
import pytest

from swarmgames.experiments.comms_replay import replay_recording

CHANNEL = Path(__file__).parent.parent / "data" / "channel"
TRACES = sorted(p.name for p in CHANNEL.iterdir() if (p / "delivery.csv").is_file())
#: Largest gap to ns-3's median delivery, points, at 1 and 2 hops (the issue's goal).
TOLERANCE = {1: 3.0, 2: 6.0}
#: Milliseconds the mean age on arrival may lie outside ns-3's range over its runs.
AGE_SLACK_MS = 2.0


@cache
def _replayed(trace: str) -> pd.DataFrame:
    return replay_recording(CHANNEL / trace)


def _ns3(trace: str) -> pd.DataFrame:
    return pd.read_csv(CHANNEL / trace / "delivery.csv")


def test_the_recordings_span_the_densities_and_sizes_of_the_goal():
    sizes, degrees, moving = [], [], []
    for trace in TRACES:
        meta = json.loads((CHANNEL / trace / "meta.json").read_text())
        assert len(meta["runs"]) >= 5
        hops = pd.read_csv(CHANNEL / trace / "hops.csv.xz")
        n = int(hops["node"].max()) + 1
        one = hops[hops["hops"] == 1]
        sizes.append(n)
        degrees.append(len(one) / (hops.groupby(["run", "t"]).ngroups * n))
        pos = pd.read_csv(CHANNEL / trace / "positions.csv")
        moving.append(pos["t"].nunique() > 2)
    assert min(sizes) <= 20 and max(sizes) >= 80
    assert min(degrees) <= 5.0 and max(degrees) >= 16.0
    assert any(moving) and not all(moving)


@pytest.mark.parametrize("trace", TRACES)
def test_delivery_by_hop_is_within_the_tolerance_of_ns3s_median(trace):
    ours = _replayed(trace).groupby("hops")["ratio"].median()
    ns3 = _ns3(trace).groupby("hops")["ratio"].median()
    for hops, tol in TOLERANCE.items():
        gap = 100 * abs(ours[hops] - ns3[hops])
        want = f"ns-3's {100 * ns3[hops]:.1f} %"
        assert gap <= tol, f"{trace}, {hops} hop(s): {100 * ours[hops]:.1f} % against {want}"


@pytest.mark.parametrize("trace", TRACES)
def test_age_on_arrival_lies_within_ns3s_range(trace):
    ours = _replayed(trace).groupby("hops")["mean_age_ms"].median()
    ns3 = _ns3(trace).groupby("hops")["mean_age_ms"]
    lo, hi = ns3.min(), ns3.max()
    for hops in TOLERANCE:
        assert lo[hops] - AGE_SLACK_MS <= ours[hops] <= hi[hops] + AGE_SLACK_MS, (
            f"{trace}, {hops} hop(s): {ours[hops]:.1f} ms against ns-3's "
            f"{lo[hops]:.1f}-{hi[hops]:.1f} ms"
        )


def test_ns3s_fall_with_density_is_reproduced():
    static = [t for t in TRACES if t.startswith("static")]
    ns3 = {t: _ns3(t).groupby("hops")["ratio"].median()[2] for t in static}
    ours = {t: _replayed(t).groupby("hops")["ratio"].median()[2] for t in static}
    by_ns3 = sorted(static, key=ns3.get)
    assert by_ns3 == sorted(static, key=ours.get)
