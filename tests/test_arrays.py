"""The shared array helpers against numpy's definitions."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays, integer_dtypes

from swarmgames.arrays import sorted_unique


@settings(max_examples=200, deadline=None)
@given(arrays(integer_dtypes(), st.integers(0, 60), elements=st.integers(-40, 40)))
def test_sorted_unique_is_numpys_unique_for_integers(keys):
    want = np.unique(keys)
    got = sorted_unique(keys)
    assert got.dtype == want.dtype and np.array_equal(got, want)


def test_sorted_unique_flattens_like_numpy():
    keys = np.array([[3, 1], [3, 2]])
    assert sorted_unique(keys).tolist() == np.unique(keys).tolist() == [1, 2, 3]
