"""The material library: one JSON file of measured surface properties, read once.

The shipped library is ``sonolux/data/materials.json`` (schema ``"sonolux-materials/1"``)::

    {"schema": "sonolux-materials/1",
     "bands_hz": [63, 125, 250, 500, 1000, 2000, 4000, 8000],
     "materials": {"plaster": {"description": "...", "absorption": [8 numbers],
                               "scattering": [8 numbers], "diffuse_rgb": [3 numbers],
                               "bands_hz": [...] (optional: the entry's own octave or
                               third-octave centres, for data measured in thirds),
                               "specular": 0.0, "roughness": 0.5, "source": {...}}, ...},
     "references": {...}}

:func:`library` returns the shipped library (cached); :func:`load_library` reads another file
(tests use a small fixture). :func:`get` looks a name up and, for an unknown name, raises
:class:`~sonolux.errors.SceneError` listing close matches.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path

from sonolux.errors import SceneError, close_matches
from sonolux.scene.schema import LIBRARY_BAND_SET, LIBRARY_BANDS_HZ, Context, Material, Table

SCHEMA = "sonolux-materials/1"

#: Where the shipped library lives.
DEFAULT_PATH = Path(__file__).resolve().parent.parent / "data" / "materials.json"


@dataclass(frozen=True, eq=False)
class Library:
    """Materials by name, on the 8 library octaves (``LIBRARY_BANDS_HZ``) unless an entry gives
    its own ``bands_hz`` (a contiguous run of octaves or third-octaves)."""

    path: str
    materials: dict[str, Material]
    references: dict

    def names(self) -> list[str]:
        return sorted(self.materials)

    def find(self, name: str) -> Material | None:
        return self.materials.get(name)

    def get(self, name: str, *, file: str | None = None, key: str = "material") -> Material:
        """The material called ``name``; SceneError with close matches if there is none."""
        m = self.materials.get(name)
        if m is None:
            raise SceneError(file or self.path, key, name,
                             f"a material of the library {self.path}",
                             matches=close_matches(name, self.materials))
        return m

    def __contains__(self, name: object) -> bool:
        return name in self.materials

    def __len__(self) -> int:
        return len(self.materials)


def load_library(path: str | Path) -> Library:
    """Read and validate a material library file (not cached)."""
    path = Path(path)
    shown = str(path)
    if not path.is_file():
        raise SceneError(shown, message="the material library file does not exist")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(shown, message=f"cannot read the material library: {exc}") from None
    except json.JSONDecodeError as exc:
        raise SceneError(shown, line=exc.lineno,
                         message=f"JSON syntax error: {exc.msg} (column {exc.colno})") from None
    ctx = Context(shown)
    root = Table(data, "", ctx)
    if data.get("schema") != SCHEMA:
        raise ctx.error("schema", data.get("schema"), f'"{SCHEMA}"')
    bands = data.get("bands_hz")
    if bands is None or [float(b) for b in bands] != [float(b) for b in LIBRARY_BANDS_HZ]:
        raise ctx.error("bands_hz", bands, "the 8 octave bands " + str(list(LIBRARY_BANDS_HZ)))
    entries = root.table("materials")
    if entries is None:
        raise ctx.error("materials", allowed="a table of materials")
    materials = {name: _entry(entries, name) for name in entries.data}
    references = data.get("references", {})
    return Library(shown, materials, references if isinstance(references, dict) else {})


def _entry(entries: Table, name: str) -> Material:
    t = entries.table(name)
    assert t is not None
    # Keys beyond these (source, notes, ...) are documentation for people; they are kept in
    # the file and not read here.
    # An entry's values are on the library's octaves unless it names its own bands (thirds
    # where its source gives them; docs/bands.md).
    grid = t.band_grid("bands_hz", LIBRARY_BAND_SET)
    return Material(
        name=name,
        absorption=t.bands("absorption", grid=grid),
        scattering=t.bands("scattering", grid=grid),
        absorption_bands=grid, scattering_bands=grid,
        diffuse_rgb=t.vector("diffuse_rgb", 3, lo=0.0, hi=1.0),
        specular=t.number("specular", 0.0, lo=0.0, hi=1.0),
        roughness=t.number("roughness", 0.5, lo=0.0, hi=1.0),
        description=str(t.data.get("description", "")),
        transmittance=t.number("transmittance", 0.0, lo=0.0, hi=1.0),
    )


@functools.lru_cache(maxsize=8)
def _cached(path: str) -> Library:
    return load_library(path)


def library(path: str | Path | None = None) -> Library:
    """The shipped library (or the one at ``path``), read once and cached."""
    return _cached(str(Path(path).resolve()) if path is not None else str(DEFAULT_PATH))


def get(name: str) -> Material:
    """The shipped library's material ``name``; SceneError listing close matches if unknown."""
    return library().get(name)

