"""Watertight seams for the exported mesh: no T-junctions where patches of different sizes meet.

Neighbouring triangles are cut into different numbers of patches (k² each, from their areas),
and the faces of a room's corner keep their own nodes (the picture stays sharp there). Where
they meet, a node of one side lies inside an edge of the other: a T-junction. Rasterizers
interpolate such an edge and the neighbour's vertex with different rounding, which shows as
hairline cracks (pixels of the background) along the seam.

:func:`close_seams` inserts every such node into the edge it lies on: the face with the long
edge is re-cut into triangles that use the same points as its neighbour, so the two sides share
their vertices exactly. An inserted vertex takes the colour interpolated along its own edge, so
the picture is unchanged (the face's linear interpolation is kept); only the mesh becomes
conforming. A face whose one edge gets points is fanned from the opposite corner; one with
points on several edges is fanned from its centroid (colour: the corners' mean, again the
linear interpolation).
"""

from __future__ import annotations

import numpy as np

#: A point is on an edge when it lies within this share of the scene's extent of the segment.
ON_EDGE_TOLERANCE = 1e-7


def t_junctions(vertices: np.ndarray, faces: np.ndarray) -> dict[tuple[int, int], list[tuple[float, int]]]:
    """{(a, b) edge with a < b: [(t along a→b in (0, 1), vertex)]} of the vertices (one per
    distinct position) lying strictly inside each face edge."""
    from scipy.spatial import cKDTree

    extent = float(np.ptp(vertices, axis=0).max()) if vertices.size else 1.0
    tol = ON_EDGE_TOLERANCE * max(extent, 1e-9)
    edges = np.unique(np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    # One vertex per position: duplicates (a sharp corner's two sides) insert once.
    _, first = np.unique(np.round(vertices / tol).astype(np.int64), axis=0, return_index=True)
    tree = cKDTree(vertices[first])
    u, v = vertices[edges[:, 0]], vertices[edges[:, 1]]
    length = np.linalg.norm(v - u, axis=1)
    found = tree.query_ball_point(0.5 * (u + v), 0.5 * length + tol)
    out: dict[tuple[int, int], list[tuple[float, int]]] = {}
    for e, near in enumerate(found):
        if len(near) <= 2:
            continue
        w = vertices[first[near]]
        d = v[e] - u[e]
        t = (w - u[e]) @ d / max(length[e] ** 2, 1e-300)
        off = np.linalg.norm(w - (u[e] + t[:, None] * d), axis=1)
        inside = (off < tol) & (t * length[e] > tol) & ((1 - t) * length[e] > tol)
        if np.any(inside):
            pts = sorted(zip(t[inside].tolist(), first[np.asarray(near)[inside]].tolist()))
            out[(int(edges[e, 0]), int(edges[e, 1]))] = pts
    return out


def close_seams(vertices: np.ndarray, faces: np.ndarray,
                colours: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices, faces, colours) with every T-junction closed; unchanged faces keep their
    order and come first."""
    inserts = t_junctions(vertices, faces)
    if not inserts:
        return vertices, faces, colours
    new_v, new_c = [vertices], [colours]
    count = vertices.shape[0]
    keep = np.ones(faces.shape[0], bool)
    added: list[list[int]] = []

    def vertex(p: np.ndarray, c: np.ndarray) -> int:
        nonlocal count
        new_v.append(p[None])
        new_c.append(c[None])
        count += 1
        return count - 1

    for f, (a, b, c) in enumerate(faces):
        sides = []
        for p, q in ((a, b), (b, c), (c, a)):
            pts = inserts.get((min(p, q), max(p, q)), [])
            if p > q:
                pts = [(1 - t, w) for t, w in reversed(pts)]
            sides.append([vertex(vertices[w], (1 - t) * colours[p] + t * colours[q])
                          for t, w in pts])
        if not any(sides):
            continue
        keep[f] = False
        ring = [a, *sides[0], b, *sides[1], c, *sides[2]]
        if sum(bool(s) for s in sides) == 1:
            k = next(i for i, s in enumerate(sides) if s)
            apex = (a, b, c)[(k + 2) % 3]
            start = ring.index(apex)
            ring = ring[start:] + ring[:start]
            added += [[apex, ring[i], ring[i + 1]] for i in range(1, len(ring) - 1)]
        else:
            centre = vertex(vertices[[a, b, c]].mean(axis=0), colours[[a, b, c]].mean(axis=0))
            added += [[centre, ring[i], ring[(i + 1) % len(ring)]] for i in range(len(ring))]
    return (np.concatenate(new_v), np.concatenate([faces[keep], np.array(added, faces.dtype)]),
            np.concatenate(new_c))
