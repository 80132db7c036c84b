"""Tests of the log-distance signal model psi_R (paper section III)."""

import numpy as np
import pytest

from swarmgames.missions import SignalModel


def test_reference_values():
    # psi_R(d) = T0 - (L0 + 10 n log10 d); ns-3 log-distance defaults (docs/reference.md section 2):
    # T0 = 16.0206 dBm, L0 = 46.6777 dB at 1 m, n = 3. At 10 m: 16.0206 - 46.6777 - 30.
    s = SignalModel(16.0206, 46.6777, 3.0, 1.0)
    assert s.power(10.0) == pytest.approx(-60.6571, abs=1e-9)
    assert s.power(100.0) == pytest.approx(-90.6571, abs=1e-9)
    assert s.power(1.0) == pytest.approx(16.0206 - 46.6777)


def test_clamped_at_reference_distance():
    s = SignalModel()
    assert np.isfinite(s.power(0.0))
    assert s.power(0.0) == s.power(0.5) == s.power(1.0)
    # co-located robots: finite link quality
    assert np.isfinite(s.link(np.zeros(3), np.zeros(3)))


def test_field_uses_3d_distance_from_altitude():
    s = SignalModel()
    f = s.field(np.array([[0.0, 0.0, 30.0]]), np.array([[0.0, 0.0], [40.0, 0.0]]))
    assert f.dtype == np.float32
    np.testing.assert_allclose(f[0], s.power(np.array([30.0, 50.0])), atol=1e-4)


def test_squared_distance_form_agrees():
    s = SignalModel(10.0, 40.0, 2.4, 2.0)
    d = np.array([0.1, 1.0, 2.0, 7.5, 368.84, 5000.0])
    np.testing.assert_allclose(s.power_sq(d**2, np.float64), s.power(d), atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"exponent": 0.0}, "exponent must be > 0"), ({"reference_distance_m": -1.0}, "reference")],
)
def test_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SignalModel(**kwargs)


def test_a_fields_rows_are_the_rows_computed_alone():
    # The whole-grid unary gives back kept rows of an earlier field for positions it held:
    # each row must be the floats a field of that position alone has.
    rng = np.random.default_rng(3)
    uav = np.column_stack([rng.uniform(-900, 900, (37, 2)), rng.uniform(10, 120, 37)])
    ground = rng.uniform(-1000, 1000, (1001, 2))
    s = SignalModel()
    whole = s.field(uav, ground)
    for rows in ([5], [0, 36], list(range(3, 20, 4)), list(range(37))[::-1]):
        np.testing.assert_array_equal(whole[rows], s.field(uav[rows], ground))
