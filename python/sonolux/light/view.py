"""A view of the baked light written as a picture: the camera, the render, the exposure and the
files, in one call (``sonolux render`` and the report both use it).

:func:`render_view` takes a :class:`~sonolux.light.field.LightField` and a :class:`ViewSettings`
and writes a tone-mapped sRGB PNG (and, if asked, linear radiance in W/m²/sr as .exr or .pfm).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from sonolux.errors import SonoluxError
from sonolux.light import image
from sonolux.light.camera import Camera, default_camera
from sonolux.light.field import LightField
from sonolux.light.render import Renderable, incident_exposure, render

METERS = ("incident", "reflected")


@dataclass(frozen=True)
class ViewSettings:
    """camera_m: the camera position (None: the paper's view from head height near the west end
    wall, looking along +x); look_at_m, or yaw_deg and pitch_deg: where it looks; fov_deg: the
    vertical field of view; size_px: (width, height) or None for the camera's default;
    samples: N for N×N rays a pixel; exposure_ev: stops added to the automatic exposure; meter:
    "incident" (the light on the surfaces in view) or "reflected" (log-average luminance);
    tone_map: one of :data:`sonolux.light.image.TONE_MAPS`."""

    camera_m: tuple[float, float, float] | None = None
    look_at_m: tuple[float, float, float] | None = None
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    fov_deg: float = 60.0
    size_px: tuple[int, int] | None = None
    samples: int = 2
    exposure_ev: float = 0.0
    meter: str = "incident"
    tone_map: str = "aces"

    def validate(self) -> ViewSettings:
        if self.meter not in METERS:
            raise SonoluxError(f"meter = {self.meter!r} is not allowed: {' or '.join(METERS)}")
        if self.tone_map not in image.TONE_MAPS:
            raise SonoluxError(f"tone map {self.tone_map!r} is not allowed: "
                               f"{', '.join(image.TONE_MAPS)}")
        return self

    def camera(self, field: LightField) -> Camera:
        settings: dict[str, Any] = {"fov_deg": self.fov_deg}
        if self.size_px:
            settings["width"], settings["height"] = self.size_px
        if self.look_at_m is not None:
            settings["look_at_m"] = self.look_at_m
        else:
            settings["yaw_deg"], settings["pitch_deg"] = self.yaw_deg, self.pitch_deg
        if self.camera_m is None:
            return default_camera(field.vertices_m.min(axis=0), field.vertices_m.max(axis=0),
                                  **settings)
        return replace(Camera(position_m=self.camera_m), **settings)


def render_view(field: LightField, png: str | Path, settings: ViewSettings | None = None,
                hdr: str | Path | None = None) -> dict[str, Any]:
    """Renders the view and writes ``png`` (and ``hdr``): a dict of what was done (camera,
    exposure scale and meter reading, seconds, the files written)."""
    settings = (settings or ViewSettings()).validate()
    camera = settings.camera(field)
    started = time.perf_counter()
    renderable = Renderable.of(field)
    rays = render(renderable, camera, samples=settings.samples, keep_samples=True)
    linear = rays.mean(axis=2)
    auto = (incident_exposure(renderable, camera) if settings.meter == "incident"
            else image.auto_exposure(linear))
    seconds = time.perf_counter() - started
    scale = auto * 2.0 ** settings.exposure_ev
    written = [image.write_png(png, image.to_srgb8(rays, scale, settings.tone_map,
                                                   samples_axis=2))]
    if hdr:
        written.append(image.write_hdr(hdr, linear))
    return {"camera": camera, "meter_reading": auto, "exposure_scale": scale,
            "seconds": seconds, "written": [str(p) for p in written]}
