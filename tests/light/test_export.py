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
    assert len(surfaces.faces) == small_light.n_patches == out["triangles"]
    assert len(surfaces.vertices) == (mesh.n_nodes if smooth else 3 * small_light.n_patches)
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
