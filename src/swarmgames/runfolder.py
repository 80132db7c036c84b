"""Run folders: one folder per run, every file written atomically.

A run folder holds the resolved ``config.toml``, data as CSV, figures as PNG and a
``summary.json``. Each file is written to a temporary file in the same folder, flushed,
``fsync``-ed and renamed over its final name (``os.replace`` is atomic on POSIX and Windows), so
an interrupted run leaves complete files or none, never a half-written one. Tables that grow
while a run goes on are appended instead (:class:`AppendFile`): each chunk goes to the operating
system in one ``write``, so a killed process leaves whole chunks. A process killed
while writing (``kill -9``) can leave its temporary file, ``.<name>.<random>.tmp``: such a
leftover never makes a folder count as "not empty", and is removed when the folder is reused.

One process at a time writes a run folder: :class:`RunFolder` takes an exclusive
``fcntl.flock`` on the folder's :data:`LOCK_FILE` before it writes anything, and a second
writer is refused with the holder's process id. The operating system releases the lock
when its process ends in any way (``kill -9`` included), so a lock never outlives its writer;
the lock file stays in the folder (removing it would let two writers lock two different
files), hidden and ignored like a leftover temporary file.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import socket
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from swarmgames.errors import OutputWriteError, RunFolderError

__all__ = [
    "LOCK_FILE",
    "AppendFile",
    "RunFolder",
    "atomic_open",
    "atomic_write_bytes",
    "atomic_write_text",
    "sha256_file",
]

#: The file a writer of a run folder holds locked (module notes).
LOCK_FILE = ".swarmgames.lock"
_CHUNK = 1 << 20


def sha256_file(path: str | Path, size: int | None = None) -> str:
    """The SHA-256 (hex) of the first ``size`` bytes of ``path`` (all of it when None).

    Raises
    ------
    OSError
        The file cannot be read; ``EOFError`` if it is shorter than ``size``.
    """
    digest = hashlib.sha256()
    left = size
    with open(path, "rb") as fh:
        while left is None or left > 0:
            chunk = fh.read(_CHUNK if left is None else min(_CHUNK, left))
            if not chunk:
                break
            digest.update(chunk)
            if left is not None:
                left -= len(chunk)
    if left:
        raise EOFError(f"{path} is shorter than {size} bytes")
    return digest.hexdigest()


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[IO]:
    """Open a temporary file beside ``path`` and rename it to ``path`` on success.

    On any exception inside the ``with`` block the temporary file is removed and ``path`` is
    left untouched (absent, or with its previous content).

    Parameters
    ----------
    path : str or Path
        Final file name.
    mode : {"w", "wb"}
        Text or binary mode.
    **kwargs
        Passed to :func:`open` (e.g. ``encoding``, ``newline``).

    Raises
    ------
    OutputWriteError
        The file could not be written (an ``OSError``: disk full, permission, ...); the
        message names the file and the reason.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb' (got {mode!r})")
    path = Path(path)
    if mode == "w":
        kwargs.setdefault("encoding", "utf-8")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise _write_error(path, exc) from None
    try:
        # mkstemp creates the file 0600; give it the permissions an ordinary open() would.
        os.chmod(tmp, 0o666 & ~_umask())
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and not isinstance(exc, OutputWriteError):
            raise _write_error(path, exc) from None
        raise


def _write_error(path: Path, exc: OSError) -> OutputWriteError:
    """One line naming the file and the system's reason (disk full, permission, ...)."""
    why = exc.strerror or str(exc) or type(exc).__name__
    return OutputWriteError(f"cannot write {path}: {why}")


def _is_leftover(p: Path) -> bool:
    """Whether ``p`` is a temporary file of :func:`atomic_open` (``.<name>.<random>.tmp``),
    left behind by a process killed while writing, or the folder's lock file."""
    name = p.name
    if name == LOCK_FILE:
        return True
    return name.startswith(".") and name.endswith(".tmp") and name.count(".") >= 3 and p.is_file()


def _check_writable(folder: Path) -> None:
    """Create and remove a temporary file in ``folder``: raises OSError where the run could
    not write its files (read-only file system, no permission), before any work is done."""
    fd, probe = tempfile.mkstemp(prefix=".probe.", suffix=".tmp", dir=folder)
    os.close(fd)
    os.unlink(probe)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically and return the path."""
    with atomic_open(path, "w", newline="") as fh:
        fh.write(text)
    return Path(path)


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically and return the path."""
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


