"""IES LM-63 photometric files: the luminous intensity distribution of a luminaire, as
manufacturers publish it (ANSI/IES LM-63-19 "Approved Method: IES Standard File Format for the
Electronic Transfer of Photometric Data"; its 1986, 1991, 1995 and 2002 versions read the same).

No well-kept Python package reads the format (checked against the PyPI index), so this module
reads it: the header line and ``[KEYWORD]`` lines (kept), ``TILT=NONE`` or ``TILT=INCLUDE``
(the tilt table is read and not applied: sonolux mounts the luminaire as it was measured), the
line of ten numbers (lamps, lumens per lamp, candela multiplier, number of vertical and
horizontal angles, photometric type, units type, width, length, height), the line of ballast
factor, ballast-lamp photometric factor (2019: file generation type) and input watts, the
vertical angles, the horizontal angles, then one row of candela values per horizontal angle.
Numbers may be split over lines in any way. Candela values are scaled by the multiplier and the
ballast factor (and, before LM-63-2019, the ballast-lamp photometric factor).

Only type C photometry (photometric type 1, the kind of almost all architectural luminaires)
is accepted. Its horizontal angles give the symmetry: one angle (0) is symmetric about the
vertical axis; 0..90 is symmetric in each quadrant; 0..180 about the 0–180° plane; 90..270
about the 90–270° plane; 0..360 has none. :meth:`Photometry.full_table` unfolds it to 0..360°.
Vertical angle γ = 0 points down the luminaire's axis (nadir); outside the vertical angles
given the luminaire emits nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sonolux.errors import SonoluxError

FEET_M = 0.3048


@dataclass(frozen=True, eq=False)
class Photometry:
    """A type C intensity distribution: ``candela`` float64[H, V] at horizontal angle
    ``horizontal_deg[h]`` (C) and vertical angle ``vertical_deg[v]`` (γ), multipliers applied.
    """

    vertical_deg: np.ndarray
    horizontal_deg: np.ndarray
    candela: np.ndarray
    lamps: int = 1
    lumens_per_lamp: float = -1.0
    input_watts: float = 0.0
    size_m: tuple[float, float, float] = (0.0, 0.0, 0.0)  # width, length, height
    keywords: dict[str, str] = field(default_factory=dict)
    source: str = ""

    def full_table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(theta_rad float64[V], phi_rad float64[K], values float64[K, V]): the distribution
        unfolded over C = 0..360° (last row equal to the first), or one row when it is
        symmetric about the axis; θ = γ, φ = C."""
        c, cd = self.horizontal_deg, self.candela
        theta = np.radians(self.vertical_deg)
        if c.size == 1:
            return theta, np.zeros(1), cd.copy()
        first, last = float(c[0]), float(c[-1])
        # Mirror images that complete the circle, as the symmetry of the layout says.
        if first == 0 and last == 90:  # each quadrant alike: mirror in 0-180, then in 90-270
            mirrors = [lambda x: 180 - x, lambda x: 180 + x, lambda x: 360 - x]
        elif first == 0 and last == 180:  # bilateral about the 0-180° plane
            mirrors = [lambda x: 360 - x]
        elif first == 90 and last == 270:  # bilateral about the 90-270° plane
            mirrors = [lambda x: 180 - x]
        elif first == 0 and last == 360:
            mirrors = []
        else:
            raise SonoluxError(f"{self.source}: horizontal angles {first:g}..{last:g}° are not a "
                               "type C layout (0; 0..90; 0..180; 90..270; 0..360)")
        all_c = np.concatenate([c] + [np.asarray(m(c), float) % 360 for m in mirrors])
        all_cd = np.concatenate([cd] * (1 + len(mirrors)))
        all_c[all_c >= 360] -= 360
        order = np.argsort(all_c, kind="stable")
        all_c, all_cd = all_c[order], all_cd[order]
        keep = np.concatenate([[True], np.diff(all_c) > 1e-9])
        c, cd = all_c[keep], all_cd[keep]
        if c[0] > 0:  # close the circle at 0° between the last angle and the first
            w = (360 - c[-1]) / (360 - c[-1] + c[0])
            c, cd = np.concatenate([[0.0], c]), np.concatenate([[cd[-1] * (1 - w) + cd[0] * w], cd])
        c, cd = np.concatenate([c, [360.0]]), np.concatenate([cd, cd[:1]])
        return theta, np.radians(c), np.ascontiguousarray(cd)

    def intensity_cd(self, gamma_deg: np.ndarray, c_deg: np.ndarray) -> np.ndarray:
        """Intensity in cd at vertical angles γ and horizontal angles C (degrees, broadcast),
        bilinear in (γ, C) as the light tracer reads the table; 0 outside the vertical range."""
        theta, phi, values = self.full_table()
        g = np.radians(np.asarray(gamma_deg, float))
        c = np.radians(np.asarray(c_deg, float)) % (2 * math.pi)
        g, c = np.broadcast_arrays(g, c)
        rows = np.array([np.interp(g, theta, row, left=np.nan, right=np.nan) for row in values])
        if phi.size == 1:
            out = rows[0]
        else:
            j = np.clip(np.searchsorted(phi, c, side="right") - 1, 0, phi.size - 2)
            v = (c - phi[j]) / (phi[j + 1] - phi[j])
            idx = np.indices(g.shape)
            out = rows[(j, *idx)] * (1 - v) + rows[(j + 1, *idx)] * v
        return np.where(np.isnan(out), 0.0, out)

    def flux_lm(self, steps: int = 720) -> float:
        """∫ I dω over the sphere (lm) of the interpolated distribution, by a midpoint rule of
        ``steps`` × ``steps`` cells in (γ, C)."""
        g = (np.arange(steps) + 0.5) * 180.0 / steps
        c = (np.arange(steps) + 0.5) * 360.0 / steps
        gg, cc = np.meshgrid(g, c, indexing="ij")
        i = self.intensity_cd(gg, cc)
        d_omega = np.sin(np.radians(gg)) * math.radians(180.0 / steps) * math.radians(360.0 / steps)
        return float(np.sum(i * d_omega))


