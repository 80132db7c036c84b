"""Statistics of a sweep's results: mean, standard deviation, n and a 95 % confidence interval
of every summary figure per group, and paired differences between a factor's levels.

They read the results table alone (what :func:`~swarmgames.experiments.sweep.sweep` returns,
or ``results.csv`` read back with :func:`pandas.read_csv`): its factor columns come first, then
``seed``, ``status``, ``error`` and ``folder``, then the runs' summaries. Only complete runs
count. A figure is a summary column whose values are numbers or booleans (a boolean's mean is
the share of runs where it held, e.g. ``consensus``); a missing value (``settled_at_s`` of a
swarm that never settled) is left out of its n.

Notes
-----
For the n values :math:`x_i` of a group, mean :math:`\\bar x`, sample standard deviation
:math:`s` (ddof = 1) and the two-sided interval

.. math:: \\bar x \\pm t_{0.975,\\,n-1}\\, s / \\sqrt{n}

(Student t; undefined, NaN, below two values). Paired differences: for every factor that
varies, each run at a level other than the factor's first is matched with the run at the
first level that has the same seed and the same levels of every other factor, and the
difference (level minus first level) is described as above. Under ``zip`` the factors move
together and count as one. Matching on the seed removes the spread the seeds cause from the
comparison.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.special import stdtrit

__all__ = [
    "META",
    "STAT_COLUMNS",
    "aggregate",
    "describe",
    "factor_columns",
    "figure_columns",
    "outcome_columns",
    "paired_differences",
    "varied_factors",
]

#: The columns between the factors and the runs' summaries.
META = ("seed", "status", "error", "folder")
#: The columns of a description after its keys.
STAT_COLUMNS = ("metric", "n", "mean", "std", "ci_low", "ci_high")
#: Summary entries that are not figures of the run.
NOT_FIGURES = frozenset({"interrupted"})
#: Figures that describe the run rather than measure its outcome (its size, its length, its
#: wall times): aggregated, but not compared between levels in ``paired.csv``.
NOT_OUTCOMES = frozenset({"n_robots", "stages", "wall_s"})
#: Confidence level of the intervals.
LEVEL = 0.95


def factor_columns(results: pd.DataFrame) -> list[str]:
    """The factor columns of a results table (those before ``seed``).

    Raises
    ------
    ValueError
        ``results`` has no ``seed`` column, or no ``status`` column.
    """
    cols = list(results.columns)
    if "seed" not in cols or "status" not in cols:
        raise ValueError(
            "results must be a sweep's results table (factor columns, then seed, status, ...; "
            f"got columns {cols[:8]})"
        )
    return cols[: cols.index("seed")]


def varied_factors(results: pd.DataFrame) -> list[str]:
    """The factors with more than one level among the runs."""
    return [c for c in factor_columns(results) if results[c].nunique(dropna=False) > 1]


def _is_number(value) -> bool:
    return isinstance(value, (bool, int, float, np.bool_, np.integer, np.floating))


def figure_columns(results: pd.DataFrame) -> list[str]:
    """The summary columns whose values in complete runs are all numbers or booleans."""
    skip = {*factor_columns(results), *META, *NOT_FIGURES}
    done = results[results["status"] == "complete"]
    return [c for c in results.columns if c not in skip and done[c].dropna().map(_is_number).all()]


def outcome_columns(results: pd.DataFrame) -> list[str]:
    """The figures that measure a run's outcome: :func:`figure_columns` without those that
    describe the run (:data:`NOT_OUTCOMES`) or time it (``*_ms``)."""
    return [c for c in figure_columns(results) if c not in NOT_OUTCOMES and not c.endswith("_ms")]


def _complete(results: pd.DataFrame, figures: list[str] | None = None):
    """The complete runs with their figures (default: all, :func:`figure_columns`) as
    floats, and the figures' names."""
    figures = figure_columns(results) if figures is None else figures
    done = results.loc[results["status"] == "complete", [*factor_columns(results), "seed"]]
    values = results.loc[done.index, figures].astype(float)
    return pd.concat([done, values], axis=1), figures


