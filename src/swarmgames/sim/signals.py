"""Termination signals stop a run like Ctrl-C.

``kill``, ``timeout``, batch schedulers and a closed terminal send SIGTERM or SIGHUP, whose
default action ends the process at once and loses every completed stage. While a run is in
progress :func:`signals_interrupt` turns them into ``KeyboardInterrupt`` in the main thread,
which the stage loop already handles: the completed stages are kept, written, and
``summary.json`` says ``"interrupted": true``.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["INTERRUPT_SIGNALS", "deferred_interrupts", "raise_if_signalled", "signals_interrupt"]

#: The signals that stop a run like Ctrl-C (those this platform has).
INTERRUPT_SIGNALS = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)
)


#: The signals :func:`signals_interrupt` turned into ``KeyboardInterrupt`` in its block.
_received: list[int] = []


def _interrupt(signum: int, frame: Any) -> None:
    _received.append(signum)
    raise KeyboardInterrupt(f"stopped by {signal.Signals(signum).name}")


def raise_if_signalled() -> None:
    """Raise ``KeyboardInterrupt`` if SIGTERM or SIGHUP came inside :func:`signals_interrupt`
    and its exception was lost.

    A handler's exception raised while C code runs Python through a callback (Numba compiling
    through ctypes, for example) is printed as "Exception ignored" and dropped, and the run
    would carry on; the stage loop calls this between stages so that the signal still stops
    it, one stage late at most.

    Examples
    --------
    >>> import os, signal
    >>> with signals_interrupt():
    ...     try:
    ...         os.kill(os.getpid(), signal.SIGTERM)
    ...         signal.sigtimedwait([], 0)  # the handler runs and raises
    ...     except KeyboardInterrupt:
    ...         pass                        # dropped, as C code would drop it
    ...     try:
    ...         raise_if_signalled()
    ...     except KeyboardInterrupt as exc:
    ...         print(exc)
    stopped by SIGTERM
    """
    if _received:
        signum = _received[0]
        _received.clear()
        raise KeyboardInterrupt(f"stopped by {signal.Signals(signum).name}")


@contextlib.contextmanager
def signals_interrupt() -> Iterator[None]:
    """Raise ``KeyboardInterrupt`` on SIGTERM and SIGHUP inside the ``with`` block.

    The previous handlers are restored on exit. Outside the main thread (where Python
    cannot install signal handlers) it does nothing.

    Examples
    --------
    >>> import signal
    >>> before = signal.getsignal(signal.SIGTERM)
    >>> with signals_interrupt():
    ...     signal.getsignal(signal.SIGTERM) is before
    False
    >>> signal.getsignal(signal.SIGTERM) is before
    True
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.signal(sig, _interrupt) for sig in INTERRUPT_SIGNALS}
    _received.clear()
    try:
        yield
    finally:
        _received.clear()
        for sig, handler in previous.items():
            # None: a handler installed from C, which Python cannot reinstall.
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[None]:
    """Hold Ctrl-C, SIGTERM and SIGHUP until the end of the ``with`` block, then raise
    ``KeyboardInterrupt`` if one came.

    For the few steps that must not be cut in two: a completed stage is appended to all the
    files of its run folder, or to none. Outside the main thread it does nothing.

    Examples
    --------
    >>> import os, signal
    >>> try:
    ...     with deferred_interrupts():
    ...         os.kill(os.getpid(), signal.SIGINT)
    ...         print("still running")
    ... except KeyboardInterrupt:
    ...     print("interrupted after the block")
    still running
    interrupted after the block
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []

    def hold(signum: int, frame: Any) -> None:
        caught.append(signum)

    sigs = (signal.SIGINT, *INTERRUPT_SIGNALS)
    previous = {sig: signal.signal(sig, hold) for sig in sigs}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)
    if caught:
        raise KeyboardInterrupt(f"stopped by {signal.Signals(caught[0]).name}")
