# The compiled core's Python face (crates/sonolux-py), checked against the built module by
# `stubtest sonolux._core` in `make lint`. Only sonolux/engine.py imports it.
#
# Arrays: points float64[k, 3] in metres; the sound field float32[receiver, direction, band,
# time] in J/m² (docs/fieldfile.md). Errors: sonolux.errors.InvalidInputError and
# GeometryError (both SonoluxError), raised with the name of the input at fault.

from collections.abc import Callable, Mapping, Sequence
from typing import Any, final

import numpy as np
from numpy.typing import NDArray

__version__: str
MAX_THREADS: int

__all__ = [
    "__version__",
    "MAX_THREADS",
    "Geometry",
    "Acoustics",
    "Directivity",
    "SoundSource",
    "ReceiverPattern",
    "Receivers",
    "SoundSettings",
    "EarlySettings",
    "early_arrivals",
    "trace_sound",
    "sound_quantum",
    "WaveSettings",
    "simulate_waves",
    "Optics",
    "Emitters",
    "LightSettings",
    "Lighting",
    "trace_light",
    "Convolver",
    "partition",
    "fold",
]

_Progress = Callable[[int, int, float], bool]

@final
class Geometry:
    def __new__(
        cls,
        vertices_m: NDArray[np.float64],
        triangles: NDArray[np.uint32],
        material_ids: NDArray[np.uint32],
        bvh_encoding: str = "auto",
    ) -> Geometry: ...
    @property
    def n_triangles(self) -> int: ...
    @property
    def build_time_s(self) -> float: ...
    @property
    def bvh_nodes(self) -> int: ...
    @property
    def bvh_compressed(self) -> bool: ...
    def report(self) -> dict[str, Any]: ...
    def winding_numbers(
        self, points_m: NDArray[np.float64], threads: int = 0
    ) -> NDArray[np.float64]: ...
    def distance_to_surface(
        self, points_m: NDArray[np.float64], threads: int = 0
    ) -> NDArray[np.float64]: ...
    def closest_hit(
        self,
        origins_m: NDArray[np.float64],
        directions: NDArray[np.float64],
        t_max: float = ...,
        threads: int = 0,
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]: ...
    def patch_index(
        self, patch_size_m: float, triangles: NDArray[np.int64], points_m: NDArray[np.float64]
    ) -> NDArray[np.int64]: ...

@final
class Acoustics:
    def __new__(
        cls,
        absorption: NDArray[np.float64],
        scattering: NDArray[np.float64],
        wall_model: str = "random-incidence",
        by_angle: Mapping[int, NDArray[np.float64]] | None = None,
        grazing: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                       NDArray[np.float64], NDArray[np.float64]] | None = None,
    ) -> Acoustics: ...
    @property
    def n_bands(self) -> int: ...
    @property
    def wall_model(self) -> str: ...
    def kept_constant(self) -> list[tuple[int, int]]: ...

@final
class Directivity:
    @staticmethod
    def omni() -> Directivity: ...
    @staticmethod
    def cone(axis: Sequence[float], half_angle_deg: float) -> Directivity: ...
    @staticmethod
    def pattern(
        gains: NDArray[np.float64], forward: Sequence[float], up: Sequence[float]
    ) -> Directivity: ...
    def gains(self, directions: NDArray[np.float64], n_bands: int) -> NDArray[np.float64]: ...
    @property
    def kind(self) -> str: ...

@final
class SoundSource:
    def __new__(
        cls, position_m: Sequence[float], power_w: float, directivity: Directivity | None = None
    ) -> SoundSource: ...

@final
class ReceiverPattern:
    @staticmethod
    def omni() -> ReceiverPattern: ...
    @staticmethod
    def first_order(a: float, axis: Sequence[float], power: float = 2.0) -> ReceiverPattern: ...
    @staticmethod
    def measured(
        gains: NDArray[np.float64], forward: Sequence[float], up: Sequence[float]
    ) -> ReceiverPattern: ...
    def gains(self, directions: NDArray[np.float64], n_bands: int) -> NDArray[np.float64]: ...

@final
class Receivers:
    def __new__(
        cls,
        positions_m: NDArray[np.float64],
        radius_m: float,
        patterns: Sequence[ReceiverPattern] | None = None,
    ) -> Receivers: ...
    @property
    def count(self) -> int: ...

@final
class SoundSettings:
    def __new__(
        cls,
        *,
        rays: int,
        first_ray: int,
        end_ray: int,
        seed: int,
        threads: int,
        estimator: str,
        speed_of_sound_m_s: float,
        air_attenuation_per_m: Sequence[float],
        energy_drop_db: float,
        max_time_s: float,
        sample_rate_hz: float,
        early_s: float,
        late_bin_s: float,
        azimuth_bands: int,
        elevation_bands: int,
        max_field_bytes: int,
        keep_counts: bool = False,
        first_receiver: int = 0,
        only_source: int | None = None,
        nee_receivers: int = 8,
        quantum: float | None = None,
    ) -> SoundSettings: ...

def sound_quantum(sources: Sequence[SoundSource], receivers: Receivers) -> float: ...

