"""Measured source directivity from AES69 (SOFA) files, read with ``sofar``.

Accepted conventions: ``FreeFieldDirectivityTF`` and ``GeneralTF`` whose receivers are the
directions around the source (a microphone array with the source at its centre, as
FreeFieldDirectivityTF defines it): ``Data.Real``/``Data.Imag`` [measurement, receiver,
frequency], ``N`` the frequencies in Hz, ``ReceiverPosition`` [receiver, 3] (spherical:
azimuth counter-clockwise from x, elevation, radius; or cartesian) in the listener's frame,
and the source oriented by ``SourceView`` and ``SourceUp`` in that frame (x forward, z up by
default). Several measurements (e.g. one per note of an instrument) are averaged in energy.

Conversion, in this order:

1. Per direction and band, the energy is the integral of |H(f)|² over the band,
   with |H|² linear between the file's frequencies; a band the file does not cover is an error.
   The edges are the bands' exact IEC 61260-1 edges (``Settings.band_set.edges_hz``).
2. On the sphere, the per-band energies are interpolated linearly on the triangulation of
   the measured directions (their convex hull, which for points on a sphere is the spherical
   Delaunay triangulation): a grid direction takes the barycentric mix of the three corners
   of the triangle its ray crosses. The measured directions must surround the source (the
   hull must contain the centre), else the file is refused.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from sonolux.errors import SonoluxError
from sonolux.scene.directivity import node_directions

CONVENTIONS = ("FreeFieldDirectivityTF", "GeneralTF")


@dataclass(frozen=True, eq=False)
class SofaDirectivity:
    """A measured directivity as read: directions float64[direction, 3] (unit, source frame x
    forward, y left, z up), frequencies_hz float64[frequency], power float64[direction,
    frequency] (|H|², averaged over measurements), and relative_phase complex128[direction,
    frequency]: unit phasors of each direction's transfer function against the direction of
    most energy, X/|X| with X = Σ H_m(u)·conj(H_m(ref)) over the measurements (their
    cross-spectrum, so several measurements average phase as they average energy); None
    where not read. The tracer uses the power; the waves' directional sources also the phase
    (:mod:`sonolux.sound.wave_sources`)."""

    path: Path
    directions: np.ndarray
    frequencies_hz: np.ndarray
    power: np.ndarray
    relative_phase: np.ndarray | None = None


def _unit_rows(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def open_sofa(path: Path) -> tuple[Any, str]:
    """(the sofar object, its convention's name) of a SOFA file, or an error naming the file."""
    import sofar

    try:
        sofa = sofar.read_sofa(str(path), verify=False, verbose=False)
    except Exception as exc:  # sofar raises many kinds for a bad file
        raise SonoluxError(f"{path}: not a readable SOFA file ({exc})") from None
    return sofa, str(getattr(sofa, "GLOBAL_SOFAConventions", ""))


def read_sofa_directivity(path: Path) -> SofaDirectivity:
    """Reads and checks a SOFA directivity; errors name the file and what is allowed."""

    def bad(problem: str) -> SonoluxError:
        return SonoluxError(f"{path}: {problem}")

    sofa, convention = open_sofa(path)
    if convention not in CONVENTIONS:
        raise bad(f"SOFA convention {convention!r}; allowed: " + ", ".join(CONVENTIONS))
    try:
        h = np.asarray(sofa.Data_Real, float) + 1j * np.asarray(sofa.Data_Imag, float)
        freqs = np.asarray(sofa.N, float).ravel()
        pos = np.asarray(sofa.ReceiverPosition, float)
        pos_type = str(getattr(sofa, "ReceiverPosition_Type", "spherical"))
        view = np.asarray(getattr(sofa, "SourceView", [1.0, 0.0, 0.0]), float).reshape(-1, 3)[0]
        up = np.asarray(getattr(sofa, "SourceUp", [0.0, 0.0, 1.0]), float).reshape(-1, 3)[0]
    except (AttributeError, ValueError) as exc:
        raise bad(f"a directivity needs Data.Real/Imag, N and ReceiverPosition ({exc})") from None
    if h.ndim != 3 or h.shape[2] != len(freqs) or h.shape[1] < 4:
        raise bad(f"Data of shape {h.shape}: [measurement, receiver ≥ 4 directions, "
                  f"{len(freqs)} frequencies] expected")
    if pos.ndim == 3:
        pos = pos[:, :, 0]
    if pos.shape != (h.shape[1], 3):
        raise bad(f"ReceiverPosition of shape {pos.shape}: one position per receiver "
                  f"({h.shape[1]}, 3) expected")
    if not (np.all(np.isfinite(h)) and np.all(np.isfinite(freqs)) and np.all(freqs >= 0)
            and np.all(np.diff(freqs) > 0)):
        raise bad("data must be finite and N increasing frequencies ≥ 0 Hz")
    if pos_type.startswith("spherical"):
        az, el = np.radians(pos[:, 0]), np.radians(pos[:, 1])
        xyz = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    else:
        xyz = pos
    if np.any(np.linalg.norm(xyz, axis=1) == 0):
        raise bad("a ReceiverPosition is at the source's centre: it has no direction")
    xyz = _unit_rows(xyz)
    forward = _unit_rows(view)
    up = up - forward * (up @ forward)
    if not (np.all(np.isfinite(forward)) and np.linalg.norm(up) > 1e-9):
        raise bad(f"SourceView {view.tolist()} and SourceUp must be non-zero and not parallel")
    up = _unit_rows(up)
    left = np.cross(up, forward)
    local = np.stack([xyz @ forward, xyz @ left, xyz @ up], axis=1)
    power = np.mean(np.abs(h) ** 2, axis=0)
    try:  # the directions must surround the source: checked here, once, at the edge
        sphere_interpolate(local, np.ones((len(local), 1)), local[:1])
    except SonoluxError as exc:
        raise bad(str(exc)) from None
    cross = np.sum(h * np.conj(h[:, int(np.argmax(power.sum(axis=1)))][:, None, :]), axis=0)
    magnitude = np.abs(cross)
    phase = np.where(magnitude > 0, cross / np.where(magnitude > 0, magnitude, 1.0), 1.0)
    return SofaDirectivity(path, local, freqs, power, phase)


def band_energy(sofa: SofaDirectivity, edges_hz: np.ndarray) -> np.ndarray:
    """The integral of |H|² over each band (edges float64[band, 2]) per direction:
    float64[direction, band]."""
    edges = np.asarray(edges_hz, float)
    f = sofa.frequencies_hz
    out = np.empty((len(sofa.directions), len(edges)))
    for b, (lo, hi) in enumerate(edges):
        if lo < f[0] or hi > f[-1]:
            raise SonoluxError(f"{sofa.path}: the band {np.sqrt(lo * hi):.0f} Hz ({lo:.1f}–{hi:.1f} Hz) "
                               f"is outside the file's frequencies ({f[0]:g}–{f[-1]:g} Hz)")
        grid = np.concatenate([[lo], f[(f > lo) & (f < hi)], [hi]])
        values = np.stack([np.interp(grid, f, p) for p in sofa.power])
        out[:, b] = np.trapezoid(values, grid, axis=1)
    return out


def sphere_interpolate(directions: np.ndarray, values: np.ndarray,
                       queries: np.ndarray) -> np.ndarray:
    """Linear interpolation on the triangulated sphere (see the module docs): values
    float64[direction, k] at unit ``directions`` [direction, 3], read at unit ``queries``
    [query, 3]; returns float64[query, k]."""
    # Duplicate directions (a measured pole repeated for every azimuth) keep their mean.
    keys, inverse = np.unique(np.round(directions, 9), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    count = np.bincount(inverse, minlength=len(keys)).astype(float)
    merged = np.zeros((len(keys), values.shape[1]))
    np.add.at(merged, inverse, values)
    merged /= count[:, None]
    try:
        hull = ConvexHull(keys)
    except QhullError:
        raise SonoluxError("the measured directions do not surround the source (they lie on "
                           "one plane or one side): a directivity needs directions all "
                           "around it") from None
    if np.any(hull.equations[:, 3] > -1e-6):
        raise SonoluxError("the measured directions do not surround the source: a directivity "
                           "needs directions all around it")
    normals, offsets = hull.equations[:, :3], -hull.equations[:, 3]
    corners = keys[hull.simplices]  # [facet, corner, 3]
    inv = np.linalg.inv(np.transpose(corners, (0, 2, 1)))  # solves Σ λ_k c_k = q
    out = np.empty((len(queries), values.shape[1]))
    for start in range(0, len(queries), 512):
        q = queries[start:start + 512]
        facet = np.argmax((q @ normals.T) / offsets, axis=1)
        lam = np.einsum("qij,qj->qi", inv[facet], q)
        lam = np.clip(lam, 0.0, None)
        lam /= lam.sum(axis=1, keepdims=True)
        out[start:start + 512] = np.einsum("qi,qik->qk", lam, merged[hull.simplices[facet]])
    return out


def sofa_gains(sofa: SofaDirectivity, edges_hz: np.ndarray) -> np.ndarray:
    """The engine's grid of per-band energy gains from a SOFA directivity, for the bands
    with edges ``edges_hz`` float64[band, 2]: float64[theta, phi, band]."""
    energy = band_energy(sofa, edges_hz)
    grid = node_directions()
    flat = sphere_interpolate(sofa.directions, energy, grid.reshape(-1, 3))
    if np.any(flat.sum(axis=0) <= 0):
        raise SonoluxError(f"{sofa.path}: a band carries no energy in any direction")
    return flat.reshape(grid.shape[0], grid.shape[1], -1)
