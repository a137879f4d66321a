"""The shoebox mesh: 12 triangles facing into the room, faces where their names say."""

from __future__ import annotations

import numpy as np

from sonolux.scene.shoebox import FACES, shoebox_mesh

SIZE = np.array([6.0, 2.5, 2.0])
# Where each face lies (axis, value) and its inward normal.
PLANES = {"west": (0, 0.0, [1, 0, 0]), "east": (0, 6.0, [-1, 0, 0]),
          "south": (1, 0.0, [0, 1, 0]), "north": (1, 2.5, [0, -1, 0]),
          "floor": (2, 0.0, [0, 0, 1]), "ceiling": (2, 2.0, [0, 0, -1])}


def test_twelve_triangles_two_per_named_face():
    vertices, triangles, names = shoebox_mesh(SIZE)
    assert vertices.shape == (8, 3) and triangles.shape == (12, 3)
    assert names == [f for f in FACES for _ in range(2)]


def test_faces_lie_on_their_planes_and_face_inward():
    vertices, triangles, names = shoebox_mesh(SIZE)
    corners = vertices[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    for k, name in enumerate(names):
        axis, value, inward = PLANES[name]
        np.testing.assert_array_equal(corners[k, :, axis], value)
        unit = normals[k] / np.linalg.norm(normals[k])
        np.testing.assert_allclose(unit, inward, atol=1e-12)


def test_signed_volume_is_minus_the_volume_and_area_is_exact():
    vertices, triangles, _ = shoebox_mesh(SIZE)
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    signed = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    assert signed == -30.0  # inward normals: negative, exactly
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()
    assert area == 2 * (6 * 2.5 + 6 * 2 + 2.5 * 2)


def test_every_edge_is_shared_by_two_triangles_wound_opposite_ways():
    _, triangles, _ = shoebox_mesh(SIZE)
    directed = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    assert len({tuple(e) for e in directed}) == 36  # no directed edge twice: consistent winding
    assert {tuple(e[::-1]) for e in directed} == {tuple(e) for e in directed}  # closed
