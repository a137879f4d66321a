"""The one gateway to the engine: the only module that imports the compiled core, ``sonolux._core``.

Everything else in sonolux reaches the core through the names here:

- :class:`Geometry`: the scene's triangles held by the core with their BVH, and the queries the
  scene and the pictures need (mesh report, winding numbers, distances, closest hits, light
  patches);
- :func:`trace_sound` and :func:`trace_light`: the two tracers, each taking the settings
  objects below and returning numpy arrays in a dict; :func:`early_arrivals`: the exact early
  sound (image sources, edge diffraction) that a hybrid bake adds to the particles;
- the settings classes of the binding, made on first use: ``Acoustics``, ``Directivity``,
  ``SoundSource``, ``Receivers``, ``SoundSettings``, ``EarlySettings``, ``Optics``, ``Emitters``,
  ``LightSettings``, ``Lighting`` (documented in ``_core.pyi``);
- the partitioned convolver of auralization: ``Convolver``, ``partition``, ``fold``;
- :func:`simulate_waves` and ``WaveSettings``: the wave solver (FDTD) of the low bands, with
  its memory estimate and the largest frequency that fits a budget.

Array conventions: points float64[k, 3] in metres; the sound field
float32[receiver, direction, band, time] (docs/fieldfile.md). The core raises
:class:`~sonolux.errors.InvalidInputError` and :class:`~sonolux.errors.GeometryError`, both
:class:`~sonolux.errors.SonoluxError`; a missing extension is a
:class:`~sonolux.errors.CoreMissingError` that says how to build it. The core is imported on
first use, so that the pure-Python parts (schema, theory, analysis) work without it.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from sonolux.errors import CoreMissingError, InvalidInputError

if TYPE_CHECKING:
    from sonolux._core import (
        Acoustics,
        EarlySettings,
        Emitters,
        Lighting,
        LightSettings,
        Optics,
        Receivers,
        SoundSettings,
        SoundSource,
        WaveSettings,
    )

#: The binding's names that this gateway hands out as they are.
_FROM_CORE = ("Acoustics", "Convolver", "Directivity", "EarlySettings", "Emitters", "Lighting",
              "LightSettings", "Optics", "ReceiverPattern", "Receivers", "SoundSettings", "SoundSource",
              "WaveSettings", "fold", "partition", "MAX_THREADS")

Progress = Callable[[int, int, float], bool]


def core() -> Any:
    """The compiled extension, or a CoreMissingError saying how to build it."""
    try:
        from sonolux import _core
    except ImportError as exc:
        raise CoreMissingError(
            f"the compiled core sonolux._core is not available ({exc}); build it with `make build`"
        ) from None
    if not _NUMPY_API_READY:
        _load_numpy_api(_core)
    return _core


_NUMPY_API_READY = False


def _load_numpy_api(module: Any) -> None:
    """Makes the binding load numpy's C API now, with Ctrl-C and SIGTERM held back meanwhile.

    The binding loads it on its first array argument, by running a little Python (numpy's
    version check); a signal handler that raised there (the command line's does) would make
    the binding panic instead of stopping cleanly. Held back here, a signal arrives just after,
    in plain Python, and ends the command as any other."""
    import signal
    import threading

    global _NUMPY_API_READY
    held = {signal.SIGINT, signal.SIGTERM}
    main = threading.current_thread() is threading.main_thread()
    before = signal.pthread_sigmask(signal.SIG_BLOCK, held) if main else None
    try:
        module.partition(np.zeros((1, 4), np.float32), 4, 8, 1)
    except Exception:  # noqa: BLE001  (only the array's conversion matters here)
        pass
    finally:
        _NUMPY_API_READY = True
        if before is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, before)


def core_available() -> bool:
    try:
        core()
    except CoreMissingError:
        return False
    return True


def _converted(make: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """``make(*args, **kwargs)``, where the binding's own argument conversion fails with a
    TypeError or OverflowError (a negative number for a count, text for a length) turned into
    an InvalidInputError: pyo3's message names the argument."""
    try:
        return make(*args, **kwargs)
    except (TypeError, OverflowError) as exc:
        raise InvalidInputError(f"{getattr(make, '__name__', 'engine')}: {exc}") from None


class _Checked:
    """A settings class of the binding, made and used as the class itself, whose conversion
    errors are :class:`InvalidInputError` (see :func:`_converted`)."""

    def __init__(self, cls: Any) -> None:
        self._cls = cls
        self.__name__ = cls.__name__
        self.__doc__ = cls.__doc__

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return _converted(self._cls, *args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self._cls, name)
        if callable(attr):  # Directivity.omni(), Directivity.cone(...)
            return lambda *args, **kwargs: _converted(attr, *args, **kwargs)
        return attr

    def __instancecheck__(self, obj: Any) -> bool:
        return isinstance(obj, self._cls)


#: The binding's settings classes, whose arguments come from users (through the library).
_SETTINGS = ("Acoustics", "Directivity", "Emitters", "Lighting", "LightSettings", "Optics",
             "ReceiverPattern", "Receivers", "SoundSettings", "SoundSource", "WaveSettings")


def __getattr__(name: str) -> Any:
    if name in _SETTINGS:
        return _Checked(getattr(core(), name))
    if name in _FROM_CORE:
        return getattr(core(), name)
    raise AttributeError(f"module 'sonolux.engine' has no attribute {name!r}")


def physical_memory_bytes() -> int:
    """This machine's memory, or 8 GiB where the system does not say."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 8 << 30


def _points(points_m: Any, name: str = "points_m") -> np.ndarray:
    """float64[k, 3], C-ordered; a single point [x, y, z] counts as k = 1. Any other shape is
    an InvalidInputError naming the argument (never reshaped into other points)."""
    p = np.asarray(points_m, dtype=np.float64)
    if p.ndim == 1 and p.shape[0] == 3:
        p = p[None]
    if p.ndim != 2 or p.shape[1] != 3:
        raise InvalidInputError(f"{name}: expected shape (k, 3), got {p.shape}")
    return np.ascontiguousarray(p)


BVH_ENCODINGS = ("auto", "full", "compressed")


class Geometry:
    """A triangle mesh held by the core, with its BVH. vertices_m float64[n, 3]; triangles
    int[m, 3]; material_ids int[m] (default 0).

    The report: ``degenerate`` int64[d]; ``open_edge_midpoints`` float64[<=20, 3]; ``area_m2``
    float64[max material id + 1]; ``bbox_min`` / ``bbox_max`` float64[3];
    ``signed_volume_m3`` > 0 when the normals face outward, < 0 when they face inward (a room
    seen from inside).

    ``bvh_encoding``: the BVH's nodes, ``"auto"`` (compressed when the tree outgrows the
    caches), ``"full"`` or ``"compressed"``: the same hits either way (docs/bvh.md, "Compressed
    nodes"); for benchmarks and tests."""

    def __init__(self, vertices_m: np.ndarray, triangles: np.ndarray,
                 material_ids: np.ndarray | None = None, bvh_encoding: str = "auto") -> None:
        if bvh_encoding not in BVH_ENCODINGS:
            raise InvalidInputError(f"bvh_encoding: got {bvh_encoding!r}, expected one of "
                                    f"{', '.join(map(repr, BVH_ENCODINGS))}")
        v = _points(vertices_m, "vertices_m")
        t = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1, 3)
        if material_ids is None:
            material_ids = np.zeros(t.shape[0], dtype=np.uint32)
        m = np.ascontiguousarray(material_ids, dtype=np.uint32).reshape(-1)
        self._native = core().Geometry(v, t, m, bvh_encoding)
        self.n_triangles = int(t.shape[0])

    @property
    def build_time_s(self) -> float:
        """Seconds the core spent building the BVH."""
        return float(self._native.build_time_s)

    @property
    def bvh_nodes(self) -> int:
        return int(self._native.bvh_nodes)

    @property
    def bvh_compressed(self) -> bool:
        """Whether the BVH is traversed on compressed nodes."""
        return bool(self._native.bvh_compressed)

    def report(self) -> dict[str, Any]:
        r = dict(self._native.report())
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
        return np.asarray(self._native.winding_numbers(p), dtype=np.float64)

    def distance_to_surface(self, points_m: Any) -> np.ndarray:
        """float64[k]: distance from each point to the nearest triangle, in metres."""
        p = _points(points_m)
        if p.shape[0] == 0:
            return np.zeros(0)
        return np.asarray(self._native.distance_to_surface(p), dtype=np.float64)

    def closest_hit(self, origins_m: Any, directions: Any, t_max: float = float("inf"),
                    threads: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """(t float64[k], inf on a miss; triangle int64[k], -1 on a miss). Directions need not
        be unit length: t is in units of the direction."""
        o, d = _points(origins_m, "origins_m"), _points(directions, "directions")
        t, tri = self._native.closest_hit(o, d, t_max, threads)
        return np.asarray(t, dtype=np.float64), np.asarray(tri, dtype=np.int64)

    def patch_index(self, patch_size_m: float, triangles: Any, points_m: Any) -> np.ndarray:
        """int64[k]: the light patch (for patches of ``patch_size_m``) holding each point on its
        triangle (int64[k]); -1 where the triangle is -1."""
        return np.asarray(self._native.patch_index(
            float(patch_size_m), np.ascontiguousarray(triangles, np.int64), _points(points_m)),
            np.int64)


def trace_sound(geometry: Geometry, acoustics: Acoustics, sources: Sequence[SoundSource],
                receivers: Receivers, settings: SoundSettings,
                progress: Progress | None = None,
                early: EarlySettings | None = None,
                cover_early: bool = True,
                bake_receivers: Receivers | None = None) -> dict[str, Any]:
    """Traces a sound bake; see ``_core.trace_sound`` for the dict it returns (the field is
    float32[receiver, direction, band, time] in J/m²). With ``early``, the specular-only paths
    that :func:`early_arrivals` counts with those settings are left out (unless
    ``cover_early`` is False), and its level of detail applies to every reflection.
    ``bake_receivers``: the whole bake's receivers when ``receivers`` is a tile of them (from
    ``settings.first_receiver``): the nee estimator draws among all, as untiled."""
    return core().trace_sound(geometry._native, acoustics, list(sources), receivers, settings,
                              progress, early, cover_early, bake_receivers)


def sound_quantum(sources: Sequence[SoundSource], receivers: Receivers) -> float:
    """The fixed-point quantum (J/m² a count) of a bake of ``sources`` into ``receivers``; a
    bake traced in parts gives each part this quantum of the whole (``SoundSettings(quantum=)``)
    so that their counts add exactly; see ``_core.sound_quantum``."""
    return float(core().sound_quantum(list(sources), receivers))


def early_arrivals(geometry: Geometry, acoustics: Acoustics, sources: Sequence[SoundSource],
                   receivers: Receivers, early: EarlySettings,
                   settings: SoundSettings) -> dict[str, Any]:
    """The exact early arrivals (image sources and edge diffraction) of every source at every
    receiver, placed in the bins of a bake with ``settings``; see ``_core.early_arrivals``."""
    return core().early_arrivals(geometry._native, acoustics, list(sources), receivers, early,
                                 settings)


def trace_light(geometry: Geometry, optics: Optics, emitters: Emitters, settings: LightSettings,
                progress: Progress | None = None,
                lighting: Lighting | None = None) -> dict[str, Any]:
    """Traces a light bake; see ``_core.trace_light`` for the dict it returns. ``lighting``
    adds luminaires, sky, sun, glazing and a work plane (``_core.Lighting``)."""
    return core().trace_light(geometry._native, optics, emitters, settings, progress, lighting)


def simulate_waves(geometry: Geometry, absorption: np.ndarray, band_centres_hz: Sequence[float],
                   sources_m: Any, receivers_m: Any, settings: WaveSettings,
                   binning: SoundSettings | None = None,
                   progress: Progress | None = None, *,
                   without_direct: bool = False,
                   terms: tuple[np.ndarray, np.ndarray, float] | None = None,
                   energy_bands: int | None = None,
                   wells: dict[int, tuple[Sequence[float], float]] | None = None
                   ) -> dict[str, Any]:
    """Runs the wave solver over the geometry (all sources at once, coherently): absorption
    float64[material, band] at ``band_centres_hz``; sources and receivers float64[k, 3]. Returns
    pressure_pa float32[receiver, time] and velocity_m_s float32[receiver, axis, time] at
    ``sample_rate_hz``, the pulse's free-field pressure at 1 m, stats, and with ``binning`` (the
    bake's SoundSettings) energy float32[receiver, direction, band, time] per joule of source
    energy (with ``without_direct``, of the room's part alone: each source's free-field direct
    sound taken out first). ``terms``: a directional source, (positions float64[term, 3],
    volume accelerations float64[term, step], pulse delay s) in place of ``sources_m``'
    pulses; see ``_core.simulate_waves``. ``energy_bands`` k: the energy holds the first k bands
    only (a hybrid's wave bands; default all). ``wells``: {material: (depths m, patch m)}, the
    materials whose surface is a profile of wells (docs/scene.md ``surface``; a well behind every
    patch of their walls, sonolux_core::wave::wells)."""
    a = np.ascontiguousarray(absorption, dtype=np.float64)
    if a.ndim != 2:
        raise InvalidInputError(f"absorption: expected shape (material, band), got {a.shape}")
    return _converted(core().simulate_waves, geometry._native, a,
                      [float(f) for f in band_centres_hz], _points(sources_m, "sources_m"),
                      _points(receivers_m, "receivers_m"), settings, binning, progress,
                      bool(without_direct),
                      *(() if terms is None else
                        (_points(terms[0], "term_positions_m"),
                         np.ascontiguousarray(terms[1], dtype=np.float64), float(terms[2]))),
                      **({} if energy_bands is None else {"energy_bands": int(energy_bands)}),
                      **({} if not wells else {"wells": {int(m): ([float(d) for d in w[0]],
                                                                  float(w[1]))
                                                         for m, w in wells.items()}}))


def wave_memory_estimate(settings: WaveSettings, geometry: Geometry, n_receivers: int,
                         band_centres_hz: Sequence[float], absorption: Any = None,
                         wells: Mapping[int, tuple[Sequence[float], float]] | None = None,
                         ) -> dict[str, int]:
    """What a wave run would take, before anything is allocated (cells, steps, bytes). With
    ``absorption`` float64[material, band] the walls are fitted as the run will fit them and
    their branches counted; ``wells`` as for :func:`simulate_waves` (their branches too)."""
    extra: dict[str, Any] = {}
    if absorption is not None:
        extra["absorption"] = np.ascontiguousarray(absorption, dtype=np.float64)
    if wells:
        extra["wells"] = {int(m): ([float(d) for d in w[0]], float(w[1])) for m, w in wells.items()}
    return dict(settings.memory_estimate(geometry._native, int(n_receivers),
                                         [float(f) for f in band_centres_hz], **extra))


def wave_max_frequency(settings: WaveSettings, geometry: Geometry, n_receivers: int,
                       band_centres_hz: Sequence[float], budget_bytes: int) -> float | None:
    """The largest max_frequency_hz whose run fits ``budget_bytes`` (None: not even 1 Hz)."""
    return settings.max_frequency_within(geometry._native, int(n_receivers),
                                         [float(f) for f in band_centres_hz], int(budget_bytes))


__all__ = ["Geometry", "core", "core_available", "early_arrivals", "physical_memory_bytes",
           "simulate_waves", "wave_max_frequency", "wave_memory_estimate", "trace_light",
           "sound_quantum", "trace_sound", *_FROM_CORE]
