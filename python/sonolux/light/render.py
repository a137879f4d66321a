"""Pictures of a baked light field: a camera ray finds the surface it sees and looks up the
light stored there.

For each pixel (``samples`` × ``samples`` rays on a fixed grid inside it, averaged):

1. find the nearest surface (the core's BVH, ``closest_hit``) and the nearest rectangle light
   (those are not scene surfaces; intersected here in numpy, on their emitting side only);
   a light in front shows its radiance Φ / (π A) and ends the ray;
2. at the surface: the diffuse radiance stored on the patches, interpolated linearly between
   their shared corners (:mod:`sonolux.light.patches`), plus the surface's own emission;
3. a material with a specular share s reflects: the ray follows the mirror direction and adds
   s ρ × what it sees there (up to ``max_bounces`` times). Glossy surfaces are drawn as mirrors.

The result is linear radiance, float32[H, W, 3] in W/m²/sr; :mod:`sonolux.light.image` makes
files of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from sonolux.engine import Geometry
from sonolux.errors import SonoluxError
from sonolux.light.camera import Camera
from sonolux.light.field import LightField
from sonolux.light.image import INCIDENT_WHITE, LOG_DELTA, luminance
from sonolux.light.patches import PatchMesh, patch_mesh
from sonolux.scene.inside import IN_AIR, OUTSIDE, RoomSpace

#: Rays handled at once (bounds the memory of the numpy stages).
CHUNK_RAYS = 1 << 18


@dataclass
class Renderable:
    """What pictures need from a field, built once: the core's geometry (BVH), the patch mesh,
    the smoothed diffuse radiance at its nodes and the triangles' unit normals."""

    field: LightField
    geometry: Geometry
    mesh: PatchMesh
    node_radiance: np.ndarray
    normals: np.ndarray
    epsilon_m: float

    @classmethod
    def of(cls, field: LightField) -> Renderable:
        geometry = Geometry(field.vertices_m, field.triangles, field.material_index)
        mesh = patch_mesh(field)
        v = field.vertices_m[field.triangles]
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        diffuse = field.diffuse_reflectance * field.irradiance_w_m2 / np.pi
        diag = float(np.linalg.norm(np.ptp(field.vertices_m, axis=0)))
        return cls(field, geometry, mesh, mesh.node_values(diffuse, field.patch_area_m2), n,
                   1e-5 * max(diag, 1.0))

    def check_camera(self, camera: Camera) -> None:
        """A clear error unless the camera stands in the room's air."""
        camera.validate()
        space = RoomSpace(self.geometry, self.field.vertices_m, self.field.triangles)
        where = int(space.classify(np.asarray(camera.position_m, float))[0])
        if where != IN_AIR:
            lo, hi = self.field.vertices_m.min(axis=0), self.field.vertices_m.max(axis=0)
            why = "outside the room" if where == OUTSIDE else "inside an obstacle"
            box = ", ".join(f"{a:g}..{b:g}" for a, b in zip(lo, hi))
            raise SonoluxError(f"camera position_m = {tuple(float(x) for x in camera.position_m)} "
                               f"is not allowed: a point in the room's air (the scene spans "
                               f"x, y, z = {box} m); this one is {why}")


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a × b for a float64[k, 3] and b float64[3] or [k, 3]."""
    ax, ay, az = a[:, 0], a[:, 1], a[:, 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=1)


def _hit_emitters(tris: np.ndarray, o: np.ndarray, d: np.ndarray,
                  t_max: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest front-side hit (Möller–Trumbore) of rays o, d float64[k, 3] with triangles
    float64[E, 3, 3] closer than t_max: (t float64[k], emitter int64[k], −1 for none)."""
    best_t, best = t_max.copy(), np.full(d.shape[0], -1, np.int64)
    for e, (a, b, c) in enumerate(tris):
        e1, e2 = b - a, c - a
        p = _cross(d, e2)
        det = p @ e1  # = −d · n: positive when the ray meets the emitting side
        ok = det > 1e-300
        inv = 1.0 / np.where(ok, det, 1.0)
        s = o - a
        u = _dot(s, p) * inv
        q = _cross(s, e1)
        v = _dot(d, q) * inv
        t = (q @ e2) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t < best_t)
        best_t = np.where(hit, t, best_t)
        best = np.where(hit, e, best)
    return best_t, best


def _barycentric(p: np.ndarray, tri: np.ndarray, vertices: np.ndarray,
                 triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    v = vertices[triangles[tri]]
    e1, e2, dp = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], p - v[:, 0]
    d11, d12, d22 = _dot(e1, e1), _dot(e1, e2), _dot(e2, e2)
    d1, d2 = _dot(dp, e1), _dot(dp, e2)
    det = np.maximum(d11 * d22 - d12 * d12, 1e-300)
    return (d22 * d1 - d12 * d2) / det, (d11 * d2 - d12 * d1) / det


