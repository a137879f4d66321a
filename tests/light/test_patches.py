"""The patch mesh that pictures and exports use agrees with the core's patch numbering."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.light.patches import patch_mesh


def test_patch_corners_match_the_core_numbering(small_scene, small_light):
    rng = np.random.default_rng(3)
    mesh = patch_mesh(small_light)
    f = small_light
    tri = rng.integers(0, f.n_triangles, 5000)
    s, t = rng.random(5000), rng.random(5000)
    flip = s + t > 1
    s, t = np.where(flip, 1 - s, s), np.where(flip, 1 - t, t)
    v = f.vertices_m[f.triangles[tri]]
    p = v[:, 0] + s[:, None] * (v[:, 1] - v[:, 0]) + t[:, None] * (v[:, 2] - v[:, 0])
    patch = small_scene.geometry.patch_index(f.patch_size_m, tri, p)
    assert np.array_equal(mesh.triangle[patch], tri)
    # The point lies in the patch the core names: its weights on that patch's corners are all
    # in [0, 1] and rebuild it (1e-9 m: double rounding only; the wrong patch misses by cm).
    w = mesh.weights(patch, s, t)
    rebuilt = np.einsum("kc,kcj->kj", w, mesh.corners_m[patch])
    assert np.abs(rebuilt - p).max() < 1e-9
    # Patch areas add up to their triangles, and equal the core's.
    areas = 0.5 * np.linalg.norm(np.cross(mesh.corners_m[:, 1] - mesh.corners_m[:, 0],
                                          mesh.corners_m[:, 2] - mesh.corners_m[:, 0]), axis=1)
    assert areas == pytest.approx(f.patch_area_m2, rel=1e-9)


def test_smoothing_keeps_a_constant_and_welds_coplanar_triangles(small_light):
    mesh = patch_mesh(small_light)
    ones = np.ones((small_light.n_patches, 3))
    assert mesh.node_values(ones, small_light.patch_area_m2) == pytest.approx(1.0)
    # paper-small: each face is two triangles cut into a k × k grid; welded across the
    # diagonal, a face has (k+1)² nodes... but faces meeting at an edge keep their own nodes.
    res = small_light.patch_resolution
    expected = sum((int(res[2 * i]) + 1) ** 2 for i in range(6))
    assert mesh.n_nodes == expected
