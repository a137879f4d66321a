"""What `sonolux info` and `sonolux bake` print about a light field."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from sonolux.light.field import LightField

#: Share of particles that may escape before a bake warns of a leak.
LEAK_WARNING_SHARE = 0.001


def info(field: LightField) -> dict[str, Any]:
    st = field.stats
    noise = field.relative_noise
    reached = field.hits > 0
    return {
        "scene": field.scene_name, "origin": field.scene_origin, "path": field.path,
        "triangles": field.n_triangles, "patches": field.n_patches,
        "patch_size_m": field.patch_size_m,
        "patch_area_m2": [float(field.patch_area_m2.min(initial=np.inf)) if field.n_patches else 0.0,
                          float(field.patch_area_m2.max(initial=0))],
        "lights": [{"name": n, "kind": k, "power_w": float(p)} for n, k, p in
                   zip(field.light_names, field.light_kinds, field.light_power_w)],
        "settings": field.settings, "stats": st,
        "flux_balance_relative_error": field.balance_relative_error().tolist(),
        "escaped_share": st["escaped_particles"] / max(st["particles"], 1),
        "patches_reached_share": float(reached.mean()) if reached.size else 0.0,
        "median_hits_per_patch": float(np.median(field.hits)) if field.hits.size else 0.0,
        "median_relative_noise": float(np.median(noise)) if noise.size else float("nan"),
        "mean_irradiance_w_m2": {k: v.tolist() for k, v in field.mean_irradiance_w_m2().items()},
    }


def _rgb(v: Any) -> str:
    v = np.asarray(v, float)
    if np.allclose(v, v[0], rtol=1e-12, atol=0):
        return f"{v[0]:.4g}"
    return "(" + ", ".join(f"{x:.4g}" for x in v) + ")"


def format_info(field: LightField, path: str | Path | None = None) -> str:
    d = info(field)
    st, se = field.stats, field.settings
    rate = st.get("particles_per_second") or 0.0
    balance = max(abs(v) for v in d["flux_balance_relative_error"])
    lights = ", ".join(f"{x['name']} ({x['kind']}, {x['power_w']:g} W)" for x in d["lights"])
    lines = [
        f"light field of {d['scene']}" + (f"  ({path})" if path else ""),
        f"  lights      {lights}",
        f"  patches     {d['patches']:,} on {d['triangles']:,} triangles, about "
        f"{d['patch_size_m']:g} m ({d['patch_area_m2'][0]:.3g}..{d['patch_area_m2'][1]:.3g} m²)",
        f"  bake        {se['particles']:,} particles, seed {se['seed']}",
        f"  traced      {st['bounces']:,} surface hits ({st['hits_per_particle']:.2f} a particle), "
        f"{st['escaped_particles']:,} escaped, in {st.get('seconds', float('nan')):.2f} s "
        f"({rate:,.0f} particles/s)",
        f"  noise       median {d['median_hits_per_patch']:.0f} hits a patch"
        + (f" (relative noise {d['median_relative_noise']:.1%})"
           if np.isfinite(d["median_relative_noise"]) else " (more particles needed)")
        + f"; {d['patches_reached_share']:.1%} of patches reached",
        f"  flux (W)    emitted {_rgb(st['flux_emitted_w'])}, absorbed {_rgb(st['flux_absorbed_w'])}, "
        f"escaped {_rgb(st['flux_escaped_w'])}, roulette {_rgb(st['flux_roulette_w'])}",
        f"  balance     emitted + roulette = absorbed + escaped, to {balance:.1e} relative",
        "  irradiance  " + ", ".join(f"{k} {_rgb(v)}" for k, v in
                                      d["mean_irradiance_w_m2"].items()) + " W/m² (mean per surface)",
    ]
    if d["escaped_share"] > LEAK_WARNING_SHARE:
        lines.append(f"  WARNING     {d['escaped_share']:.2%} of particles escaped: the geometry "
                     "leaks")
    return "\n".join(lines)