def shade(r: Renderable, origins: np.ndarray, dirs: np.ndarray, *, max_bounces: int = 4,
          smooth: bool = True, threads: int = 0) -> np.ndarray:
    """float64[k, 3]: the radiance arriving along rays (origins float64[k, 3], unit dirs)."""
    f = r.field
    k = dirs.shape[0]
    out = np.zeros((k, 3))
    weight = np.ones((k, 3))
    live = np.arange(k)
    o, d = np.array(origins, float), np.array(dirs, float)
    rect = f.rectangle_emitters
    rect_tris, rect_radiance = f.emitter_triangles_m[rect], f.emitter_radiance[rect]
    diffuse_patch = f.diffuse_reflectance * f.irradiance_w_m2 / np.pi
    for bounce in range(max_bounces + 1):
        # Find the nearest surface and the nearest rectangle light.
        t, tri = r.geometry.closest_hit(o, d, threads=threads)
        t, tri = np.asarray(t, float), np.asarray(tri, np.int64)
        if rect_tris.shape[0]:
            t_light, light = _hit_emitters(rect_tris, o, d, t)
            lit = light >= 0
            out[live[lit]] += weight[live[lit]] * rect_radiance[light[lit]]
            tri = np.where(lit, -1, tri)
        hit = tri >= 0
        live, o, d, t, tri = live[hit], o[hit], d[hit], t[hit], tri[hit]
        if live.size == 0:
            break
        # Look up the diffuse radiance stored there, and the surface's own emission.
        p = o + d * t[:, None]
        patch = r.geometry.patch_index(f.patch_size_m, tri, p)
        if smooth:
            s, u = _barycentric(p, tri, f.vertices_m, f.triangles)
            w = r.mesh.weights(patch, s, u)
            radiance = np.einsum("kc,kcj->kj", w, r.node_radiance[r.mesh.nodes[patch]])
        else:
            radiance = diffuse_patch[patch]
        n = r.normals[tri]
        facing = _dot(d, n) < 0
        radiance = radiance + np.where(facing[:, None], f.emitted_radiance[tri], 0.0)
        out[live] += weight[live] * radiance
        # Follow the mirror direction of surfaces with a specular share.
        m = f.material_index[tri]
        spec = f.specular[m]
        go = spec > 0
        if bounce == max_bounces or not np.any(go):
            break
        weight[live[go]] *= f.rho[m[go]] * spec[go][:, None]
        n = np.where(facing[:, None], n, -n)[go]
        d = d[go] - 2 * _dot(d[go], n)[:, None] * n
        o = p[go] + n * r.epsilon_m
        live = live[go]
    return out


def incident_exposure(field: LightField | Renderable, camera: Camera) -> float:
    """The exposure an incident-light meter gives: INCIDENT_WHITE / the log-average of E / π
    (the radiance of a white Lambertian surface) over the surfaces the pixel centres see. A
    white surface under the average light is then exposed to 0.6 and an 18 % grey card to
    0.108, so a white room looks white and a dark floor dark, whatever the mix in view."""
    r = field if isinstance(field, Renderable) else Renderable.of(field)
    f = r.field
    origin, dirs = camera.rays(1)
    d = np.ascontiguousarray(dirs.reshape(-1, 3))
    o = np.ascontiguousarray(np.broadcast_to(origin, d.shape))
    t, tri = r.geometry.closest_hit(o, d)
    t, tri = np.asarray(t, float), np.asarray(tri, np.int64)
    rect = f.rectangle_emitters
    _, light = _hit_emitters(f.emitter_triangles_m[rect], o, d, t)
    keep = (tri >= 0) & (light < 0)
    if not np.any(keep):
        return 1.0
    p = o[keep] + d[keep] * t[keep, None]
    patch = r.geometry.patch_index(f.patch_size_m, tri[keep], p)
    white = luminance(f.irradiance_w_m2 / np.pi)[:, None]
    nodes = r.mesh.node_values(white, f.patch_area_m2)[:, 0]
    s, u = _barycentric(p, tri[keep], f.vertices_m, f.triangles)
    e = (r.mesh.weights(patch, s, u) * nodes[r.mesh.nodes[patch]]).sum(axis=1)
    log_avg = float(np.exp(np.mean(np.log(LOG_DELTA + np.maximum(e, 0.0)))))
    return INCIDENT_WHITE / max(log_avg, LOG_DELTA)


def render(field: LightField | Renderable, camera: Camera, *, samples: int = 2,
           max_bounces: int = 4, smooth: bool = True, threads: int = 0,
           keep_samples: bool = False) -> np.ndarray:
    """float32[H, W, 3]: linear radiance (W/m²/sr) seen by ``camera``, the mean of ``samples`` ×
    ``samples`` rays per pixel on a fixed grid (the same picture every time). With
    ``keep_samples`` the rays' values are returned, float32[H, W, samples², 3], so that a
    picture can be tone-mapped before it is averaged (edges of a bright light stay smooth)."""
    r = field if isinstance(field, Renderable) else Renderable.of(field)
    if not (isinstance(samples, int) and 1 <= samples <= 16):
        raise SonoluxError(f"render samples = {samples!r} is not allowed: a whole number from 1 "
                           "to 16 (rays per pixel = samples²)")
    r.check_camera(camera)
    origin, dirs = camera.rays(samples)
    flat = dirs.reshape(-1, 3)
    out = np.empty((flat.shape[0], 3))
    for a in range(0, flat.shape[0], CHUNK_RAYS):
        d = flat[a:a + CHUNK_RAYS]
        out[a:a + CHUNK_RAYS] = shade(r, np.broadcast_to(origin, d.shape), d,
                                      max_bounces=max_bounces, smooth=smooth, threads=threads)
    out = out.reshape(camera.height, camera.width, samples * samples, 3).astype(np.float32)
    return out if keep_samples else out.mean(axis=2)


def coverage(field: LightField | Renderable, camera: Camera) -> dict[str, Any]:
    """Share of pixel centres that see a surface, a rectangle light, or nothing (a leak)."""
    r = field if isinstance(field, Renderable) else Renderable.of(field)
    origin, dirs = camera.rays(1)
    d = dirs.reshape(-1, 3)
    o = np.broadcast_to(origin, d.shape)
    t, tri = r.geometry.closest_hit(o, d)
    rect = r.field.rectangle_emitters
    _, light = _hit_emitters(r.field.emitter_triangles_m[rect], o, d, t)
    return {"surface": float(np.mean((tri >= 0) & (light < 0))), "light": float(np.mean(light >= 0)),
            "nothing": float(np.mean((tri < 0) & (light < 0)))}
