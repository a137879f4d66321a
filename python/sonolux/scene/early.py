"""What a scene says about its exact early sound (``[early]``). Validated here, once; the physics
lives in the core (``crates/sonolux-core/src/early``) and the bake's use of it in
:mod:`sonolux.sound.early`.

A scene with an ``[early]`` table is baked as a hybrid: specular image sources (Allen and
Berkley 1979; Borish 1984 on meshes) up to ``max_order`` reflections and the transition time,
plus first-order edge diffraction (Biot–Tolstoy–Medwin, Svensson, Fred and Vanderkooy 1999),
give the early part exactly; the particles give everything else and leave out the
specular-only paths the images already count (docs/early-sound.md).

Keys: ``max_order`` (default 3, 0 to 12), ``transition_ms`` (``"auto"``, the default: the
perceptual mixing time 20 V/S + 12 ms of Lindau, Kosanke and Weinzierl 2012; or a time in
(0, 1000] ms), ``diffraction`` (default true), ``level_of_detail`` (default false: Rindel's
finite-panel specular share K on every reflection of the image sources and the particles alike,
s' = 1 − (1 − s)K, on panels with a diffracting edge; with ``max_order = 0`` and
``diffraction = false`` it is a particles-only bake with level of detail),
``diffraction_piece_m`` (default 0.25: the longest piece of an edge whose visibility is tested
as one, in (0, 10] m), ``level_of_detail_rays`` (``"level"``, the default since session 11:
the bands of one geometry share rays, hero-band sampled; ``"octave"``: with level of detail each
octave of bands traces its own rays, about 2.3–3.2× the time; measured in docs/early-sound.md),
``diffuse_connections`` (default false; true: with the sphere estimator the particles send the
diffusely reflected part of each reflection straight to the receivers that see it, for the
arrivals before the transition, as ODEON's early scattering; false: the spheres collect it,
which at equal wall time was the less noisy in both benchmark rooms; docs/early-sound.md
"Early diffuse connections").

With ``level_of_detail``, features small against a band's wavelength (ka < 1) are also left out
of that band's geometry, replaced by the surface they sit on (:mod:`sonolux.scene.simplify`).
"""

from __future__ import annotations

from dataclasses import dataclass

from sonolux.scene.schema import Table

EARLY_KEYS = ("max_order", "transition_ms", "diffraction", "level_of_detail",
              "diffraction_piece_m", "level_of_detail_rays", "diffuse_connections")
#: How the bands of a bake with level of detail share rays (docs/early-sound.md): "octave",
#: each octave of bands its own rays; "level", one set of rays for all bands of one geometry.
LOD_RAYS = ("octave", "level")
#: Highest image-source order a scene may ask for: the tree grows as about (planes)^order, and
#: beyond order 12 even a shoebox holds millions of images per source.
MAX_ORDER = 12


@dataclass(frozen=True)
class EarlySpec:
    max_order: int = 3
    #: None = automatic (the mixing time of the room).
    transition_s: float | None = None
    diffraction: bool = True
    level_of_detail: bool = False
    diffraction_piece_m: float = 0.25
    level_of_detail_rays: str = "level"
    diffuse_connections: bool = False


def _boolean(t: Table, name: str, default: bool) -> bool:
    v = t.data.get(name, default)
    if not isinstance(v, bool):
        raise t.ctx.error(t.path(name), v, "true or false")
    return v


def _choice(t: Table, name: str, default: str, allowed: tuple[str, ...]) -> str:
    v = t.data.get(name, default)
    if v not in allowed:
        raise t.ctx.error(t.path(name), v, " or ".join(f'"{a}"' for a in allowed))
    return str(v)


def read_early(t: Table | None) -> EarlySpec | None:
    """The ``[early]`` table, or None when the scene has none (particles only)."""
    if t is None:
        return None
    t.check_keys(EARLY_KEYS)
    d = EarlySpec()
    transition = t.data.get("transition_ms", "auto")
    if transition == "auto":
        transition_s = None
    elif isinstance(transition, (int, float)) and not isinstance(transition, bool) \
            and 0.0 < transition <= 1000.0:
        transition_s = float(transition) * 1e-3
    else:
        raise t.ctx.error(t.path("transition_ms"), transition,
                          '"auto" or a time in (0, 1000] ms')
    return EarlySpec(
        max_order=t.integer("max_order", d.max_order, lo=0, hi=MAX_ORDER),
        transition_s=transition_s,
        diffraction=_boolean(t, "diffraction", d.diffraction),
        level_of_detail=_boolean(t, "level_of_detail", d.level_of_detail),
        diffraction_piece_m=t.number("diffraction_piece_m", d.diffraction_piece_m, lo=0.0,
                                     lo_open=True, hi=10.0),
        level_of_detail_rays=_choice(t, "level_of_detail_rays", d.level_of_detail_rays, LOD_RAYS),
        diffuse_connections=_boolean(t, "diffuse_connections", d.diffuse_connections),
    )
