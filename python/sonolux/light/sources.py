"""The light sources beyond Lambertian triangles, as the core takes them: IES luminaires
(point sources with their intensity table) and daylight (the sky and the sun entering through
every glazing triangle, with the glazing's transmittance). Everything is photometric here and
turned into radiant-equivalent watts per channel with :mod:`sonolux.light.photometry`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sonolux.light.daylight import Sky, make_sky, sun_direction, sun_position
from sonolux.light.photometry import channel_scale_per_candela
from sonolux.scene.schema import Scene

WHITE = np.ones(3)


def scene_sky(scene: Scene) -> Sky | None:
    """The scene's ``[daylight]`` sky as a table (None without one)."""
    d = scene.daylight
    if d is None:
        return None
    if d.sky == "overcast":
        return make_sky("overcast", sky_horizontal_lx=d.sky_horizontal_lx,
                        ground_reflectance=d.ground_reflectance)
    sun = sun_direction(sun_position(d.date_time, d.latitude_deg, d.longitude_deg), d.north_deg)
    return make_sky("clear", sky_horizontal_lx=d.sky_horizontal_lx, sun=sun,
                    sun_normal_lx=d.sun_normal_lx, ground_reflectance=d.ground_reflectance)


def glazing_triangles(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(triangles_m float64[g, 3, 3], transmittance float64[g]) of every glazing triangle."""
    tau = np.array([m.transmittance for m in scene.materials])[scene.material_index]
    mine = tau > 0
    return np.ascontiguousarray(scene.vertices_m[scene.triangles[mine]]), tau[mine]


def other_sources(scene: Scene) -> tuple[dict[str, Any], Sky | None]:
    """(the core's ``sources`` dict, the sky or None). The dict's arrays are documented on the
    binding's ``trace_light``; tables hold cd (luminaires) or cd/m² (the sky)."""
    tables: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    out: dict[str, Any] = {"tables": tables}
    ies = [li for li in scene.lights if li.kind == "ies"]
    if ies:
        for li in ies:
            tables.append(li.photometry.full_table())
        out.update(point_position=np.array([li.position_m for li in ies], float),
                   point_frame=np.array([li.frame for li in ies], float),
                   point_scale=np.array([channel_scale_per_candela(li.color_rgb) for li in ies]),
                   point_table=np.arange(len(ies), dtype=np.int64))
    sky = scene_sky(scene)
    if sky is not None:
        tris, tau = glazing_triangles(scene)
        if tris.shape[0]:
            per_cd = channel_scale_per_candela(WHITE)
            tables.append((sky.theta_rad, sky.phi_rad, sky.values))
            out.update(sky_corners=tris, sky_scale=np.outer(tau, per_cd),
                       sky_table=np.full(tris.shape[0], len(tables) - 1, np.int64))
            if sky.sun_travel is not None and sky.sun_normal_lx > 0:
                out.update(sun_corners=tris,
                           sun_direction=np.repeat(sky.sun_travel[None], tris.shape[0], axis=0),
                           sun_irradiance=np.outer(tau * sky.sun_normal_lx, per_cd))
    if len(out) == 1:
        return {}, sky
    return out, sky
