"""Settings of a sound bake that are not part of the scene: how many rays, which estimator,
how directions and time are binned. One dataclass with defaults and ``validate()``.
"""

from __future__ import annotations

from dataclasses import dataclass

from sonolux.errors import SettingError, SonoluxError, check_number, format_value, number_allowed
from sonolux.limits import MAX_RAYS, MAX_TIME_S
from sonolux.scene.schema import WALL_MODELS

ESTIMATORS = ("paper", "rain", "nee", "auto")
#: The most receivers one diffuse reflection of the "nee" estimator connects to (the core's bound).
MAX_NEE_RECEIVERS = 256
STORAGES = ("compact", "full")


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
        "rain" pays off with few receivers and diffuse surfaces. "nee": rain through
        ``nee_receivers`` receivers a diffuse reflection, drawn by importance and weighted by
        1/(M p) (unbiased; crates/sonolux-core/src/sound/nee.rs): rain's smooth diffuse part at a
        cost that does not grow with the receivers. "auto": a pilot of each (the first round of
        its progressive bake) and the one whose counted work × (standard error / target)² is
        smallest: the same choice on any machine; the chosen pilot is kept as round 1
        (:func:`sonolux.sound.progressive.choose`).
    nee_receivers: M, the receivers each diffuse reflection connects to with "nee" (1–256).
    azimuth_bands: number of azimuth sectors, the first centred on 0° (+x, front).
    elevation_bands: 1 (horizontal only, as the paper) or more bands of equal solid angle
        (3 = below / level / above).
    early_s: length of the part kept at one-sample resolution (the paper's filters: 80 ms).
    late_bin_s: width of the time bins after it.
    max_time_s: length of the responses; None = from the scene (its max_time_s, else 1.5 × the
        longest Sabine or Fitzroy T60 plus the time to cross the room: sound.bake.auto_max_time).
    ray_range: (first, end) to trace only part of the bake (it merges exactly with the rest).
    air_absorption: False turns the air's absorption off (for comparisons with theory that
        leaves it out); the scene's air still sets the speed of sound.
    max_field_bytes: the most memory the engine's accumulator may take at once (it estimates
        it before it allocates and refuses a larger one); None = the memory budget. It
        is also the wave solver's memory limit.
    storage: "compact" (the default: the early part's non-zero one-sample cells, up to the
        later of ``early_s`` and the mixing time after the farthest receiver's direct sound,
        and the late part stored at ``compact_late_bin_s``, shown at ``late_bin_s``:
        :mod:`sonolux.sound.compact`) or "full" (every cell dense, as given).
    compact_late_bin_s: the stored late bins of a compact field, a whole multiple of
        ``late_bin_s``; "auto": the shortest Sabine T60 of the bands (air included) / 100,
        rounded down to a multiple of ``late_bin_s`` (a decay of 0.6 dB a bin), at most 50 ms.
        It keeps every ISO 3382-1 parameter within a tenth of its JND of the full field's
        (measured: tests/sound/test_compact.py, docs/fieldfile.md).
    compact_arrivals: the strongest early arrivals (direction, sample) a receiver of a compact
        field keeps exact; the rest of its early part is an envelope of
        ``compact_envelope_s`` bins.
    memory_bytes: the bake's memory budget: receivers are traced in tiles small enough to keep
        the whole bake within it (:mod:`sonolux.sound.budget`); None = 80% of the memory this
        machine has available (:func:`sonolux.memory.budget_bytes`).
    waves: bake the bands below a crossover with the wave solver (FDTD), the rest with the
        tracer, joined into one field (:mod:`sonolux.sound.waves`); None = as the scene's
        ``[waves]`` table says (off without one).
    crossover_hz: where the waves hand over to the rays (snapped to the nearest band edge);
        None = the scene's, else automatic, from the room's Schroeder frequency and the grid's
        budget.
    wave_time_budget_s: the wave run time above which the bake warns (predicted from the rate
        measured on this machine; it does not move the crossover, which depends on the scene
        alone); None = the scene's, else 600 s.
    sources: the names of the scene's sources to bake (None: all). Each source is traced
        alone and keeps its own field (docs/fieldfile.md); a bake of some of them gives each
        the bits it has in a bake of all.
    wall_model: how a surface's absorption depends on the angle of incidence,
        "random-incidence", "locally-reacting" or "locally-reacting-modes" (docs/walls.md);
        None = the scene's ``[settings] wall_model``, else "locally-reacting-modes" with
        waves (the wave solver's wall with the gaps' grazing modes in the rays, so that the
        hybrid has one wall model) and "random-incidence" without.
    """

    rays: int | str = "auto"
    estimator: str = "paper"
    nee_receivers: int = 8
    azimuth_bands: int = 8
    elevation_bands: int = 1
    early_s: float = 0.08
    late_bin_s: float = 0.001
    max_time_s: float | None = None
    ray_range: tuple[int, int] | None = None
    air_absorption: bool = True
    max_field_bytes: int | None = None
    storage: str = "compact"
    compact_late_bin_s: float | str = "auto"
    compact_arrivals: int = 128
    compact_envelope_s: float = 0.001
    memory_bytes: int | None = None
    waves: bool | None = None
    crossover_hz: float | None = None
    wave_time_budget_s: float | None = None
    sources: tuple[str, ...] | None = None
    wall_model: str | None = None

    def validate(self) -> SoundOptions:
        """Every option checked by :func:`sonolux.errors.check_number` (the test shared with
        the scene file and the command line): a :class:`SettingError` names the option."""
        def bad(field: str, value: object, allowed: str) -> SonoluxError:
            return SettingError(f"sound option {field} = {format_value(value)} is not allowed: "
                                f"{allowed}")

        if self.rays != "auto":
            check_number("sound option rays", self.rays, 1, MAX_RAYS, integer=True)
        if self.estimator not in ESTIMATORS:
            raise bad("estimator", self.estimator, " or ".join(ESTIMATORS))
        check_number("sound option nee_receivers", self.nee_receivers, 1, MAX_NEE_RECEIVERS,
                     integer=True)
        check_number("sound option azimuth_bands", self.azimuth_bands, 1, 360, integer=True)
        check_number("sound option elevation_bands", self.elevation_bands, 1, 90, integer=True)
        check_number("sound option early_s", self.early_s, 0.0, 1.0, unit="s")
        check_number("sound option late_bin_s", self.late_bin_s, 1e-5, 0.1, unit="s")
        check_number("sound option max_time_s", self.max_time_s, 0.0, MAX_TIME_S, lo_open=True,
                     none_ok=True, unit="s")
        if self.ray_range is not None:
            if not (isinstance(self.ray_range, (tuple, list)) and len(self.ray_range) == 2
                    and all(number_allowed(v, 0, MAX_RAYS, integer=True) for v in self.ray_range)
                    and self.ray_range[0] < self.ray_range[1]):
                raise bad("ray_range", self.ray_range, "(first, end) with 0 ≤ first < end")
        check_number("sound option max_field_bytes", self.max_field_bytes, 1, none_ok=True,
                     integer=True)
        if self.sources is not None and not (
                isinstance(self.sources, (tuple, list)) and self.sources
                and all(isinstance(n, str) and n for n in self.sources)
                and len(set(self.sources)) == len(self.sources)):
            raise bad("sources", self.sources, "a list of distinct source names of the scene")
        if self.storage not in STORAGES:
            raise bad("storage", self.storage, " or ".join(STORAGES))
        if self.compact_late_bin_s != "auto":
            check_number("sound option compact_late_bin_s", self.compact_late_bin_s, 1e-5, 1.0,
                         unit="s")
            split = self.compact_late_bin_s / self.late_bin_s  # type: ignore[operator]
            if abs(split - round(split)) > 1e-6 * split or round(split) < 1:
                raise bad("compact_late_bin_s", self.compact_late_bin_s,
                          f"'auto' or a whole multiple of late_bin_s = {self.late_bin_s:g} s")
        check_number("sound option compact_arrivals", self.compact_arrivals, 0, 1_000_000,
                     integer=True)
        check_number("sound option compact_envelope_s", self.compact_envelope_s, 1e-6, 0.1,
                     unit="s")
        check_number("sound option memory_bytes", self.memory_bytes, 1, none_ok=True,
                     integer=True, unit="bytes")
        if self.waves is not None and not isinstance(self.waves, bool):
            raise bad("waves", self.waves, "true, false or None (the scene's [waves])")
        check_number("sound option crossover_hz", self.crossover_hz, 10.0, 20_000.0,
                     none_ok=True, unit="Hz")
        check_number("sound option wave_time_budget_s", self.wave_time_budget_s, 0.0, 1e6,
                     lo_open=True, none_ok=True, unit="s")
        if self.wall_model is not None and self.wall_model not in WALL_MODELS:
            raise bad("wall_model", self.wall_model, " or ".join(WALL_MODELS) + " or None")
        if self.waves is False and self.crossover_hz is not None:
            raise bad("crossover_hz", self.crossover_hz, "only with waves = true")
        return self
