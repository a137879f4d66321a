"""The scene's data model (dataclasses) and the helpers that validate what a user wrote.

Conventions, shared with the Rust core: lengths in metres, z up, azimuth 0° = +x growing
counter-clockwise seen from above. Every array is a contiguous numpy array whose shape and
axis order are documented on the field. Triangles are wound so that their normal
(``cross(v1 - v0, v2 - v0)``) faces into the room, towards the listener.

The validation helpers (:class:`Context`, :class:`Table`) read one TOML table (or dict) at a
time and raise :class:`~sonolux.errors.SceneError` naming the file, line, dotted key, value and
what is allowed. They never guess: an unknown key is an error that lists the keys allowed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.acoustics.bands import (
    DEFAULT_OCTAVES_HZ,
    OCTAVE,
    BandSet,
    allowed_text,
    band_set_of,
    convert_coefficients,
)
from sonolux.acoustics.surface import WellSurface, random_incidence
from sonolux.errors import (  # noqa: F401  (interval_text: re-exported)
    _MISSING,
    SceneError,
    close_matches,
    interval_text,
    number_allowed,
    range_text,
)
from sonolux.scene.toml_lines import find_line

#: The speed of sound a material's profile is read with when no scene says (20 °C air, m/s).
DEFAULT_SPEED_OF_SOUND_M_S = 343.2

#: Octave-band centres of the material library, in Hz. Every material carries one value per band.
LIBRARY_BANDS_HZ: tuple[int, ...] = (63, 125, 250, 500, 1000, 2000, 4000, 8000)
LIBRARY_BAND_SET = BandSet(OCTAVE, LIBRARY_BANDS_HZ)

REQUIRED = _MISSING  # marks a getter's default as "the key must be present"


# --- the data model ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Material:
    """Surface properties: for sound, values per band on the bands the data was given in.

    absorption: float64[n], energy absorption coefficient per band of ``absorption_bands``
        (by default the library's 8 octaves, 63..8000 Hz), in [0, 1].
    scattering: float64[k], share of reflected sound energy scattered diffusely, per band of
        ``scattering_bands``, in [0, 1]. A scene's bands take them through
        :meth:`absorption_in` and :meth:`scattering_in`.
    diffuse_rgb: float64[3], reflectance of light per linear RGB channel, in [0, 1]: the total,
        of which the share ``specular`` is reflected specularly and the rest diffusely.
    specular: share of reflected light that is specular, in [0, 1].
    roughness: roughness of the specular lobe, in [0, 1].
    transmittance: visible transmittance (glazing), the share of light passing straight through,
        the same in every channel; diffuse_rgb + transmittance ≤ 1. Daylight enters through
        every triangle of a material with transmittance > 0.
    surface: the surface's profile (``[materials.NAME.surface]``), or None. When given, the
        scattering is the profile's (:mod:`sonolux.acoustics.surface`): its random-incidence
        coefficient per band, α(θ) and s(θ) for the rays and a well behind each patch of the
        waves' walls; ``absorption`` is then the absorption of the surface's flat face.
    """

    name: str
    absorption: np.ndarray
    scattering: np.ndarray
    diffuse_rgb: np.ndarray
    specular: float = 0.0
    roughness: float = 0.5
    description: str = ""
    transmittance: float = 0.0
    absorption_bands: BandSet = LIBRARY_BAND_SET
    scattering_bands: BandSet = LIBRARY_BAND_SET
    surface: WellSurface | None = None

    def absorption_in(self, bands: BandSet) -> np.ndarray:
        """float64[band]: the absorption on ``bands``, converted as docs/bands.md says."""
        return convert_coefficients(self.absorption, self.absorption_bands, bands)

    def scattering_in(self, bands: BandSet,
                      speed_of_sound_m_s: float = DEFAULT_SPEED_OF_SOUND_M_S) -> np.ndarray:
        """float64[band]: the scattering on ``bands``, converted as docs/bands.md says; for a
        described surface, the profile's random-incidence coefficient in each band."""
        if self.surface is not None:
            return random_incidence(self.surface, self.absorption_in(bands), bands,
                                    speed_of_sound_m_s)[1]
        return convert_coefficients(self.scattering, self.scattering_bands, bands)


#: The tracer's wall models (``[settings] wall_model``; sonolux_core::sound::reflectance).
WALL_MODELS = ("random-incidence", "locally-reacting", "locally-reacting-modes")


@dataclass(frozen=True)
class Air:
    """The air the sound travels through (ISO 9613-1 inputs)."""

    temperature_c: float = 20.0
    humidity_percent: float = 50.0
    pressure_kpa: float = 101.325

    @property
    def speed_of_sound_m_s(self) -> float:
        """c = 331.3 * sqrt(1 + T / 273.15) m/s, T in °C."""
        return 331.3 * math.sqrt(1.0 + self.temperature_c / 273.15)


@dataclass(frozen=True)
class Settings:
    """How a scene is to be simulated.

    ``bands`` is the kind of band, "octave" or "third-octave"; ``bands_hz`` the nominal centres
    of a contiguous run of that kind (IEC 61260-1; see :mod:`sonolux.acoustics.bands`).
    """

    sample_rate_hz: int = 48000
    bands_hz: tuple[float, ...] = DEFAULT_OCTAVES_HZ
    energy_drop_db: float = 60.0
    max_time_s: float = 0.0  # 0 = until the energy has dropped by energy_drop_db
    seed: int = 1
    threads: int = 0  # 0 = all cores
    air: Air = field(default_factory=Air)
    bands: str = OCTAVE
    #: How a surface's absorption depends on the angle of incidence (:data:`WALL_MODELS`;
    #: docs/walls.md); None: automatic, "locally-reacting-modes" in a bake with waves (the
    #: wave solver's wall, the gaps' grazing modes in the rays), else "random-incidence".
    wall_model: str | None = None

    @property
    def band_set(self) -> BandSet:
        """The simulated bands: nominal centres, exact mid-band frequencies and edges."""
        return BandSet(self.bands, tuple(self.bands_hz))

    @property
    def speed_of_sound_m_s(self) -> float:
        return self.air.speed_of_sound_m_s


@dataclass(frozen=True, eq=False)
class SoundSource:
    """A sound source. position_m: float64[3]; axis: float64[3] unit vector (cone only);
    forward, up: float64[3] unit and perpendicular (tabulated patterns only); sofa: the
    measured directivity read from its file (directivity "sofa" only)."""

    name: str
    position_m: np.ndarray
    power_w: float = 1.0
    directivity: str = "omni"  # "omni", "cone", a built-in pattern or "sofa"
    cone_half_angle_deg: float | None = None
    axis: np.ndarray | None = None
    forward: np.ndarray | None = None
    up: np.ndarray | None = None
    sofa: Any = None


@dataclass(frozen=True, eq=False)
class Light:
    """A light, resolved to the triangles that emit.

    triangles_m: float64[k, 3, 3], axes (triangle, corner, xyz); each triangle emits on the side
    of its normal ``cross(v1 - v0, v2 - v0)``. power_w is the radiant flux of the whole light,
    shared among the triangles in proportion to their area. color_rgb: float64[3]. material: the
    emitting material's name (surface lights), whose triangles in the scene are these.
    """

    name: str
    kind: str  # "rectangle", "surface" or "ies"
    triangles_m: np.ndarray
    power_w: float
    color_rgb: np.ndarray
    material: str | None = None
    #: An "ies" luminaire: its centre float64[3], its frame float64[3, 3] (rows: the C = 0°
    #: direction, the C = 90° direction, the γ = 0° axis) and its photometry
    #: (:class:`sonolux.light.ies.Photometry`, candela scaled to the luminaire as placed).
    position_m: np.ndarray | None = None
    frame: np.ndarray | None = None
    photometry: Any = None

    @property
    def area_m2(self) -> float:
        t = self.triangles_m
        return float(0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum())


@dataclass(frozen=True, eq=False)
class Receivers:
    """Spherical sound receivers that were kept, and how many candidates were dropped and why.

    positions_m: float64[k, 3] centres. For a grid, origin_m (float64[2], xy) is the anchor
    cell and grid_index (int64[k, 2], axes (receiver, (i, j))) places receiver r at
    ``origin_m + spacing_m * grid_index[r]`` at ``height_m``; the anchor cell is (0, 0).
    """

    kind: str  # "grid" or "points"
    positions_m: np.ndarray
    radius_m: float
    height_m: float | None = None
    spacing_m: float | None = None
    origin_m: np.ndarray | None = None
    grid_index: np.ndarray | None = None
    candidates: int = 0
    dropped_outside: int = 0
    dropped_inside_obstacle: int = 0
    dropped_near_surface: int = 0
    #: Directional channels (points only, :mod:`sonolux.scene.receiver_channels`): each point
    #: holds one receiver per channel, consecutive; ``channels`` the channels in order,
    #: ``channel_of`` int64[k] and ``point_of`` int64[k] each receiver's channel and point.
    #: Empty/None: one omnidirectional receiver a point.
    channels: tuple[Any, ...] = ()
    channel_of: np.ndarray | None = None
    point_of: np.ndarray | None = None

    @property
    def count(self) -> int:
        return int(self.positions_m.shape[0])


@dataclass(eq=False)
class Scene:
    """A loaded, validated scene: one triangle soup plus what lives in it.

    vertices_m: float64[n, 3]; triangles: int64[m, 3] (vertex indices, wound so the normal faces
    into the room); material_index: int32[m] into ``materials``; surface_tag: str[m] ("floor",
    "north", ... for shoeboxes, the mesh group name for meshes). ``origin`` says where the scene
    came from (a path, "<dict>" or "built-in NAME"); ``mesh_report`` is the core's geometry
    report (see :class:`sonolux.engine.Geometry`); ``geometry`` is that handle.
    """

    name: str
    origin: str
    vertices_m: np.ndarray
    triangles: np.ndarray
    material_index: np.ndarray
    materials: list[Material]
    surface_tag: np.ndarray
    sources: list[SoundSource]
    lights: list[Light]
    receivers: Receivers
    settings: Settings
    mesh_report: dict[str, Any]
    warnings: list[str] = field(default_factory=list)
    #: ``[daylight]`` (a :class:`sonolux.scene.lighting.DaylightSpec`) or None, and
    #: ``[workplane]`` (a :class:`sonolux.scene.lighting.WorkplaneSpec`).
    daylight: Any = None
    workplane: Any = None
    #: ``[early]`` (a :class:`sonolux.scene.early.EarlySpec`), or None: particles only.
    early: Any = None
    #: ``[speech]`` (a :class:`sonolux.scene.speech.SpeechSpec`): talker and noise for STI.
    speech: Any = None
    #: ``[waves]`` (a :class:`sonolux.scene.waves.WavesSpec`) or None: the hybrid's defaults.
    waves: Any = None
    #: The core's mesh and BVH, built once when the scene was loaded and shared by the tracers.
    geometry: Any = field(default=None, repr=False)

    @property
    def volume_m3(self) -> float:
        """Volume of the air, from the signed volume (negative when normals face inward)."""
        return abs(float(self.mesh_report["signed_volume_m3"]))

    @property
    def area_m2(self) -> float:
        """Total surface area (degenerate triangles skipped)."""
        return float(np.sum(self.mesh_report["area_m2"]))

    def area_by_material_m2(self) -> dict[str, float]:
        areas = np.asarray(self.mesh_report["area_m2"], dtype=np.float64)
        out = {m.name: 0.0 for m in self.materials}
        for i, m in enumerate(self.materials):
            out[m.name] = float(areas[i]) if i < areas.shape[0] else 0.0
        return out


@dataclass(eq=False)
class GeometryPart:
    """What one ``[[geometry]]`` entry contributes, before the parts are joined.

    vertices_m: float64[n, 3]; triangles: int64[m, 3]; group: int64[m] index into
    group_material / group_tag (one group per mesh material, or per shoebox face).
    """

    vertices_m: np.ndarray
    triangles: np.ndarray
    group: np.ndarray
    group_material: list[Material]
    group_tag: list[str]
    warnings: list[str] = field(default_factory=list)


# --- validation helpers -----------------------------------------------------------------------


@dataclass(frozen=True)
class Context:
    """Where a scene came from: display name, source text (for line numbers), base directory."""

    file: str
    text: str | None = None
    base_dir: Path = Path(".")

    def error(self, key: str | None, value: Any = _MISSING, allowed: str = "", *,
              matches: Sequence[str] = (), message: str | None = None) -> SceneError:
        line = find_line(self.text, key) if (self.text and key) else None
        return SceneError(self.file, key, value, allowed, line=line, matches=matches,
                          message=message)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


class Table:
    """One TOML table (or dict) being read, with its dotted key path for messages."""

    def __init__(self, data: Any, key: str, ctx: Context) -> None:
        if not isinstance(data, dict):
            raise ctx.error(key or "(top level)", data, "a table")
        self.data = data
        self.key = key
        self.ctx = ctx

    def path(self, name: str) -> str:
        return f"{self.key}.{name}" if self.key else name

    def has(self, name: str) -> bool:
        return name in self.data

    def check_keys(self, allowed: Sequence[str]) -> None:
        for k in self.data:
            if k not in allowed:
                raise self.ctx.error(
                    self.path(k),
                    message="unknown key; the keys allowed here are " + ", ".join(allowed),
                    matches=close_matches(k, allowed))

    def _get(self, name: str, default: Any, allowed: str) -> Any:
        if name in self.data:
            return self.data[name]
        if default is REQUIRED:
            raise self.ctx.error(self.path(name), allowed=allowed)
        return _MISSING

    def number(self, name: str, default: Any = REQUIRED, *, lo: float | None = None,
               hi: float | None = None, lo_open: bool = False, hi_open: bool = False,
               integer: bool = False) -> Any:
        allowed = range_text(lo, hi, lo_open, hi_open, "an integer" if integer else "a number")
        v = self._get(name, default, allowed)
        if v is _MISSING:
            return default
        check_number(self.ctx, self.path(name), v, lo, hi, lo_open, hi_open, integer)
        return int(v) if integer else float(v)

    def integer(self, name: str, default: Any = REQUIRED, **kw: Any) -> Any:
        return self.number(name, default, integer=True, **kw)

    def string(self, name: str, default: Any = REQUIRED,
               choices: Sequence[str] | None = None) -> Any:
        allowed = ("one of " + ", ".join(f'"{c}"' for c in choices)) if choices else "a string"
        v = self._get(name, default, allowed)
        if v is _MISSING:
            return default
        if not isinstance(v, str):
            raise self.ctx.error(self.path(name), v, allowed)
        if choices is not None and v not in choices:
            raise self.ctx.error(self.path(name), v, allowed, matches=close_matches(v, choices))
        return v

    def vector(self, name: str, n: int, default: Any = REQUIRED, *, lo: float | None = None,
               hi: float | None = None, lo_open: bool = False, nonzero: bool = False) -> Any:
        """A list of ``n`` finite numbers, as float64[n]."""
        interval = interval_text(lo, hi, lo_open)
        allowed = f"a list of {n} numbers" + (f", each {interval}" if interval else "")
        v = self._get(name, default, allowed)
        if v is _MISSING:
            return None if default is None else np.array(default, dtype=np.float64)
        return check_vector(self.ctx, self.path(name), v, n, allowed, lo=lo, hi=hi,
                            lo_open=lo_open, nonzero=nonzero)

    def bands(self, name: str, default: Any = REQUIRED,
              grid: BandSet = LIBRARY_BAND_SET) -> Any:
        """One number in [0, 1] for every band of ``grid``, or a list of one per band:
        float64[grid.n_bands]."""
        span = f"{grid.nominal_hz[0]:g}..{grid.nominal_hz[-1]:g} Hz"
        allowed = (f"a number in [0, 1], or a list of {grid.n_bands} such numbers "
                   f"({grid.kind} bands {span})")
        v = self._get(name, default, allowed)
        if v is _MISSING:
            return default
        if _is_number(v):
            check_number(self.ctx, self.path(name), v, 0.0, 1.0, False, False, False)
            return np.full(grid.n_bands, float(v))
        return check_vector(self.ctx, self.path(name), v, grid.n_bands, allowed, lo=0.0, hi=1.0)

    def band_grid(self, name: str, default: BandSet) -> BandSet:
        """A list of nominal band centres: a contiguous run of octaves or of thirds."""
        if name not in self.data:
            return default
        v = self.data[name]
        try:
            return band_set_of(v) if isinstance(v, list) else _no_bands()
        except (ValueError, TypeError):
            raise self.ctx.error(self.path(name), v, allowed_text()) from None

    def table(self, name: str) -> Table | None:
        if name not in self.data:
            return None
        return Table(self.data[name], self.path(name), self.ctx)

    def tables(self, name: str) -> list[Table]:
        """An array of tables (``[[name]]``); a single table is not accepted."""
        v = self.data.get(name, [])
        if not isinstance(v, list):
            raise self.ctx.error(self.path(name), v, f"an array of tables ([[{name}]])")
        return [Table(item, f"{self.path(name)}[{i}]", self.ctx) for i, item in enumerate(v)]


def _no_bands() -> BandSet:
    raise ValueError("not a list")


def check_number(ctx: Context, key: str, v: Any, lo: float | None, hi: float | None,
                 lo_open: bool, hi_open: bool, integer: bool) -> None:
    if not number_allowed(v, lo, hi, lo_open, hi_open, integer):
        raise ctx.error(key, v, range_text(lo, hi, lo_open, hi_open,
                                           "an integer" if integer else "a number"))


def check_vector(ctx: Context, key: str, v: Any, n: int, allowed: str, *,
                 lo: float | None = None, hi: float | None = None, lo_open: bool = False,
                 nonzero: bool = False) -> np.ndarray:
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise ctx.error(key, v, allowed)
    for i, x in enumerate(v):
        check_number(ctx, f"{key}[{i}]", x, lo, hi, lo_open, False, False)
    out = np.array(v, dtype=np.float64)
    # A direction is divided by its length: a length that underflows to 0 (components near
    # 1e-160 and below) or overflows to inf cannot be, though the vector is not zero.
    length = float(np.linalg.norm(out))
    if nonzero and not (0.0 < length < np.inf):
        raise ctx.error(key, v, "a non-zero vector whose length is a finite, non-zero float "
                        "(components between about 1e-150 and 1e150)")
    return out
