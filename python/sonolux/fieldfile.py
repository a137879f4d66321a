"""The field file: one HDF5 file (h5py) for what a bake computed, sound and light side by side,
written to a temporary file and renamed, so that an interrupted bake never leaves a broken
file behind.

Schema ``sonolux-field/1``:

    /          attrs: schema, sonolux_version, created_utc, scene_name, scene_origin,
               bake (JSON: what the bake shared between the senses and how long each part took)
    /sound     the sound field, when the bake traced sound (:mod:`sonolux.sound.fieldfile`)
    /light     the light field, when it traced light (:mod:`sonolux.light.fieldfile`)

Both groups are optional, at least one is there. Readers ignore groups they do not know;
:func:`open_field` needs ``/sound`` and :func:`open_light_field` needs ``/light``.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sonolux.errors import SonoluxError

if TYPE_CHECKING:
    from sonolux.light.field import LightField
    from sonolux.sound.field import SoundField

SCHEMA = "sonolux-field/1"


def json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.integer, np.floating)):
        return o.item()
    return str(o)


def save_fields(path: str | Path, *, sound: SoundField | None = None,
                light: LightField | None = None, bake: dict[str, Any] | None = None) -> Path:
    """Writes the fields given to ``path`` (a temporary file beside it, then renamed)."""
    import h5py

    from sonolux import __version__
    from sonolux.light.fieldfile import write_group as write_light
    from sonolux.sound.fieldfile import write_group as write_sound

    if sound is None and light is None:
        raise SonoluxError(f"{path}: nothing to write (neither a sound nor a light field)")
    first = sound if sound is not None else light
    assert first is not None
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        with h5py.File(tmp, "w") as f:
            f.attrs.update(schema=SCHEMA, sonolux_version=__version__,
                           created_utc=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                           scene_name=first.scene_name, scene_origin=first.scene_origin)
            if bake is not None:
                f.attrs["bake"] = json.dumps(bake, default=json_default)
            if sound is not None:
                write_sound(f, sound, json_default)
            if light is not None:
                write_light(f, light, json_default)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    for field in (sound, light):
        if field is not None:
            field.path = str(path)
    return path


@contextmanager
def open_file(path: str | Path) -> Iterator[Any]:
    """The open h5py file, after checking that it is a sonolux field file."""
    import h5py

    path = Path(path)
    if not path.exists():
        raise SonoluxError(f"{path}: no such file")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise SonoluxError(f"{path}: not an HDF5 file sonolux can read ({exc})") from None
    with f:
        schema = f.attrs.get("schema")
        if schema != SCHEMA:
            raise SonoluxError(f"{path}: not a sonolux field file (schema {schema!r}, expected "
                               f"{SCHEMA!r})")
        yield f


def contents(path: str | Path) -> dict[str, Any]:
    """What the file holds: {"sound": bool, "light": bool, "bake": dict or None}."""
    with open_file(path) as f:
        bake = f.attrs.get("bake")
        return {"sound": "sound" in f, "light": "light" in f,
                "bake": json.loads(bake) if bake is not None else None}


def open_field(path: str | Path) -> SoundField:
    """The sound field of a field file; a missing, unreadable or foreign file, or one baked
    without sound, is a clear error."""
    from sonolux.sound.fieldfile import read_group

    with open_file(path) as f:
        return read_group(f, str(path))


def open_light_field(path: str | Path) -> LightField:
    """The light field of a field file; a clear error when the file has none."""
    from sonolux.light.fieldfile import read_group

    with open_file(path) as f:
        return read_group(f, str(path))