def _error(source: str, what: str) -> SonoluxError:
    return SonoluxError(f"{source}: not a readable IES LM-63 file: {what}")


def parse_ies(text: str, source: str = "<ies>") -> Photometry:
    """Reads the text of an LM-63 file (see the module docstring)."""
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    keywords: dict[str, str] = {}
    version = lines[0].strip().upper() if lines else ""
    k = 0
    while k < len(lines) and not lines[k].strip().upper().startswith("TILT"):
        line = lines[k].strip()
        if line.startswith("[") and "]" in line:
            key, value = line[1:].split("]", 1)
            keywords[key.strip().upper()] = value.strip()
        k += 1
    if k == len(lines):
        raise _error(source, "no TILT= line")
    tilt = lines[k].split("=", 1)[1].strip().upper() if "=" in lines[k] else ""
    numbers: list[float] = []
    for n, line in enumerate(lines[k + 1:], start=k + 2):
        for word in line.replace(",", " ").split():
            try:
                numbers.append(float(word))
            except ValueError:
                raise _error(source, f"line {n}: {word!r} is not a number") from None
    pos = 0

    def take(count: int, what: str) -> np.ndarray:
        nonlocal pos
        if pos + count > len(numbers):
            raise _error(source, f"the file ends before its {what} ({count} numbers expected, "
                                 f"{len(numbers) - pos} left)")
        out = np.array(numbers[pos:pos + count])
        pos += count
        return out

    if tilt == "INCLUDE":
        take(1, "lamp-to-luminaire geometry")
        pairs = int(take(1, "number of tilt angles")[0])
        take(2 * max(pairs, 0), "tilt angles and factors")
    elif tilt != "NONE":
        raise _error(source, f"TILT={tilt}: only TILT=NONE or TILT=INCLUDE are read (a tilt "
                             "table in another file is not)")
    head = take(10, "line of ten numbers (lamps, lumens, multiplier, angles, type, units, size)")
    lamps, lumens, multiplier, n_v, n_h, ptype, units = head[:7]
    if ptype != 1:
        raise _error(source, f"photometric type {ptype:g}: only type C (1) is supported")
    if n_v < 2 or n_h < 1 or n_v != int(n_v) or n_h != int(n_h):
        raise _error(source, f"{n_v:g} vertical and {n_h:g} horizontal angles: at least 2 and 1")
    if units not in (1, 2):
        raise _error(source, f"units type {units:g}: 1 (feet) or 2 (metres)")
    ballast, lamp_factor, watts = take(3, "ballast factor, photometric factor, input watts")
    vertical = take(int(n_v), "vertical angles")
    horizontal = take(int(n_h), "horizontal angles")
    candela = take(int(n_v) * int(n_h), "candela values").reshape(int(n_h), int(n_v))
    if pos != len(numbers):
        raise _error(source, f"{len(numbers) - pos} numbers after the candela values")
    if np.any(np.diff(vertical) <= 0) or vertical[0] < 0 or vertical[-1] > 180:
        raise _error(source, "vertical angles must increase within 0..180°")
    if np.any(np.diff(horizontal) <= 0) or horizontal[0] < 0 or horizontal[-1] > 360:
        raise _error(source, "horizontal angles must increase within 0..360°")
    if np.any(candela < 0) or not np.all(np.isfinite(candela)):
        raise _error(source, "candela values must be finite and not negative")
    factor = multiplier * ballast * (1.0 if "LM-63-2019" in version else lamp_factor)
    if not factor > 0:
        raise _error(source, f"the candela multiplier × ballast factor is {factor:g}; it must be "
                             "positive")
    scale = FEET_M if units == 1 else 1.0
    photometry = Photometry(vertical, horizontal, candela * factor, lamps=int(lamps),
                            lumens_per_lamp=float(lumens), input_watts=float(watts),
                            size_m=(head[7] * scale, head[8] * scale, head[9] * scale),
                            keywords=keywords, source=source)
    photometry.full_table()  # the symmetry check
    return photometry


def read_ies(path: str | Path) -> Photometry:
    """Reads an LM-63 file (see :func:`parse_ies`)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="latin-1")
    except OSError as exc:
        raise SonoluxError(f"{p}: cannot read the IES file: {exc.strerror or exc}") from None
    return parse_ies(text, str(p))


def format_ies(vertical_deg: np.ndarray, horizontal_deg: np.ndarray, candela: np.ndarray, *,
               lumens_per_lamp: float = -1.0, keywords: dict[str, str] | None = None) -> str:
    """The text of an LM-63-2002 type C file with absolute photometry: candela float64[H, V]."""
    v, h = np.asarray(vertical_deg, float), np.asarray(horizontal_deg, float)
    cd = np.asarray(candela, float).reshape(h.size, v.size)
    out = ["IESNA:LM-63-2002"]
    out += [f"[{k}] {val}" for k, val in (keywords or {"TEST": "sonolux"}).items()]
    out += ["TILT=NONE", f"1 {lumens_per_lamp:g} 1 {v.size} {h.size} 1 2 0 0 0", "1 1 0"]
    out.append(" ".join(f"{x:g}" for x in v))
    out.append(" ".join(f"{x:g}" for x in h))
    out += [" ".join(f"{x:.6g}" for x in row) for row in cd]
    return "\n".join(out) + "\n"
