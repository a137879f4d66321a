"""The sound field: per receiver, per direction, per band, the energy over time.

Axes and units (the same in memory, from the engine and in the file, see
:mod:`sonolux.fieldfile` and ``docs/fieldfile.md``):

- ``energy``: float32[receiver, direction, band, time], J/m² per time bin (a bin's total).
- ``counts`` (ray-range bakes only): uint64[receiver, direction, band, time], the exact
  fixed-point sums: energy = counts × quantum.
- ``theory``: what theory expects of the baked room (volume, area, Sabine and Eyring T60 per
  band: :func:`sonolux.scene.summary.theory`), written by the bake; None in files of format 1.
- ``bin_start_s``, ``bin_width_s``: float64[time]; one-sample bins for the first ``early_bins``
  (exact arrival times of early reflections), then ``late_bin_s`` wide.
- directions: ``azimuth_bands`` sectors, the first centred on 0° (+x, "front"), counter-clockwise
  seen from above (the third of eight, centred on +90°, is "left"), times ``elevation_bands``
  bands of equal solid angle from below to above: index = elevation × azimuth_bands + azimuth.
- receivers: ``positions_m`` float64[receiver, 3]; a grid also has ``grid_index`` int[receiver, 2].
- sources: a bake of several sources keeps a field per source (``source_names``,
  :meth:`SoundField.for_source`, :meth:`SoundField.mixed`); ``energy`` is then their sum, made
  one receiver at a time, and ``per_source`` the sources' fields one after the other along the
  receiver axis, [source × receiver, direction, band, time] (source k's receivers are rows
  k × n_receivers … (k + 1) × n_receivers - 1; so are ``counts`` and the ``receiver`` of
  ``early``). A field of one source, or of a file from before, has ``per_source`` None.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from sonolux.acoustics.bands import BandSet, band_set_of
from sonolux.errors import SonoluxError, check_number
from sonolux.limits import MAX_SEED
from sonolux.sound.compact import CompactArray, add_counts, energy_of, reduced
from sonolux.sound.lazy import SourceMix

EIGHT_NAMES = ("front", "front-left", "left", "back-left", "back", "back-right", "right",
               "front-right")


def direction_names(n_azimuth: int, n_elevation: int) -> list[str]:
    """Names of the direction bins in index order (e.g. "front", "left@above")."""
    if n_azimuth == 8:
        az = list(EIGHT_NAMES)
    else:
        az = [f"az{round(360 * k / n_azimuth):g}" for k in range(n_azimuth)]
    if n_elevation == 1:
        return az
    el = ["below", "level", "above"] if n_elevation == 3 else [f"el{k}" for k in range(n_elevation)]
    return [f"{a}@{e}" for e in el for a in az]


def add_arrivals(particles: np.ndarray, arrivals: dict[str, np.ndarray]) -> np.ndarray:
    """float32[receiver, direction, band, time]: the particles' field plus every arrival's
    energy in its (receiver, direction, time) bin. Each touched cell is summed in float64, the
    arrivals in their order, then rounded once (the same bits every time); the field is copied
    once, never widened. Arrivals past the field's end (time_bin −1) are left out. A compact
    field (:class:`CompactArray`) gets the same values in its own layout."""
    if isinstance(particles, CompactArray):
        keep = arrivals["time_bin"] >= 0
        return particles.add_sparse(arrivals["receiver"][keep], arrivals["direction_bin"][keep],
                                    arrivals["energy"][keep], arrivals["time_bin"][keep])
    out = np.array(particles, dtype=np.float32, order="C", copy=True)
    keep = arrivals["time_bin"] >= 0
    n_bands = out.shape[2]
    r, d, t = (arrivals[k][keep].astype(np.int64) for k in ("receiver", "direction_bin", "time_bin"))
    bands = np.arange(n_bands, dtype=np.int64)
    cells = np.ravel_multi_index((np.repeat(r, n_bands), np.repeat(d, n_bands),
                                  np.tile(bands, r.size), np.repeat(t, n_bands)), out.shape)
    unique, slot = np.unique(cells, return_inverse=True)
    sums = np.zeros(unique.size, np.float64)
    np.add.at(sums, slot, arrivals["energy"][keep].astype(np.float64).reshape(-1))
    flat = out.reshape(-1)
    flat[unique] = (flat[unique].astype(np.float64) + sums).astype(np.float32)
    return out


@dataclass
class SoundField:
    energy: np.ndarray
    bin_start_s: np.ndarray
    bin_width_s: np.ndarray
    bands_hz: np.ndarray
    positions_m: np.ndarray
    radius_m: float
    grid_index: np.ndarray | None
    grid_spacing_m: float | None
    source_positions_m: np.ndarray
    source_powers_w: np.ndarray
    settings: dict[str, Any]
    stats: dict[str, Any]
    scene_name: str = ""
    scene_origin: str = ""
    counts: np.ndarray | None = field(default=None, repr=False)
    quantum: float = 0.0
    path: str | None = None
    theory: dict[str, Any] | None = None
    #: The exact early arrivals of a hybrid bake (:mod:`sonolux.sound.early`), already added to
    #: ``energy``; None for particles only, and in a ray range that does not start at ray 0 (the
    #: arrivals are computed once a bake, by that range, and join the others when they merge).
    early: dict[str, np.ndarray] | None = field(default=None, repr=False)
    #: The wave part of a hybrid bake (:mod:`sonolux.sound.waves`): ``pressure``
    #: float32[receiver, time] below the crossover at ``sample_rate_hz``, ``crossover_hz``,
    #: ``wave_bands`` (bands [0, wave_bands) of ``energy`` came from the waves),
    #: ``max_frequency_hz``, ``schroeder_hz``; None for rays only.
    waves: dict[str, Any] | None = field(default=None, repr=False)
    #: A bake of several sources: each source's energy, stacked along the receiver axis
    #: ([source × receiver, direction, band, time], dense or compact); None for one source.
    per_source: Any = field(default=None, repr=False)

    # --- shape -------------------------------------------------------------------------------
    @property
    def n_receivers(self) -> int:
        return int(self.energy.shape[0])

    @property
    def sample_rate_hz(self) -> int:
        return int(self.settings["sample_rate_hz"])

    @property
    def band_set(self) -> BandSet | None:
        """The bands as IEC 61260-1 octaves or thirds: the kind the bake recorded (files from
        before third-octaves hold octaves), or None when ``bands_hz`` is no such run (a
        synthetic field of arbitrary centres)."""
        try:
            return band_set_of(self.bands_hz, self.settings.get("bands"))
        except ValueError:
            return None

    @property
    def synthesis_bands_hz(self) -> np.ndarray:
        """float64[band]: the centres the synthesis filter bank is built on, the exact mid-band
        frequencies (so that its crossovers, at the geometric means of neighbouring centres,
        are the IEC 61260-1 band edges), or ``bands_hz`` for arbitrary centres."""
        bands = self.band_set
        return np.asarray(self.bands_hz, float) if bands is None else bands.exact_hz

    @property
    def azimuth_bands(self) -> int:
        return int(self.settings["azimuth_bands"])

    @property
    def elevation_bands(self) -> int:
        return int(self.settings["elevation_bands"])

    @property
    def direction_names(self) -> list[str]:
        return direction_names(self.azimuth_bands, self.elevation_bands)

    @property
    def azimuth_centres_deg(self) -> np.ndarray:
        return 360.0 * np.arange(self.azimuth_bands) / self.azimuth_bands

    @property
    def compact(self) -> bool:
        """Whether the energy is held compactly (:mod:`sonolux.sound.compact`)."""
        return isinstance(self.energy, CompactArray)

    @property
    def bytes_per_receiver(self) -> int:
        """Bytes of energy held per receiver (in memory; the file adds gzip)."""
        if not self.n_receivers:
            return 0
        return int(self.energy.nbytes) // self.n_receivers

    # --- lookups -----------------------------------------------------------------------------
    def cell_at(self, x: float, y: float, z: float | None = None) -> int:
        """The receiver whose cell holds the position: the nearest receiver in plan (in 3D when
        z is given). A position farther than one cell (or 2 radii for listed points) from every
        receiver is outside the field: an error names the nearest one."""
        p = np.array([check_number("x", x), check_number("y", y)]
                     + ([] if z is None else [check_number("z", z)]), float)
        d = np.linalg.norm(self.positions_m[:, : p.size] - p, axis=1)
        k = int(np.argmin(d))
        reach = (self.grid_spacing_m or 2 * self.radius_m) * (np.sqrt(2) / 2 + 1e-9)
        if d[k] > reach:
            near = ", ".join(f"{v:g}" for v in self.positions_m[k])
            raise SonoluxError(f"position ({x:g}, {y:g}) is outside the sound field: the nearest "
                               f"receiver, #{k} at ({near}) m, is {d[k]:.2f} m away")
        return k

    def direction_index(self, direction: str | int) -> int:
        names = self.direction_names
        if isinstance(direction, (int, np.integer)):
            if 0 <= direction < len(names):
                return int(direction)
        elif direction in names:
            return names.index(direction)
        raise SonoluxError(f"direction {direction!r} is not one of: {', '.join(names)}")

    def receiver_index(self, receiver: int) -> int:
        """``receiver`` checked: a whole number from 0 to n_receivers - 1."""
        return check_number("receiver", receiver, 0, self.n_receivers - 1, integer=True)

    def receiver_energy(self, receiver: int) -> np.ndarray:
        """float32[direction, band, time] of one receiver, J/m² per bin."""
        return self.energy[receiver]

    def omni_energy(self, receiver: int) -> np.ndarray:
        """float64[band, time]: the energy from all directions."""
        return self.energy[receiver].sum(axis=0, dtype=np.float64)

    def impulse_response(self, receiver: int, direction: str | int | None = None,
                         seed: int = 0) -> np.ndarray:
        """Pressure impulse response (float64[samples]) of one receiver and direction (None:
        all directions). See :func:`sonolux.sound.synthesis.pressure_ir`; in a hybrid field the
        waves' own pressure below the crossover (:func:`sonolux.sound.waves.joined_response`)."""
        from sonolux.sound.synthesis import pressure_ir
        from sonolux.sound.waves import joined_response, ray_bands

        receiver = self.receiver_index(receiver)
        seed = check_number("seed", seed, 0, MAX_SEED, integer=True)
        d = None if direction is None else self.direction_index(direction)
        e = (self.omni_energy(receiver) if d is None
             else self.energy[receiver, d].astype(np.float64))
        ir = pressure_ir(ray_bands(self, e), self.bin_start_s, self.bin_width_s,
                         self.synthesis_bands_hz,
                         self.sample_rate_hz, self.settings["volume_m3"],
                         self.settings["speed_of_sound_m_s"], seed=seed)
        return joined_response(self, receiver, d, ir)

    def paper_filters(self, receiver: int, length: int = 3840) -> np.ndarray:
        """The paper's filters: float64[direction, band, length] energy taps at the sample rate."""
        from sonolux.memory import check_memory
        from sonolux.sound.synthesis import paper_filters

        receiver = self.receiver_index(receiver)
        length = check_number("length", length, 0, 10_000_000, integer=True, unit="taps")
        check_memory(2.0 * 8 * self.energy.shape[1] * self.energy.shape[2] * length,
                     "the paper's filters", f"length = {length:,} taps")
        return np.stack([paper_filters(self.energy[receiver, d].astype(np.float64),
                                       self.bin_start_s, self.bin_width_s, self.sample_rate_hz,
                                       length) for d in range(self.energy.shape[1])])

    # --- sources -----------------------------------------------------------------------------
    @property
    def source_names(self) -> list[str]:
        """The names of the sources whose fields this one holds, in order: the scene's source
        names, or ["all"] for a field of every source summed (files from before fields per
        source, a mix made by :meth:`mixed` is ["mix"])."""
        names = self.settings.get("source_names")
        return [str(n) for n in names] if names else ["all"]

    def source_index(self, source: str | int) -> int:
        """The index of a source given by name or index; an unknown one is an error that
        names the sources there are."""
        names = self.source_names
        if isinstance(source, (int, np.integer)) and not isinstance(source, bool):
            if 0 <= source < len(names):
                return int(source)
        elif isinstance(source, str):
            if source in names:
                return names.index(source)
            if source.isdigit() and int(source) < len(names) and source not in names:
                return int(source)
        raise SonoluxError(f"source {source!r} is not in this field: its sources are "
                           + ", ".join(f"{k} = {n!r}" for k, n in enumerate(names)))

    def source_energies(self) -> list[Any]:
        """Each source's energy [receiver, direction, band, time], in ``source_names`` order."""
        if self.per_source is None:
            return [self.energy]
        return [source_rows(self.per_source, k, self.n_receivers) for k in range(len(self.source_names))]

    def for_source(self, source: str | int) -> SoundField:
        """The field of one source alone (by name or index): bit for bit what a bake of that
        source alone (``SoundOptions(sources=[name])``) gives."""
        k = self.source_index(source)
        if self.per_source is None:
            return self
        n = self.n_receivers
        early = None
        if self.early is not None:
            keep = np.asarray(self.early["source"]) == k
            early = {key: np.asarray(v)[keep] for key, v in self.early.items()}
            early["receiver"] = early["receiver"] - k * n
            early["source"] = np.zeros_like(early["source"])  # its field's one source
        settings = dict(self.settings, source_names=[self.source_names[k]])
        for key in ("source_directivity", "source_axis_gain"):  # per source, as source_names
            per = self.settings.get(key)
            if isinstance(per, list) and len(per) == len(self.source_names):
                settings[key] = [per[k]]
        return SoundField(**{**self.__dict__, "energy": source_rows(self.per_source, k, self.n_receivers),
                             "counts": None if self.counts is None
                             else source_rows(self.counts, k, n),
                             "per_source": None, "early": early, "settings": settings,
                             "source_positions_m": self.source_positions_m[k:k + 1],
                             "source_powers_w": self.source_powers_w[k:k + 1], "path": None})

    def mixed(self, gains: Any) -> SoundField:
        """The field of the sources played together, each scaled by an energy gain (a power
        ratio: 1 as baked, 0.5 for -3 dB, 0 off): ``gains`` is one number per source in
        ``source_names`` order, or a mapping {name: gain} (sources left out: 0). The result
        has one source, "mix"; its energy is made one receiver at a time."""
        names = self.source_names
        if isinstance(gains, dict):
            values = [0.0] * len(names)
            for name, g in gains.items():
                values[self.source_index(name)] = g
        else:
            values = list(np.atleast_1d(np.asarray(gains, dtype=object)))
            if len(values) != len(names):
                raise SonoluxError(f"gains: {len(values)} given for {len(names)} sources "
                                   f"({', '.join(names)})")
        g = [check_number(f"gain of source {names[k]!r}", v, 0.0, 1e12)
             for k, v in enumerate(values)]
        settings = dict(self.settings, source_names=["mix"],
                        mix={n: float(v) for n, v in zip(names, g)})
        powers = self.source_powers_w * np.asarray(g) if self.source_powers_w.size == len(g) \
            else self.source_powers_w
        return SoundField(**{**self.__dict__, "energy": SourceMix(self.source_energies(), g),
                             "counts": None, "per_source": None, "early": None,
                             "settings": settings, "source_powers_w": powers, "path": None})

    # --- ranges ------------------------------------------------------------------------------
    def merge(self, other: SoundField) -> SoundField:
        """Adds the field of another ray range of the same bake: exact (integer counts), so
        the ranges of a bake merge to the same bits as the bake done at once."""
        if self.counts is None or other.counts is None:
            raise SonoluxError("only fields baked with a ray range carry the counts to merge")
        same = ("rays", "seed", "estimator", "nee_receivers", "max_time_s", "early_bins",
                "late_bin_s", "early")
        if self.quantum != other.quantum or any(self.settings.get(k) != other.settings.get(k) for k in same) \
                or self.counts.shape != other.counts.shape:
            raise SonoluxError("these two fields come from different bakes and cannot be merged")
        counts = add_counts(self.counts, other.counts)
        energy = energy_of(counts, self.quantum)
        # A hybrid bake's arrivals live in the range that starts at ray 0 only (computed once).
        early = self.early if self.early is not None else other.early
        if self.early is not None and other.early is not None:
            raise SonoluxError("both fields hold the bake's early arrivals (each starts at ray 0): "
                               "merging them would count those rays twice")
        mine = self.settings.get("ray_ranges", [self.settings["ray_range"]])
        theirs = other.settings.get("ray_ranges", [other.settings["ray_range"]])
        for a0, a1 in mine:
            for b0, b1 in theirs:
                if max(a0, b0) < min(a1, b1):
                    raise SonoluxError(f"ray ranges {a0}..{a1} and {b0}..{b1} overlap: merging "
                                       "them would count those rays twice")
        ranges = sorted([list(r) for r in mine + theirs])
        summed = ("rays", "segments", "surface_hits", "escaped_rays", "deposits")
        stats = {k: (np.add(v, other.stats[k]) if k.startswith("energy_") or k in summed else v)
                 for k, v in self.stats.items()}
        if "early" not in stats and "early" in other.stats:
            stats["early"] = other.stats["early"]
        settings = dict(self.settings, ray_range=[ranges[0][0], max(r[1] for r in ranges)],
                        ray_ranges=ranges)
        covered = 0
        for a, b in ranges:
            covered = b if a <= covered else covered
        if covered >= int(self.settings["rays"]):  # complete: as the bake done at once
            energy = reduced(energy, self.settings)
        if early is not None:
            energy = add_arrivals(energy, early)
        # A hybrid's waves live in the range from ray 0 only (computed once), joined when whole.
        from sonolux.sound.waves import is_wave_part, with_wave_part

        if is_wave_part(self.waves) and is_wave_part(other.waves):
            raise SonoluxError("both fields hold the bake's waves (each starts at ray 0): "
                               "merging them would count those rays twice")
        waves = self.waves if is_wave_part(self.waves) else other.waves
        if self.settings.get("with_waves") or other.settings.get("with_waves"):
            settings["with_waves"] = True
        merged = with_source_energy(
            SoundField(**{**self.__dict__, "counts": counts, "stats": stats,
                          "settings": settings, "path": None, "early": early, "waves": waves}),
            energy)
        if covered >= int(self.settings["rays"]) and settings.get("with_waves"):
            if not is_wave_part(waves):
                raise SonoluxError("these ranges make a whole hybrid bake, but neither holds its "
                                   "waves (the range from ray 0 computes them)")
            merged = replace(with_wave_part(merged, waves), counts=None)
        return merged


def with_source_energy(field: SoundField, stacked: Any) -> SoundField:
    """``field`` with its energy from ``stacked``: the sources' fields one after the other
    along the receiver axis (one source: the field's energy itself). Several sources keep it as
    ``per_source`` and show their sum as ``energy``."""
    n_sources = len(field.settings.get("source_names") or ["all"])
    if n_sources == 1:
        return replace(field, energy=stacked, per_source=None)
    n = stacked.shape[0] // n_sources
    if n * n_sources != stacked.shape[0]:
        raise SonoluxError(f"a field of {n_sources} sources has {stacked.shape[0]} rows, not a "
                           "multiple of them")
    parts = [source_rows(stacked, k, n) for k in range(n_sources)]
    return replace(field, energy=SourceMix(parts, [1.0] * n_sources), per_source=stacked)


def source_rows(array: Any, k: int, n_receivers: int) -> Any:
    """Source k's rows of an array stacked per source (dense: a view)."""
    n = n_receivers
    if isinstance(array, CompactArray):
        return array.select(np.arange(k * n, (k + 1) * n))
    return array[k * n:(k + 1) * n]
