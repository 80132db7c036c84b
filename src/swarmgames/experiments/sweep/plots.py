"""The figure of one summary figure across a sweep: mean and 95 % interval per group."""

from __future__ import annotations

import pandas as pd
from matplotlib.figure import Figure

from swarmgames.experiments.sweep.stats import aggregate, varied_factors

__all__ = ["plot_metric"]


def _is_numeric(column: pd.Series) -> bool:
    return pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column)


def plot_metric(results: pd.DataFrame, metric: str) -> Figure:
    """``metric`` against the first numeric factor that varies (else the first that varies,
    as categories), one line per combination of the other varied factors, error bars the
    95 % confidence interval over the seeds (none below two complete runs).

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
    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = fig.subplots()
    groups = agg.groupby(others, sort=False) if others else [((), agg)]
    for key, group in groups:
        group = group.sort_values(x) if positions is None and x is not None else group
        if x is None:
            xs = [0] * len(group)
        else:
            xs = group[x].map(positions) if positions is not None else group[x]
        err = [
            (group["mean"] - group["ci_low"]).fillna(0.0),
            (group["ci_high"] - group["mean"]).fillna(0.0),
        ]
        values = key if isinstance(key, tuple) else (key,)
        label = ", ".join(f"{c}={v}" for c, v in zip(others, values, strict=True)) or None
        ax.errorbar(xs, group["mean"], yerr=err, marker="o", capsize=3, label=label)
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
    ax.set_xlabel(x or "")
    ax.set_ylabel(metric)
    if others:
        ax.legend(fontsize="small")
    ax.set_title(f"{metric}: mean and 95 % confidence interval over the seeds", fontsize="medium")
    return fig
