"""Frequency bands: octaves and third-octaves of IEC 61260-1, and conversions between them.

A band set is a contiguous run of one kind of band, named by its **nominal** centres (the
labels people read and the keys of files and tables) and computed with its **exact** base-10
mid-band frequencies and band edges (IEC 61260-1:2014, *Electroacoustics -- Octave-band and
fractional-octave-band filters -- Part 1: Specifications*, clause 5):

- octave ratio G = 10^(3/10) (eq. 1), reference frequency f_r = 1000 Hz;
- exact mid-band frequency of band x for bands of 1/b octave, b odd: f_m = f_r G^(x/b) (eq. 2):
  for third-octaves f_m = 1000 · 10^(x/10) Hz, for octaves f_m = 1000 · 10^(3x/10) Hz;
- band edges f_1 = f_m G^(-1/(2b)) and f_2 = f_m G^(1/(2b)) (eq. 4 and 5);
- nominal mid-band frequencies (Annex E): the exact ones rounded to the R10 series of preferred
  numbers of ISO 3 / ISO 266 (1, 1.25, 1.6, 2, 2.5, 3.15, 4, 5, 6.3, 8 × 10^k).

Octaves 31.5 Hz … 16 kHz (x = -5 … 4) and third-octaves 25 Hz … 20 kHz (x = -16 … 13) are
known. The octave with exact centre f_m is exactly the union of the thirds f_m/10^0.1, f_m and
f_m·10^0.1 (their edges meet), which is what lets octave results be summed from thirds.

Coefficients (absorption, scattering) move between the kinds as docs/bands.md explains:
octave data → thirds: each third takes the value of the octave it lies in (no slope is
invented inside an octave, and the mean of the three thirds returns the octave value: the
round trip of ISO 11654:1997, 4.1, whose practical absorption coefficient of an octave is the
arithmetic mean of its three thirds); thirds → octave: that arithmetic mean. Outside the range
a material's data covers, the nearest band it gives is held (never extrapolated along a slope).

Results move from thirds to octaves only by adding energy (:func:`octave_energies`), never by
averaging times or levels.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

OCTAVE = "octave"
THIRD_OCTAVE = "third-octave"
KINDS = (OCTAVE, THIRD_OCTAVE)

#: The R10 preferred numbers (ISO 3), the mantissas of the nominal mid-band frequencies.
_R10 = (1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0)
#: Band numbers x (third-octave steps from 1 kHz) of the bands sonolux knows.
_THIRD_X = tuple(range(-16, 14))  # 25 Hz … 20 kHz
_OCTAVE_X = tuple(range(-15, 13, 3))  # 31.5 Hz … 16 kHz, in third-octave steps

#: Default runs: today's octaves 125 Hz … 4 kHz, and their thirds 100 Hz … 5 kHz (the ranges
#: ISO 3382-1:2009, 5.2, asks a measurement to cover at least).
DEFAULT_OCTAVES_HZ: tuple[float, ...] = (125, 250, 500, 1000, 2000, 4000)
DEFAULT_THIRDS_HZ: tuple[float, ...] = (100, 125, 160, 200, 250, 315, 400, 500, 630, 800, 1000,
                                        1250, 1600, 2000, 2500, 3150, 4000, 5000)


def _nominal(x: int) -> float:
    """Nominal mid-band frequency of third-octave band number x (an int where it is whole)."""
    mantissa = _R10[x % 10]
    value = round(mantissa * 10.0 ** (3 + x // 10), 6)
    return int(value) if value == int(value) else value


def _exact(x: int) -> float:
    return 1000.0 * 10.0 ** (x / 10.0)


#: Nominal centres of every known band, per kind, ascending.
NOMINAL_HZ: dict[str, tuple[float, ...]] = {
    OCTAVE: tuple(_nominal(x) for x in _OCTAVE_X),
    THIRD_OCTAVE: tuple(_nominal(x) for x in _THIRD_X),
}
_X_OF: dict[str, dict[float, int]] = {
    OCTAVE: {_nominal(x): x for x in _OCTAVE_X},
    THIRD_OCTAVE: {_nominal(x): x for x in _THIRD_X},
}


@dataclass(frozen=True)
class BandSet:
    """A contiguous run of octave or third-octave bands.

    kind: "octave" or "third-octave"; nominal_hz: the nominal centres (labels, keys).
    """

    kind: str
    nominal_hz: tuple[float, ...]

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"band kind {self.kind!r}: one of {KINDS}")
        if not is_contiguous_run(self.nominal_hz, self.kind):
            raise ValueError(f"{list(self.nominal_hz)} is not a contiguous run of {self.kind} "
                             f"bands {NOMINAL_HZ[self.kind][0]:g} … {NOMINAL_HZ[self.kind][-1]:g} Hz")

    @property
    def n_bands(self) -> int:
        return len(self.nominal_hz)

    @property
    def per_octave(self) -> int:
        """Bands per octave, b: 1 or 3."""
        return 1 if self.kind == OCTAVE else 3

    @property
    def band_numbers(self) -> np.ndarray:
        """int64[band]: x, the band's number in third-octave steps from 1 kHz."""
        return np.array([_X_OF[self.kind][f] for f in self.nominal_hz], dtype=np.int64)

    @property
    def exact_hz(self) -> np.ndarray:
        """float64[band]: the exact base-10 mid-band frequencies, f_m = 1000 · 10^(x/10) Hz."""
        return 1000.0 * 10.0 ** (self.band_numbers / 10.0)

    @property
    def edges_hz(self) -> np.ndarray:
        """float64[band, 2]: lower and upper band edges, f_m · 10^(∓3/(20 b)) Hz."""
        half = 10.0 ** (0.3 / (2 * self.per_octave))
        f = self.exact_hz
        return np.stack([f / half, f * half], axis=1)

    def labels(self) -> list[str]:
        return [f"{f:g}" for f in self.nominal_hz]


