"""Lazy, quiet import of the ns-3 Python bindings (the optional ``ns3`` package).

``from ns import ns`` is expensive and fussy (docs/reference.md section 4):

* it takes 12-18 s and about 665 MB in every process, so it happens at most once per process
  and only when the ``ns3`` backend is actually chosen;
* the ``ns3`` package finds its shared libraries by globbing, recursively, every folder on
  ``PATH``, ``LD_LIBRARY_PATH`` *and the current working directory*, so the import runs from a
  small empty temporary folder (a large working directory makes it slow; a second ns-3 build
  below it makes it fail with "multiple build profiles");
* cppyy prints harmless "Failed to materialize symbols" lines on the C-level standard error;
  they are filtered out, every other line is passed through.

References
----------
.. [1] ns-3 3.44 Python bindings, https://www.nsnam.org/docs/manual/html/python.html
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import threading
from collections.abc import Iterator
from typing import Any

from swarmgames.errors import BackendUnavailableError

__all__ = ["INSTALL_HINT", "load_ns3", "ns3_available", "quiet_stderr"]

#: What to tell a user who chose the ns-3 backend without the optional package.
INSTALL_HINT = (
    "the 'ns3' backend needs the ns-3 Python bindings: pip install 'swarmgames[ns3]' "
    "(Linux x86-64; compiles cppyy, needs g++ and the Python headers, about 3 minutes)"
)

#: Lines of cppyy/LLVM chatter that carry no information for users.
NOISE = ("Failed to materialize symbols", "JIT session error")

_lock = threading.Lock()
_ns: Any = None


@contextlib.contextmanager
def quiet_stderr(noise: tuple[str, ...] = NOISE) -> Iterator[None]:
    """Capture the process-level standard error (file descriptor 2) and re-emit every line
    that contains none of ``noise``.

    C++ code writes to the descriptor directly, past ``sys.stderr``, so the descriptor itself is
    redirected to a temporary file for the duration of the block.
    """
    try:
        fd = sys.__stderr__.fileno() if sys.__stderr__ is not None else 2
    except (AttributeError, OSError, ValueError):  # pragma: no cover - no real stderr
        yield
        return
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        sys.stderr.flush()
        saved = os.dup(fd)
        os.dup2(tmp.fileno(), fd)
        try:
            yield
        finally:
            with contextlib.suppress(Exception):
                sys.stderr.flush()
            os.dup2(saved, fd)
            os.close(saved)
            tmp.seek(0)
            text = tmp.read().decode("utf-8", errors="replace")
            kept = [ln for ln in text.splitlines(True) if not any(n in ln for n in noise)]
            if kept:
                sys.stderr.write("".join(kept))
                sys.stderr.flush()


def _import_ns() -> Any:
    cwd = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="swarmgames-ns3-") as small:
        os.chdir(small)
        try:
            with quiet_stderr():
                from ns import ns

                # Touch the modules the backend uses so their JIT chatter is filtered too.
                _ = (ns.olsr.RoutingProtocol, ns.YansWifiPhyHelper, ns.Ipv4AddressGenerator)
        finally:
            os.chdir(cwd)
    return ns


def load_ns3() -> Any:
    """Import ns-3 once per process and return its ``ns`` namespace.

    Returns
    -------
    module
        The cppyy namespace ``ns`` (``ns.Simulator``, ``ns.olsr``, ...).

    Raises
    ------
    BackendUnavailableError
        If the ``ns3`` package is not installed or cannot be loaded; the message says how to
        install it and, for a broken install, what went wrong.
    """
    global _ns
    with _lock:
        if _ns is None:
            try:
                _ns = _import_ns()
            except ModuleNotFoundError as exc:
                if exc.name in ("ns", "cppyy"):
                    raise BackendUnavailableError(INSTALL_HINT) from None
                raise BackendUnavailableError(f"{INSTALL_HINT}; import failed: {exc}") from exc
            except Exception as exc:  # cppyy raises plain Exceptions on a broken build
                raise BackendUnavailableError(f"{INSTALL_HINT}; import failed: {exc}") from exc
        return _ns


def ns3_available() -> bool:
    """Whether the ``ns3`` package is installed (cheap: does not import it)."""
    import importlib.util

    return importlib.util.find_spec("ns") is not None
