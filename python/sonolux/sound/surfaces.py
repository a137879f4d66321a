"""The rays' and image sources' side of described surfaces: each profiled material's α(θ, f)
and s(θ, f) table for the tracer (sonolux_core::sound::scattering), from the profile's model
(:mod:`sonolux.acoustics.surface`; docs/scene.md ``surface``, docs/waves.md "Scattering on the
waves' side")."""

from __future__ import annotations

import numpy as np

from sonolux.acoustics.surface import rays_table
from sonolux.errors import SettingError
from sonolux.scene.schema import Scene


def tables_by_angle(scene: Scene) -> dict[int, np.ndarray] | None:
    """{material index: float64[2, angle, band]} (absorption, then scattering) for the materials
    with a surface profile (angles evenly spaced in cos θ from grazing to normal), or None when
    no material has one."""
    bands, c = scene.settings.band_set, scene.settings.speed_of_sound_m_s
    tables = {}
    for i, m in enumerate(scene.materials):
        if m.surface is not None:
            try:
                tables[i] = rays_table(m.surface, m.absorption_in(bands), bands, c)
            except ValueError as exc:
                raise SettingError(f"material {m.name}: {exc}") from None
    return tables or None


def refuse_with_levels(scene: Scene) -> None:
    """Level-of-detail band groups rebuild the materials per group and do not carry s(θ) yet."""
    named = [m.name for m in scene.materials if m.surface is not None]
    if named:
        raise SettingError(f"materials {', '.join(named)}: a surface profile (surface = {{...}}) "
                         "cannot be baked with level-of-detail band groups yet; give those "
                         "materials a scattering coefficient instead, or leave level of detail off")


def wells_of(scene: Scene) -> dict[int, tuple[tuple[float, ...], float]] | None:
    """{material index: (depths m, patch m)} for the waves' walls of the materials with a
    surface profile (sonolux_core::wave::wells), or None when no material has one."""
    wells = {i: (m.surface.depths_m, m.surface.patch_m)
             for i, m in enumerate(scene.materials) if m.surface is not None}
    return wells or None


def flat_in_the_waves(scene: Scene) -> str | None:
    """A line for the log naming the materials whose scattering coefficient the rays apply and
    the waves' flat walls cannot (no ``surface``), or None (docs/waves.md, "Scattering on the
    waves' side": what a coefficient alone means)."""
    named = [m.name for m in scene.materials
             if m.surface is None and np.any(np.asarray(m.scattering) > 0)]
    if not named:
        return None
    return (f"waves: the scattering of {', '.join(named)} is a coefficient: the rays apply it at "
            "every angle, the waves' walls stay flat, so T30 may step at the crossover; a "
            "material's surface = {depths_m, patch_m} gives both halves one surface "
            "(docs/waves.md)")
