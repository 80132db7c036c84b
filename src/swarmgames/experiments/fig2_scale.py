"""Virtual mean neighbours at scale: the claim of the paper's Figure 2a put to the test.

The paper's Figure 2a compares swarms of up to 7 UAVs with and without virtual mean
neighbours (eq. 3), sees no significant difference for up to 5, and expects one in large
swarms. In such small swarms every robot is within two hops of every other, so no member of
a local game reaches outside it and eq. 3 changes nothing.
:func:`reproduce_fig2_scale` runs the ``fig2-scale`` scenario instead. It is the coverage
mission at constant density, where the swarm takes off from one disc and must spread out.
Its neighbourhoods span three hops and more, and it runs for every swarm size, seed and
setting of ``game.virtual_mean``, on the sweep machinery (:func:`swarmgames.sweep`, one sweep
per size, each resumable). The tables are the sweep's: ``results.csv`` (one row per run),
``aggregate.csv`` (mean, standard deviation, n and Student-t 95 % interval per size and
variant), ``paired.csv`` (each variant minus the first, matched on size and seed), and one
figure per metric against N.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C (eq. 3) and Fig. 2a.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from swarmgames.config import ScenarioConfig, resolve_scenario
from swarmgames.config.io import parse_config, to_data
from swarmgames.errors import ConfigError

__all__ = [
    "DEFAULT_SIZES",
    "METRICS",
    "SCENARIO",
    "VARIANTS",
    "Fig2ScaleResult",
    "reproduce_fig2_scale",
    "scenario_for",
]

#: The built-in scenario the study starts from (its 100-UAV instance).
SCENARIO = "fig2-scale"
#: Swarm sizes of the study.
DEFAULT_SIZES = (10, 20, 50, 100, 200, 500, 1000)
#: Settings of ``game.virtual_mean`` compared, the first one the baseline of ``paired.csv``.
VARIANTS = ("eq3", "outside", "exact", "off")
#: Figures plotted against N.
METRICS = ("coverage_end_dbm", "coverage_gain_db", "mean_payoff_end", "median_stage_ms")
#: Where each size's sweep lives inside the study's folder.
SIZE_FOLDER = "n{n}"
#: What a study was asked, written before its first run; the same study resumes into it.
STUDY_FILE = "study.json"
N_COLUMN = "swarm.n_robots"
VARIANT_COLUMN = "game.virtual_mean"


def scenario_for(n: int, base: ScenarioConfig) -> ScenarioConfig:
    """``base`` for ``n`` UAVs at its density: the ROI rescaled so that every UAV has the
    same area to cover as in ``base``, everything else kept (the take-off disc too, which
    ``swarm.start_max_neighbours`` grows with N).

    The isotropic ROI :math:`\\mathcal{N}(\\mu, \\sigma^2 I)` at confidence ``c`` is the
    disc of area :math:`\\pi k^2 \\sigma^2`, :math:`k^2 = -2 \\ln(1 - c)`; holding its area
    per UAV, :math:`a = \\pi k^2 \\sigma^2_{base} / n_{base}`, gives
    :math:`\\sigma^2_n = n a / (\\pi k^2)`.

    Parameters
    ----------
    n : int
        Swarm size, >= 1.
    base : ScenarioConfig
        A coverage scenario with an isotropic ROI, e.g. ``fig2-scale``.

    Returns
    -------
    ScenarioConfig

    Raises
    ------
    ConfigError
        ``base`` is not a coverage scenario with an isotropic ROI.
    """
    cov = base.mission.roi_cov_m2
    if base.scenario != "coverage" or cov[0][1] != 0.0 or cov[0][0] != cov[1][1]:
        raise ConfigError(
            "scenario: fig2-scale rescales an isotropic coverage ROI (got scenario = "
            f"{base.scenario!r}, coverage.roi_cov_m2 = {cov!r})"
        )
    confidence = base.mission.confidence
    k2 = -2.0 * math.log1p(-confidence)
    area = math.pi * k2 * cov[0][0] / base.swarm.n_robots  # the base's ROI area per UAV
    var = n * area / (math.pi * k2)
    data = to_data(base)
    data["swarm"]["n_robots"] = n
    data["coverage"]["roi_cov_m2"] = [[var, 0.0], [0.0, var]]
    data["name"] = f"{base.name}-n{n}"
    return parse_config(data, source=f"{base.name} for {n} UAVs")


@dataclass(frozen=True, eq=False)
class Fig2ScaleResult:
    """The study's runs.

    Attributes
    ----------
    results : DataFrame
        One row per run: ``swarm.n_robots``, ``game.virtual_mean``, ``seed``, ``status``,
        ``error``, ``folder`` and the run's summary, plus ``coverage_gain_db`` (coverage at
        the end minus at the start, dB).
    config : ScenarioConfig
        The base scenario (before rescaling).
    """

    results: pd.DataFrame
    config: ScenarioConfig

    @property
    def interrupted(self) -> bool:
        """A signal stopped the study before every run finished."""
        return bool((self.results["status"] == "interrupted").any())

    def aggregate(self) -> pd.DataFrame:
        """Mean, std, n and 95 % interval of every figure per size and variant."""
        from swarmgames.experiments.sweep import aggregate

        return aggregate(self.results)

    def paired(self) -> pd.DataFrame:
        """Each variant minus the first (:data:`VARIANTS`), matched on size and seed."""
        from swarmgames.experiments.sweep import paired_differences

        diff = paired_differences(self.results)
        return diff[diff["factor"] == VARIANT_COLUMN].reset_index(drop=True)

    def write(self, folder) -> list[Path]:
        """``results.csv``, ``aggregate.csv``, ``paired.csv``, one ``<metric>.png`` per
        figure of :data:`METRICS` the runs have, and the base ``config.toml``."""
        from swarmgames.config import to_toml
        from swarmgames.experiments.sweep.plots import plot_metric
        from swarmgames.experiments.sweep.stats import figure_columns

        files = [
            folder.write_csv("results.csv", self.results),
            folder.write_csv("aggregate.csv", self.aggregate()),
            folder.write_csv("paired.csv", self.paired()),
            folder.write_text("config.toml", to_toml(self.config)),
        ]
        if (self.results["status"] == "complete").any():
            figures = figure_columns(self.results)
            for metric in (m for m in METRICS if m in figures):
                files.append(folder.save_figure(f"{metric}.png", plot_metric(self.results, metric)))
        return files


def reproduce_fig2_scale(
    out: str | Path,
    *,
    sizes: Sequence[int] = DEFAULT_SIZES,
    seeds: Sequence[int] = (0, 1, 2, 3, 4),
    variants: Sequence[Any] = VARIANTS,
    base: ScenarioConfig | None = None,
    jobs: int | None = None,
    executor: str = "local",
    address: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Fig2ScaleResult:
    """Run the study: every size × variant × seed, one sweep per size under ``out``.

    Parameters
    ----------
    out : str or Path
        The study's folder: ``study.json``, ``out/n<N>/`` the sweep of N UAVs, and the
        tables and figures of :meth:`Fig2ScaleResult.write` (of the runs asked for this
        time). Running the study into it again resumes it: finished runs are read, not run,
        also when sizes, seeds or variants were added.
    sizes : sequence of int
        Swarm sizes (default :data:`DEFAULT_SIZES`).
    seeds : sequence of int
        Seeds of every size and variant (default 0-4).
    variants : sequence
        Values of ``game.virtual_mean`` (default :data:`VARIANTS`).
    base : ScenarioConfig, optional
        The scenario to rescale (default: the built-in ``fig2-scale``).
    jobs, executor, address
        As :func:`swarmgames.sweep`.
    progress : callable, optional
        Called as ``progress(done, total)`` after each size's sweep, in runs.

    Returns
    -------
    Fig2ScaleResult

    Raises
    ------
    ConfigError
        Bad sizes, seeds or variants, or a combination the schema rejects, before anything
        runs.
    RunFolderError
        ``out`` holds something other than this study.
    """
    from swarmgames.experiments.sweep import sweep
    from swarmgames.experiments.sweep.grid import factors_from_mapping, plan_sweep, study_levels

    base = resolve_scenario(SCENARIO) if base is None else base
    root = Path(out)
    sizes = study_levels(sizes, "sizes")
    if not all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in sizes):
        raise ConfigError(f"sizes: must be integers >= 1 (got {sizes!r})")
    variants = study_levels(variants, "variants")
    seeds = study_levels(seeds, "seeds")
    configs = {n: scenario_for(n, base) for n in sizes}
    for n in sizes:  # every combination is checked before the first run
        plan_sweep(configs[n], factors_from_mapping({VARIANT_COLUMN: variants}), seeds, False)
    folder = _open_root(root, base, sizes, seeds, variants)
    frames = []
    total = len(sizes) * len(variants) * len(tuple(seeds))
    for n in sizes:
        frame = sweep(
            configs[n],
            {VARIANT_COLUMN: list(variants)},
            seeds,
            jobs=jobs,
            executor=executor,  # type: ignore[arg-type]
            address=address,
            out=root / SIZE_FOLDER.format(n=n),
            metrics=[m for m in METRICS if m != "coverage_gain_db"],
        )
        frame["folder"] = [f"{SIZE_FOLDER.format(n=n)}/{f}" for f in frame["folder"]]
        frame.insert(0, N_COLUMN, n)
        frames.append(frame)
        if progress is not None:
            progress(sum(len(f) for f in frames), total)
        if (frame["status"] == "interrupted").any():
            break  # a signal stopped this size's sweep: the larger sizes do not start
    results = pd.concat(frames, ignore_index=True)
    if {"coverage_end_dbm", "coverage_start_dbm"} <= set(results.columns):
        results["coverage_gain_db"] = results["coverage_end_dbm"] - results["coverage_start_dbm"]
    result = Fig2ScaleResult(results=results, config=base)
    result.write(folder)
    return result


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
        "study": SCENARIO,
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
                f"{root} holds a fig2-scale study of another scenario (its {STUDY_FILE} "
                "has another config); choose another --out"
            )
    elif root.is_dir() and any(root.iterdir()):
        raise RunFolderError(
            f"output folder {root} is not empty and holds no fig2-scale study (no "
            f"{STUDY_FILE}); choose another --out"
        )
    folder = RunFolder(root, force=True)
    folder.write_json(STUDY_FILE, spec)
    return folder
