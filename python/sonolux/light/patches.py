"""The patches as a mesh of their own, for pictures and exports: corner positions, corner
nodes shared between neighbouring patches, and radiance smoothed onto those nodes.

Numbering (the core's, ``crates/sonolux-core/src/light/patches.rs``): triangle (a, b, c) with
resolution k is cut along its barycentric grid p = a + (i/k)(b − a) + (j/k)(c − a). Row i
(i = 0..k−1) holds, for j = 0..k−1−i, the "lower" patch with grid corners (i, j), (i+1, j),
(i, j+1) at local index i(2k − i) + 2j, and, while i + j < k − 1, the "upper" patch (i+1, j),
(i+1, j+1), (i, j+1) right after it. Both keep the triangle's winding.

Smoothing: a node's radiance is the area-weighted mean of the patches that touch it; nodes at
the same place are one node when their triangles are coplanar (same plane, same side) and of
the same material, so a wall made of two triangles is smooth across its diagonal while the
corner between wall and floor stays sharp. A point's radiance is then interpolated linearly
from its patch's three nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sonolux.light.field import LightField

#: Nodes closer than this share a key (metres), and plane normals/offsets are rounded to it.
WELD_M = 1e-6


def _grid_template(k: int) -> tuple[np.ndarray, np.ndarray]:
    """(corners int64[k², 3, 2]: grid (i, j) of each patch's corners in local index order,
    upper bool[k²])."""
    corners, upper = [], []
    for i in range(k):
        for j in range(k - i):
            corners.append(((i, j), (i + 1, j), (i, j + 1)))
            upper.append(False)
            if i + j < k - 1:
                corners.append(((i + 1, j), (i + 1, j + 1), (i, j + 1)))
                upper.append(True)
    return np.asarray(corners, np.int64), np.asarray(upper, bool)


@dataclass
class PatchMesh:
    """corners_m float64[P, 3, 3] (patch, corner, xyz); nodes int64[P, 3] into node_m
    float64[N, 3]; grid int64[P, 3, 2] (the corners' (i, j) on their triangle's grid); upper
    bool[P]; triangle int64[P]; resolution int64[P] (k of the patch's triangle)."""

    corners_m: np.ndarray
    nodes: np.ndarray
    node_m: np.ndarray
    grid: np.ndarray
    upper: np.ndarray
    triangle: np.ndarray
    resolution: np.ndarray

    @property
    def n_nodes(self) -> int:
        return int(self.node_m.shape[0])

    def node_values(self, per_patch: np.ndarray, area_m2: np.ndarray) -> np.ndarray:
        """float64[N, C]: the area-weighted mean of per_patch float64[P, C] at each node."""
        w = np.repeat(area_m2, 3)
        idx = self.nodes.reshape(-1)
        total = np.bincount(idx, w, minlength=self.n_nodes)
        out = np.stack([np.bincount(idx, w * np.repeat(per_patch[:, c], 3), minlength=self.n_nodes)
                        for c in range(per_patch.shape[1])], axis=1)
        return out / np.maximum(total, 1e-300)[:, None]

    def weights(self, patch: np.ndarray, s: np.ndarray, t: np.ndarray) -> np.ndarray:
        """float64[k, 3]: linear weights of the three corners of ``patch`` int64[k] at the
        points with barycentric (s, t) on their triangle (clipped to the patch)."""
        k = self.resolution[patch].astype(np.float64)
        g = self.grid[patch]
        fs = s * k - g[:, 0, 0]
        ft = t * k - g[:, 0, 1]
        lower = np.stack([1.0 - fs - ft, fs, ft], axis=1)
        # Upper patch: corners (i+1, j), (i+1, j+1), (i, j+1) and (fs, ft) from its first corner.
        fs_u, ft_u = s * k - (g[:, 0, 0] - 1), t * k - g[:, 0, 1]
        upper = np.stack([1.0 - ft_u, fs_u + ft_u - 1.0, 1.0 - fs_u], axis=1)
        w = np.where(self.upper[patch][:, None], upper, lower)
        w = np.clip(w, 0.0, 1.0)
        return w / np.maximum(w.sum(axis=1, keepdims=True), 1e-12)


def patch_mesh(field: LightField) -> PatchMesh:
    """The patches of ``field`` as triangles with shared, smoothing nodes."""
    v = field.vertices_m[field.triangles]  # [T, 3, 3]
    res = field.patch_resolution.astype(np.int64)
    offset = field.patch_offset.astype(np.int64)
    n_p = int(offset[-1])
    corners = np.zeros((n_p, 3, 3))
    grid = np.zeros((n_p, 3, 2), np.int64)
    upper = np.zeros(n_p, bool)
    tri_of = np.zeros(n_p, np.int64)
    for k in np.unique(res):
        tris = np.flatnonzero(res == k)
        tmpl, up = _grid_template(int(k))
        rows = (offset[tris][:, None] + np.arange(k * k)[None]).reshape(-1)
        a, e1, e2 = v[tris, 0], v[tris, 1] - v[tris, 0], v[tris, 2] - v[tris, 0]
        ij = tmpl.astype(np.float64) / k  # [k², 3, 2]
        pos = (a[:, None, None] + ij[None, ..., 0:1] * e1[:, None, None]
               + ij[None, ..., 1:2] * e2[:, None, None])
        corners[rows] = pos.reshape(-1, 3, 3)
        grid[rows] = np.broadcast_to(tmpl, (tris.size, *tmpl.shape)).reshape(-1, 3, 2)
        upper[rows] = np.tile(up, tris.size)
        tri_of[rows] = np.repeat(tris, k * k)
    # Weld: a node is (position, plane of its triangle, material).
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    plane = np.column_stack([n, np.einsum("ij,ij->i", n, v[:, 0]), field.material_index])
    scale = max(float(np.abs(field.vertices_m).max(initial=1.0)), 1.0)
    key = np.column_stack([corners.reshape(-1, 3) / scale,
                           np.repeat(plane[tri_of] / np.array([1, 1, 1, scale, 1]), 3, axis=0)])
    key = np.round(key / WELD_M).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    nodes = inverse.reshape(n_p, 3)
    node_m = corners.reshape(-1, 3)[first]
    return PatchMesh(corners, nodes, node_m, grid, upper, tri_of, res[tri_of])
