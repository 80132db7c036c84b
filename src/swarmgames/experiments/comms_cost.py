"""``swarmgames reproduce comms-cost``: bytes per robot and stage of three ways to coordinate.

On the benchmark's constant-density coverage swarm (``scaled_config``: the ROI grows with N,
about 15 robots within 2 hops of each) and settled routing tables (the ``oracle`` provider:
what OLSR converges to), one control period costs each robot, in payload bytes it transmits:

(a) **local games** — every robot's state message flooded for h = 2 hops over the links that
    exist now (the routed communication layer, :mod:`swarmgames.comms`), sent and relayed;
(b) **a centralised controller** — every robot sends its state (``15 + 8 D`` bytes: the state
    message without N_j and S̄_j) hop by hop along its route to one controller (the robot
    nearest the swarm's centroid), which sends every robot its action (14 bytes: robot id,
    timestamp, action index) back along the same routes. The routes are the shortest-path
    tree of the 1-hop table links from the controller; a robot relays the messages of its
    whole subtree, up and down;
(c) **swarm-wide flooding** — every robot's full state message reaches the whole swarm: with
    duplicate suppression every robot of a connected component transmits each message of its
    component exactly once (checked against the simulated flood, :func:`flood`, in the tests).

Reported per N and seed: the mean and the maximum over the robots (a centralised
controller's bottleneck is the robots near it); :meth:`CommsCostResult.aggregate` averages
them over the seeds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.sparse as sp
from matplotlib.figure import Figure
from scipy.sparse import csgraph

from swarmgames.comms import RoutedComms, message_bytes
from swarmgames.comms.wire import HEADER_BYTES
from swarmgames.config import scaled_config
from swarmgames.errors import ConfigError

__all__ = ["ACTION_BYTES", "CommsCostResult", "centralised_bytes", "comms_cost", "flood_all_bytes"]

#: A centralised controller's action message: robot id (uint32), timestamp (float64),
#: action index (uint16).
ACTION_BYTES = 4 + 8 + 2
#: The default swarm sizes.
DEFAULT_SIZES = (10, 100, 1000, 10000)


def _one_hop(snapshot) -> sp.csr_array:
    one = np.asarray(snapshot.hops) == 1
    n = snapshot.n_robots
    return sp.csr_array(
        (
            np.ones(int(one.sum())),
            (np.asarray(snapshot.owner)[one], np.asarray(snapshot.dest)[one]),
        ),
        shape=(n, n),
    )


def centralised_bytes(snapshot, states: np.ndarray) -> np.ndarray:
    """Payload bytes each robot transmits in one period under a centralised controller
    (module notes, scheme b); robots that cannot reach the controller send nothing."""
    n, dim = states.shape
    leader = int(np.argmin(np.linalg.norm(states[:, :2] - states[:, :2].mean(axis=0), axis=1)))
    order, pred = csgraph.breadth_first_order(_one_hop(snapshot), leader, directed=False)
    depth = np.full(n, -1)
    depth[order] = csgraph.shortest_path(
        _one_hop(snapshot), directed=False, unweighted=True, indices=leader
    )[order].astype(int)
    below = np.zeros(n, dtype=np.int64)  # robots in each robot's subtree, itself excluded
    for d in range(int(depth.max(initial=0)), 0, -1):  # one numpy step per tree level
        at = np.flatnonzero(depth == d)
        np.add.at(below, pred[at], below[at] + 1)
    up = HEADER_BYTES + 8 * dim
    out = np.zeros(n, dtype=np.int64)
    member = depth > 0
    out[member] = (1 + below[member]) * up  # its own state and its subtree's, upwards
    out[depth >= 0] += below[depth >= 0] * ACTION_BYTES  # the subtree's actions, downwards
    return out


def flood_all_bytes(snapshot, sizes: np.ndarray) -> np.ndarray:
    """Payload bytes each robot transmits in one period when every message floods the whole
    swarm (module notes, scheme c): the sizes of all messages of its component."""
    _, label = csgraph.connected_components(_one_hop(snapshot), directed=False)
    total = np.bincount(label, weights=np.asarray(sizes, dtype=float))
    return total[label].astype(np.int64)


@dataclass(eq=False)
class CommsCostResult:
    """One row per (N, scheme, seed): ``mean_bytes``, ``max_bytes`` per robot and stage."""

    frame: pd.DataFrame

    def aggregate(self) -> pd.DataFrame:
        """Per (N, scheme): mean and sample standard deviation over the seeds."""
        grp = self.frame.groupby(["n_robots", "scheme"], sort=False)[["mean_bytes", "max_bytes"]]
        out = grp.agg(["mean", "std", "count"])
        out.columns = [f"{a}_{b}".replace("_count", "_n") for a, b in out.columns]
        return out.reset_index()

    def plot(self) -> Figure:
        """Bytes per robot and stage against N, log-log, mean (line) and maximum (dashed)."""
        fig = Figure(figsize=(6.5, 4.5), layout="constrained")
        ax = fig.subplots()
        agg = self.aggregate()
        for i, (scheme, grp) in enumerate(agg.groupby("scheme", sort=False)):
            ax.errorbar(
                grp["n_robots"],
                grp["mean_bytes_mean"],
                yerr=grp["mean_bytes_std"].fillna(0.0),
                fmt="o-",
                color=f"C{i}",
                capsize=3,
                label=scheme,
            )
            ax.plot(grp["n_robots"], grp["max_bytes_mean"], "--", color=f"C{i}", alpha=0.6)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("swarm size N")
        ax.set_ylabel("payload bytes per robot and stage (mean; dashed: max)")
        ax.legend(fontsize="small")
        return fig

    def write(self, folder) -> list:
        """Write ``comms_cost.csv`` (every seed), ``comms_cost_aggregate.csv`` and
        ``comms_cost.png`` into a RunFolder."""
        return [
            folder.write_csv("comms_cost.csv", self.frame),
            folder.write_csv("comms_cost_aggregate.csv", self.aggregate()),
            folder.save_figure("comms_cost.png", self.plot()),
        ]


def comms_cost(
    sizes: Sequence[int] = DEFAULT_SIZES, seeds: Sequence[int] = (0, 1, 2), hops: int = 2
) -> CommsCostResult:
    """Measure the three schemes (module notes) at every swarm size, on every seed (the
    take-off draw).

    Raises
    ------
    ConfigError
        Empty ``sizes`` or ``seeds``, or a size < 2.
    """
    from swarmgames.sim import build_mission
    from swarmgames.sim.providers import provider_from_config

    sizes = [int(n) for n in sizes]
    if not sizes or min(sizes) < 2:
        raise ConfigError(f"sizes must be swarm sizes >= 2 (got {sizes})")
    if not list(seeds):
        raise ConfigError("seeds must not be empty")
    rows = []
    for n, seed in ((n, int(s)) for n in sizes for s in seeds):
        cfg = scaled_config(n, backend="oracle").with_overrides({"network.hops": hops})
        rng = np.random.default_rng(seed)
        states = build_mission(cfg).initial_states(n, rng)
        provider = provider_from_config(cfg.network, n, rng)
        snap = provider.reset(states[:, :3], 0.0)
        comms = RoutedComms(n, states.shape[1], hops, provider.model)
        _, stats = comms.exchange(0.0, snap, states, rng)
        local = stats.bytes_sent + stats.bytes_forwarded
        full = message_bytes(states.shape[1], np.diff(snap.neighbourhood_matrix(hops).indptr))
        for scheme, b in (
            (f"local games ({hops}-hop routed flooding)", local),
            ("centralised controller (states up, actions down)", centralised_bytes(snap, states)),
            ("every state flooded to the whole swarm", flood_all_bytes(snap, full)),
        ):
            rows.append(
                {
                    "n_robots": n,
                    "seed": seed,
                    "scheme": scheme,
                    "mean_bytes": float(np.mean(b)),
                    "max_bytes": int(np.max(b)),
                }
            )
    return CommsCostResult(pd.DataFrame(rows))
