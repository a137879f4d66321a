"""Settings of a sound bake that are not part of the scene: how many rays, which estimator,
how directions and time are binned. One dataclass with defaults and ``validate()``.
"""

from __future__ import annotations

from dataclasses import dataclass

from sonolux.errors import SonoluxError

ESTIMATORS = ("paper", "rain")


@dataclass(frozen=True)
class SoundOptions:
    """How to bake the sound field.

    rays: rays per source, or "auto" (see :func:`sonolux.sound.bake.auto_rays`).
    estimator: "paper" (sphere receivers, the method of Pope and Chalmers; the default) or
        "rain" (exact direct sound, and every diffuse reflection sent to every receiver at once).
        The default is measured (benchmarks/sound.py): on the paper-medium grid, "paper" brings
        T30 of all 55 receivers × 6 bands within 2% of a reference in 48 s, "rain" had not after
        30 s (extrapolated: about 2600 s), because rain costs one deposit per receiver per
        reflection and, with scattering 0.1, most energy still reaches the spheres specularly.
        "rain" pays off with few receivers and diffuse surfaces.
    azimuth_bands: number of azimuth sectors, the first centred on 0° (+x, front).
    elevation_bands: 1 (horizontal only, as the paper) or more bands of equal solid angle
        (3 = below / level / above).
    early_s: length of the part kept at one-sample resolution (the paper's filters: 80 ms).
    late_bin_s: width of the time bins after it.
    max_time_s: length of the responses; None = from the scene (its max_time_s, else 1.5 × the
        longest Sabine T60 plus the time to cross the room).
    ray_range: (first, end) to trace only part of the bake (it merges exactly with the rest).
    air_absorption: False turns the air's absorption off (for comparisons with theory that
        leaves it out); the scene's air still sets the speed of sound.
    max_field_bytes: the most memory the field may take (the engine estimates it before it
        allocates and refuses a larger one); None = half of this machine's memory.
    """

    rays: int | str = "auto"
    estimator: str = "paper"
    azimuth_bands: int = 8
    elevation_bands: int = 1
    early_s: float = 0.08
    late_bin_s: float = 0.001
    max_time_s: float | None = None
    ray_range: tuple[int, int] | None = None
    air_absorption: bool = True
    max_field_bytes: int | None = None

    def validate(self) -> SoundOptions:
        def bad(field: str, value: object, allowed: str) -> SonoluxError:
            return SonoluxError(f"sound option {field} = {value!r} is not allowed: {allowed}")

        if self.rays != "auto" and not (isinstance(self.rays, int) and self.rays >= 1):
            raise bad("rays", self.rays, 'a whole number ≥ 1, or "auto"')
        if self.estimator not in ESTIMATORS:
            raise bad("estimator", self.estimator, " or ".join(ESTIMATORS))
        if not (isinstance(self.azimuth_bands, int) and 1 <= self.azimuth_bands <= 360):
            raise bad("azimuth_bands", self.azimuth_bands, "a whole number from 1 to 360")
        if not (isinstance(self.elevation_bands, int) and 1 <= self.elevation_bands <= 90):
            raise bad("elevation_bands", self.elevation_bands, "a whole number from 1 to 90")
        if not (0.0 <= self.early_s <= 1.0):
            raise bad("early_s", self.early_s, "a time from 0 to 1 s")
        if not (1e-5 <= self.late_bin_s <= 0.1):
            raise bad("late_bin_s", self.late_bin_s, "a width from 10 µs to 0.1 s")
        if self.max_time_s is not None and not (0.0 < self.max_time_s <= 120.0):
            raise bad("max_time_s", self.max_time_s, "a time in (0, 120] s")
        if self.ray_range is not None:
            a, b = self.ray_range
            if not (0 <= a < b):
                raise bad("ray_range", self.ray_range, "first < end, both ≥ 0")
        if self.max_field_bytes is not None and not (
                isinstance(self.max_field_bytes, int) and self.max_field_bytes >= 1):
            raise bad("max_field_bytes", self.max_field_bytes, "a whole number of bytes ≥ 1")
        return self
