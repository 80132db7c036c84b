"""Coverage at scale: the communication-aware game against its own ablation and Lloyd.

The coverage mission at constant density (the ``coverage-large`` preset, which derives its
ROI and take-off disc from ``swarm.n_robots``) for every swarm size, seed and controller:

* ``game``: the preset as it is (local graphical games with the preset's link term, link
  keeping);
* ``game-nolink``: the same games without the communication-aware link term
  (``coverage.link_term = "off"``): the pairwise term keeps the crowding penalty alone, so
  the variant differs from ``game`` by the link term and nothing else;
* ``lloyd``: the Lloyd/Voronoi baseline of the coverage mission (``sim.controller =
  "lloyd"``, centralised states, no game).

:func:`reproduce_coverage_scale` runs them on the sweep machinery (:func:`swarmgames.sweep`,
one sweep per size with the three variants as zipped factors, each resumable) and measures
every complete run from its folder (:func:`run_measures`). The study's folder holds
``runs.csv`` (one row per run), ``aggregate.csv`` (mean, standard deviation, n and
Student-t 95 % interval per size and variant, and of the paired differences),
``paired.csv`` (per size and seed, ``game - lloyd`` and ``game - game-nolink``) and
``coverage-scale.png`` (:func:`~swarmgames.experiments.coverage_scale_plot.plot_coverage_scale`).

Notes
-----
Links are the radio's one-hop links at the recorded positions (``trajectory.csv``): the pairs
whose mean received power reaches the reception threshold (the radio's deterministic range,
368.84 m for the preset's Friis link; shadowing and fading, when configured, are left out).
``links_lost`` is :math:`|E_0 \\setminus E_T|`, the links of the take-off positions that the
final positions no longer hold. It counts the communication the mission destroyed: links
broken and formed again later in the run do not count (summing the links broken between
consecutive stages would count such flicker and grow with the number of stages), and new
links do not make up for lost ones (they join other pairs). ``links_lost_share`` divides it
by :math:`|E_0|`, comparable across sizes. ``components_start``, ``components_end`` and
``max_hops_end`` are the run's own figures of its first and last stage (``swarm`` table and
``summary.json``: connected components and longest shortest path of the 1-hop links of the
routing tables, :func:`swarmgames.sim.loop.swarm_graph_stats`).

Between the first and the last stage a swarm can come apart and join again, which neither
end shows. ``spanning_links_lost`` sums, over consecutive stages t, t + 1, the links of the
relative neighbourhood graph [2]_ of stage t's links (those no third robot is closer to both
ends of, :func:`swarmgames.missions.geometry.relative_neighbours`) that stage t + 1 no
longer holds: that graph holds a minimum spanning tree of each component, so these are the
losses that put connectivity at stake, where most other links may go at no cost to it.
``splits`` sums, over the same steps, how many more components of stage t + 1 the robots of
each component of stage t fall into: the times a connected group actually came apart.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), eqs. 1, 5, 6.
.. [2] G. T. Toussaint, "The relative neighbourhood graph of a finite planar set", Pattern
   Recognition 12(4), 1980.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd

from swarmgames.config import ScenarioConfig, resolve_scenario
from swarmgames.config.io import apply_overrides, to_data
from swarmgames.errors import ConfigError

__all__ = [
    "COMPARISONS",
    "DEFAULT_SIZES",
    "HEADLINE",
    "MEASURES",
    "SCENARIO",
    "VARIANTS",
    "VARIANT_OVERRIDES",
    "CoverageScaleResult",
    "reproduce_coverage_scale",
    "run_connectivity",
    "run_measures",
    "trajectory_stages",
]

#: The built-in scenario the study starts from.
SCENARIO = "coverage-large"
#: Swarm sizes of the study.
DEFAULT_SIZES = (7, 100, 1000, 10000)
#: The controllers compared (module notes).
VARIANTS = ("game", "game-nolink", "lloyd")
#: Paired differences, ``(minuend, subtrahend)``, on the same size and seed.
COMPARISONS = (("game", "lloyd"), ("game", "game-nolink"))
#: Per-run measures, in the order of ``runs.csv`` (docs/results.md, "Coverage at scale").
MEASURES = (
    "coverage_start_dbm",
    "coverage_end_dbm",
    "coverage_gain_db",
    "components_start",
    "components_end",
    "max_hops_end",
    "links_start",
    "links_end",
    "links_lost",
    "links_lost_share",
    "spanning_links_lost",
    "splits",
    "median_stage_s",
    "bytes_per_robot_stage",
    "olsr_bytes_per_robot_stage",
)
#: The measures the command prints per size and variant.
HEADLINE = ("coverage_end_dbm", "components_end", "links_lost")
#: Where each size's sweep lives inside the study's folder.
SIZE_FOLDER = "n{n}"
#: What a study was asked, written before its first run; the same study resumes into it.
STUDY_FILE = "study.json"
#: The figure of the study.
FIGURE = "coverage-scale.png"
KEYS = ("n_robots", "variant")


#: The configuration fields each variant sets on the base scenario (module notes).
VARIANT_OVERRIDES: Mapping[str, Mapping[str, Any]] = MappingProxyType(
    {
        "game": {},
        "game-nolink": {"coverage.link_term": "off"},
        "lloyd": {"sim.controller": "lloyd"},
    }
)


def _zipped_factors(base: ScenarioConfig, variants: Sequence[str]) -> dict[str, list[Any]]:
    """The variants as zipped sweep factors: every field some variant sets, at each variant's
    value (the base's where the variant leaves it)."""
    data = to_data(base)
    paths = dict.fromkeys(p for v in variants for p in VARIANT_OVERRIDES[v])
    factors = {}
    for path in paths:
        section, field = path.split(".")
        factors[path] = [VARIANT_OVERRIDES[v].get(path, data[section][field]) for v in variants]
    return factors


def _link_keys(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Links ``(i, j)``, ``i < j``, of ``n`` robots as sorted keys ``i * n + j``."""
    return np.sort(i.astype(np.int64) * np.int64(n) + j)


def trajectory_stages(trajectory: pd.DataFrame) -> list[np.ndarray]:
    """The positions ``(N, 3)`` of every stage of a ``trajectory`` table, in time order (the
    robots in id order)."""
    ordered = trajectory.sort_values(["t", "robot"], kind="stable")
    bounds = np.flatnonzero(np.diff(ordered["t"].to_numpy())) + 1
    return np.split(ordered[["x", "y", "z"]].to_numpy(dtype=float), bounds)


def run_connectivity(stages: Sequence[np.ndarray], model) -> dict[str, float]:
    """What the run did to its links from one stage to the next (module notes).

    Parameters
    ----------
    stages : sequence of ndarray, shape (N, 3)
        The robots' positions at every stage, in order, metres.
    model : PropagationModel
        The radio (a deterministic one: the links are the pairs within its range).

    Returns
    -------
    dict
        ``links_start``, ``links_end``, ``links_lost`` (the take-off links the end no longer
        holds), ``spanning_links_lost`` (the links of each stage's relative neighbourhood
        graph that the next stage no longer holds, summed over the stages) and ``splits``
        (the connected groups of a stage that the next stage holds in more than one
        component, counted once for every extra component, summed over the stages).
    """
    from scipy.sparse.csgraph import connected_components

    from swarmgames.missions.geometry import relative_neighbours
    from swarmgames.network.links import link_graph

    graphs = [link_graph(pos, model) for pos in stages]
    keys = [_link_keys(g.n_robots, g.i, g.j) for g in graphs]
    labels = [connected_components(g.adjacency(), directed=False)[1] for g in graphs]
    spanning_lost = splits = 0
    for t in range(len(stages) - 1):
        g = graphs[t]
        kept = relative_neighbours(stages[t], g.i, g.j, g.indptr, g.indices)
        span = _link_keys(g.n_robots, g.i[kept], g.j[kept])
        spanning_lost += int(np.setdiff1d(span, keys[t + 1], assume_unique=True).size)
        before, after = labels[t], labels[t + 1]
        groups = np.unique(before.astype(np.int64) * (after.max() + 1) + after).size
        splits += groups - np.unique(before).size
    start, end = keys[0], keys[-1]
    return {
        "links_start": float(start.size),
        "links_end": float(end.size),
        "links_lost": float(np.setdiff1d(start, end, assume_unique=True).size),
        "spanning_links_lost": float(spanning_lost),
        "splits": float(splits),
    }


def run_measures(folder: str | Path, config: ScenarioConfig) -> dict[str, float]:
    """The measures of one complete run, read from its run folder (module notes).

    Parameters
    ----------
    folder : str or Path
        A complete run folder (``summary.json`` and the ``swarm`` and ``trajectory``
        tables).
    config : ScenarioConfig
        The run's configuration (its radio defines the links).

    Returns
    -------
    dict
        :data:`MEASURES`: coverage at the start and end (dBm) and the gain (dB), components
        at the first stage, components and longest route (hops) at the last stage, radio
        links at take-off and at the end, links lost and their share of the take-off links
        (NaN without take-off links), relative neighbour links lost and component splits
        from stage to stage (:func:`run_connectivity`), the median wall time of a stage (s),
        and game and OLSR payload bytes sent and relayed per robot and stage.

    Raises
    ------
    InputDataError
        The folder's ``swarm`` or ``trajectory`` table cannot be read.
    """
    import json

    from swarmgames.network.parameters import RadioParameters
    from swarmgames.network.propagation import PropagationModel
    from swarmgames.sim.tables import read_table

    folder = Path(folder)
    summary = json.loads((folder / "summary.json").read_text(encoding="utf-8"))
    swarm = read_table(folder, "swarm")
    radio = config.network.radio.model_dump() | {"shadowing_sigma_db": 0.0, "nakagami_m": None}
    model = PropagationModel(RadioParameters(**radio))
    links = run_connectivity(trajectory_stages(read_table(folder, "trajectory")), model)
    lost = links["links_lost"]
    return {
        "coverage_start_dbm": float(summary["coverage_start_dbm"]),
        "coverage_end_dbm": float(summary["coverage_end_dbm"]),
        "coverage_gain_db": float(summary["coverage_end_dbm"] - summary["coverage_start_dbm"]),
        "components_start": float(swarm["components"].iloc[0]),
        "components_end": float(summary["components_end"]),
        "max_hops_end": float(summary["max_hops_end"]),
        "links_start": links["links_start"],
        "links_end": links["links_end"],
        "links_lost": lost,
        "links_lost_share": lost / links["links_start"] if links["links_start"] else float("nan"),
        "spanning_links_lost": links["spanning_links_lost"],
        "splits": links["splits"],
        "median_stage_s": float(summary["median_stage_ms"]) / 1e3,
        "bytes_per_robot_stage": float(summary["bytes_per_robot_stage"]),
        "olsr_bytes_per_robot_stage": float(summary["olsr_bytes_per_robot_stage"]),
    }


@dataclass(frozen=True, eq=False)
class CoverageScaleResult:
    """The study's runs.

    Attributes
    ----------
    runs : DataFrame
        One row per run: ``n_robots``, ``variant``, ``seed``, ``status``, ``error``,
        ``folder`` (relative to the study's folder), then :data:`MEASURES` (NaN unless the
        run is complete).
    config : ScenarioConfig
        The base scenario (before each size and variant).
    """

    runs: pd.DataFrame
    config: ScenarioConfig

    @property
    def interrupted(self) -> bool:
        """A signal stopped the study before every run finished."""
        return bool((self.runs["status"] == "interrupted").any())

    def paired(self) -> pd.DataFrame:
        """Per size, comparison of :data:`COMPARISONS` and seed where both runs are complete:
        ``n_robots``, ``comparison`` (``"game - lloyd"``), ``seed`` and every measure's
        difference (minuend minus subtrahend)."""
        done = self.runs[self.runs["status"] == "complete"]
        frames = []
        for a, b in COMPARISONS:
            left = done[done["variant"] == a].set_index(["n_robots", "seed"])[list(MEASURES)]
            right = done[done["variant"] == b].set_index(["n_robots", "seed"])[list(MEASURES)]
            both = left.index.intersection(right.index, sort=False)
            if len(both) == 0:
                continue
            diff = (left.loc[both] - right.loc[both]).reset_index()
            diff.insert(1, "comparison", f"{a} - {b}")
            frames.append(diff)
        if not frames:
            return pd.DataFrame(columns=["n_robots", "comparison", "seed", *MEASURES])
        return pd.concat(frames, ignore_index=True).sort_values(
            ["n_robots", "comparison", "seed"], kind="stable", ignore_index=True
        )

    def aggregate(self) -> pd.DataFrame:
        """Mean, std, n and 95 % interval of every measure over the seeds, per size and
        variant, then per size and comparison of :meth:`paired` (``variant`` ``"game -
        lloyd"``): ``n_robots``, ``variant``, ``metric``, ``n``, ``mean``, ``std``,
        ``ci_low``, ``ci_high``."""
        from swarmgames.experiments.sweep.stats import describe

        done = self.runs[self.runs["status"] == "complete"]
        runs = describe(done[[*KEYS, *MEASURES]], list(KEYS), list(MEASURES))
        paired = self.paired().rename(columns={"comparison": "variant"})
        diffs = describe(paired[[*KEYS, *MEASURES]], list(KEYS), list(MEASURES))
        return pd.concat([runs, diffs], ignore_index=True).sort_values(
            ["n_robots"], kind="stable", ignore_index=True
        )

    def write(self, folder) -> list[Path]:
        """``runs.csv``, ``aggregate.csv``, ``paired.csv``, the base ``config.toml`` and,
        once a run is complete, ``coverage-scale.png``."""
        from swarmgames.config import to_toml

        aggregate = self.aggregate()
        files = [
            folder.write_csv("runs.csv", self.runs),
            folder.write_csv("aggregate.csv", aggregate),
            folder.write_csv("paired.csv", self.paired()),
            folder.write_text("config.toml", to_toml(self.config)),
        ]
        if (self.runs["status"] == "complete").any():
            from swarmgames.experiments.coverage_scale_plot import plot_coverage_scale

            files.append(folder.save_figure(FIGURE, plot_coverage_scale(aggregate, self.runs)))
        return files


def reproduce_coverage_scale(
    out: str | Path,
    *,
    sizes: Sequence[int] = DEFAULT_SIZES,
    seeds: Sequence[int] = (0, 1, 2, 3, 4),
    variants: Sequence[str] = VARIANTS,
    base: ScenarioConfig | None = None,
    jobs: int | None = None,
    executor: str = "local",
    address: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> CoverageScaleResult:
    """Run the study: every size × variant × seed, one sweep per size under ``out``.

    Parameters
    ----------
    out : str or Path
        The study's folder: ``study.json``, ``out/n<N>/`` the sweep of N UAVs, and the
        files of :meth:`CoverageScaleResult.write` (of the runs asked for this time).
        Running the study into it again resumes it: complete runs are read, not run, also
        when sizes or seeds were added.
    sizes : sequence of int
        Swarm sizes, distinct integers >= 1 (default :data:`DEFAULT_SIZES`).
    seeds : sequence of int
        Seeds of every size and variant, distinct integers >= 0 (default 0-4).
    variants : sequence of str
        Some of :data:`VARIANTS` (default all), in that order.
    base : ScenarioConfig, optional
        A coverage scenario at constant density (``coverage.area_per_robot_m2`` set; default
        the built-in ``coverage-large``).
    jobs, executor, address
        As :func:`swarmgames.sweep`.
    progress : callable, optional
        Called as ``progress(done, total)`` after each size's sweep, in runs.

    Returns
    -------
    CoverageScaleResult

    Raises
    ------
    ConfigError
        Bad sizes, seeds or variants, a base that is not a coverage scenario at constant
        density, or a combination the schema rejects, before anything runs.
    RunFolderError
        ``out`` holds something other than this study.
    """
    from swarmgames.experiments.sweep import sweep
    from swarmgames.experiments.sweep.grid import factors_from_mapping, plan_sweep, study_levels

    base = resolve_scenario(SCENARIO) if base is None else base
    if base.scenario != "coverage":
        raise ConfigError(
            f"scenario: coverage-scale runs the coverage mission (got {base.scenario!r})"
        )
    if base.mission.area_per_robot_m2 is None:
        raise ConfigError(
            "coverage.area_per_robot_m2: coverage-scale keeps the density of the swarm, so it "
            "must be set (got None)"
        )
    sizes = study_levels(sizes, "sizes")
    if not all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in sizes):
        raise ConfigError(f"sizes: must be integers >= 1 (got {sizes!r})")
    variants = study_levels(variants, "variants")
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        raise ConfigError(f"variants: must be some of {', '.join(VARIANTS)} (got {unknown[0]!r})")
    variants = tuple(v for v in VARIANTS if v in variants)
    seeds = study_levels(seeds, "seeds")
    factors = _zipped_factors(base, variants)
    configs = {
        n: apply_overrides(base, {"swarm.n_robots": n}, source=f"{base.name} for {n} UAVs")
        for n in sizes
    }
    plans = {n: plan_sweep(configs[n], factors_from_mapping(factors), seeds, True) for n in sizes}
    folder = _open_root(Path(out), base, sizes, seeds, variants)
    frames = []
    total = len(sizes) * len(variants) * len(seeds)
    for n in sizes:
        frame = sweep(
            configs[n],
            factors,
            seeds,
            zip=True,
            jobs=jobs,
            executor=executor,  # type: ignore[arg-type]
            address=address,
            out=Path(out) / SIZE_FOLDER.format(n=n),
            metrics=[],  # the study draws its own figure
        )
        frames.append(_rows(n, frame, plans[n], variants, Path(out)))
        if progress is not None:
            progress(sum(len(f) for f in frames), total)
        if (frame["status"] == "interrupted").any():
            break  # a signal stopped this size's sweep: the larger sizes do not start
    runs = pd.concat(frames, ignore_index=True)
    runs.attrs["rerun"] = {k: v for f in frames for k, v in f.attrs.get("rerun", {}).items()}
    result = CoverageScaleResult(runs=runs, config=base)
    result.write(folder)
    return result


def _rows(n: int, frame: pd.DataFrame, plan, variants, root: Path) -> pd.DataFrame:
    """The study's rows of one size's sweep (its results in grid order: the variants in
    order, the seeds innermost), each complete run measured from its folder."""
    size = SIZE_FOLDER.format(n=n)
    rows = []
    for k, (point, rec) in enumerate(zip(plan.points, frame.to_dict("records"), strict=True)):
        folder = f"{size}/{rec['folder']}"
        row: dict[str, Any] = {
            "n_robots": n,
            "variant": variants[k // len(plan.seeds)],
            "seed": rec["seed"],
            "status": rec["status"],
            "error": rec["error"],
            "folder": folder,
        }
        measured: Mapping[str, float] = {}
        if rec["status"] == "complete":
            measured = run_measures(root / folder, point.config)
        rows.append(row | {m: measured.get(m, float("nan")) for m in MEASURES})
    out = pd.DataFrame(rows)
    out.attrs["rerun"] = {f"{size}/{k}": v for k, v in frame.attrs.get("rerun", {}).items()}
    return out


def _open_root(root: Path, base: ScenarioConfig, sizes, seeds, variants):
    """The study's folder, with ``study.json`` (what was asked) written first. A study of the
    same scenario may come back with other sizes, seeds or variants (the runs it shares are
    read, not run); a folder that holds a study of another scenario, or something else, is
    refused before anything runs."""
    import json

    from swarmgames.config import to_toml
    from swarmgames.errors import RunFolderError
    from swarmgames.runfolder import RunFolder

    spec = {
        "study": "coverage-scale",
        "sizes": list(sizes),
        "seeds": list(seeds),
        "variants": list(variants),
        "config": to_toml(base),
    }
    marker = root / STUDY_FILE
    if marker.exists():
        try:
            held = json.loads(marker.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            held = None
        if not isinstance(held, dict) or held.get("config") != spec["config"]:
            raise RunFolderError(
                f"{root} holds a coverage-scale study of another scenario (its {STUDY_FILE} "
                "has another config); choose another --out"
            )
    elif root.is_dir() and any(root.iterdir()):
        raise RunFolderError(
            f"output folder {root} is not empty and holds no coverage-scale study (no "
            f"{STUDY_FILE}); choose another --out"
        )
    folder = RunFolder(root, force=True)
    folder.write_json(STUDY_FILE, spec)
    return folder
