"""Read-only arrays for the immutable data containers of every layer, the one gather of CSR
rows the vectorised code uses everywhere, and the sorted unique integers it takes."""

from __future__ import annotations

import numpy as np

__all__ = ["csr_gather", "freeze_fields", "frozen", "sorted_unique"]


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


def sorted_unique(keys: np.ndarray) -> np.ndarray:
    """The sorted distinct values of an integer array: ``np.unique(keys)``, by one sort.

    numpy 2's ``np.unique`` hashes the values first and then sorts the distinct ones, which
    took 26 ms for 150 000 keys against 2 ms for a sort and a comparison of neighbours (the
    keys of a 10 000-UAV flood hop, the pairs of a link graph).

    Examples
    --------
    >>> sorted_unique(np.array([5, 3, 5, 1, 3])).tolist()
    [1, 3, 5]
    """
    s = np.sort(np.asarray(keys).ravel())
    if s.size < 2:
        return s
    keep = np.empty(s.size, dtype=bool)
    keep[0] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    return s[keep]


def pad_columns(a: np.ndarray, width: int, fill) -> np.ndarray:
    """``a`` (R, C) widened to (R, ``width``) with ``fill`` in the new columns (``a`` itself
    when already that wide): ``np.pad``'s constant padding of the last axis, without its
    general machinery (tens of microseconds a call).

    Examples
    --------
    >>> pad_columns(np.array([[1, 2]]), 3, -1).tolist()
    [[1, 2, -1]]
    """
    a = np.asarray(a)
    if a.shape[1] >= width:
        return a
    out = np.full((a.shape[0], width), fill, dtype=a.dtype)
    out[:, : a.shape[1]] = a
    return out