def is_contiguous_run(bands_hz: Sequence[float], kind: str) -> bool:
    """True when ``bands_hz`` is a non-empty run of neighbouring nominal centres of ``kind``."""
    known = NOMINAL_HZ[kind]
    if not bands_hz or not all(_is_number(b) and float(b) in known for b in bands_hz):
        return False
    first = known.index(float(bands_hz[0]))
    return [float(b) for b in bands_hz] == [float(b) for b in known[first:first + len(bands_hz)]]


def band_set_of(bands_hz: Sequence[float], kind: str | None = None) -> BandSet:
    """The band set whose nominal centres are ``bands_hz``; without ``kind`` it is inferred:
    octaves when the run is one of octaves (so a single band common to both is an octave),
    else third-octaves. ValueError when it is neither."""
    centres = [float(b) for b in np.asarray(bands_hz, dtype=np.float64).ravel()]
    for k in (kind,) if kind is not None else KINDS:
        if is_contiguous_run(centres, k):
            return BandSet(k, tuple(_canonical(f, k) for f in centres))
    raise ValueError(f"{centres} is not a contiguous run of octave or third-octave centres")


def _canonical(f: float, kind: str) -> float:
    """The table's own value for a nominal centre (an int where whole)."""
    return NOMINAL_HZ[kind][NOMINAL_HZ[kind].index(f)]


def _is_number(v: object) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def allowed_text(kind: str | None = None) -> str:
    """What a list of centres may be, for error messages."""
    runs = {k: f"a contiguous run of the {k} centres " + ", ".join(
        f"{f:g}" for f in NOMINAL_HZ[k]) + " Hz" for k in KINDS}
    return runs[kind] if kind is not None else f"{runs[OCTAVE]}, or {runs[THIRD_OCTAVE]}"


# --- coefficients between band sets ---------------------------------------------------------
def _on_thirds(values: np.ndarray, source: BandSet) -> np.ndarray:
    """float64[30]: the coefficients on every known third, from data on ``source``.

    Octave data: each third takes its octave's value. Beyond the data: the nearest band held."""
    x_all = np.array(_THIRD_X)
    x_src = source.band_numbers
    if source.kind == OCTAVE:
        # A third belongs to the octave whose centre is within one third-octave step of it.
        index = np.rint((x_all - x_src[0]) / 3.0).astype(np.int64)
    else:
        index = x_all - x_src[0]
    return values[np.clip(index, 0, x_src.size - 1)]


