"""One normaliser of random seeds, shared by every layer (numpy only).

Functions that draw random numbers accept ``seed: int | numpy.random.Generator | None``,
normalise it once with :func:`as_generator` and pass the Generator down (scikit-learn's
``check_random_state``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["as_generator"]


def as_generator(seed: int | np.random.Generator | None) -> np.random.Generator:
    """Normalise ``seed`` to a ``numpy.random.Generator``, once.

    Parameters
    ----------
    seed : int, numpy.random.Generator or None
        A Generator is returned as is (its stream is shared, not copied); an int seeds a new
        Generator; None gives a Generator seeded from the operating system's entropy.

    Returns
    -------
    numpy.random.Generator

    Raises
    ------
    TypeError
        If ``seed`` is anything else (a bool, a float, a string...).

    Examples
    --------
    >>> rng = as_generator(7)
    >>> as_generator(rng) is rng
    True
    >>> bool(as_generator(7).integers(100) == as_generator(7).integers(100))
    True
    """
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer))):
        raise TypeError(f"seed must be an int, a numpy Generator or None (got {seed!r})")
    return np.random.default_rng(seed)
