"""Which points lie in the room's air: inside the room, and not inside a closed obstacle.

The scene's triangles are split into connected components (triangles sharing vertices). The
component with the largest bounding box is the room's shell; every other *closed* component
(each edge shared by exactly two triangles) is an obstacle. A point is

- ``OUTSIDE`` when the winding number of the whole scene is below 0.5 in magnitude and no
  obstacle contains it (the generalised winding number is ±1 inside a closed surface and 0
  outside; with the shell facing in and obstacles facing out, it is 0 inside an obstacle too);
- ``IN_OBSTACLE`` when the winding number of some obstacle alone is at least 0.5 in magnitude
  (whatever the way its triangles are wound);
- ``IN_AIR`` otherwise.

Winding numbers and distances come from the core (:mod:`sonolux.engine`).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from sonolux.engine import Geometry

IN_AIR, OUTSIDE, IN_OBSTACLE = 0, 1, 2


def triangle_components(n_vertices: int, triangles: np.ndarray) -> tuple[int, np.ndarray]:
    """(count, int64[m] component of each triangle), joining triangles that share a vertex."""
    m = triangles.shape[0]
    if m == 0:
        return 0, np.zeros(0, dtype=np.int64)
    rows = np.repeat(triangles[:, 0], 2)
    cols = triangles[:, 1:].reshape(-1)
    graph = coo_matrix((np.ones(rows.shape[0]), (rows, cols)), shape=(n_vertices, n_vertices))
    _, labels = connected_components(graph, directed=False)
    # Renumber so that components are numbered by first appearance among the triangles.
    tri_label = labels[triangles[:, 0]]
    _, first, inverse = np.unique(tri_label, return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))
    return int(first.shape[0]), order[inverse].astype(np.int64)


def is_closed(triangles: np.ndarray) -> bool:
    """True when every undirected edge is shared by exactly two triangles."""
    if triangles.shape[0] == 0:
        return False
    edges = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(np.all(counts == 2))


class RoomSpace:
    """Point classification and surface distances for one scene's triangles."""

    def __init__(self, geometry: Geometry, vertices_m: np.ndarray, triangles: np.ndarray) -> None:
        self.geometry = geometry
        self.obstacles: list[Geometry] = []
        count, comp = triangle_components(vertices_m.shape[0], triangles)
        if count > 1:
            sizes = []
            for c in range(count):
                used = vertices_m[np.unique(triangles[comp == c])]
                sizes.append(float(np.prod(used.max(axis=0) - used.min(axis=0))))
            shell = int(np.argmax(sizes))
            for c in range(count):
                tris = triangles[comp == c]
                if c != shell and is_closed(tris):
                    used, local = np.unique(tris, return_inverse=True)
                    self.obstacles.append(Geometry(vertices_m[used], local.reshape(-1, 3)))

    def classify(self, points_m: np.ndarray) -> np.ndarray:
        """int8[k]: IN_AIR, OUTSIDE or IN_OBSTACLE for each point (float64[k, 3])."""
        p = np.ascontiguousarray(points_m, dtype=np.float64).reshape(-1, 3)
        out = np.full(p.shape[0], IN_AIR, dtype=np.int8)
        if p.shape[0] == 0:
            return out
        w = self.geometry.winding_numbers(p)
        in_obstacle = np.zeros(p.shape[0], dtype=bool)
        for obstacle in self.obstacles:
            in_obstacle |= np.abs(obstacle.winding_numbers(p)) >= 0.5
        out[np.abs(w) < 0.5] = OUTSIDE
        out[in_obstacle] = IN_OBSTACLE
        return out

    def distance_to_surface(self, points_m: np.ndarray) -> np.ndarray:
        return self.geometry.distance_to_surface(points_m)
