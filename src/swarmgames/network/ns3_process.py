"""ns-3 in a child process of its own, so that an abort inside ns-3 costs the caller nothing.

ns-3 stops its whole process on a failed ``NS_ASSERT`` or an ``NS_FATAL_ERROR`` (docs/ns3.md,
"Known ns-3 faults"). Every ns-3 scenario therefore runs in a child process
(:mod:`swarmgames.network.ns3_worker`) that the :class:`~swarmgames.network.ns3_backend.
Ns3Provider`, the state-message sockets (:class:`~swarmgames.network.ns3_packets.StateFlood`)
and the OLSR counters (:class:`~swarmgames.network.ns3_olsr_traffic.Ns3OlsrTraffic`) send
requests to:

* requests and replies are ``(operation, arguments)`` and ``(status, value)`` tuples of
  numbers, strings and numpy arrays over a socket pair between the two processes; nothing is
  read from a file;
* the child's standard output and error go to a log file that the parent reads after every
  request: lines other than cppyy's JIT chatter are passed on to the parent's standard error,
  as they were written;
* when the child dies, the request raises :class:`Ns3ProcessDied` with ns-3's own line
  (``NS_ASSERT failed, cond=..., +34.052927252s 10 file=..., line=...``) parsed into the
  reason, ns-3's time stamp and node; the provider turns it into a one-line
  :class:`~swarmgames.errors.Ns3CrashError` with the run number and the caller's time;
* the child ends with its parent (:func:`swarmgames.lifetime.end_with`) and when the parent
  closes the socket.

One process serves the calling process's scenarios one after another (:func:`shared_process`),
so the import of ns-3 (5-18 s, about 665 MB) is paid once; after a crash the next scenario
starts a fresh process.
"""

from __future__ import annotations

import atexit
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from swarmgames.errors import BackendUnavailableError, ConfigError
from swarmgames.network.ns3_import import INSTALL_HINT, NOISE, ns3_available

__all__ = ["WORKER_MODULE", "Ns3Process", "Ns3ProcessDied", "parse_abort", "shared_process"]

#: The module the child process runs (``python -m``); tests put a stand-in here.
WORKER_MODULE = "swarmgames.network.ns3_worker"
_NS3_WORKER = WORKER_MODULE

#: Errors the child reports by name, and the exception the parent raises for each.
_ERRORS: dict[str, type[Exception]] = {
    "BackendUnavailableError": BackendUnavailableError,
    "ConfigError": ConfigError,
    "RuntimeError": RuntimeError,
    "TypeError": TypeError,
    "ValueError": ValueError,
}

#: ns-3's fatal lines: ``NS_ASSERT`` (``assert.h``), ``NS_FATAL_ERROR`` (``fatal-error.h``)
#: and ``NS_ABORT_*`` (``abort.h``).
_FATAL = re.compile(r"NS_ASSERT failed|NS_FATAL_ERROR|aborted\. |\bmsg=\"")
#: The time stamp and node context ns-3 writes into a fatal line: ``+34.052927252s 10``.
_STAMP = re.compile(r",?\s*\+(-?\d+(?:\.\d*)?(?:e[-+]?\d+)?)s (-?\d+)")
#: The source file of a fatal line, whose folder is the build machine's.
_FILE = re.compile(r"file=(?:[^,\s]*/)?([^,/\s]+)")
#: Longest reason quoted, characters.
_MAX_REASON = 300


class Ns3ProcessDied(Exception):
    """The ns-3 process ended while it served a request.

    Attributes
    ----------
    reason : str
        ns-3's fatal line without its time stamp and with the file's folder left out, or how
        the process ended.
    ns3_time : float or None
        ns-3's clock at the failure, seconds (from the fatal line).
    node : int or None
        The ns-3 node whose event failed (from the fatal line; -1 for none).
    exit_code : int
        The process's exit status (negative: killed by that signal).
    """

    def __init__(self, reason: str, ns3_time: float | None, node: int | None, exit_code: int):
        super().__init__(reason)
        self.reason, self.ns3_time, self.node, self.exit_code = reason, ns3_time, node, exit_code


def parse_abort(text: str, exit_code: int) -> tuple[str, float | None, int | None]:
    """ns-3's reason, time stamp and node from what a dead ns-3 process wrote.

    Parameters
    ----------
    text : str
        The process's standard output and error.
    exit_code : int
        Its exit status (negative: the signal that ended it).

    Returns
    -------
    reason : str
        The first fatal line of ns-3 (``NS_ASSERT failed, cond="...", file=phy-entity.cc,
        line=490``) without its time stamp and the file's folder, at most 300 characters; or,
        without one, how the process ended (``killed by SIGSEGV``, ``exit code 3``).
    ns3_time : float or None
        ns-3's clock in the fatal line, seconds.
    node : int or None
        The node in the fatal line.
    """
    for line in text.splitlines():
        if not _FATAL.search(line) or any(n in line for n in NOISE):
            continue
        stamp = _STAMP.search(line)
        ns3_time = node = None
        if stamp is not None:
            ns3_time, node = float(stamp.group(1)), int(stamp.group(2))
            line = line[: stamp.start()] + "," + line[stamp.end() :]
        reason = _FILE.sub(r"file=\1", line).strip().replace(",,", ",")
        if len(reason) > _MAX_REASON:
            reason = reason[: _MAX_REASON - 1] + "…"
        return reason, ns3_time, node
    if exit_code < 0:
        try:
            how = f"killed by {signal.Signals(-exit_code).name}"
        except ValueError:
            how = f"killed by signal {-exit_code}"
    else:
        how = f"exit code {exit_code}"
    return f"the ns-3 process ended without a message from ns-3 ({how})", None, None


