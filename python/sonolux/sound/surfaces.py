"""The rays' and image sources' side of described surfaces: each profiled material's s(θ, f)
table for the tracer (sonolux_core::sound::scattering), from the profile's model
(:mod:`sonolux.acoustics.surface`; docs/scene.md ``surface``, docs/waves.md "Scattering on the
waves' side")."""

from __future__ import annotations

import numpy as np

from sonolux.acoustics.surface import rays_table
from sonolux.errors import SettingError
from sonolux.scene.schema import Scene


def scattering_tables(scene: Scene) -> dict[int, np.ndarray] | None:
    """{material index: float64[angle, band]} for the materials with a surface profile (angles
    evenly spaced in cos θ from grazing to normal), or None when no material has one."""
    tables = {i: rays_table(m.surface, scene.settings.band_set, scene.settings.speed_of_sound_m_s)
              for i, m in enumerate(scene.materials) if m.surface is not None}
    return tables or None


def refuse_with_levels(scene: Scene) -> None:
    """Level-of-detail band groups rebuild the materials per group and do not carry s(θ) yet."""
    named = [m.name for m in scene.materials if m.surface is not None]
    if named:
        raise SettingError(f"materials {', '.join(named)}: a surface profile (surface = {{...}}) "
                         "cannot be baked with level-of-detail band groups yet; give those "
                         "materials a scattering coefficient instead, or leave level of detail off")
