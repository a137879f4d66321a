"""Writes l-room.obj: an L-shaped classroom with tables, chairs and a cabinet (about 650
triangles), and on request a dense variant for benchmarks (about 100,000 triangles).

Run from anywhere: ``python examples/l-room/make_l_room.py`` rewrites ``l-room.obj`` beside
this file (the committed file is its output). ``write_obj(path, dense=True)`` adds a bumpy
sculpture of ~82,000 triangles and tessellates every wall, floor and ceiling into ~0.2 m
squares: the room that ``benchmarks/mesh_room.py`` traces as its 100k-triangle case.

Conventions of docs/scene.md: metres, z up; the room's triangles face into the room, the
furniture's out of each closed piece (into the room's air). The footprint is a 12 x 9 m
rectangle less a 5 x 4 m notch at the north-east corner, 3.2 m high, so its bounding box is
[0, 12] x [0, 9] x [0, 3.2]. Furniture stands 5 mm above the floor (its feet left out, as
real furniture touches the floor only at points) and its parts do not touch, so every piece
is a closed surface of its own.

Groups (usemtl names, mapped to library materials by l-room.toml): Floor, Ceiling, Wall,
Window, Table, Chair, Cabinet, and in the dense variant Sculpture.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

HEIGHT_M = 3.2
# Footprint, counter-clockwise seen from above (so the interior is on the left of each edge).
FOOTPRINT = [(0, 0), (7, 0), (12, 0), (12, 5), (7, 5), (7, 9), (0, 9), (0, 5)]
GAP_M = 0.005  # between furniture and floor, and between a piece's parts
# The dense variant's sculpture: centre and mean radius; bumps reach 12 % beyond it.
SCULPTURE_CENTRE_M = (5.5, 3.8, 1.2)
SCULPTURE_RADIUS_M = 0.6


class ObjWriter:
    """Collects triangles by group, welding equal vertices."""

    def __init__(self) -> None:
        self.vertices: dict[tuple[float, float, float], int] = {}
        self.groups: dict[str, list[tuple[int, int, int]]] = {}

    def vertex(self, p) -> int:
        key = tuple(round(float(c), 6) for c in p)
        return self.vertices.setdefault(key, len(self.vertices))

    def triangle(self, group: str, a, b, c) -> None:
        self.groups.setdefault(group, []).append((self.vertex(a), self.vertex(b), self.vertex(c)))

    def quad(self, group: str, a, b, c, d, steps: int = 1) -> None:
        """Quad a-b-c-d (its normal is (b - a) x (d - a)), as steps x steps pairs of triangles."""
        a, b, c, d = (np.asarray(p, float) for p in (a, b, c, d))
        at = lambda u, v: a + (b - a) * u + (d - a) * v + (a - b + c - d) * u * v  # noqa: E731
        for i in range(steps):
            for j in range(steps):
                u0, u1, v0, v1 = i / steps, (i + 1) / steps, j / steps, (j + 1) / steps
                p00, p10, p11, p01 = at(u0, v0), at(u1, v0), at(u1, v1), at(u0, v1)
                self.triangle(group, p00, p10, p11)
                self.triangle(group, p00, p11, p01)

    def box(self, group: str, lo, hi) -> None:
        """A closed axis-aligned box, faces out of it."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        self.quad(group, (x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0))  # bottom, -z
        self.quad(group, (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1))  # top, +z
        self.quad(group, (x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1))  # south, -y
        self.quad(group, (x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0))  # north, +y
        self.quad(group, (x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0))  # west, -x
        self.quad(group, (x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1))  # east, +x

    def write(self, path: Path, header: str) -> int:
        lines = [f"# {line}" if line else "#" for line in header.splitlines()]
        for p in self.vertices:
            lines.append("v " + " ".join(f"{c:.6g}" for c in p))
        n = 0
        for group, tris in self.groups.items():
            lines.append(f"usemtl {group}")
            lines.extend(f"f {a + 1} {b + 1} {c + 1}" for a, b, c in tris)
            n += len(tris)
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return n