def trace_sound(
    geometry: Geometry,
    acoustics: Acoustics,
    sources: Sequence[SoundSource],
    receivers: Receivers,
    settings: SoundSettings,
    progress: _Progress | None = None,
    early: EarlySettings | None = None,
    cover_early: bool = True,
    bake_receivers: Receivers | None = None,
) -> dict[str, Any]: ...

@final
class WaveSettings:
    """How to run the wave solver (FDTD): grid from max_frequency_hz, length duration_s."""

    def __new__(
        cls,
        *,
        max_frequency_hz: float,
        duration_s: float,
        points_per_wavelength: float = 10.0,
        courant: float = ...,
        speed_of_sound_m_s: float = 343.0,
        air_density_kg_m3: float = 1.2,
        absorption_kind: str = "random",
        threads: int = 0,
        memory_limit_bytes: int = ...,
    ) -> WaveSettings: ...
    @property
    def spacing_m(self) -> float: ...
    @property
    def sample_rate_hz(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def memory_limit_bytes(self) -> int: ...
    def memory_estimate(
        self, geometry: Geometry, n_receivers: int, band_centres_hz: Sequence[float],
        absorption: NDArray[np.float64] | None = None,
        wells: Mapping[int, tuple[Sequence[float], float]] | None = None,
    ) -> dict[str, int]: ...
    def max_frequency_within(
        self, geometry: Geometry, n_receivers: int, band_centres_hz: Sequence[float],
        budget_bytes: int
    ) -> float | None: ...

def simulate_waves(
    geometry: Geometry,
    absorption: NDArray[np.float64],
    band_centres_hz: Sequence[float],
    sources_m: NDArray[np.float64],
    receivers_m: NDArray[np.float64],
    settings: WaveSettings,
    binning: SoundSettings | None = None,
    progress: _Progress | None = None,
    without_direct: bool = False,
    term_positions_m: NDArray[np.float64] | None = None,
    term_signals_m3_s2: NDArray[np.float64] | None = None,
    pulse_delay_s: float = 0.0,
    energy_bands: int | None = None,
    wells: Mapping[int, tuple[Sequence[float], float]] | None = None,
) -> dict[str, Any]: ...

@final
class EarlySettings:
    """Exact early sound: image sources, edge diffraction (BTM), level of detail."""

    def __new__(
        cls,
        *,
        max_order: int,
        max_time_s: float,
        speed_of_sound_m_s: float,
        air_attenuation_per_m: Sequence[float],
        band_centres_hz: Sequence[float],
        bands_per_octave: float,
        diffraction: bool,
        level_of_detail: bool,
        threads: int,
        diffraction_piece_m: float = 0.25,
        plane_tolerance_m: float = 1e-3,
        connect_diffuse: bool = True,
    ) -> EarlySettings: ...
    @property
    def max_order(self) -> int: ...
    @property
    def max_time_s(self) -> float: ...
    @property
    def connect_diffuse(self) -> bool: ...

def early_arrivals(
    geometry: Geometry,
    acoustics: Acoustics,
    sources: Sequence[SoundSource],
    receivers: Receivers,
    early: EarlySettings,
    settings: SoundSettings,
) -> dict[str, Any]: ...

@final
class Optics:
    def __new__(
        cls, rho: NDArray[np.float64], specular: NDArray[np.float64], roughness: NDArray[np.float64]
    ) -> Optics: ...

@final
class Emitters:
    def __new__(cls, triangles_m: NDArray[np.float64], flux_w: NDArray[np.float64]) -> Emitters: ...
    @property
    def count(self) -> int: ...

@final
class LightSettings:
    def __new__(
        cls,
        *,
        particles: int,
        first_ray: int,
        end_ray: int,
        seed: int,
        threads: int,
        patch_size_m: float,
        max_bounces: int = 10000,
    ) -> LightSettings: ...

@final
class Lighting:
    def __new__(
        cls,
        *,
        sources: dict[str, Any] | None = None,
        transmittance: NDArray[np.float64] | None = None,
        work_plane: dict[str, Any] | None = None,
    ) -> Lighting: ...

def trace_light(
    geometry: Geometry,
    optics: Optics,
    emitters: Emitters,
    settings: LightSettings,
    progress: _Progress | None = None,
    lighting: Lighting | None = None,
) -> dict[str, Any]: ...

@final
class Convolver:
    def __new__(cls, block: int, partitions: int, fft_size: int) -> Convolver: ...
    @property
    def block(self) -> int: ...
    @property
    def fft_size(self) -> int: ...
    @property
    def partitions(self) -> int: ...
    @property
    def bins(self) -> int: ...
    def push(self, x: NDArray[np.float32]) -> None: ...
    def apply(self, filters: NDArray[np.float32]) -> NDArray[np.float32]: ...
    def inverse(self, spectra: NDArray[np.float32]) -> NDArray[np.float32]: ...
    def output(self, filters: NDArray[np.float32]) -> NDArray[np.float32]: ...

def partition(
    filters: NDArray[np.float32], block: int, fft_size: int, partitions: int
) -> NDArray[np.float32]: ...
def fold(filters: NDArray[np.float32], mix: NDArray[np.float32]) -> NDArray[np.float32]: ...