class AppendFile:
    """A file that grows by whole chunks (the tables of a run in progress).

    Parameters
    ----------
    path : Path
        The file; created if missing.
    keep : int, optional
        Keep the first ``keep`` bytes and drop the rest (a resumed run continues from its
        checkpoint); default: start empty.

    Raises
    ------
    RunFolderError
        The file is shorter than ``keep`` bytes (it is not the one the checkpoint knew), or
        cannot be opened.

    Notes
    -----
    :meth:`append` hands each chunk to the operating system at once (no buffer in the
    process), so a process killed at any moment (``kill -9``, out of memory) leaves every
    chunk that was appended, and at most the last one cut short by a system crash; callers
    that need a chunk on disk through a power cut call :meth:`sync`.
    """

    def __init__(self, path: Path, keep: int | None = None) -> None:
        self.path = Path(path)
        try:
            self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT, 0o666)
        except OSError as exc:
            why = exc.strerror or type(exc).__name__
            raise RunFolderError(f"cannot write {self.path}: {why}") from None
        size = os.fstat(self._fd).st_size
        if keep is not None and size < keep:
            os.close(self._fd)
            raise RunFolderError(
                f"{self.path} has {size} bytes but its checkpoint knew {keep}: the file was "
                "changed after the run stopped"
            )
        self.size = 0 if keep is None else int(keep)
        self._hash = hashlib.sha256()
        if self.size:
            with open(self.path, "rb") as fh:
                left = self.size
                while left:
                    chunk = fh.read(min(_CHUNK, left))
                    self._hash.update(chunk)
                    left -= len(chunk)
        os.ftruncate(self._fd, self.size)
        os.lseek(self._fd, self.size, os.SEEK_SET)

    @property
    def sha256(self) -> str:
        """The SHA-256 (hex) of the file's content so far (kept as chunks are appended)."""
        return self._hash.hexdigest()

    def append(self, data: bytes) -> None:
        """Append ``data`` (``write`` until all of it is written).

        Raises
        ------
        OutputWriteError
            The system refused (disk full, quota, I/O error): the file is cut back to the
            chunks before this one, and the error names the file and the reason.
        """
        view = memoryview(data)
        try:
            while view:
                done = os.write(self._fd, view)
                view = view[done:]
        except OSError as exc:
            with contextlib.suppress(OSError):  # no half chunk is left behind
                os.ftruncate(self._fd, self.size)
                os.lseek(self._fd, self.size, os.SEEK_SET)
            raise _write_error(self.path, exc) from None
        self.size += len(data)
        self._hash.update(data)

    def sync(self) -> None:
        """Make the appended bytes durable (``fsync``)."""
        os.fsync(self._fd)

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __repr__(self) -> str:
        return f"AppendFile({str(self.path)!r}, size={self.size})"


