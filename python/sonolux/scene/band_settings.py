"""The scene's choice of frequency bands (``[settings]`` keys ``bands``, ``bands_hz``,
``band_range_hz``), validated once, here.

- ``bands = "octave"`` (the default) or ``"third-octave"``: that kind's default run (octaves
  125 Hz … 4 kHz, as before; thirds 100 Hz … 5 kHz, the ranges of ISO 3382-1:2009, 5.2);
- ``bands = [centres]`` or ``bands_hz = [centres]``: an explicit contiguous run of nominal
  centres; its kind is inferred (octaves when the run is one of octaves), or checked against
  ``bands`` when that names a kind;
- ``band_range_hz = [lowest, highest]`` with a kind: every band of that kind between the two
  nominal centres.

Every band must lie below the Nyquist frequency of ``sample_rate_hz`` (the synthesis filter
bank splits the spectrum up to there).
"""

from __future__ import annotations

from typing import Any

from sonolux.acoustics.bands import (
    DEFAULT_OCTAVES_HZ,
    DEFAULT_THIRDS_HZ,
    KINDS,
    NOMINAL_HZ,
    OCTAVE,
    BandSet,
    allowed_text,
    band_set_of,
    held_bands,
)
from sonolux.scene.schema import Table

DEFAULTS = {OCTAVE: DEFAULT_OCTAVES_HZ, "third-octave": DEFAULT_THIRDS_HZ}
_KIND_TEXT = 'one of "octave", "third-octave", or a list of band centres'


def read_bands(t: Table, sample_rate_hz: int) -> BandSet:
    """The band set a ``[settings]`` table asks for."""
    given = t.data.get("bands", None)
    listed = t.data.get("bands_hz", None)
    span = t.data.get("band_range_hz", None)
    kind: str | None = None
    centres: Any = None
    if isinstance(given, list):
        if listed is not None or span is not None:
            other = "bands_hz" if listed is not None else "band_range_hz"
            raise t.ctx.error(t.path(other), listed if listed is not None else span,
                              "nothing when bands is a list of centres (give one of them)")
        centres, key = given, "bands"
    elif given is not None:
        if given not in KINDS:
            raise t.ctx.error(t.path("bands"), given, _KIND_TEXT)
        kind = given
    if centres is None and listed is not None:
        if span is not None:
            raise t.ctx.error(t.path("band_range_hz"), span,
                              "nothing when bands_hz lists the centres (give one of them)")
        centres, key = listed, "bands_hz"
    if centres is not None:
        try:
            bands = band_set_of(centres, kind) if isinstance(centres, list) else None
        except (ValueError, TypeError):
            bands = None
        if bands is None:
            raise t.ctx.error(t.path(key), centres, allowed_text(kind))
    elif span is not None:
        bands = _range(t, span, kind or OCTAVE)
    else:
        kind = kind or OCTAVE
        bands = BandSet(kind, tuple(DEFAULTS[kind]))
    nyquist = sample_rate_hz / 2.0
    if max(bands.exact_hz[-1], bands.nominal_hz[-1]) >= nyquist:
        where = "bands" if isinstance(given, list) else (
            "bands_hz" if listed is not None else "band_range_hz" if span is not None else "bands")
        raise t.ctx.error(t.path(where), list(bands.nominal_hz),
                          f"bands below the Nyquist frequency {nyquist:g} Hz of sample_rate_hz "
                          f"= {sample_rate_hz}")
    return bands


def held_band_warnings(materials: list, bands: BandSet) -> list[str]:
    """Sentences naming the materials whose data does not reach every simulated band (their
    nearest band's value is held there, docs/bands.md)."""
    out = []
    for m in materials:
        for what, grid in (("absorption", m.absorption_bands), ("scattering", m.scattering_bands)):
            held = held_bands(grid, bands)
            if held:
                out.append(f"material {m.name!r} gives its {what} for {grid.nominal_hz[0]:g}.."
                           f"{grid.nominal_hz[-1]:g} Hz only: at "
                           + ", ".join(f"{f:g}" for f in held)
                           + " Hz the nearest band's value is held")
    return out


def _range(t: Table, span: Any, kind: str) -> BandSet:
    known = NOMINAL_HZ[kind]
    allowed = (f"[lowest, highest]: two {kind} centres of " + ", ".join(f"{f:g}" for f in known)
               + " Hz, lowest ≤ highest")
    ok = (isinstance(span, list) and len(span) == 2
          and all(isinstance(f, (int, float)) and not isinstance(f, bool) and float(f) in known
                  for f in span))
    if ok:
        i, j = known.index(float(span[0])), known.index(float(span[1]))
        ok = i <= j
    if not ok:
        raise t.ctx.error(t.path("band_range_hz"), span, allowed)
    return BandSet(kind, known[i:j + 1])


__all__ = ["DEFAULTS", "held_band_warnings", "read_bands"]
