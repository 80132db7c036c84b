"""Keep freed memory for reuse: glibc ``malloc`` settings for a process that runs stages.

A stage allocates and frees the same large arrays again and again: each chunk's pairwise
table (up to 16 MB), and in a dense swarm the OLSR model's 2-hop tuples and their splits
(27 M tuples, 216 MB per column, at 300 UAVs within range). By default glibc serves blocks
above a threshold (128 KB, adapting up to 32 MB) with a fresh ``mmap`` and unmaps them when
freed, and returns the top of its heap to the system past a trim threshold. Every such array
is then faulted in again, page by page, zeroed by the kernel. Where a page fault is
expensive, as in a virtual machine, this dominates. On the 2-core development VM a fresh page
costs about 10 µs (0.55 s to first touch 216 MB, 2 ms per MB): in a dense swarm the OLSR
advance takes 0.4 s with the settings below and 2.1 s without. A sparse swarm's blocks (16 MB at
most) are refaulted only until glibc's adaptive threshold has risen past them, so a whole run
or the benchmark suite runs the same either way (docs/bench.md, "Freed memory kept for
reuse"). The results are the same bit for bit: only where the memory comes from changes.

:func:`reuse_freed_memory` serves every block from the heap (``M_MMAP_MAX = 0``; glibc
still falls back to ``mmap`` when the heap cannot grow) and keeps up to 2 GiB of freed memory
at its top (``M_TRIM_THRESHOLD``). The price is a resident set that does not shrink
after a peak until the process ends. The ``swarmgames`` command and the sweep's worker
processes call it at start. A Python program calls it itself, before its first stage.
``SWARMGAMES_MALLOC=system`` in the environment leaves the allocator as it is.
"""

from __future__ import annotations

import ctypes
import os
import platform

__all__ = ["ENV_VAR", "reuse_freed_memory", "reusing_freed_memory"]

#: Environment variable: ``system`` leaves glibc's allocator settings alone.
ENV_VAR = "SWARMGAMES_MALLOC"

# mallopt parameters, <malloc.h>.
_M_TRIM_THRESHOLD = -1
_M_MMAP_MAX = -4
_TRIM_BYTES = 2**31 - 1  # the largest value mallopt takes (an int)

_applied: list[bool] = []


def reuse_freed_memory() -> bool:
    """Make glibc keep freed memory for the process's next arrays (module docstring).

    Returns
    -------
    bool
        True when the settings were applied; False when ``SWARMGAMES_MALLOC=system`` is
        set, the C library is not glibc (macOS, Windows, musl), or ``mallopt`` refused.
        Calling it again is harmless.
    """
    if os.environ.get(ENV_VAR, "").strip().lower() == "system":
        return False
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return False
    try:
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    ok = bool(mallopt(_M_MMAP_MAX, 0)) and bool(mallopt(_M_TRIM_THRESHOLD, _TRIM_BYTES))
    if ok and not _applied:
        _applied.append(True)
    return ok


def reusing_freed_memory() -> bool:
    """Whether :func:`reuse_freed_memory` has applied its settings in this process (the
    benchmarks record it, since it changes their timings)."""
    return bool(_applied)
