"""The checkpoint: the side file beside a bake's output that holds its finished ray ranges.

A bake that runs in ray ranges (:mod:`sonolux.ranges`) sums the ranges it has finished and,
every so often, writes that sum here: ``room.h5`` gets ``room.h5.checkpoint``. A later
``sonolux bake ... --resume`` reads it and traces only the rays that are missing; because the
sums are the tracer's exact fixed-point counts, the result has the bits of one uninterrupted
bake.

Nothing is lost and nothing foreign is merged:

- the file is written beside its target, flushed to disk (fsync), renamed into place and the
  folder synced, so that a kill at any moment leaves either the old checkpoint or the new one;
- it ends with the SHA-256 of everything before it: a truncated or damaged file is detected;
- it is stamped with the bake's fingerprint (:func:`fingerprint`: the scene's content, meshes
  included through the triangles they resolve to, the bake's settings, the sonolux version):
  a checkpoint of another scene, other settings or another version is detected.

Layout (``docs/distributed.md``)::

    SONOLUX-CHECKPOINT 1\\n
    <header: one line of JSON>\\n
    <array 0, zlib-compressed> <array 1> ...      (names, dtypes, shapes and sizes in the header)
    <SHA-256 of all the bytes above, 32 bytes>
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
import json
import os
import tempfile
import time
import zlib
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.outputs import follow_umask

MAGIC = b"SONOLUX-CHECKPOINT 1\n"
SUFFIX = ".checkpoint"
DIGEST_BYTES = 32
#: Fault injection for the kill tests only: seconds to sleep halfway through writing a
#: checkpoint (after its header, before its arrays), so that a test can kill the bake there.
PAUSE_ENV = "SONOLUX_FAULT_CHECKPOINT_PAUSE_S"


class CheckpointError(SonoluxError):
    """A checkpoint that cannot be used: ``reason`` is "damaged" (unreadable, truncated, bad
    checksum) or "foreign" (another scene, other settings, another version or ray range)."""

    def __init__(self, message: str, reason: str) -> None:
        super().__init__(message)
        self.reason = reason

    def __reduce__(self):  # picklable with its reason
        return (CheckpointError, (str(self), self.reason))


def side_file(output: str | Path) -> Path:
    """The checkpoint beside an output file: ``room.h5`` → ``room.h5.checkpoint``."""
    output = Path(output)
    return output.with_name(output.name + SUFFIX)


# --- the fingerprint ----------------------------------------------------------------------
def _feed(h: Any, value: Any) -> None:
    """Feeds a canonical encoding of ``value`` to the hash: dataclasses by field, dicts by sorted
    key, arrays by dtype, shape and bytes, floats by their exact repr."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(b"D" + type(value).__name__.encode())
        for f in dataclasses.fields(value):
            h.update(b"k" + f.name.encode())
            _feed(h, getattr(value, f.name))
    elif isinstance(value, dict):
        h.update(b"{%d" % len(value))
        for k in sorted(value, key=str):
            _feed(h, str(k))
            _feed(h, value[k])
    elif isinstance(value, (list, tuple)):
        h.update(b"[%d" % len(value))
        for v in value:
            _feed(h, v)
    elif isinstance(value, (set, frozenset)):
        _feed(h, sorted(value, key=repr))
    elif isinstance(value, np.ndarray):
        a = np.ascontiguousarray(value)
        if a.dtype.kind in "OUS":
            _feed(h, a.tolist())
        else:
            h.update(b"A" + a.dtype.str.encode() + repr(a.shape).encode())
            h.update(a.tobytes())
    elif isinstance(value, np.generic):
        _feed(h, value.item())
    elif isinstance(value, enum.Enum):
        _feed(h, value.value)
    elif value is None or isinstance(value, (bool, int, float, str, bytes, os.PathLike)):
        h.update(type(value).__name__.encode() + b":" + repr(value).encode())
    else:
        raise TypeError(f"cannot fingerprint a {type(value).__name__}")


