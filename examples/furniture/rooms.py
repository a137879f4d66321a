"""Rooms for level of detail (docs/early-sound.md): a room with a wall of small boxes and the
same room with a flat wall, and a furnished meeting room. Each is a shoebox plus an OBJ of its
furniture written by :func:`write_obj`; nothing here is physics, only geometry.

Run as a script to write ``furniture.obj`` beside this file (the tests write the box wall where
they need it).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

#: The box-wall room: 8 × 6 × 3 m, the west wall (x = 0) carries 10 × 5 cubes of 0.3 m on a
#: 0.6 m grid, standing 1 cm off the wall (no coplanar faces with it).
BOX_ROOM_M = (8.0, 6.0, 3.0)
BOX_SIZE_M = 0.3
BOX_PITCH_M = 0.6

#: The meeting room: 7 × 5 × 2.8 m with a table, eight chairs, a cupboard and a shelf.
MEETING_ROOM_M = (7.0, 5.0, 2.8)


def box(lo, hi) -> trimesh.Trimesh:
    """An axis-aligned box from corner ``lo`` to corner ``hi`` (m)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    move = trimesh.transformations.translation_matrix((lo + hi) / 2)
    return trimesh.creation.box(extents=hi - lo, transform=move)


def boxes_on_wall() -> list[trimesh.Trimesh]:
    """The cubes on the box-wall room's west wall."""
    out = []
    _, w, h = BOX_ROOM_M
    for y in np.arange(BOX_PITCH_M / 2, w, BOX_PITCH_M):
        for z in np.arange(BOX_PITCH_M / 2, h, BOX_PITCH_M):
            c = np.array([0.01 + BOX_SIZE_M / 2, y, z])
            out.append(box(c - BOX_SIZE_M / 2, c + BOX_SIZE_M / 2))
    return out


def furniture() -> dict[str, list[trimesh.Trimesh]]:
    """The meeting room's furniture by material group: a 3 × 1.2 m table (0.75 m high, four
    legs), eight chairs (seat and back), a 2 × 0.5 × 1.8 m cupboard and a wall shelf."""
    wood: list[trimesh.Trimesh] = []
    # Table top and legs.
    wood.append(box((2.0, 1.9, 0.72), (5.0, 3.1, 0.75)))
    for x in (2.05, 4.9):
        for y in (1.95, 3.0):
            wood.append(box((x, y, 0.005), (x + 0.05, y + 0.05, 0.72)))
    # Chairs: four a side, seat 0.45 m high, back 0.9 m.
    for x in (2.3, 3.0, 3.7, 4.4):
        for side, y0 in ((-1, 1.35), (1, 3.2)):
            wood.append(box((x, y0, 0.42), (x + 0.45, y0 + 0.45, 0.45)))
            yb = y0 if side < 0 else y0 + 0.42
            wood.append(box((x, yb, 0.45), (x + 0.45, yb + 0.03, 0.9)))
    cupboard = [box((0.3, 4.45, 0.005), (2.3, 4.95, 1.8))]
    shelf = [box((6.6, 1.0, 1.5), (6.95, 3.5, 1.53)), box((6.6, 1.0, 1.9), (6.95, 3.5, 1.93))]
    return {"wood": wood, "cupboard": cupboard, "shelf": shelf}


def write_obj(path: Path, groups: dict[str, list[trimesh.Trimesh]]) -> Path:
    """Writes the groups as one OBJ with a ``g`` line per group (sonolux maps groups to
    materials)."""
    lines, offset = [], 1
    for name, meshes in groups.items():
        m = trimesh.util.concatenate(meshes)
        lines.append(f"g {name}")
        lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in m.vertices]
        lines += [f"f {a + offset} {b + offset} {c + offset}" for a, b, c in m.faces]
        offset += len(m.vertices)
    path.write_text("\n".join(lines) + "\n")
    return path


if __name__ == "__main__":
    here = Path(__file__).parent
    print("wrote", write_obj(here / "furniture.obj", furniture()))
