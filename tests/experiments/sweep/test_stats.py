"""Statistics of a sweep's results against hand computations: per-group mean, standard
deviation, n and Student-t interval, paired differences on the same seeds, and the same
numbers from ``results.csv`` read back."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from swarmgames.experiments.sweep import aggregate, paired_differences
from swarmgames.experiments.sweep.stats import factor_columns, figure_columns, varied_factors

# Two-sided 95 % quantiles of Student's t (any t table): t_{0.975, 1} and t_{0.975, 2}.
T1, T2 = 12.706204736174707, 4.302652729911275

# f by (a, b) and seed; (a=2, b=y) failed on seed 0.
F = {
    (1, "x"): [1.0, 2.0, 4.0],
    (2, "x"): [2.0, 4.0, 7.0],
    (1, "y"): [0.0, 0.0, 1.0],
    (2, "y"): [None, 5.0, 6.0],
}


def _results() -> pd.DataFrame:
    rows = []
    for (a, b), values in F.items():
        for seed, f in enumerate(values):
            failed = f is None
            rows.append(
                {
                    "a": a,
                    "b": b,
                    "fixed": "same",  # a factor with one level
                    "seed": seed,
                    "status": "failed" if failed else "complete",
                    "error": "RuntimeError: broke" if failed else "",
                    "folder": f"runs/{a}{b}{seed}",
                    "solver": None if failed else "mean_field",  # text: not a figure
                    "f": f,
                    "settled": None if failed else f > 1.5,  # a boolean: a share
                    "late": None if failed or seed == 0 else 10.0 * seed,  # missing values
                    "interrupted": False,
                }
            )
    return pd.DataFrame(rows)


def _row(frame, **where) -> pd.Series:
    mask = np.logical_and.reduce([frame[k] == v for k, v in where.items()])
    (index,) = np.flatnonzero(mask)
    return frame.iloc[index]


def test_the_columns_of_a_results_table():
    res = _results()
    assert factor_columns(res) == ["a", "b", "fixed"]
    assert varied_factors(res) == ["a", "b"]
    assert figure_columns(res) == ["f", "settled", "late"]


def test_aggregate_equals_a_hand_computation():
    agg = aggregate(_results())
    assert list(agg.columns) == [
        "a", "b", "fixed", "metric", "n", "mean", "std", "ci_low", "ci_high"
    ]  # fmt: skip
    assert len(agg) == 4 * 3  # every group, every figure
    row = _row(agg, a=1, b="x", metric="f")
    mean, std = 7 / 3, math.sqrt(7 / 3)  # of 1, 2, 4
    assert row["n"] == 3
    assert row["mean"] == pytest.approx(mean) and row["std"] == pytest.approx(std)
    assert row["ci_low"] == pytest.approx(mean - T2 * std / math.sqrt(3))
    assert row["ci_high"] == pytest.approx(mean + T2 * std / math.sqrt(3))
    # The failed run is not counted: two values, 5 and 6.
    row = _row(agg, a=2, b="y", metric="f")
    assert (row["n"], row["mean"]) == (2, 5.5)
    assert row["ci_high"] - row["mean"] == pytest.approx(T1 * math.sqrt(0.5) / math.sqrt(2))
    # A boolean's mean is the share of runs where it held: 2 > 1.5, 4 > 1.5, not 1.
    assert _row(agg, a=1, b="x", metric="settled")["mean"] == pytest.approx(2 / 3)
    # Missing values leave the n: seeds 1 and 2 only; one value has no interval.
    row = _row(agg, a=1, b="x", metric="late")
    assert (row["n"], row["mean"]) == (2, 15.0)
    row = _row(agg, a=2, b="y", metric="late")
    assert row["n"] == 2
    assert _row(agg, a=1, b="y", metric="f")["n"] == 3


def test_paired_differences_match_each_level_with_the_first_on_the_same_seed():
    paired = paired_differences(_results())
    assert list(paired.columns[:4]) == ["factor", "baseline", "a", "b"]
    f = paired[paired["metric"] == "f"]
    # a = 2 minus a = 1, b fixed: b = x gives 1, 2, 3.
    row = _row(f, factor="a", a=2, b="x")
    assert row["baseline"] == "1"
    assert (row["n"], row["mean"], row["std"]) == (3, 2.0, 1.0)
    assert row["ci_low"] == pytest.approx(2.0 - T2 / math.sqrt(3))
    # b = y: seed 0 failed at a = 2, so seeds 1 and 2: 5 - 0 and 6 - 1.
    row = _row(f, factor="a", a=2, b="y")
    assert (row["n"], row["mean"], row["std"]) == (2, 5.0, 0.0)
    assert (row["ci_low"], row["ci_high"]) == (5.0, 5.0)
    # y minus x, a fixed.
    row = _row(f, factor="b", a=1, b="y")
    assert (row["baseline"], row["n"], row["mean"]) == ("x", 3, -2.0)
    row = _row(f, factor="b", a=2, b="y")  # 5 - 4 and 6 - 7
    assert (row["n"], row["mean"], row["std"]) == (2, 0.0, pytest.approx(math.sqrt(2)))
    assert row["ci_high"] == pytest.approx(T1)
    assert set(paired["factor"]) == {"a", "b"}  # never the one-level factor
    assert len(paired) == 4 * 3


def test_zipped_factors_count_as_one():
    res = _results()
    res = res[((res["a"] == 1) & (res["b"] == "x")) | ((res["a"] == 2) & (res["b"] == "y"))]
    paired = paired_differences(res.reset_index(drop=True), zipped=True)
    row = _row(paired, metric="f")
    assert (row["factor"], row["baseline"]) == ("a + b", "a=1, b=x")
    assert (row["a"], row["b"], row["n"], row["mean"]) == (2, "y", 2, 2.5)  # 5 - 2, 6 - 4


def test_no_varied_factor_has_no_paired_differences():
    res = _results()
    res = res[(res["a"] == 1) & (res["b"] == "x")]
    assert paired_differences(res).empty
    assert len(aggregate(res)) == 3


def test_results_csv_read_back_gives_the_same_numbers(tmp_path):
    res = _results()
    res.to_csv(tmp_path / "results.csv", index=False)
    back = pd.read_csv(tmp_path / "results.csv")
    pd.testing.assert_frame_equal(aggregate(back), aggregate(res), check_dtype=False)
    pd.testing.assert_frame_equal(
        paired_differences(back), paired_differences(res), check_dtype=False
    )


def test_a_frame_that_is_not_a_results_table_is_rejected():
    with pytest.raises(ValueError, match="must be a sweep's results table"):
        aggregate(pd.DataFrame({"x": [1.0]}))
