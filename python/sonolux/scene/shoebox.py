"""Shoebox rooms: a box spanning [0, L] x [0, W] x [0, H] metres, x along the length.

Its six faces are named ``west`` (x = 0), ``east`` (x = L), ``south`` (y = 0), ``north``
(y = W), ``floor`` (z = 0) and ``ceiling`` (z = H). Each is two triangles whose normals face
into the room, the side a listener sees. ``[geometry.materials]`` gives each face a material;
``walls`` sets the four walls and ``default`` all six, a face's own name wins over both.
"""

from __future__ import annotations

import numpy as np

from sonolux.scene.material_names import MaterialNames
from sonolux.scene.schema import GeometryPart, Table

FACES = ("floor", "ceiling", "west", "east", "south", "north")
WALLS = ("west", "east", "south", "north")
SHOEBOX_KEYS = ("type", "size_m", "materials")

# Corner (ix, iy, iz) of the unit box is vertex ix + 2 iy + 4 iz. Each face lists its corners
# counter-clockwise as seen from inside the room, so that cross(v1 - v0, v2 - v0) faces inward.
_FACE_QUADS = {
    "floor": (0, 1, 3, 2),    # z = 0, normal +z
    "ceiling": (4, 6, 7, 5),  # z = H, normal -z
    "west": (0, 2, 6, 4),     # x = 0, normal +x
    "east": (1, 5, 7, 3),     # x = L, normal -x
    "south": (0, 4, 5, 1),    # y = 0, normal +y
    "north": (2, 3, 7, 6),    # y = W, normal -y
}


def shoebox_mesh(size_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(vertices float64[8, 3], triangles int64[12, 3], face name of each triangle)."""
    corners = np.array([[ix, iy, iz] for iz in (0, 1) for iy in (0, 1) for ix in (0, 1)],
                       dtype=np.float64)
    vertices = corners * np.asarray(size_m, dtype=np.float64)
    triangles, names = [], []
    for face in FACES:
        a, b, c, d = _FACE_QUADS[face]
        triangles += [(a, b, c), (a, c, d)]
        names += [face, face]
    return np.ascontiguousarray(vertices), np.array(triangles, dtype=np.int64), names


def face_materials(table: Table | None) -> dict[str, str | None]:
    """Material name of each face from ``[geometry.materials]`` (None where none is given)."""
    out: dict[str, str | None] = dict.fromkeys(FACES)
    if table is None:
        return out
    table.check_keys((*FACES, "walls", "default"))
    default = table.string("default", None)
    walls = table.string("walls", default)
    for face in FACES:
        out[face] = table.string(face, walls if face in WALLS else default)
    return out


def build_shoebox(t: Table, names: MaterialNames) -> GeometryPart:
    """The GeometryPart of one ``type = "shoebox"`` entry."""
    t.check_keys(SHOEBOX_KEYS)
    size_m = t.vector("size_m", 3, lo=0.0, lo_open=True)
    mats_table = t.table("materials")
    per_face = face_materials(mats_table)
    missing = [f for f in FACES if per_face[f] is None]
    if missing:
        raise t.ctx.error(t.path("materials"), message=(
            "no material for " + ", ".join(missing) + "; set each face (floor, ceiling, west, "
            "east, south, north), or walls = NAME for the four walls, or default = NAME"))
    vertices, triangles, _ = shoebox_mesh(size_m)
    materials = []
    for face in FACES:
        name = per_face[face]
        assert name is not None
        key_face = face if (mats_table is not None and mats_table.has(face)) else (
            "walls" if face in WALLS and mats_table is not None and mats_table.has("walls")
            else "default")
        materials.append(names.resolve(name, t.path(f"materials.{key_face}")))
    group = np.repeat(np.arange(len(FACES), dtype=np.int64), 2)
    return GeometryPart(vertices, triangles, group, materials, list(FACES))