def convert_coefficients(values, source: BandSet, target: BandSet) -> np.ndarray:
    """float64[target band]: coefficients given on ``source`` bands, on ``target`` bands.

    Same kind: the matching bands, the nearest held beyond the data. Octaves → thirds: each
    third takes its octave's value. Thirds → octaves: the arithmetic mean of the octave's three
    thirds (ISO 11654:1997, 4.1, without its rounding), computed as a + ((b - a) + (c - a))/3 so
    that three equal thirds give their value exactly. See docs/bands.md.
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    if v.size != source.n_bands:
        raise ValueError(f"{v.size} values for {source.n_bands} bands")
    if source.kind == target.kind:
        step = 1 if source.kind == THIRD_OCTAVE else 3
        index = (target.band_numbers - source.band_numbers[0]) // step
        return v[np.clip(index, 0, v.size - 1)].copy()
    thirds = _on_thirds(v, source)
    if target.kind == THIRD_OCTAVE:
        return thirds[target.band_numbers - _THIRD_X[0]].copy()
    centre = target.band_numbers - _THIRD_X[0]
    a, lo, hi = thirds[centre], thirds[centre - 1], thirds[centre + 1]
    return a + ((lo - a) + (hi - a)) / 3.0


def held_bands(source: BandSet, target: BandSet) -> list[float]:
    """Nominal centres of ``target`` that lie (partly) outside the frequency range ``source``
    covers, where :func:`convert_coefficients` holds the nearest band's value."""
    lo, hi = source.edges_hz[0, 0], source.edges_hz[-1, 1]
    edges = target.edges_hz
    out = (edges[:, 0] < lo * (1 - 1e-9)) | (edges[:, 1] > hi * (1 + 1e-9))
    return [f for f, o in zip(target.nominal_hz, out) if o]


# --- results between band sets --------------------------------------------------------------
def octave_grouping(thirds: BandSet) -> tuple[BandSet, np.ndarray]:
    """The octaves made whole by ``thirds``, and for each its three third indices: int64[oct, 3].

    An octave is kept only when all three of its thirds are in the set (a partial octave would
    be missing energy). ValueError when the set is not of thirds or holds no whole octave."""
    if thirds.kind != THIRD_OCTAVE:
        raise ValueError(f"octave energies need a third-octave field, not {thirds.kind} bands")
    x = thirds.band_numbers
    octave_x = [c for c in _OCTAVE_X if c - 1 in x and c + 1 in x]
    if not octave_x:
        raise ValueError(f"the third-octave bands {thirds.labels()} Hz hold no whole octave "
                         "(its three thirds)")
    first = int(x[0])
    groups = np.array([[c - 1 - first, c - first, c + 1 - first] for c in octave_x],
                      dtype=np.int64)
    return BandSet(OCTAVE, tuple(_nominal(c) for c in octave_x)), groups


def octave_energies(energy, thirds: BandSet, axis: int = -1) -> tuple[BandSet, np.ndarray]:
    """Octave-band energies from third-octave energies: the sum of each octave's three thirds.

    ``energy`` has the band axis ``axis`` on ``thirds``; the result has the same shape with
    that axis on the octaves :func:`octave_grouping` finds. Energies add because the thirds'
    bands are disjoint and together make the octave (IEC 61260-1 edges), so the octave's
    energy is the sum; decay times and levels are then computed from the sum, never averaged.
    """
    octaves, groups = octave_grouping(thirds)
    e = np.asarray(energy)
    moved = np.moveaxis(e, axis, -1)
    total = moved[..., groups[:, 0]] + moved[..., groups[:, 1]] + moved[..., groups[:, 2]]
    return octaves, np.moveaxis(total, -1, axis)


__all__ = ["DEFAULT_OCTAVES_HZ", "DEFAULT_THIRDS_HZ", "KINDS", "NOMINAL_HZ", "OCTAVE",
           "THIRD_OCTAVE", "BandSet", "allowed_text", "band_set_of", "convert_coefficients",
           "held_bands", "is_contiguous_run", "octave_energies", "octave_grouping"]
