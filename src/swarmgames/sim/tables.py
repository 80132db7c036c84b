"""The formats of a run's tables, written stage by stage and read back.

A run writes three tables, ``trajectory``, ``metrics`` and ``swarm``
(:mod:`swarmgames.missions.protocol` documents their columns), in one of three formats
(``sim.tables``):

``csv``
    ``<table>.csv``: plain text, one header, then every stage's rows appended.
``csv.gz``
    ``<table>.csv.gz``: the same text, each stage's rows one gzip member (a file of
    concatenated members is one gzip stream to every reader: pandas, ``zcat``), about a
    quarter of the size.
``parquet``
    ``<table>.parquet/``: a Parquet dataset of one file per stage (``part-000000.parquet``,
    ...), each written atomically; ``pandas.read_parquet`` (and pyarrow, polars, DuckDB)
    read the folder as one table, with the columns' types. Needs pyarrow (``pip install
    "swarmgames[parquet]"``); about a tenth of the CSV's size and several times faster to
    write and read.

``auto`` (the default) picks ``csv`` while the trajectory has at most
:data:`LARGE_ROWS` rows (every run of up to a few hundred UAVs), and above that ``parquet``
if pyarrow is installed, else ``csv.gz``. Whatever the format, every completed stage is in
the table at once, whole: a run killed at any moment leaves tables that read.
"""

from __future__ import annotations

import contextlib
import gzip
import hashlib
import io
import os
import shutil
from pathlib import Path
from typing import Any

import pandas as pd

from swarmgames.errors import InputDataError, RunFolderError
from swarmgames.runfolder import sha256_file

__all__ = [
    "FORMATS",
    "LARGE_ROWS",
    "TABLE_NAMES",
    "choose_format",
    "open_table",
    "read_table",
    "table_file",
    "table_sha256",
]

#: The tables of a run.
TABLE_NAMES = ("trajectory", "metrics", "swarm")
#: The formats of ``sim.tables`` besides ``auto``.
FORMATS = ("csv", "csv.gz", "parquet")
#: Trajectory rows (robots times stages) above which ``auto`` leaves plain CSV.
LARGE_ROWS = 500_000


def has_pyarrow() -> bool:
    """Whether pyarrow can be imported (the ``parquet`` format needs it)."""
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        return False
    return True


def choose_format(setting: str, n_robots: int, n_stages: int) -> str:
    """The format ``sim.tables = setting`` gives a run of ``n_robots`` robots and
    ``n_stages`` stages (see the module docstring).

    Raises
    ------
    RunFolderError
        ``parquet`` asked for without pyarrow (the message has the pip command).

    Examples
    --------
    >>> choose_format("auto", 7, 90)
    'csv'
    """
    if setting == "auto":
        if n_robots * (n_stages + 1) <= LARGE_ROWS:
            return "csv"
        return "parquet" if has_pyarrow() else "csv.gz"
    if setting == "parquet" and not has_pyarrow():
        raise RunFolderError(
            'sim.tables = "parquet" needs pyarrow: pip install "swarmgames[parquet]" (or '
            'choose sim.tables = "csv.gz")'
        )
    if setting not in FORMATS:
        raise ValueError(f"unknown table format {setting!r}; expected auto or one of {FORMATS}")
    return setting


def table_file(name: str, fmt: str) -> str:
    """The file (or, for Parquet, folder) name of table ``name`` in format ``fmt``."""
    return f"{name}.{fmt}"


def _csv_bytes(frame: pd.DataFrame, header: bool) -> bytes:
    buf = io.StringIO()
    frame.to_csv(buf, index=False, header=header, lineterminator="\n")
    return buf.getvalue().encode("utf-8")


class _TextTable:
    """``csv`` and ``csv.gz``: chunks appended to one file (:class:`AppendFile`)."""

    def __init__(self, folder, name: str, fmt: str, keep: int | None, rows: int) -> None:
        self.file = folder.append_file(table_file(name, fmt), keep)
        self.gzip = fmt == "csv.gz"
        self.rows = rows

    @property
    def size(self) -> int:
        """Bytes written: where a resumed run cuts the file back to."""
        return self.file.size

    @property
    def sha256(self) -> str:
        """SHA-256 of the bytes written (:func:`table_sha256`)."""
        return self.file.sha256

    def append(self, frame: pd.DataFrame) -> None:
        """Append ``frame``'s rows (with the header if the table is empty)."""
        data = _csv_bytes(frame, header=self.rows == 0)
        if self.gzip:  # one member per chunk; mtime 0: the same run gives the same bytes
            data = gzip.compress(data, compresslevel=6, mtime=0)
        self.file.append(data)
        self.rows += len(frame)

    def close(self) -> None:
        self.file.close()