class Ns3Process:
    """A child process that runs ns-3 and serves requests (module docstring).

    Parameters
    ----------
    module : str, optional
        The module the child runs with ``python -m`` (default: :data:`WORKER_MODULE`).

    Raises
    ------
    BackendUnavailableError
        If the child cannot import ns-3.
    """

    def __init__(self, module: str | None = None) -> None:
        module = WORKER_MODULE if module is None else module
        self._folder = Path(tempfile.mkdtemp(prefix="swarmgames-ns3-log-"))
        self._log_path = self._folder / "ns3.log"
        ours, theirs = socket.socketpair()
        env = {**os.environ, "CPPYY_CRASH_QUIET": "1"}  # no debugger backtrace on an abort
        with open(self._log_path, "ab") as log:  # appended to by the child, read from here
            self._proc = subprocess.Popen(
                [sys.executable, "-m", module, str(theirs.fileno()), str(os.getpid())],
                pass_fds=(theirs.fileno(),),
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=log,
                env=env,
            )
        theirs.close()
        self._conn = Connection(ours.detach())
        self._log = open(self._log_path, "rb")  # noqa: SIM115 - read as the child writes
        self._lock = threading.Lock()
        self.died: Ns3ProcessDied | None = None
        atexit.register(self.close)
        try:
            self.version = self.call("hello")
        except BaseException:
            self.close()
            raise

    @property
    def alive(self) -> bool:
        """Whether the process still serves requests."""
        return self.died is None and self._proc.poll() is None

    @property
    def pid(self) -> int:
        """The child's process id."""
        return self._proc.pid

    def call(self, op: str, *args: Any) -> Any:
        """Send request ``op`` with ``args`` and return the child's answer.

        Raises
        ------
        Ns3ProcessDied
            If the process ended before answering (and at every later call).
        BackendUnavailableError, ConfigError, RuntimeError, TypeError, ValueError
            As the child raised it, with its message.
        """
        with self._lock:
            if self.died is not None:
                raise self.died
            try:
                self._conn.send((op, args))
                status, value = self._conn.recv()
            except (EOFError, OSError):
                self.died = self._collect()
                raise self.died from None
            finally:
                self._relay()
        if status == "ok":
            return value
        kind, message = value
        if kind in _ERRORS:
            raise _ERRORS[kind](message)
        raise RuntimeError(f"ns-3: {kind}: {message}")

    def close(self) -> None:
        """End the process (it exits when its socket closes) and remove its log."""
        atexit.unregister(self.close)
        if self._proc.poll() is None:
            self._conn.close()
            try:
                self._proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        else:
            self._conn.close()
        self._log.close()
        shutil.rmtree(self._folder, ignore_errors=True)

    def _relay(self) -> None:
        """Pass on what the child wrote since the last call, less cppyy's chatter."""
        if self.died is not None:  # its last words are in the error
            return
        text = self._log.read().decode("utf-8", errors="replace")
        kept = [ln for ln in text.splitlines(True) if not any(n in ln for n in NOISE)]
        if kept:
            sys.stderr.write("".join(kept))
            sys.stderr.flush()

    def _collect(self) -> Ns3ProcessDied:
        """Wait for the dead child and read why it died."""
        try:
            code = self._proc.wait(timeout=30)
        except subprocess.TimeoutExpired:  # the socket closed but the process hangs on
            self._proc.kill()
            code = self._proc.wait()
        text = self._log.read().decode("utf-8", errors="replace")
        reason, ns3_time, node = parse_abort(text, code)
        return Ns3ProcessDied(reason, ns3_time, node, code)


_shared: list[Ns3Process] = []
_shared_lock = threading.Lock()


def shared_process() -> Ns3Process:
    """The calling process's ns-3 process, started at the first call and again after one died.

    Raises
    ------
    BackendUnavailableError
        If the ``ns3`` package is not installed or cannot be imported.
    """
    if WORKER_MODULE == _NS3_WORKER and not ns3_available():  # cheap: does not import it
        raise BackendUnavailableError(INSTALL_HINT)
    with _shared_lock:
        if not _shared or not _shared[0].alive:
            if _shared:
                _shared.pop().close()
            _shared.append(Ns3Process())
        return _shared[0]
