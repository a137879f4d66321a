"""Per-band simplified geometry: the level of detail sound sees (docs/early-sound.md, "Per-band
geometry"). Light keeps the full mesh; nothing here changes the scene.

Sound ignores an object that is small against its wavelength. The criterion is Rayleigh's: a
rigid body whose size is small against the wavelength, ka < 1 (k = 2π f / c, a the radius of a
sphere that holds it), scatters a share of order (ka)⁴ of what its own cross-section would
reflect geometrically (Lord Rayleigh, "The Theory of Sound" II §334–335; Morse and Ingard,
"Theoretical Acoustics" 1968, §8.2: a rigid sphere's scattering cross-section is
σ = (7π/9) k⁴ a⁶ for ka ≪ 1). So, per band:

- **A small feature** is a connected piece of the mesh (triangles joined by shared corners)
  whose holding radius a satisfies k a < 1 at the band's exact centre, i.e. whose diameter is
  below λ/π ≈ 0.32 λ. The room's shell (the largest piece) is never one. A 0.3 m cube
  (a = 0.26 m) is small up to 210 Hz; a chair of seat and back (a ≈ 0.4 m) to about 140 Hz; a
  3 × 1.2 m table never in the audible bands. Details joined to a larger piece (a moulding on a
  column) stay: only whole pieces are removed.
- **What replaces it**: the surface it sits on, the plane of the nearest remaining triangle (the
  wall a box hangs on, the floor a chair stands on), taken as all remaining triangles of that
  plane and material. At these wavelengths the wave sees that surface, not the feature.
- **Its absorption area is kept**: Σ α S of the feature's faces, band by band, is added to the
  surface it sits on (α' = α + ΔA / S). The materials' α are what a consultant measured per m²
  (or per object, ISO 354, measured down to 100 Hz in a reverberation room, where objects small
  against λ still absorb): removing an absorbing chair must not make the room more reverberant.
  If α' would exceed 1 it is capped and the loss reported.
- **Its volume goes back to the air**: the simplified room holds Σ V of the features more air
  (reported; 0.9 % for the box wall of the tests).
- **Its scattering is kept, too**: the power the feature scatters, Rayleigh's σ per unit incident
  intensity for the sphere of the same volume (the excluded volume sets the low-frequency
  scattering of a rigid body), is given to the surface it sits on as a scattering coefficient:
  that surface receives w c S / 4 of a diffuse field, the feature scatters w c σ, so
  s_add = 4 Σ σ / S, combined with the surface's own as s' = 1 − (1 − s)(1 − s_add). It is small
  (0.03 for the box wall at 125 Hz): a small feature is almost invisible.

Bands whose set of small features is the same form one **level**; each level is traced with its
own geometry, bands and rays (:mod:`sonolux.sound.levels`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from sonolux.scene.inside import triangle_components

#: Two triangles lie in one plane when their unit normals agree to this and their distance along
#: the normal is below PLANE_TOLERANCE_M.
PLANE_COS = 1.0 - 1e-6
PLANE_TOLERANCE_M = 1e-3


@dataclass(frozen=True)
class Feature:
    """A connected piece of the mesh: its triangles, holding radius (m), area (m²) and volume
    (m³, 0 for an open piece)."""

    triangles: np.ndarray
    radius_m: float
    area_m2: float
    volume_m3: float


@dataclass
class Level:
    """The geometry of the bands ``bands`` (a slice of the scene's bands): triangles (into the
    scene's vertices), a material per triangle and the materials' absorption and scattering
    float64[material, band] over **all** bands (the added materials last). ``removed`` is the
    number of features left out (0: the scene's own geometry and materials)."""

    bands: slice
    triangles: np.ndarray
    material_index: np.ndarray
    absorption: np.ndarray
    scattering: np.ndarray
    removed: int = 0
    volume_added_m3: float = 0.0
    #: Absorption area per band that a capped α' could not hold (m²).
    area_lost_m2: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: Per appended material, in order: (the scene material it was made from, ΔA/S added to its
    #: α per band, s_add per band): what a described surface's α(θ)/s(θ) table of that
    #: material becomes on it (:mod:`sonolux.sound.levels`).
    seats: tuple[tuple[int, np.ndarray, np.ndarray], ...] = ()


def features(vertices_m: np.ndarray, triangles: np.ndarray) -> tuple[list[Feature], int]:
    """The mesh's connected pieces and the index of the shell (the piece with the largest holding
    radius)."""
    count, comp = triangle_components(vertices_m.shape[0], triangles)
    out = []
    for c in range(count):
        tris = np.flatnonzero(comp == c)
        corners = vertices_m[triangles[tris]]
        pts = corners.reshape(-1, 3)
        centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
        radius = float(np.sqrt(((pts - centre) ** 2).sum(axis=1).max()))
        cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        area = 0.5 * float(np.linalg.norm(cross, axis=1).sum())
        volume = abs(float(np.einsum("ij,ij->i", corners[:, 0], cross).sum()) / 6.0)
        out.append(Feature(tris, radius, area, volume))
    shell = int(np.argmax([f.radius_m for f in out])) if out else -1
    return out, shell


def small_features(feats: list[Feature], shell: int, band_hz: float,
                   speed_of_sound_m_s: float) -> tuple[int, ...]:
    """The features small against the wavelength at ``band_hz``: k a < 1."""
    k = 2.0 * math.pi * band_hz / speed_of_sound_m_s
    return tuple(i for i, f in enumerate(feats) if i != shell and k * f.radius_m < 1.0)


def _unit_normals(vertices_m: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    c = vertices_m[triangles]
    n = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    area2 = np.linalg.norm(n, axis=1)
    return n / np.maximum(area2, 1e-300)[:, None], 0.5 * area2


def point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance from each point p float64[n, 3] to each triangle tri float64[m, 3, 3],
    float64[n, m]: the closest point of a triangle by its Voronoi regions (Ericson, "Real-Time
    Collision Detection" 2005, §5.1.5), vectorised."""
    a, b, c = (tri[None, :, i] for i in range(3))
    p = p[:, None]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp, cp = p - b, p - c
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = 1.0 / (va + vb + vc)
        v, w = vb * denom, vc * denom
        q = a + ab * v[..., None] + ac * w[..., None]  # inside the face
        t_ab = np.clip(d1 / (d1 - d3), 0, 1)
        t_ac = np.clip(d2 / (d2 - d6), 0, 1)
        t_bc = np.clip((d4 - d3) / ((d4 - d3) + (d5 - d6)), 0, 1)
    edge_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    edge_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    edge_bc = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
    q = np.where(edge_bc[..., None], b + (c - b) * np.nan_to_num(t_bc)[..., None], q)
    q = np.where(edge_ac[..., None], a + ac * np.nan_to_num(t_ac)[..., None], q)
    q = np.where(edge_ab[..., None], a + ab * np.nan_to_num(t_ab)[..., None], q)
    q = np.where(((d6 >= 0) & (d5 <= d6))[..., None], c, q)
    q = np.where(((d3 >= 0) & (d4 <= d3))[..., None], b, q)
    q = np.where(((d1 <= 0) & (d2 <= 0))[..., None], a, q)
    return np.linalg.norm(p - q, axis=-1)


def _seat(vertices_m: np.ndarray, triangles: np.ndarray, kept: np.ndarray, feat: Feature,
          material_index: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """The kept triangles the feature sits on: those of the nearest kept triangle's plane and
    material. Kept triangles are tested in order of their boxes' gap to the feature's box, until
    the next gap exceeds the nearest distance found."""
    pts = vertices_m[np.unique(triangles[feat.triangles])]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    corners = vertices_m[triangles[kept]]
    gap = np.linalg.norm(np.maximum(0.0, np.maximum(corners.min(axis=1) - hi,
                                                    lo - corners.max(axis=1))), axis=1)
    order = np.argsort(gap, kind="stable")
    best, nearest = np.inf, -1
    for start in range(0, order.size, 256):
        chunk = order[start:start + 256]
        if gap[chunk[0]] > best:
            break
        d = point_triangle_distance(pts, corners[chunk]).min(axis=0)
        j = int(np.argmin(d))
        if d[j] < best:
            best, nearest = float(d[j]), int(kept[chunk[j]])
    n0, p0 = normals[nearest], vertices_m[triangles[nearest, 0]]
    same = kept[(normals[kept] @ n0 > PLANE_COS)
                & (np.abs((vertices_m[triangles[kept, 0]] - p0) @ n0) < PLANE_TOLERANCE_M)
                & (material_index[kept] == material_index[nearest])]
    return same


def simplified(vertices_m: np.ndarray, triangles: np.ndarray, material_index: np.ndarray,
               absorption: np.ndarray, scattering: np.ndarray, removed: Sequence[int],
               feats: list[Feature], bands_hz: np.ndarray,
               speed_of_sound_m_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                   np.ndarray, float, np.ndarray, tuple]:
    """The mesh without the ``removed`` features, their absorption area and scattering given to
    the surfaces they sit on: (triangle ids kept, material per kept triangle, absorption,
    scattering [material, band] with the new materials appended, volume given back (m³),
    absorption area lost to capping per band (m²), per new material (its origin, ΔA/S,
    s_add))."""
    gone = np.zeros(triangles.shape[0], bool)
    for i in removed:
        gone[feats[i].triangles] = True
    kept = np.flatnonzero(~gone)
    normals, areas = _unit_normals(vertices_m, triangles)
    k = 2.0 * math.pi * np.asarray(bands_hz, float) / speed_of_sound_m_s
    # Per seat (a tuple of kept triangle ids): added absorption area and scattering cross-section.
    added: dict[tuple[int, ...], list[np.ndarray]] = {}
    volume = 0.0
    for i in removed:
        f = feats[i]
        seat = tuple(_seat(vertices_m, triangles, kept, f, material_index, normals).tolist())
        area_alpha = (areas[f.triangles, None] * absorption[material_index[f.triangles]]).sum(0)
        radius_v = (3.0 * f.volume_m3 / (4.0 * math.pi)) ** (1.0 / 3.0)
        sigma = 7.0 * math.pi / 9.0 * k ** 4 * radius_v ** 6
        acc = added.setdefault(seat, [np.zeros_like(k), np.zeros_like(k)])
        acc[0] += area_alpha
        acc[1] += sigma
        volume += f.volume_m3
    mats = material_index[kept].astype(np.int32)
    alpha, scat = [absorption], [scattering]
    lost = np.zeros_like(k)
    position = {t: j for j, t in enumerate(kept.tolist())}
    n_mat = absorption.shape[0]
    seats = []
    for seat, (area_alpha, sigma) in added.items():
        ids = np.array(seat, dtype=np.int64)
        s_area = float(areas[ids].sum())
        m = int(material_index[ids[0]])
        a_new = absorption[m] + area_alpha / s_area
        lost += np.maximum(a_new - 1.0, 0.0) * s_area
        s_add = np.minimum(4.0 * sigma / s_area, 1.0)
        alpha.append(np.minimum(a_new, 1.0)[None])
        scat.append((1.0 - (1.0 - scattering[m]) * (1.0 - s_add))[None])
        seats.append((m, area_alpha / s_area, s_add))
        mats[[position[t] for t in seat]] = n_mat
        n_mat += 1
    return (kept, mats, np.concatenate(alpha), np.concatenate(scat), volume, lost, tuple(seats))


def band_levels(vertices_m: np.ndarray, triangles: np.ndarray, material_index: np.ndarray,
                absorption: np.ndarray, scattering: np.ndarray, bands_hz: Sequence[float],
                speed_of_sound_m_s: float) -> list[Level]:
    """The scene's bands grouped by the features small against their wavelength, each group
    with its geometry; one level with nothing removed when no band has a small feature."""
    bands = np.asarray(bands_hz, float)
    feats, shell = features(vertices_m, triangles)
    sets = [small_features(feats, shell, f, speed_of_sound_m_s) for f in bands]
    levels: list[Level] = []
    lo = 0
    for hi in range(1, len(bands) + 1):
        if hi < len(bands) and sets[hi] == sets[lo]:
            continue
        removed = sets[lo]
        if removed:
            kept, mats, alpha, scat, volume, lost, seats = simplified(
                vertices_m, triangles, material_index, absorption, scattering, removed, feats,
                bands, speed_of_sound_m_s)
            levels.append(Level(slice(lo, hi), np.ascontiguousarray(triangles[kept]), mats,
                                alpha, scat, len(removed), volume, lost, seats))
        else:
            levels.append(Level(slice(lo, hi), triangles, material_index, absorption, scattering))
        lo = hi
    return levels


__all__ = ["Feature", "Level", "band_levels", "features", "simplified", "small_features"]
