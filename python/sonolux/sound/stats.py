"""The statistics of a sound bake's parts (ray ranges, or the sources of a bake traced one by
one) put together."""

from __future__ import annotations

from typing import Any

import numpy as np

#: Statistics that add up over ranges; ``energy_*`` arrays add up too.
SUMMED_STATS = ("rays", "segments", "surface_hits", "escaped_rays", "deposits", "shadow_rays",
                "draws", "seconds")


def combine_stats(a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any]:
    """The statistics of two ranges together: counts and energies add, the maximum of the
    reflections is kept, the mean free path is weighted by the surface hits."""
    out = dict(a)
    for k, v in a.items():
        if k in SUMMED_STATS or k.startswith("energy_"):
            out[k] = np.add(v, b.get(k, 0)).tolist() if isinstance(v, (list, np.ndarray)) \
                else v + b.get(k, 0)
    out["max_reflections"] = max(a.get("max_reflections", 0), b.get("max_reflections", 0))
    wa, wb = a.get("surface_hits", 0), b.get("surface_hits", 0)
    for k in ("mean_free_path_m", "free_path_relative_variance"):
        if k in a and k in b and wa + wb > 0:
            out[k] = (a[k] * wa + b[k] * wb) / (wa + wb)
    if "early" not in out and "early" in b:
        out["early"] = b["early"]
    out["escapes"] = (list(a.get("escapes", [])) + list(b.get("escapes", [])))[:20]
    out["saturated"] = bool(a.get("saturated")) or bool(b.get("saturated"))
    out["cancelled"] = bool(a.get("cancelled")) or bool(b.get("cancelled"))
    return out
