"""Data-only storage of a run's state: nested values as JSON, arrays as ``.npz``.

A checkpoint (:class:`~swarmgames.sim.loop.LoopState` and the provider's, the communication
model's and the random generators' states) and every stage record
(:class:`~swarmgames.sim.loop.StageRecord`) are stored as one ``.npz`` archive each, read
back with ``numpy.load(..., allow_pickle=False)``: the member ``tree`` holds the structure as
UTF-8 JSON, with the dtype, shape and place of every array, and the member ``data`` the
arrays' bytes one after the other (one member for all of them: an archive of a checkpoint
holds hundreds of small arrays, and a member each would cost ten times more to write).
Reading one never runs code from it: the JSON names at most a class of :data:`CLASSES`,
built from its stored fields, and only dtypes of numbers, booleans and strings are read.

The JSON tree has the plain JSON values for ``None``, ``bool``, ``int``, ``float`` (``NaN`` and
``Infinity`` as Python's :mod:`json` writes them) and ``str``, and one-key objects for the rest:
``{"$array": key}`` (an array), ``{"$scalar": key}`` (a numpy scalar, stored as a 0-d array),
``{"$list": [...]}``, ``{"$tuple": [...]}``, ``{"$dict": [[key, value], ...]}`` (any keys) and
``{"$object": name, "fields": {...}}`` (a class of :data:`CLASSES`). Values come back with
their types and bits: an integer stays a Python ``int`` (random states hold 128-bit ones), an
array keeps its dtype and shape.

Records that grow a file stage by stage are *frames*: :data:`FRAME_MAGIC`, the archive's length
(8 bytes, little-endian) and the archive, so that a file cut short by a system crash still
yields every whole frame before the cut.
"""

from __future__ import annotations

import dataclasses
import io
import json
import struct
import zipfile
from collections.abc import Iterator
from typing import Any

import numpy as np

from swarmgames.comms.beliefs import BeliefTable
from swarmgames.network.olsr.tables import KeyedTable, KeySet
from swarmgames.network.provider import NetworkState
from swarmgames.sim.loop import LoopState, StageRecord
from swarmgames.topology import TopologySnapshot

__all__ = ["CLASSES", "FRAME_MAGIC", "dumps", "frame", "loads", "split_frames"]

#: The classes a stored tree may name, by name: dataclasses are built with their fields
#: (their checks run), the others get their attributes back.
CLASSES: dict[str, type] = {
    cls.__name__: cls
    for cls in (
        BeliefTable,
        KeyedTable,
        KeySet,
        LoopState,
        NetworkState,
        StageRecord,
        TopologySnapshot,
    )
}
_NAMES = {cls: name for name, cls in CLASSES.items()}

#: The start of every frame of an appended file.
FRAME_MAGIC = b"SGF1"
_LENGTH = struct.Struct("<Q")


def _encode(x: Any, arrays: dict[str, np.ndarray]) -> Any:
    if x is None or isinstance(x, (bool, str)):
        return x
    if isinstance(x, (int, float)) and not isinstance(x, np.generic):
        return int(x) if isinstance(x, int) else float(x)
    if isinstance(x, (np.ndarray, np.generic)):
        arr = np.asarray(x)
        if arr.dtype.hasobject:
            raise TypeError("arrays of Python objects cannot be stored")
        key = f"a{len(arrays)}"
        arrays[key] = arr
        return {"$array" if isinstance(x, np.ndarray) else "$scalar": key}
    if isinstance(x, list):
        return {"$list": [_encode(v, arrays) for v in x]}
    if isinstance(x, tuple):
        return {"$tuple": [_encode(v, arrays) for v in x]}
    if isinstance(x, dict):
        return {"$dict": [[_encode(k, arrays), _encode(v, arrays)] for k, v in x.items()]}
    name = _NAMES.get(type(x))
    if name is None:
        raise TypeError(f"a {type(x).__name__} cannot be stored in a run folder")
    if dataclasses.is_dataclass(x):
        fields = {f.name: getattr(x, f.name) for f in dataclasses.fields(x)}
    else:
        fields = vars(x)
    return {"$object": name, "fields": {k: _encode(v, arrays) for k, v in fields.items()}}


def dumps(obj: Any) -> bytes:
    """``obj`` as the bytes of an ``.npz`` archive (module notes).

    Raises
    ------
    TypeError
        ``obj`` holds a value of a type that cannot be stored.
    """
    arrays: dict[str, np.ndarray] = {}
    tree = _encode(obj, arrays)
    index, chunks, at = {}, [], 0
    for key, arr in arrays.items():
        raw = np.ascontiguousarray(arr).tobytes()
        index[key] = [arr.dtype.str, list(arr.shape), at, len(raw)]
        chunks.append(raw)
        at += len(raw)
    head = json.dumps({"tree": tree, "arrays": index}, separators=(",", ":")).encode("utf-8")
    buf = io.BytesIO()
    np.savez(
        buf,
        tree=np.frombuffer(head, dtype=np.uint8),
        data=np.frombuffer(b"".join(chunks), dtype=np.uint8),
    )
    return buf.getvalue()


