"""The rays' and image sources' side of described surfaces: each profiled material's α(θ, f)
and s(θ, f) table for the tracer (sonolux_core::sound::scattering), from the profile's model
(:mod:`sonolux.acoustics.surface`; docs/scene.md ``surface``, docs/waves-walls.md "Scattering on the
waves' side")."""

from __future__ import annotations

import numpy as np

from sonolux.acoustics.surface import rays_table
from sonolux.errors import SettingError
from sonolux.scene.schema import Scene
from sonolux.scene.simplify import Level


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


def level_tables(tables: dict[int, np.ndarray] | None, level: Level,
                 ) -> dict[int, np.ndarray] | None:
    """The tables of a level-of-detail band group (:mod:`sonolux.scene.simplify`): each
    profiled material's own, cut to the group's bands; and for a material the level appended (a
    profiled surface that took in the small features sitting on it), the same surface with what
    they added, as the level adds it to the coefficients: α'(θ) = min(α(θ) + ΔA/S, 1) and
    s'(θ) = 1 − (1 − s(θ))(1 − s_add) at every angle. None when no material has a profile."""
    if tables is None:
        return None
    b = level.bands
    out = {m: np.ascontiguousarray(t[:, :, b]) for m, t in tables.items()}
    first_added = level.absorption.shape[0] - len(level.seats)
    for j, (m, extra_alpha, s_add) in enumerate(level.seats):
        if m in tables:
            alpha = np.minimum(tables[m][0] + np.asarray(extra_alpha)[None, :], 1.0)
            scattering = 1.0 - (1.0 - tables[m][1]) * (1.0 - np.asarray(s_add)[None, :])
            out[first_added + j] = np.ascontiguousarray(np.stack([alpha, scattering])[:, :, b])
    return out


def wells_of(scene: Scene) -> dict[int, tuple[tuple[float, ...], float]] | None:
    """{material index: (depths m, patch m)} for the waves' walls of the materials with a
    surface profile (sonolux_core::wave::wells), or None when no material has one."""
    wells = {i: (m.surface.depths_m, m.surface.patch_m)
             for i, m in enumerate(scene.materials) if m.surface is not None}
    return wells or None


def flat_in_the_waves(scene: Scene) -> str | None:
    """A line for the log naming the materials whose scattering coefficient the rays apply and
    the waves' flat walls cannot (no ``surface``), or None (docs/waves-walls.md, "Scattering on the
    waves' side": what a coefficient alone means)."""
    named = [m.name for m in scene.materials
             if m.surface is None and np.any(np.asarray(m.scattering) > 0)]
    if not named:
        return None
    return (f"waves: the scattering of {', '.join(named)} is a coefficient: the rays apply it at "
            "every angle, the waves' walls stay flat, so T30 may step at the crossover; a "
            "material's surface = {depths_m, patch_m} gives both halves one surface "
            "(docs/waves-walls.md)")