class _ParquetTable:
    """``parquet``: one file per chunk in the table's folder, each written atomically."""

    def __init__(self, folder, name: str, keep: int | None, rows: int) -> None:
        self.dir = folder.file(table_file(name, "parquet"))
        if keep is None and self.dir.exists():
            shutil.rmtree(self.dir) if self.dir.is_dir() else self.dir.unlink()
        self.dir.mkdir(parents=True, exist_ok=True)
        parts = sorted(self.dir.glob("part-*.parquet"))
        if keep is not None:
            if len(parts) < keep:
                raise RunFolderError(
                    f"{self.dir} has {len(parts)} parts but its checkpoint knew {keep}: the "
                    "folder was changed after the run stopped"
                )
            for p in parts[keep:]:
                p.unlink()
        self.parts = 0 if keep is None else int(keep)
        self.rows = rows
        self._folder, self._name = folder, name
        self._hash = hashlib.sha256()
        for p in parts[: self.parts]:
            self._hash.update(p.read_bytes())
        if self.dir not in folder.written:
            folder.written.append(self.dir)

    @property
    def size(self) -> int:
        """Parts written: where a resumed run cuts the dataset back to."""
        return self.parts

    @property
    def sha256(self) -> str:
        """SHA-256 of the parts written, one after the other (:func:`table_sha256`)."""
        return self._hash.hexdigest()

    def append(self, frame: pd.DataFrame) -> None:
        """Write ``frame`` as the next part."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        from swarmgames.runfolder import atomic_open

        table = pa.Table.from_pandas(frame, preserve_index=False)
        buf = io.BytesIO()
        pq.write_table(table, buf, compression="zstd")
        with atomic_open(self.dir / f"part-{self.parts:06d}.parquet", "wb") as fh:
            fh.write(buf.getvalue())
        self._hash.update(buf.getvalue())
        self.parts += 1
        self.rows += len(frame)

    def close(self) -> None:
        """Nothing stays open between parts."""


def open_table(folder, name: str, fmt: str, keep: int | None = None, rows: int = 0) -> Any:
    """A table of a run folder to append stage chunks to.

    Parameters
    ----------
    folder : RunFolder
    name : {"trajectory", "metrics", "swarm"}
    fmt : {"csv", "csv.gz", "parquet"}
    keep : int, optional
        Continue a table cut back to ``keep`` (bytes; Parquet: parts) holding ``rows`` rows
        (a resumed run); default: a new, empty table.
    rows : int
        Rows of the kept part.

    Returns
    -------
    object with ``append(frame)``, ``close()``, ``size`` and ``rows``
    """
    if fmt == "parquet":
        return _ParquetTable(folder, name, keep, rows)
    return _TextTable(folder, name, fmt, keep, rows)


def table_sha256(path: Path, fmt: str, size: int) -> str:
    """The SHA-256 of the first ``size`` bytes of a text table (Parquet: of its first ``size``
    parts, one after the other), as the table computed it while it grew.

    Raises
    ------
    OSError
        The table cannot be read, or has fewer bytes (parts) than ``size``.
    """
    if fmt != "parquet":
        return sha256_file(path, size)
    parts = sorted(Path(path).glob("part-*.parquet"))
    if len(parts) < size:
        raise FileNotFoundError(f"{path} has {len(parts)} parts, not {size}")
    digest = hashlib.sha256()
    for p in parts[:size]:
        digest.update(p.read_bytes())
    return digest.hexdigest()


def read_table(folder: str | Path, name: str) -> pd.DataFrame:
    """Table ``name`` of the run folder at ``folder``, in whichever format it was written.

    Raises
    ------
    InputDataError
        The folder has no such table, or it cannot be read (one line naming the file).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "swarm.csv").write_text("t,mean_payoff\\n10.0,-3.5\\n")
    >>> read_table(d, "swarm")["mean_payoff"].tolist()
    [-3.5]
    """
    folder = Path(folder)
    for fmt in ("parquet", "csv.gz", "csv"):
        path = folder / table_file(name, fmt)
        if not path.exists():
            continue
        try:
            if fmt == "parquet":
                parts = sorted(path.glob("part-*.parquet")) if path.is_dir() else [path]
                if not parts:
                    return pd.DataFrame()
                return pd.concat([pd.read_parquet(p) for p in parts], ignore_index=True)
            with contextlib.suppress(pd.errors.EmptyDataError):
                return pd.read_csv(path)
            return pd.DataFrame()  # no stage was completed
        except ImportError:
            raise InputDataError(
                f'{path} is a Parquet table: pip install "swarmgames[parquet]" to read it'
            ) from None
        except (OSError, ValueError, EOFError, gzip.BadGzipFile) as exc:
            raise InputDataError(f"cannot read {path}: {exc}") from None
    raise InputDataError(f"{folder} has no {name} table ({name}.csv, .csv.gz or .parquet)")


def remove_stale(folder, fmt: str) -> None:
    """Remove tables of the other formats left in ``folder`` by an earlier run (a rerun
    with ``--force`` into the same folder must not leave two versions of a table)."""
    for name in TABLE_NAMES:
        for other in FORMATS:
            if other == fmt:
                continue
            p = folder.file(table_file(name, other))
            if p.is_dir():
                shutil.rmtree(p)
            elif p.exists():
                os.unlink(p)
