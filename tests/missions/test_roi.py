"""Tests of the Gaussian region of interest (paper section III)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from swarmgames.missions import GaussianROI


@pytest.mark.parametrize("confidence", [0.5, 0.9, 0.95, 0.99])
def test_mass_equals_confidence(confidence):
    # The concentration ellipse of a bivariate Gaussian holds mass c when its squared
    # Mahalanobis radius is the chi-squared(2) quantile at c (scipy.stats.chi2 as reference).
    roi = GaussianROI((100.0, -50.0), ((200.0**2, 3000.0), (3000.0, 120.0**2)), confidence, 4.0)
    assert roi.k2 == pytest.approx(stats.chi2.ppf(confidence, df=2), rel=1e-12)
    assert roi.mass == pytest.approx(confidence, abs=2e-3)


def test_mass_converges_with_cell_size():
    cov = ((250.0**2, 0.0), (0.0, 250.0**2))
    errors = [abs(GaussianROI((0, 0), cov, 0.95, a).mass - 0.95) for a in (40.0, 20.0, 10.0)]
    assert errors[2] < errors[0]
    assert errors[2] < 1e-3


@settings(max_examples=30, deadline=None)
@given(
    sx=st.floats(50, 400),
    sy=st.floats(50, 400),
    rho=st.floats(-0.8, 0.8),
    c=st.floats(0.3, 0.99),
)
def test_grid_points_inside_and_mass_property(sx, sy, rho, c):
    cov = ((sx * sx, rho * sx * sy), (rho * sx * sy, sy * sy))
    roi = GaussianROI((10.0, 20.0), cov, c, min(sx, sy) / 15.0)
    assert roi.contains(roi.points).all()
    assert np.all(roi.weights > 0)
    assert roi.mass == pytest.approx(c, abs=0.01)


def test_monte_carlo_contains_matches_confidence():
    # Independent check of the ellipse itself: samples of N(mu, Sigma) fall inside with
    # probability c.
    rng = np.random.default_rng(1)
    mean, cov = np.array([5.0, 5.0]), np.array([[300.0**2, 2e4], [2e4, 150.0**2]])
    roi = GaussianROI(mean, cov, 0.9, 20.0)
    x = rng.multivariate_normal(mean, cov, size=200_000)
    assert roi.contains(x).mean() == pytest.approx(0.9, abs=0.003)


def test_arrays_read_only_and_expectation():
    roi = GaussianROI((0, 0), ((1e4, 0), (0, 1e4)), 0.95, 10.0)
    with pytest.raises(ValueError):
        roi.points[0, 0] = 1.0
    assert roi.expectation(np.full(roi.n_cells, -70.0)) == pytest.approx(-70.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"cov": ((1.0, 2.0), (2.0, 1.0))}, "cov must be symmetric positive definite"),
        ({"cov": ((1.0, 0.5), (0.0, 1.0))}, "cov must be symmetric positive definite"),
        ({"confidence": 1.0}, r"confidence must be in \(0, 1\) \(got 1.0\)"),
        ({"cell_m": 0.0}, r"cell_m must be > 0 \(got 0.0\)"),
        ({"cell_m": 5000.0}, "cell_m must be <= the ROI's shortest semi-axis"),
        ({"cell_m": 0.01}, r"grid cells, more than 4,000,000; choose a larger cell"),
        ({"mean": (np.nan, 0.0)}, "mean must be 2 finite numbers"),
    ],
)
def test_bad_roi_rejected(kwargs, match):
    args = {"mean": (0.0, 0.0), "cov": ((1e4, 0.0), (0.0, 1e4)), "confidence": 0.95, "cell_m": 10.0}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        GaussianROI(**args)


def test_expectation_sums_in_cell_order_whatever_the_cpu():
    # The same IEEE operations as a Python loop in cell order (no BLAS kernel choice, no
    # reassociation), for one row and for a stack of rows.
    roi = GaussianROI((0.0, 0.0), ((200.0**2, 0.0), (0.0, 120.0**2)), 0.95, 20.0)
    v = np.random.default_rng(3).normal(-90.0, 6.0, (3, roi.n_cells))
    want = []
    for row in v:
        s = 0.0
        for a, w in zip(row.tolist(), roi.weights.tolist(), strict=True):
            s += a * w
        want.append(s / roi.mass)
    assert roi.expectation(v).tolist() == want
    assert roi.expectation(v[0]) == want[0] and np.ndim(roi.expectation(v[0])) == 0