def fingerprint(*parts: Any) -> str:
    """The SHA-256 (hex) of the canonical encoding of ``parts``: equal for equal content, in
    any process, on any machine."""
    h = hashlib.sha256()
    for p in parts:
        _feed(h, p)
    return h.hexdigest()


# --- writing --------------------------------------------------------------------------------
def write(path: str | Path, header: dict[str, Any], arrays: dict[str, np.ndarray]) -> Path:
    """Writes a checkpoint: a temporary file beside ``path``, fsync'd, renamed into place, the
    folder synced. ``header`` is JSON-able; ``arrays`` are stored exactly (zlib)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    blobs, entries = [], []
    for name, array in arrays.items():
        a = np.ascontiguousarray(array)
        blob = zlib.compress(a.data, 1)
        blobs.append(blob)
        entries.append({"name": name, "dtype": a.dtype.str, "shape": list(a.shape),
                        "bytes": len(blob)})
    head = dict(header, written_utc=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                arrays=entries)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            digest = hashlib.sha256()
            for piece in (MAGIC, json.dumps(head).encode() + b"\n"):
                f.write(piece)
                digest.update(piece)
            pause = float(os.environ.get(PAUSE_ENV, "0") or 0)
            if pause > 0:
                f.flush()
                time.sleep(pause)
            for blob in blobs:
                f.write(blob)
                digest.update(blob)
            f.write(digest.digest())
            f.flush()
            os.fsync(f.fileno())
        follow_umask(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    _sync_folder(path.parent)
    return path


def _sync_folder(folder: Path) -> None:
    """Makes the rename itself durable (where the system allows opening a folder)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def remove_leftovers(path: str | Path) -> int:
    """Removes temporary files that a killed write of the checkpoint ``path`` left beside it;
    returns how many."""
    path = Path(path)
    n = 0
    for tmp in path.parent.glob(f".{path.name}.*.tmp"):
        tmp.unlink(missing_ok=True)
        n += 1
    return n


# --- reading --------------------------------------------------------------------------------
def read_header(path: str | Path) -> dict[str, Any]:
    """The header of a checkpoint alone, without reading its arrays or checking its checksum
    (:func:`read` does both): for deciding what to do with it before it is read whole."""
    try:
        with open(path, "rb") as f:
            if f.read(len(MAGIC)) != MAGIC:
                raise CheckpointError(f"{path}: damaged checkpoint (not a sonolux checkpoint)",
                                      "damaged")
            return json.loads(f.readline())
    except (OSError, ValueError) as exc:
        raise CheckpointError(f"{path}: damaged checkpoint ({exc})", "damaged") from None


def read(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(header, arrays) of a checkpoint; a :class:`CheckpointError` with reason "damaged" when
    the file is truncated, altered or not a checkpoint."""
    path = Path(path)

    def damaged(why: str) -> CheckpointError:
        return CheckpointError(f"{path}: damaged checkpoint ({why})", "damaged")

    try:
        data = path.read_bytes()
    except OSError as exc:
        raise damaged(f"cannot read it: {exc.strerror or exc}") from None
    if not data.startswith(MAGIC):
        raise damaged("not a sonolux checkpoint")
    if len(data) < len(MAGIC) + DIGEST_BYTES or \
            hashlib.sha256(data[:-DIGEST_BYTES]).digest() != data[-DIGEST_BYTES:]:
        raise damaged("its SHA-256 checksum does not match: truncated or altered")
    end = data.index(b"\n", len(MAGIC))
    try:
        header = json.loads(data[len(MAGIC):end])
        arrays, at = {}, end + 1
        for e in header["arrays"]:
            raw = zlib.decompress(data[at:at + e["bytes"]])
            arrays[e["name"]] = np.frombuffer(raw, dtype=np.dtype(e["dtype"])).reshape(e["shape"])
            at += e["bytes"]
    except (ValueError, KeyError, TypeError, zlib.error) as exc:
        raise damaged(f"malformed content: {exc}") from None
    if at != len(data) - DIGEST_BYTES:
        raise damaged("its arrays do not fill the file")
    return header, arrays