def room(w: ObjWriter, steps_per_m: float) -> None:
    """Floor and ceiling as three rectangles; walls, one quad per footprint edge (the south
    wall's east part is a window)."""
    h = HEIGHT_M
    for (x0, y0), (x1, y1) in [((0, 0), (7, 5)), ((7, 0), (12, 5)), ((0, 5), (7, 9))]:
        n = max(1, round(steps_per_m * max(x1 - x0, y1 - y0)))
        w.quad("Floor", (x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0), n)  # +z
        w.quad("Ceiling", (x0, y0, h), (x0, y1, h), (x1, y1, h), (x1, y0, h), n)  # -z
    for k, (x0, y0) in enumerate(FOOTPRINT):
        x1, y1 = FOOTPRINT[(k + 1) % len(FOOTPRINT)]
        group = "Window" if (x0, y0) == (7, 0) else "Wall"
        n = max(1, round(steps_per_m * max(math.hypot(x1 - x0, y1 - y0), h)))
        # Interior on the left of (x0, y0) -> (x1, y1): this order faces it.
        w.quad(group, (x0, y0, 0), (x0, y0, h), (x1, y1, h), (x1, y1, 0), n)


def table(w: ObjWriter, cx: float, cy: float, size=(1.6, 0.8), height=0.75) -> None:
    """A top 40 mm thick on four 50 mm legs."""
    sx, sy = size[0] / 2, size[1] / 2
    top = height - 0.04
    w.box("Table", (cx - sx, cy - sy, top), (cx + sx, cy + sy, height))
    for dx in (-sx + 0.05, sx - 0.1):
        for dy in (-sy + 0.05, sy - 0.1):
            w.box("Table", (cx + dx, cy + dy, GAP_M), (cx + dx + 0.05, cy + dy + 0.05, top - GAP_M))


def chair(w: ObjWriter, cx: float, cy: float, facing_north: bool) -> None:
    """A 0.45 m seat at 0.45 m on four 30 mm legs, with a back on the side away from the table."""
    s, seat = 0.225, 0.45
    w.box("Chair", (cx - s, cy - s, seat - 0.04), (cx + s, cy + s, seat))
    for dx in (-s + 0.02, s - 0.05):
        for dy in (-s + 0.02, s - 0.05):
            w.box("Chair", (cx + dx, cy + dy, GAP_M), (cx + dx + 0.03, cy + dy + 0.03, seat - 0.04 - GAP_M))
    by = cy - s if facing_north else cy + s - 0.04
    w.box("Chair", (cx - s, by, seat + GAP_M), (cx + s, by + 0.04, seat + 0.45))


def sculpture(w: ObjWriter, centre, radius: float, subdivisions: int = 6) -> None:
    """A bumpy closed blob (an icosphere radially displaced by smooth bumps), faces out."""
    import trimesh  # a dependency of sonolux already

    ico = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    u = np.asarray(ico.vertices, float)
    r = radius * (1.0 + 0.12 * np.sin(7 * u[:, 0]) * np.sin(6 * u[:, 1] + 1) * np.sin(5 * u[:, 2] + 2))
    p = u * r[:, None] + np.asarray(centre, float)
    for a, b, c in np.asarray(ico.faces):
        w.triangle("Sculpture", p[a], p[b], p[c])


def build(dense: bool = False) -> ObjWriter:
    w = ObjWriter()
    room(w, steps_per_m=5.0 if dense else 0.0)
    # Three tables, two chairs at each, facing the talker's end (west) of the main arm.
    for cx, cy in [(3.5, 2.0), (8.5, 2.0), (3.0, 7.0)]:
        table(w, cx, cy)
        for dx in (-0.4, 0.4):
            chair(w, cx + dx, cy + 0.75, facing_north=True)
    w.box("Cabinet", (10.4, 4.35, GAP_M), (11.9, 4.9, 2.0))
    if dense:
        sculpture(w, centre=SCULPTURE_CENTRE_M, radius=SCULPTURE_RADIUS_M)
    return w


def write_obj(path: Path, dense: bool = False) -> int:
    """Writes the room (dense: the 100k-triangle variant) to `path`; returns its triangles."""
    what = "the dense 100k-triangle variant" if dense else "the example"
    return build(dense).write(Path(path), f"L-shaped classroom, {what}, written by make_l_room.py.\n"
                              "Metres, z up; room faces into the room, furniture out of itself.")


if __name__ == "__main__":
    out = Path(__file__).resolve().parent / "l-room.obj"
    print(f"{out}: {write_obj(out)} triangles")
