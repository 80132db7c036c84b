"""Child processes that end with their parent: sweep workers and the ns-3 process.

A child that outlives the process that started it runs for nobody (nothing reads its
results) and may hold a run folder's lock. :func:`end_with` has the calling process killed
when its parent ends, however the parent ends (``kill -9`` included).

References
----------
.. [1] Linux ``prctl(2)``, ``PR_SET_PDEATHSIG``.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time

__all__ = ["end_with"]

#: ``prctl`` option: the signal a process gets when its parent ends (Linux).
_PR_SET_PDEATHSIG = 1
#: How often a child looks whether its parent is still there, s.
_PARENT_POLL_S = 0.5


def end_with(parent: int) -> None:
    """Have this process killed when process ``parent`` ends.

    On Linux the kernel's parent-death signal does it; a thread that polls the parent's
    process id does it elsewhere (macOS has no such signal) and, on Linux, also covers a
    parent that was gone before the signal was set.

    Parameters
    ----------
    parent : int
        The parent's process id, as the parent saw it (``os.getpid()`` there).
    """
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def _watch_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(_PARENT_POLL_S)
    os.kill(os.getpid(), signal.SIGKILL)  # the parent is gone: nobody reads this work
