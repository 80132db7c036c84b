"""Tests of the discrete action models."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.game import ActionModel, DisplacementActions, action_mask_of


def test_headings_are_stay_plus_evenly_spaced_moves():
    m = DisplacementActions.headings(10.0, 8)
    assert isinstance(m, ActionModel) and m.n_actions == 9
    d = m.displacements
    np.testing.assert_allclose(d[0], [0.0, 0.0])
    np.testing.assert_allclose(np.linalg.norm(d[1:], axis=1), 10.0)
    np.testing.assert_allclose(d[3], [0.0, 10.0], atol=1e-12)  # heading 2 of 8 = 90 degrees


def test_apply_broadcasts_over_leading_axes():
    m = DisplacementActions.headings(1.0, 4, dim=3)
    out = m.apply(np.zeros((2, 5, 3)))
    assert out.shape == (2, 5, 5, 3)
    np.testing.assert_allclose(out[1, 2, 1], [1.0, 0.0, 0.0])


def test_bounds_invalidate_moves_leaving_the_box_but_never_stay():
    m = DisplacementActions.headings(1.0, 4, lower=[0.0, 0.0], upper=[10.0, 10.0])
    valid = m.valid(np.array([[0.0, 0.0], [5.0, 5.0]]))
    assert valid[0].tolist() == [True, True, True, False, False]
    assert valid[1].all()
    outside = m.valid(np.array([[-5.0, -5.0]]))
    assert outside[0].tolist() == [True, False, False, False, False]


def test_action_mask_of_a_model_without_valid_is_all_true():
    class Plain:
        n_actions = 3

        def apply(self, states):
            return np.repeat(states[..., None, :], 3, axis=-2)

    assert action_mask_of(Plain(), np.zeros((4, 2))).all()


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: DisplacementActions.headings(0.0), r"step must be > 0 \(got 0.0\)"),
        (lambda: DisplacementActions.headings(1.0, 0), r"n_headings must be >= 1 \(got 0\)"),
        (lambda: DisplacementActions.headings(1.0, dim=1), r"dim must be >= 2 \(got 1\)"),
        (lambda: DisplacementActions(np.zeros((0, 2))), r"displacements must have shape"),
        (lambda: DisplacementActions([[np.nan, 0.0]]), r"displacements must be finite"),
        (lambda: DisplacementActions([[0.0, 0.0]], lower=[0.0]), r"lower must have shape"),
    ],
)
def test_invalid_action_models_are_rejected(call, match):
    with pytest.raises(ValueError, match=match):
        call()
