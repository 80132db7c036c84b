"""The figures of a sweep: one summary figure against a factor (mean and 95 % band per
group, every run a dot), and the paired differences of each factor's levels with their
95 % intervals. Axis labels come from the configuration schema's descriptions (factors) and
the figures' unit suffixes (:mod:`swarmgames.labels`)."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from swarmgames.experiments.sweep.stats import STAT_COLUMNS, aggregate, varied_factors
from swarmgames.labels import column_label

__all__ = ["factor_label", "plot_metric", "plot_paired"]


def _is_numeric(column: pd.Series) -> bool:
    return pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column)


def factor_label(path: str) -> str:
    """An axis label for a factor ``section.field``: the path and the first clause of the
    field's description in the configuration schema (its unit included), e.g.
    ``"swarm.n_robots: Number of UAVs"``; the path alone for a field the schema does not
    describe (a mission's or a plug-in's)."""
    from swarmgames.config import ScenarioConfig

    model, info = ScenarioConfig, None
    for part in path.split("."):
        fields = getattr(model, "model_fields", {})
        if part not in fields:
            return path
        info = fields[part]
        model = info.annotation
    text = (info.description or "") if info is not None else ""
    clause = re.split(r"(?<=[a-z)]\.)\s|;\s|\s\(", text.strip(), maxsplit=1)[0].rstrip(".")
    if not clause or len(clause) > 70:
        return path
    return f"{path}: {clause}"


def plot_metric(results: pd.DataFrame, metric: str) -> Figure:
    """``metric`` against the first numeric factor that varies (else the first that varies,
    as categories), one line per combination of the other varied factors: the mean over the
    seeds, its 95 % Student-t confidence band (none below two complete runs) and every run
    as a dot, so that a wide band from two seeds is read as what it is.

    Parameters
    ----------
    results : DataFrame
        A sweep's results table (:mod:`~swarmgames.experiments.sweep.stats`).
    metric : str
        One of its figures.

    Returns
    -------
    matplotlib.figure.Figure
    """
    agg = aggregate(results)
    agg = agg[agg["metric"] == metric]
    varied = varied_factors(results)
    numeric = [c for c in varied if _is_numeric(results[c])]
    x = numeric[0] if numeric else (varied[0] if varied else None)
    others = [c for c in varied if c != x]
    positions = None
    if x is not None and x not in numeric:
        positions = {level: i for i, level in enumerate(dict.fromkeys(results[x]))}
    done = results[results["status"] == "complete"]
    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = fig.subplots()
    groups = agg.groupby(others, sort=False) if others else [((), agg)]
    for key, group in groups:
        group = group.sort_values(x) if positions is None and x is not None else group
        values = key if isinstance(key, tuple) else (key,)
        label = ", ".join(f"{c}={v}" for c, v in zip(others, values, strict=True)) or None
        runs = done
        for c, v in zip(others, values, strict=True):
            runs = runs[runs[c] == v]
        xs, run_xs = _positions(group, runs, x, positions)
        (line,) = ax.plot(xs, group["mean"], marker="o", label=label)
        colour = line.get_color()
        if (group["n"] >= 2).any():
            ax.fill_between(xs, group["ci_low"], group["ci_high"], color=colour, alpha=0.2, lw=0)
        ax.plot(run_xs, runs[metric].astype(float), ls="none", marker=".", ms=4, color=colour)
    if positions is not None:
        ax.set_xticks(list(positions.values()), [str(level) for level in positions])
    elif x is not None and results[x].nunique() <= 12:
        levels = sorted(results[x].unique())
        if levels[0] > 0 and levels[-1] >= 20 * levels[0]:  # sizes 10 ... 1000: log axis
            ax.set_xscale("log")
            ax.minorticks_off()
        ax.set_xticks(levels, [f"{v:g}" for v in levels])  # the levels themselves
    elif x is None:
        ax.set_xticks([0], ["all runs"])
    ax.set_xlabel(factor_label(x) if x else "")
    ax.set_ylabel(column_label(metric))
    ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    if others:
        ax.legend(fontsize="small")
    n = int(agg["n"].min()) if len(agg) else 0
    ax.set_title(
        f"{column_label(metric)}: mean, 95 % band over the seeds (n = {n}), runs as dots",
        fontsize="medium",
    )
    return fig


def _positions(group, runs, x, positions):
    """The x positions of a line's means and of its runs."""
    if x is None:
        return np.zeros(len(group)), np.zeros(len(runs))
    if positions is not None:
        return group[x].map(positions).to_numpy(), runs[x].map(positions).to_numpy()
    return group[x].to_numpy(), runs[x].to_numpy()


def plot_paired(paired: pd.DataFrame, metric: str) -> Figure:
    """The paired differences of ``metric`` (``paired.csv``): one row per factor level (and
    levels of the other factors), its mean difference from the factor's first level on the
    same seeds and the 95 % interval, against zero.

    Parameters
    ----------
    paired : DataFrame
        :func:`~swarmgames.experiments.sweep.stats.paired_differences` of a sweep.
    metric : str
        One of its figures.

    Returns
    -------
    matplotlib.figure.Figure
    """
    rows = paired[paired["metric"] == metric].reset_index(drop=True)
    keys = [c for c in rows.columns if c not in ("factor", "baseline", *STAT_COLUMNS)]
    labels = [
        ", ".join(f"{k}={row[k]}" for k in keys) + f"  − {row['factor']}={row['baseline']}"
        for row in rows.to_dict("records")
    ]
    fig = Figure(figsize=(8.0, 1.4 + 0.45 * max(1, len(rows))), layout="constrained")
    ax = fig.subplots()
    y = np.arange(len(rows))[::-1]
    mean = rows["mean"].to_numpy(dtype=float)
    low = mean - rows["ci_low"].to_numpy(dtype=float)
    high = rows["ci_high"].to_numpy(dtype=float) - mean
    err = np.nan_to_num(np.vstack([low, high]), nan=0.0)
    ax.errorbar(mean, y, xerr=err, fmt="o", capsize=3, color="tab:blue")
    ax.axvline(0.0, color="0.4", lw=0.8, ls="--")
    ax.set_yticks(y, labels, fontsize="small")
    ax.set_ylim(-0.7, len(rows) - 0.3)
    ax.set_xlabel(f"difference in {column_label(metric)}")
    ax.ticklabel_format(axis="x", useOffset=False, style="plain")
    n = int(rows["n"].min()) if len(rows) else 0
    fig.suptitle(
        f"paired differences on the same seeds: mean and 95 % interval (n = {n})",
        fontsize="medium",
    )
    return fig
