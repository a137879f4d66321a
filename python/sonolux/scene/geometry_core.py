"""The one place where the scene layer calls the Rust core's geometry queries.

``sonolux._core.Geometry`` is built from the scene's triangles and answers: a report of the
mesh (degenerate triangles, open / non-manifold / inconsistently wound edges, signed volume,
area per material), generalised winding numbers, distances to the surface and closest hits.
This module converts arrays to what the binding takes (contiguous float64 / uint32) and back,
and turns a missing extension or a rejected input into a :class:`~sonolux.errors.SonoluxError`.

Array conventions: points_m float64[k, 3]; the report's ``degenerate`` int64[d];
``open_edge_midpoints`` float64[<=20, 3]; ``area_m2`` float64[max material id + 1];
``bbox_min`` / ``bbox_max`` float64[3]. ``signed_volume_m3`` is > 0 when the normals face
outward and < 0 when they face inward (a room seen from inside).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sonolux.errors import SonoluxError


class CoreMissingError(SonoluxError):
    """The compiled extension is not built or cannot be imported."""


def core_module() -> Any:
    """The compiled extension, or a SonoluxError saying how to build it."""
    # Imported lazily so that the pure-Python parts (schema, errors, theory) work without it.
    try:
        from sonolux import _core
    except ImportError as exc:
        raise CoreMissingError(
            f"the compiled core sonolux._core is not available ({exc}); build it with `make build`"
        ) from None
    return _core


def core_available() -> bool:
    try:
        core_module()
    except CoreMissingError:
        return False
    return True


def _points(points_m: Any) -> np.ndarray:
    p = np.ascontiguousarray(points_m, dtype=np.float64).reshape(-1, 3)
    return p


class Geometry:
    """A triangle mesh held by the core. vertices_m float64[n, 3]; triangles int[m, 3]."""

    def __init__(self, vertices_m: np.ndarray, triangles: np.ndarray,
                 material_ids: np.ndarray | None = None) -> None:
        core = core_module()
        v = np.ascontiguousarray(vertices_m, dtype=np.float64).reshape(-1, 3)
        t = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1, 3)
        if material_ids is None:
            material_ids = np.zeros(t.shape[0], dtype=np.uint32)
        m = np.ascontiguousarray(material_ids, dtype=np.uint32).reshape(-1)
        try:
            self._g = core.Geometry(v, t, m)
        except Exception as exc:  # noqa: BLE001  (the binding raises its own error kinds)
            raise SonoluxError(f"the core rejected the geometry: {exc}") from None
        self.n_triangles = int(t.shape[0])

    def report(self) -> dict[str, Any]:
        r = dict(self._g.report())
        r["degenerate"] = np.asarray(r.get("degenerate", []), dtype=np.int64).reshape(-1)
        r["open_edge_midpoints"] = np.asarray(r.get("open_edge_midpoints", []),
                                              dtype=np.float64).reshape(-1, 3)
        r["area_m2"] = np.asarray(r["area_m2"], dtype=np.float64).reshape(-1)
        r["bbox_min"] = np.asarray(r["bbox_min"], dtype=np.float64).reshape(3)
        r["bbox_max"] = np.asarray(r["bbox_max"], dtype=np.float64).reshape(3)
        for k in ("n_triangles", "n_degenerate", "n_open_edges", "n_nonmanifold_edges",
                  "n_inconsistent_edges"):
            r[k] = int(r.get(k, 0))
        r["signed_volume_m3"] = float(r["signed_volume_m3"])
        return r

    def winding_numbers(self, points_m: Any) -> np.ndarray:
        """float64[k]: about ±1 inside a closed surface, about 0 outside."""
        p = _points(points_m)
        if p.shape[0] == 0:
            return np.zeros(0)
        return np.asarray(self._g.winding_numbers(p), dtype=np.float64)

    def distance_to_surface(self, points_m: Any) -> np.ndarray:
        """float64[k]: distance from each point to the nearest triangle, in metres."""
        p = _points(points_m)
        if p.shape[0] == 0:
            return np.zeros(0)
        return np.asarray(self._g.distance_to_surface(p), dtype=np.float64)

    def closest_hit(self, origins_m: Any, directions: Any,
                    t_max: float = float("inf")) -> tuple[np.ndarray, np.ndarray]:
        """(t float64[k], inf on a miss; triangle int64[k], -1 on a miss)."""
        o, d = _points(origins_m), _points(directions)
        t, tri = self._g.closest_hit(o, d, t_max)
        return np.asarray(t, dtype=np.float64), np.asarray(tri, dtype=np.int64)
