"""The glTF export loads back (trimesh) with the patches, their colours and y up."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from sonolux.light.export import export_gltf
from sonolux.light.patches import patch_mesh


@pytest.mark.parametrize("smooth", [True, False])
def test_gltf_round_trip(small_light, tmp_path, smooth):
    import trimesh

    path = tmp_path / "room.glb"
    out = export_gltf(small_light, path, smooth=smooth)
    scene = trimesh.load(path)
    surfaces, lights = scene.geometry["surfaces"], scene.geometry["lights"]
    mesh = patch_mesh(small_light)
    # Every patch is there; faces along seams are re-cut (tests below).
    assert len(surfaces.faces) == out["triangles"] >= small_light.n_patches
    assert len(surfaces.vertices) >= (mesh.n_nodes if smooth else 3 * small_light.n_patches)
    assert surfaces.area == pytest.approx(small_light.patch_area_m2.sum(), rel=1e-9)
    # y up: the room's 6 × 2.5 × 2 m box becomes x 0..6, y 0..2 (height), z -2.5..0.
    assert surfaces.bounds == pytest.approx(np.array([[0, 0, -2.5], [6, 2, 0]]), abs=1e-6)
    assert len(lights.faces) == 2 and lights.bounds[0][1] == pytest.approx(1.999, abs=1e-6)
    colours = surfaces.visual.vertex_attributes["color"]
    assert colours.shape == (len(surfaces.vertices), 4)
    # Lit surfaces, not black; the floor (30%) darker than the walls (98%).
    y_up = np.asarray(surfaces.vertices)
    floor = colours[np.isclose(y_up[:, 1], 0)][:, 0].mean()
    wall = colours[np.isclose(y_up[:, 0], 0) & (y_up[:, 1] > 0.5)][:, 0].mean()
    assert 0 < floor < wall < 255
    # An unlit material, so viewers show the baked light as it is.
    glb = path.read_bytes()
    (n,) = struct.unpack_from("<I", glb, 12)
    tree = json.loads(glb[20:20 + n])
    assert "KHR_materials_unlit" in tree["extensionsUsed"]
    assert all(p["material"] == 0 for m in tree["meshes"] for p in m["primitives"])
    assert [p.name for p in tmp_path.iterdir()] == ["room.glb"]


def _brute_force_t_junctions(vertices, faces, tol=1e-7):
    """(face, vertex) pairs where a vertex lies strictly inside an edge of a face: checked
    directly, edge by edge against every vertex (independent of sonolux.light.seams)."""
    found = []
    for f, tri in enumerate(faces):
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            u, v = vertices[a], vertices[b]
            d = v - u
            t = (vertices - u) @ d / (d @ d)
            off = np.linalg.norm(vertices - (u + t[:, None] * d), axis=1)
            length = np.sqrt(d @ d)
            hit = (off < tol) & (t * length > tol) & ((1 - t) * length > tol)
            found += [(f, int(w)) for w in np.flatnonzero(hit)]
    return found


def test_seams_are_closed_without_changing_the_picture(small_light):
    from sonolux.light.seams import close_seams

    mesh = patch_mesh(small_light)
    vertices, faces = mesh.node_m, mesh.nodes
    colours = np.random.default_rng(1).random((vertices.shape[0], 3))
    before = _brute_force_t_junctions(vertices, faces)
    assert len(before) > 50  # paper-small's corners meet with different patch sizes
    v2, f2, c2 = close_seams(vertices, faces, colours)
    assert _brute_force_t_junctions(v2, f2) == []

    def area(v, f):
        return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]),
                                    axis=1)
    assert area(v2, f2).sum() == pytest.approx(area(vertices, faces).sum(), rel=1e-12)
    assert np.all(area(v2, f2) > 0)  # no degenerate triangle
    # Unchanged faces are kept as they were, first; every new vertex sits on an old face with
    # the colour that face interpolates there (so the picture does not change).
    kept = f2[: np.isin(np.arange(len(faces)), [f for f, _ in before], invert=True).sum()]
    assert np.array_equal(kept, faces[np.isin(np.arange(len(faces)), [f for f, _ in before],
                                              invert=True)])
    assert np.array_equal(v2[: len(vertices)], vertices)
    for w in range(len(vertices), len(v2)):
        owners = [f for f, _ in before]
        ok = False
        for f in owners:
            a, b, c = vertices[faces[f]]
            m = np.column_stack([b - a, c - a])
            st, *_ = np.linalg.lstsq(m, v2[w] - a, rcond=None)
            bary = np.array([1 - st.sum(), *st])
            if np.linalg.norm(m @ st + a - v2[w]) < 1e-9 and np.all(bary > -1e-9):
                ok = ok or np.allclose(bary @ colours[faces[f]], c2[w], atol=1e-9)
        assert ok, w