class RunFolder:
    """The output folder of one run.

    Parameters
    ----------
    path : str or Path
        Folder to write into; created if missing.
    force : bool, default False
        Allow writing into an existing, non-empty folder (files of the same name are replaced).

    Attributes
    ----------
    created : list of Path
        The folders this RunFolder created (``path`` and any missing parents, outermost
        first); empty when ``path`` existed. :meth:`discard_if_empty` removes only these.
    written : list of Path
        The files written so far, in order.

    Raises
    ------
    RunFolderError
        If ``path`` exists, is not empty (temporary files left by a killed write and the lock
        file do not count) and ``force`` is false; is not a folder; cannot be created or
        written into (below a file, read-only, no permission); or another process holds its
        lock (the message gives that process's id).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> run = RunFolder(pathlib.Path(tempfile.mkdtemp()) / "demo")
    >>> run.write_json("summary.json", {"ok": True}).name
    'summary.json'
    """

    def __init__(self, path: str | Path, force: bool = False) -> None:
        self.path = Path(path)
        self._lock = -1
        self._held = False  # whether this object ever held the lock
        if self.path.exists() and not self.path.is_dir():
            raise RunFolderError(f"output path {self.path} exists and is not a folder")
        self.created = [p for p in (*reversed(self.path.parents), self.path) if not p.exists()]
        try:
            self.path.mkdir(parents=True, exist_ok=True)
            self._take_lock()
            if any(not _is_leftover(p) for p in self._entries()) and not force:
                raise RunFolderError(
                    f"output folder {self.path} is not empty; use --force (force=True) to "
                    "write into it, or choose another --out"
                )
            _check_writable(self.path)
        except OSError as exc:
            self.discard_if_empty()
            if isinstance(exc, RunFolderError):
                raise
            why = exc.strerror or type(exc).__name__
            raise RunFolderError(f"cannot write into output folder {self.path}: {why}") from None
        for p in self._entries():
            if _is_leftover(p) and p.name != LOCK_FILE:
                with contextlib.suppress(OSError):
                    p.unlink()
        self.written: list[Path] = []

    def _take_lock(self) -> None:
        """Hold the folder's lock file exclusively, or raise naming the process that does."""
        lock = self.path / LOCK_FILE
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 200, 0).decode("utf-8", "replace").strip() or "?"
            os.close(fd)
            raise RunFolderError(
                f"output folder {self.path} is being written by another swarmgames process "
                f"({holder}); wait for it to end, or choose another --out"
            ) from None
        except OSError:
            os.close(fd)
            raise
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}\n".encode(), 0)
        self._lock, self._held = fd, True

    def close(self) -> None:
        """Release the folder's lock (idempotent); :func:`swarmgames.run` releases it at
        the end of the run, and the object's collection or the process's end does too."""
        if self._lock >= 0:
            os.close(self._lock)
            self._lock = -1

    def __del__(self) -> None:
        self.close()

    def __enter__(self) -> RunFolder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _entries(self) -> list[Path]:
        try:
            return list(self.path.iterdir())
        except OSError as exc:
            why = exc.strerror or type(exc).__name__
            raise RunFolderError(f"cannot read output folder {self.path}: {why}") from None

    def discard_if_empty(self) -> None:
        """Remove the folders this RunFolder created, innermost first, as far as they are
        empty (a run that failed before writing leaves no trace; the lock is released). A
        folder that existed before is never removed."""
        if self.created and self._held:
            with contextlib.suppress(OSError):
                if all(p.name == LOCK_FILE for p in self.path.iterdir()):
                    (self.path / LOCK_FILE).unlink()
        self.close()
        for p in reversed(self.created):
            try:
                p.rmdir()  # only succeeds on an empty folder
            except OSError:
                return

    def __repr__(self) -> str:
        return f"RunFolder({str(self.path)!r})"

    def file(self, name: str) -> Path:
        """Path of ``name`` inside the folder (``name`` may not leave the folder)."""
        p = (self.path / name).resolve()
        if self.path.resolve() not in p.parents:
            raise ValueError(f"file name must stay inside the run folder (got {name!r})")
        return p

    def _done(self, p: Path) -> Path:
        if p not in self.written:  # a file rewritten (the manifest of a run) counts once
            self.written.append(p)
        return p

    def append_file(self, name: str, keep: int | None = None) -> AppendFile:
        """Open ``name`` as an :class:`AppendFile` (see there for ``keep``)."""
        path = self.file(name)
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = AppendFile(path, keep)
        if path not in self.written:
            self.written.append(path)
        return handle

    def write_text(self, name: str, text: str) -> Path:
        """Write a text file atomically."""
        return self._done(atomic_write_text(self.file(name), text))

    def write_bytes(self, name: str, data: bytes) -> Path:
        """Write a binary file atomically."""
        return self._done(atomic_write_bytes(self.file(name), data))

    def write_json(self, name: str, obj: Any) -> Path:
        """Write ``obj`` as indented JSON (numpy scalars and arrays are converted)."""
        return self.write_text(name, json.dumps(obj, indent=2, default=_json_default) + "\n")

    def write_csv(self, name: str, frame: Any, **kwargs: Any) -> Path:
        """Write a pandas DataFrame as CSV without its index (unless ``index=True``)."""
        kwargs.setdefault("index", False)
        with atomic_open(self.file(name), "w", newline="") as fh:
            frame.to_csv(fh, **kwargs)
        return self._done(self.file(name))

    @classmethod
    def of(cls, folder: RunFolder | str | Path, force: bool = False) -> RunFolder:
        """``folder`` itself if it is a RunFolder, else a RunFolder at that path."""
        return folder if isinstance(folder, RunFolder) else cls(folder, force=force)

    def save_figure(self, name: str, fig: Any, dpi: int = 150) -> Path:
        """Save a matplotlib figure (format from the file name) atomically, then close it if
        pyplot manages it (so that writing many figures does not accumulate them). A figure
        with a layout engine (constrained layout) is saved as laid out, in one draw; others
        are cropped to their content (``bbox_inches="tight"``, a second draw)."""
        fmt = Path(name).suffix.lstrip(".") or "png"
        bbox = None if fig.get_layout_engine() is not None else "tight"
        try:
            with atomic_open(self.file(name), "wb") as fh:
                fig.savefig(fh, format=fmt, dpi=dpi, bbox_inches=bbox)
        finally:
            plt = sys.modules.get("matplotlib.pyplot")
            if plt is not None and getattr(fig, "number", None) in plt.get_fignums():
                plt.close(fig)
        return self._done(self.file(name))


def _json_default(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot serialise {type(obj).__name__} to JSON")