def describe(frame: pd.DataFrame, keys: list[str], figures: list[str]) -> pd.DataFrame:
    """Per group of ``keys`` (in order of first appearance) and figure (in the order given):
    ``n``, ``mean``, ``std`` and the 95 % interval ``ci_low``, ``ci_high`` (module notes).

    Parameters
    ----------
    frame : DataFrame
        One row per run, the ``keys`` and the ``figures`` (floats, NaN where missing).
    keys : list of str
        The group columns (none: one group of every row).
    figures : list of str

    Returns
    -------
    DataFrame
        Columns ``keys`` then :data:`STAT_COLUMNS`, one row per group and figure.

    Examples
    --------
    >>> frame = pd.DataFrame({"k": [1, 1, 1], "x": [1.0, 2.0, 3.0]})
    >>> describe(frame, ["k"], ["x"]).round(4).to_dict("records")
    [{'k': 1, 'metric': 'x', 'n': 3, 'mean': 2.0, 'std': 1.0, 'ci_low': -0.4841, 'ci_high': 4.4841}]
    """
    if not figures:
        return pd.DataFrame(columns=[*keys, *STAT_COLUMNS])
    group = frame.groupby(keys, sort=False).ngroup() if keys else 0
    long = frame.assign(_group=group).melt(
        id_vars=["_group", *keys], value_vars=figures, var_name="metric"
    )
    long["metric"] = pd.Categorical(long["metric"], categories=figures)
    out = (
        long.groupby(["_group", *keys, "metric"], sort=False, observed=True)["value"]
        .agg(n="count", mean="mean", std="std")
        .reset_index()
        .sort_values(["_group", "metric"], kind="stable")
    )
    n = out["n"].to_numpy()
    # Student's t quantile (what scipy.stats.t.ppf computes, without importing scipy.stats).
    t = stdtrit(np.maximum(n - 1, 1), 0.5 + LEVEL / 2)
    half = np.where(n >= 2, t * out["std"].to_numpy() / np.sqrt(np.maximum(n, 1)), np.nan)
    out = out.assign(
        metric=out["metric"].astype(str),
        n=n.astype(int),
        ci_low=out["mean"] - half,
        ci_high=out["mean"] + half,
    )
    return out.drop(columns="_group").reset_index(drop=True)[[*keys, *STAT_COLUMNS]]


def aggregate(results: pd.DataFrame) -> pd.DataFrame:
    """Every figure of the complete runs described per combination of the factors
    (:func:`describe`; what ``aggregate.csv`` holds).

    Parameters
    ----------
    results : DataFrame
        A sweep's results table (module notes).

    Returns
    -------
    DataFrame
        The factor columns, then ``metric``, ``n``, ``mean``, ``std``, ``ci_low``,
        ``ci_high``: one row per combination and figure.
    """
    done, figures = _complete(results)
    return describe(done, factor_columns(results), figures)


def _label(columns: list[str], row: pd.Series) -> str:
    if len(columns) == 1:
        return str(row[columns[0]])
    return ", ".join(f"{c}={row[c]}" for c in columns)


def paired_differences(results: pd.DataFrame, zipped: bool = False) -> pd.DataFrame:
    """Differences of each level of each varied factor from its first level, matched on the
    seed and the other factors' levels, described like :func:`aggregate` (module notes;
    what ``paired.csv`` holds).

    Parameters
    ----------
    results : DataFrame
        A sweep's results table; its first row holds every factor's first level (the order
        in which a sweep writes its runs).
    zipped : bool
        The factors were zipped: they move together and count as one factor.

    Returns
    -------
    DataFrame
        ``factor`` (its path, or the zipped paths joined by ``" + "``), ``baseline`` (its
        first level), the varied factor columns (the level compared and the other factors'
        fixed levels), then ``metric``, ``n``, ``mean``, ``std``, ``ci_low``, ``ci_high`` of
        the differences, for the outcome figures (:func:`outcome_columns`). No rows when no
        factor varies.
    """
    varied = varied_factors(results)
    columns = ["factor", "baseline", *varied, *STAT_COLUMNS]
    if not varied:
        return pd.DataFrame(columns=columns)
    done, figures = _complete(results, outcome_columns(results))
    first = results.iloc[0]
    frames = []
    for factor in [varied] if zipped else [[c] for c in varied]:
        others = [c for c in varied if c not in factor]
        at_base = (done[factor] == first[factor]).all(axis=1)
        base = done.loc[at_base, [*others, "seed", *figures]]
        pairs = done[~at_base].merge(base, on=[*others, "seed"], suffixes=("", "__base"))
        diff = pairs[[*varied, "seed"]].assign(
            **{f: pairs[f] - pairs[f"{f}__base"] for f in figures}
        )
        described = describe(diff, varied, figures)
        described.insert(0, "factor", " + ".join(factor))
        described.insert(1, "baseline", _label(factor, first))
        frames.append(described)
    return pd.concat(frames, ignore_index=True)[columns]
