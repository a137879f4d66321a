"""The exact early part of a hybrid sound bake: image sources and edge diffraction from the core
(``crates/sonolux-core/src/early``), added to the particles' field without counting a path twice.

How the two parts share the work (docs/early-sound.md): the image sources count every
specular-only path of up to ``max_order`` reflections that arrives before the transition time,
each at its exact time and direction with the energy Π(1 − α)(1 − s) per band (Allen and
Berkley 1979; Borish 1984); the particle tracer, run with the same :class:`EarlySettings`, skips
the deposits of exactly those paths (a ray that has only reflected specularly, at most
``max_order`` times, before the transition), and keeps everything with a diffuse bounce. The
diffracted arrivals (Svensson, Fred and Vanderkooy 1999) are sound the particles never carry.
With ``diffuse_connections`` (off by default) the particles also send each reflection's diffuse
share straight to the receivers that see it for the arrivals before the transition (ODEON's early
scattering: Naylor 1993; Rindel and Christensen 2003), and their spheres skip exactly those legs
(``sonolux_core::sound::nee::EarlyConnections``).

The arrivals are kept in the field (``SoundField.early``) beside the particles' part, so that ray
ranges still merge exactly: the field's energy is always
``float32(float64(particles) + deposit(arrivals))``, computed by
:func:`sonolux.sound.field.add_arrivals`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from sonolux import engine
from sonolux.scene.early import EarlySpec
from sonolux.scene.schema import Scene
from sonolux.sound.field import add_arrivals

#: The arrays of an arrival list (one row an arrival), as ``engine.early_arrivals`` returns them.
ARRIVAL_KEYS = ("source", "receiver", "time_s", "from_direction", "kind", "order", "energy",
                "direction_bin", "time_bin")


def transition_s(scene: Scene, spec: EarlySpec) -> tuple[float, str]:
    """The transition time from image sources to particles, and why: the scene's
    ``transition_ms``, or the perceptual mixing time t = 20 V/S + 12 ms of Lindau, Kosanke and
    Weinzierl ("Perceptual evaluation of model- and signal-based predictors of the mixing time
    in binaural room impulse responses", JAES 60(11), 2012)."""
    if spec.transition_s is not None:
        return spec.transition_s, f"transition {spec.transition_s * 1e3:g} ms (the scene's)"
    t = (20.0 * scene.volume_m3 / scene.area_m2 + 12.0) * 1e-3
    return t, (f"transition {t * 1e3:.1f} ms: the mixing time 20 V/S + 12 ms "
               f"(V = {scene.volume_m3:.4g} m³, S = {scene.area_m2:.4g} m²; Lindau et al. 2012)")


def bands_per_octave(bands_hz: Sequence[float]) -> float:
    """Bands per octave of a run of logarithmically spaced centres (1 for a single band)."""
    if len(bands_hz) < 2:
        return 1.0
    return 1.0 / math.log2(float(bands_hz[1]) / float(bands_hz[0]))


def early_settings(scene: Scene, spec: EarlySpec, air_per_m: np.ndarray,
                   log: Callable[[str], None] | None = None,
                   bands: slice = slice(None)) -> Any:
    """The engine's ``EarlySettings`` for a scene's ``[early]`` table, for the scene's bands or
    the slice ``bands`` of them (a level of :mod:`sonolux.sound.levels`)."""
    t, why = transition_s(scene, spec)
    if log:
        log(f"early sound: image sources to order {spec.max_order}, {why}"
            + (", edge diffraction" if spec.diffraction else "")
            + (", level of detail" if spec.level_of_detail else "")
            + (", early diffuse connections" if spec.diffuse_connections else ""))
    return engine.EarlySettings(
        max_order=spec.max_order, max_time_s=t,
        speed_of_sound_m_s=scene.settings.speed_of_sound_m_s,
        air_attenuation_per_m=[float(a) for a in np.asarray(air_per_m)[bands]],
        band_centres_hz=[float(f) for f in scene.settings.band_set.exact_hz[bands]],
        # The core puts a band's edges at centre · 2^(±1/(2 b)); this b gives IEC 61260-1's
        # base-10 edges centre · G^(±1/(2 per_octave)), G = 10^(3/10).
        bands_per_octave=scene.settings.band_set.per_octave / (0.3 * math.log2(10.0)),
        diffraction=spec.diffraction, level_of_detail=spec.level_of_detail,
        threads=scene.settings.threads, diffraction_piece_m=spec.diffraction_piece_m,
        connect_diffuse=spec.diffuse_connections)


def arrival_table(arrivals: dict[str, Any]) -> dict[str, np.ndarray]:
    """The arrays of an arrival list, without the core's statistics."""
    return {k: np.asarray(arrivals[k]) for k in ARRIVAL_KEYS}


__all__ = ["ARRIVAL_KEYS", "add_arrivals", "arrival_table", "bands_per_octave", "early_settings",
           "transition_s"]
