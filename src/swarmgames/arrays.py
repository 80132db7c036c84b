"""Read-only arrays for the immutable data containers of every layer, and the one gather of
CSR rows the vectorised code uses everywhere."""

from __future__ import annotations

import numpy as np

__all__ = ["csr_gather", "freeze_fields", "frozen"]


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


def csr_gather(indptr: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the CSR entries of ``rows`` (in row order) and, for each, the index into
    ``rows`` it came from: the vectorised "for each row, for each entry".

    Examples
    --------
    >>> pos, which = csr_gather(np.array([0, 2, 3, 5]), np.array([2, 0]))
    >>> pos.tolist(), which.tolist()
    ([3, 4, 0, 1], [0, 0, 1, 1])
    """
    starts = indptr[rows]
    counts = indptr[rows + 1] - starts
    owner = np.repeat(np.arange(rows.size), counts)
    offset = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    return np.repeat(starts, counts) + offset, owner