#: Kinds of dtype an archive may hold: booleans, integers, floats, complex, strings.
_KINDS = frozenset("biufcUS")


def _arrays(index: Any, data: np.ndarray) -> dict[str, np.ndarray]:
    """The arrays ``index`` places in ``data`` (copies: the loop writes into some)."""
    if not isinstance(index, dict):
        raise _Malformed("no array index")
    arrays = {}
    for key, entry in index.items():
        if not (isinstance(entry, list) and len(entry) == 4 and isinstance(entry[0], str)):
            raise _Malformed(f"a bad entry for array {key!r}")
        descr, shape, at, size = entry
        dtype = np.dtype(descr)
        if dtype.kind not in _KINDS or dtype.hasobject or dtype.fields is not None:
            raise _Malformed(f"array {key!r} has dtype {descr!r}")
        count = int(np.prod(shape, dtype=np.int64)) if shape else 1
        if count < 0 or count * dtype.itemsize != size or not 0 <= at <= data.size - size:
            raise _Malformed(f"array {key!r} does not fit the data")
        flat = np.frombuffer(data, dtype=dtype, count=count, offset=at)
        arrays[key] = flat.reshape(shape).copy()
    return arrays


class _Malformed(ValueError):
    pass


def _decode(x: Any, arrays: dict[str, np.ndarray]) -> Any:
    if x is None or isinstance(x, (bool, int, float, str)):
        return x
    if not isinstance(x, dict) or not x:
        raise _Malformed("a value of no known form")
    kind = next(iter(x))
    body = x[kind]
    if kind in ("$array", "$scalar") and len(x) == 1:
        if body not in arrays:
            raise _Malformed(f"no array {body!r}")
        return arrays[body] if kind == "$array" else arrays[body][()]
    if kind in ("$list", "$tuple") and len(x) == 1 and isinstance(body, list):
        items = [_decode(v, arrays) for v in body]
        return items if kind == "$list" else tuple(items)
    if kind == "$dict" and len(x) == 1 and isinstance(body, list):
        if not all(isinstance(p, list) and len(p) == 2 for p in body):
            raise _Malformed("a dict entry that is not a pair")
        return {_decode(k, arrays): _decode(v, arrays) for k, v in body}
    if kind == "$object" and set(x) == {"$object", "fields"} and isinstance(x["fields"], dict):
        cls = CLASSES.get(body) if isinstance(body, str) else None
        if cls is None:
            raise _Malformed(f"a class that is not stored: {body!r}")
        fields = {k: _decode(v, arrays) for k, v in x["fields"].items()}
        if dataclasses.is_dataclass(cls):
            return cls(**fields)
        obj = cls.__new__(cls)
        for k, v in fields.items():
            setattr(obj, k, v)
        return obj
    raise _Malformed(f"a value of no known form ({kind!r})")


def loads(data: bytes) -> Any:
    """The object :func:`dumps` stored in ``data``.

    Raises
    ------
    ValueError
        ``data`` is not such an archive (damaged, or something else); nothing in it ran.
    """
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            head, raw = archive["tree"], archive["data"]
        if head.dtype != np.uint8 or raw.dtype != np.uint8 or head.ndim != 1 or raw.ndim != 1:
            raise _Malformed("members of another kind")
        meta = json.loads(head.tobytes().decode("utf-8"))
        if not isinstance(meta, dict) or set(meta) != {"tree", "arrays"}:
            raise _Malformed("no tree")
        return _decode(meta["tree"], _arrays(meta["arrays"], raw))
    except (
        ValueError,
        TypeError,
        KeyError,
        OSError,
        EOFError,
        RecursionError,
        zipfile.BadZipFile,
    ) as exc:
        why = f"{type(exc).__name__}: {exc}"[:200]
        raise ValueError(f"not a swarmgames data file ({why})") from None


def frame(data: bytes) -> bytes:
    """``data`` as one frame of an appended file."""
    return FRAME_MAGIC + _LENGTH.pack(len(data)) + data


def split_frames(data: bytes, strict: bool = True) -> Iterator[bytes]:
    """The payloads of the frames in ``data``, in order.

    Parameters
    ----------
    data : bytes
    strict : bool
        Raise on a damaged or cut frame; False: stop there (a file cut short by a crash).

    Raises
    ------
    ValueError
        ``strict`` and a frame is damaged or cut short.
    """
    at, head = 0, len(FRAME_MAGIC) + _LENGTH.size
    while at < len(data):
        if data[at : at + len(FRAME_MAGIC)] != FRAME_MAGIC or at + head > len(data):
            if strict:
                raise ValueError(f"no frame at byte {at}")
            return
        (size,) = _LENGTH.unpack_from(data, at + len(FRAME_MAGIC))
        if at + head + size > len(data):
            if strict:
                raise ValueError(f"the frame at byte {at} is cut short")
            return
        yield data[at + head : at + head + size]
        at += head + size
