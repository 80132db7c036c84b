"""Read-only arrays for the immutable data containers of every layer."""

from __future__ import annotations

import numpy as np

__all__ = ["freeze_fields", "frozen"]


def frozen(a, dtype=None) -> np.ndarray:
    """A read-only C-contiguous copy of ``a`` (in ``dtype``, if given).

    Examples
    --------
    >>> x = frozen([1, 2], float)
    >>> x.flags.writeable, x.dtype.name
    (False, 'float64')
    """
    out = np.array(a, dtype=dtype, copy=True, order="C")
    out.setflags(write=False)
    return out


def freeze_fields(obj) -> None:
    """Replace every writeable ndarray field of a frozen dataclass by a read-only view (no
    copy); call it from ``__post_init__``."""
    for name, value in vars(obj).items():
        if isinstance(value, np.ndarray) and value.flags.writeable:
            view = value.view()
            view.setflags(write=False)
            object.__setattr__(obj, name, view)
