"""Waves below the crossover, rays above: the hybrid sound bake (``sonolux bake --waves``).

Below a few hundred hertz a room is modes and interference, which no particle tracer gives; the
core's wave solver (FDTD, ``docs/waves.md``) does. A hybrid bake runs both and joins them:

- **Crossover.** Schroeder's frequency f_S = 2000·√(T/V) (T the Eyring T60 of the scene's
  materials averaged over its bands up to 1 kHz, V the mesh's volume; Schroeder, "Die
  statistischen Parameter der Frequenzkurven von grossen Räumen", Acustica 4, 1954) marks
  where a room's modes overlap; the tracer is sound from about twice that. The grid allows
  f_grid = the largest maximum frequency whose run fits the memory budget (the bake's
  ``max_field_bytes``, else 4 GiB) and the grid budget (:data:`GRID_UPDATE_BUDGET` cell updates
  over the bake): numbers of the scene alone, so the crossover is the same on every machine.
  The time it will take is predicted from the rate measured on this machine by a short run on
  the chosen grid (:func:`measured_rate`), printed, and a warning when it is over the time
  budget. The crossover is the band edge (geometric mean
  of two neighbouring band centres) nearest max(2·f_S, the lowest edge) in log frequency, but
  not above f_grid/√2; or the edge nearest a crossover the user gives. Whole bands go to one
  side: **no band straddles the crossover**, since it always lies on a band edge. The grid is
  then made for f_max = crossover·√2, so the last wave band and its filter skirt lie where the
  scheme is accurate (10 points per wavelength: phase error ≤ 1.1%).
- **Energy field.** Bands below the crossover come from the waves (energy per band, direction
  and time bin in the tracer's own bins, air included: ``bands::direction_energies``), bands
  above from the tracer. Like the tracer's, a wave receiver is a sphere: its energy is the mean
  over seven points of it (:func:`ball_points`); its pressure is the centre's. Sources are
  incoherent in the tracer's field, so each source is its own wave run and the energies add,
  each times the source's power (the wave energies are per joule of source energy in each
  band, the tracer's convention: a free field gives P/(4πr²)).
- **Pressure.** The field keeps the waves' own pressure response below the crossover,
  ``waves["pressure"]`` float32[receiver, time] at the wave rate, time 0 at emission, in the
  synthesis' unit (pressure / √(ρc), √(W/m²): Σp²/fs is J/m²). It is the impulse response
  (the run divided by the source pulse's spectrum), summed over the sources with √power
  (coherently: every source plays the same signal), low-passed by H_L = the sum of the wave
  bands' weights of the synthesis' amplitude-complementary bank
  (:func:`sonolux.sound.synthesis.band_split_weights`: cos² from the last wave band's centre to
  the first ray band's) made power-complementary to the synthesis' 1 − H_L, G = √(H_L(2 − H_L))
  so that |G|² + |1 − H_L|² = 1: the waves and the synthesis' random phases are incoherent, and
  amplitude-complementary filters would lose up to 3 dB at the crossover (measured: 0.9 dB in
  the 250 Hz octave of a hybrid crossing at 354 Hz). Each band is damped by the air as
  exp(−m·c·t/2), and the whole high-passed at the
  energy field's lowest band edge (:func:`low_edge_gain`): a hybrid response holds nothing
  below the lowest band's lower edge (88 Hz for octaves from 125 Hz). A consumer's pressure
  response is G·(waves) + (1 − H_L)·(synthesis): the synthesis is given the ray bands only,
  whose weights sum to exactly 1 − H_L (:func:`joined_response`). Per direction, the wave
  pressure is weighted by √(the direction's share of the wave bands' energy in each time bin),
  so that the directions' energies add up to the omni response's.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import fft as sfft
from scipy import signal as ssignal

from sonolux import engine
from sonolux.errors import SettingError, SonoluxError
from sonolux.memory import budget_bytes, gb
from sonolux.progress import ProgressLine
from sonolux.sound.surfaces import flat_in_the_waves, wells_of
from sonolux.sound.synthesis import band_split_weights
from sonolux.sound.wave_spheres import BALL_POINTS, add_direct, ball_points, point_weights

#: Cell updates of the short run that measures the solver's rate on the scene's own grid before
#: the crossover is chosen (:func:`measured_rate`), at least :data:`PROBE_MIN_STEPS` steps:
#: about half a second here, long enough that a shared machine's scheduling hiccups of tens of
#: milliseconds do not decide the crossover.
PROBE_UPDATES = 3e8
PROBE_MIN_STEPS = 40
#: Frequencies where the pulse's spectrum is this far below its peak are left out of the
#: deconvolution (as ``bands::BandFilters::inverse_of`` does).
PULSE_FLOOR = 1e-6


@dataclass(frozen=True)
class Crossover:
    """Where the waves hand over to the rays, and why."""

    crossover_hz: float
    #: Bands [0, wave_bands) come from the waves.
    wave_bands: int
    #: The grid's maximum frequency (crossover·√2).
    max_frequency_hz: float
    schroeder_hz: float
    grid_limit_hz: float
    why: str
    #: The solver's rate measured on this machine on the chosen grid (cell updates/s): for the
    #: printed time only, the choice does not depend on it (nan when not measured).
    updates_per_s: float


def band_edges_hz(bands_hz: np.ndarray) -> np.ndarray:
    """float64[band - 1]: the edges between neighbouring bands (geometric means)."""
    b = np.asarray(bands_hz, float)
    return np.sqrt(b[:-1] * b[1:])


def schroeder_hz(theory: dict[str, Any]) -> float:
    """2000·√(T/V), T the mean Eyring T60 over the bands up to 1 kHz (all bands if none)."""
    bands = np.asarray(theory["bands_hz"], float)
    t60 = np.array([np.nan if t is None else t for t in theory["eyring_t60_s"]], float)
    pick = bands <= 1000.0 if np.any(bands <= 1000.0) else np.ones(bands.size, bool)
    t = float(np.nanmean(t60[pick])) if np.any(np.isfinite(t60[pick])) else 10.0
    return 2000.0 * math.sqrt(t / theory["volume_m3"])


def wave_settings(f_max_hz: float, duration_s: float, c: float, threads: int,
                  memory_limit_bytes: int) -> Any:
    return engine.WaveSettings(max_frequency_hz=float(f_max_hz), duration_s=float(duration_s),
                               speed_of_sound_m_s=float(c), threads=int(threads),
                               memory_limit_bytes=int(memory_limit_bytes))


def run_seconds(estimate: dict[str, int], updates_per_s: float) -> float:
    """The planned run time of an estimate: cells × steps at the measured rate (all threads)."""
    return estimate["cells"] * estimate["steps"] / updates_per_s


def measured_rate(scene: Any, absorption: np.ndarray, max_frequency_hz: float,
                  memory_limit_bytes: int) -> float:
    """Air-cell updates per second of the solver on this machine now, on the scene's own grid
    at ``max_frequency_hz`` with the scene's threads: a run of :data:`PROBE_UPDATES` updates
    (its setup, voxelisation and fits, is not timed). The machine's speed is not a constant:
    ``make bench`` measured 1.2-2.2 G/s per core by grid size here, and a shared machine gives
    a fraction of it; the automatic crossover's time budget is spent at the rate measured."""
    bands = np.asarray(scene.settings.bands_hz, float)
    c = scene.settings.speed_of_sound_m_s
    probe = wave_settings(max_frequency_hz, 1.0, c, scene.settings.threads, memory_limit_bytes)
    cells = engine.wave_memory_estimate(probe, scene.geometry, 1, bands)["cells"]
    steps = max(PROBE_MIN_STEPS, math.ceil(PROBE_UPDATES / max(cells, 1)))
    probe = wave_settings(max_frequency_hz, steps / probe.sample_rate_hz, c,
                          scene.settings.threads, memory_limit_bytes)
    at = np.asarray([scene.sources[0].position_m], float)
    out = engine.simulate_waves(scene.geometry, absorption, bands, at, at, probe)
    return float(out["stats"]["air_updates_per_s"]) * (
        out["stats"]["cells"] / max(out["stats"]["air_cells"], 1))


#: The automatic crossover's time budget when neither the options nor the scene give one, s.
DEFAULT_TIME_BUDGET_S = 600.0


def with_scene(scene: Any, options: Any) -> Any:
    """``options`` with its wave settings resolved against the scene's ``[waves]`` table
    (:mod:`sonolux.scene.waves`): what the options give wins, None takes the scene's. Without
    a table the options come back as they are (None: off, automatic crossover,
    :data:`DEFAULT_TIME_BUDGET_S`, which the bake reads as such), so that a checkpoint's
    settings are the same whichever entry resolved them."""
    from dataclasses import replace

    spec = getattr(scene, "waves", None)
    on = options.waves if options.waves is not None or spec is None else spec.enabled
    crossover = options.crossover_hz
    if crossover is None and on and spec is not None:
        crossover = spec.crossover_hz
    if crossover is not None and not on:
        raise SettingError(f"crossover_hz = {crossover:g} Hz is only allowed with waves "
                           "(--waves, waves=True, or [waves] enabled = true in the scene)")
    if spec is None:
        return options
    budget = options.wave_time_budget_s
    if budget is None:
        budget = spec.time_budget_s
    return replace(options, waves=on, crossover_hz=crossover, wave_time_budget_s=budget).validate()


def check_scene(scene: Any) -> None:
    """Refuses, before anything is baked, a scene the waves cannot take: fewer than two bands.
    Directional sources are clusters of monopoles fitted to their pattern per band
    (:mod:`sonolux.sound.wave_sources`)."""
    bands = np.asarray(scene.settings.bands_hz, float)
    if bands.size < 2:
        raise SettingError("waves need at least two bands (one below the crossover, one above): "
                           f"the scene has {bands.size}")


#: The automatic crossover's grid budget, in air-cell updates over the whole bake (cells × steps
#: × sources): 3·10¹¹, the default time budget of 600 s at 0.5 G updates/s, the rate the
#: solver keeps on one loaded core of the machine it was built on (docs/waves.md, "Performance":
#: 1.2-2.2 G/s per idle core). A number of the scene alone, so that the crossover, and with it
#: the bits of the hybrid, are the same on every machine; the time it will take there is
#: measured and printed, not used.
GRID_UPDATE_BUDGET = 3e11
#: The automatic crossover's memory budget when the bake gives none (``max_field_bytes``): the
#: core's default ``memory_limit_bytes`` (4 GiB), not what this machine has free (that would
#: make the crossover depend on the machine). A machine with less is refused by the core's own
#: estimate before the run, naming the largest frequency that fits.
GRID_MEMORY_BYTES = 4 << 30


def choose_crossover(scene: Any, duration_s: float, *, crossover_hz: float | None,
                     time_budget_s: float, memory_limit_bytes: int,
                     absorption: np.ndarray, update_budget: float = GRID_UPDATE_BUDGET,
                     measure: bool = True) -> Crossover:
    """The crossover of a hybrid bake of ``scene`` (see the module's doc); ``absorption``
    float64[material, band], the bake's. A function of the scene, ``crossover_hz``,
    ``memory_limit_bytes`` and ``update_budget`` only: the machine's speed, measured on the
    chosen grid (``measure``), gives the predicted time that is printed, and a warning in
    ``why`` when it is over ``time_budget_s`` (the crossover is not lowered for it)."""
    from sonolux.scene.summary import theory

    check_scene(scene)
    bands = np.asarray(scene.settings.bands_hz, float)
    edges = band_edges_hz(bands)
    f_s = schroeder_hz(theory(scene))
    c, threads = scene.settings.speed_of_sound_m_s, scene.settings.threads
    n_rec, n_src = BALL_POINTS * scene.receivers.count, len(scene.sources)

    def estimate(f_max: float) -> dict[str, int]:
        s = wave_settings(f_max, duration_s + 0.05, c, threads, memory_limit_bytes)
        return engine.wave_memory_estimate(s, scene.geometry, n_rec, bands)

    def updates(f_max: float) -> float:
        e = estimate(f_max)
        return float(e["cells"]) * e["steps"] * n_src

    probe = wave_settings(bands[0], duration_s + 0.05, c, threads, memory_limit_bytes)
    f_mem = engine.wave_max_frequency(probe, scene.geometry, n_rec, bands, memory_limit_bytes) or 0.0
    # Cell updates grow as f⁴ (cells f³, steps f): bisect the budget in log frequency.
    lo, hi = 1.0, max(f_mem, 2.0)
    if updates(hi) <= update_budget:
        f_work = hi
    else:
        while hi / lo > 1.01:
            mid = math.sqrt(lo * hi)
            lo, hi = (mid, hi) if updates(mid) <= update_budget else (lo, mid)
        f_work = lo
    f_grid = min(f_mem, f_work)
    limit = (f"memory, {memory_limit_bytes / 2**30:.3g} GiB" if f_mem <= f_work else
             f"the grid budget of {update_budget:.3g} cell updates")
    fits = edges[edges * math.sqrt(2) <= f_grid]
    if crossover_hz is None:
        target = max(2.0 * f_s, edges[0])
        if fits.size == 0:
            raise SettingError(f"waves: the grid allows up to {f_grid:.0f} Hz ({limit}), too little "
                               f"for a crossover at the lowest band edge {edges[0]:.0f} Hz (its grid "
                               f"needs {edges[0] * math.sqrt(2):.0f} Hz); give a larger memory "
                               "budget or bake without --waves")
        x = float(fits[np.argmin(np.abs(np.log(fits / target)))])
        why = (f"crossover {x:.0f} Hz: Schroeder frequency {f_s:.0f} Hz (2000·√(T/V)), "
               f"2·f_S = {2 * f_s:.0f} Hz, snapped to a band edge within the grid's limit of "
               f"{f_grid:.0f} Hz ({limit})")
    else:
        x = float(edges[np.argmin(np.abs(np.log(edges / crossover_hz)))])
        if x * math.sqrt(2) > f_mem:
            raise SettingError(f"waves crossover_hz = {crossover_hz:g} Hz (band edge {x:.0f} Hz) "
                               f"needs a grid up to {x * math.sqrt(2):.0f} Hz, but the memory budget "
                               f"allows {f_mem:.0f} Hz: the largest crossover that fits is "
                               + (f"{fits.max():.0f} Hz" if fits.size else "none"))
        why = (f"crossover {x:.0f} Hz: the band edge nearest the {crossover_hz:g} Hz asked "
               f"(Schroeder frequency {f_s:.0f} Hz)")
    f_max = x * math.sqrt(2)
    # The machine's speed: measured on the chosen grid, for the printed time only.
    rate = measured_rate(scene, absorption, f_max, memory_limit_bytes) if measure else math.nan
    predicted = updates(f_max) / rate
    if predicted > time_budget_s:
        faster = fits[[updates(e * math.sqrt(2)) / rate <= time_budget_s for e in fits]]
        why += (f"; warning: about {predicted:.0f} s at the {rate / 1e9:.2f} G cell updates/s "
                f"measured here, over the time budget of {time_budget_s:g} s (the crossover is "
                "not lowered for it, so that every machine bakes the same bits): "
                + (f"give crossover_hz = {faster.max():.0f} or less to stay within it"
                   if faster.size else "no crossover stays within it"))
    k = int(np.searchsorted(edges, x) + 1)
    return Crossover(crossover_hz=x, wave_bands=k, max_frequency_hz=f_max,
                     schroeder_hz=f_s, grid_limit_hz=f_grid, why=why, updates_per_s=rate)


def bake_waves(scene: Any, arrays: dict[str, np.ndarray], binning: Any, cross: Crossover,
               duration_s: float, memory_limit_bytes: int,
               bins: tuple[np.ndarray, np.ndarray], directions: tuple[int, int], *,
               progress: bool | Callable[[int, int, float], bool] = False,
               log: Callable[[str], None] | None = None,
               directivities: list[Any] | None = None) -> dict[str, Any]:
    """One wave run per source; returns energy float32[receiver, direction, wave band, time]
    (the bands below the crossover only: the rays give the rest), pressure
    float32[receiver, time] at sample_rate_hz (the low part, see the module's doc), and stats.
    ``bins``: the field's (bin_start_s, bin_width_s) and (azimuth, elevation) bands, where the
    direct sound is put.
    ``directivities``: each source's engine directivity (None or omitted: omni); a directional
    source is a cluster of monopoles fitted to it per band (:mod:`sonolux.sound.wave_sources`)."""
    from sonolux.sound import wave_sources

    bands = np.asarray(scene.settings.bands_hz, float)
    c = scene.settings.speed_of_sound_m_s
    pulse_s = 6.0 / (math.pi * cross.max_frequency_hz)  # the pulse's delay, 6σ
    settings = wave_settings(cross.max_frequency_hz, duration_s + pulse_s, c,
                             scene.settings.threads, memory_limit_bytes)
    centres = np.ascontiguousarray(scene.receivers.positions_m, float)
    receivers = ball_points(scene.geometry, centres, scene.receivers.radius_m)
    est = engine.wave_memory_estimate(settings, scene.geometry, len(receivers), bands,
                                      absorption=arrays["absorption"], wells=wells_of(scene))
    k = cross.wave_bands
    if log:
        log(f"waves: {cross.why}; grid {settings.spacing_m * 1e3:.1f} mm up to "
            f"{cross.max_frequency_hz:.0f} Hz, {est['cells']:,} cells × {est['steps']:,} steps × "
            f"{len(scene.sources)} source(s), about {gb(est['total_bytes'])} and "
            f"{run_seconds(est, cross.updates_per_s) * len(scene.sources):.0f} s at the measured "
            f"{cross.updates_per_s / 1e9:.2f} G cell updates/s")
        note = flat_in_the_waves(scene)
        if note:
            log(note)
    energy, pressure, stats = None, None, []
    for i, src in enumerate(scene.sources):
        label = f"waves {scene.name} source {i + 1}/{len(scene.sources)}"
        callback = ProgressLine(label, unit="steps") if progress is True else (progress or None)
        source_m = np.asarray(src.position_m, float)
        pattern = None if directivities is None else directivities[i]
        if pattern is None or src.directivity == "omni":
            out = engine.simulate_waves(scene.geometry, arrays["absorption"], bands,
                                        source_m[None], receivers, settings, binning, callback,
                                        without_direct=True, energy_bands=k,
                                        wells=wells_of(scene))
            gains = None
        else:
            fitted = wave_sources.fit_on_grid(
                src, pattern, bands, settings.spacing_m, c, clearance_m=float(
                    scene.geometry.distance_to_surface(np.ascontiguousarray(source_m[None]))[0]),
                wave_bands=k)
            longer = wave_settings(cross.max_frequency_hz, duration_s + wave_sources.pulse_delay_s(
                bands, cross.max_frequency_hz, fitted), c, scene.settings.threads,
                memory_limit_bytes)
            cluster = wave_sources.terms(source_m, fitted, bands, cross.max_frequency_hz,
                                         longer.spacing_m, longer.sample_rate_hz,
                                         int(longer.steps), c,
                                         courant=c / (longer.sample_rate_hz * longer.spacing_m))
            if np.any(np.abs(scene.geometry.winding_numbers(cluster[0])) < 0.5):
                raise SettingError(
                    f"waves: source {src.name or i + 1} ({src.directivity}) at "
                    f"{tuple(round(float(v), 3) for v in source_m)} m is within "
                    f"{1e3 * wave_sources.reach_m(fitted, settings.spacing_m):.0f} mm of a wall: "
                    "its cluster of monopoles needs that much air on every side; "
                    "move it into the room or make it omni")
            if log:
                log(wave_sources.describe(f"{src.name or i + 1} ({src.directivity})", fitted,
                                          len(cluster[0]), cross.wave_bands))
            out = engine.simulate_waves(scene.geometry, arrays["absorption"], bands,
                                        source_m[None], receivers, longer, binning, callback,
                                        without_direct=True, terms=cluster, energy_bands=k,
                                        wells=wells_of(scene))
            towards = centres - source_m
            norm = np.linalg.norm(towards, axis=1, keepdims=True)
            gains = np.asarray(pattern.gains(towards / np.maximum(norm, 1e-12), bands.size), float)
        if out["cancelled"]:
            raise SonoluxError("the wave simulation was stopped before its end")
        # The sphere's energy: the room's part averaged over its points ([receiver][point] in
        # order; points on the source's own near field left out), plus the direct sound's
        # exact mean over the sphere.
        w = point_weights(receivers, source_m, centres, 2.0 * settings.spacing_m + (
            0.0 if pattern is None or src.directivity == "omni"
            else wave_sources.reach_m(fitted, settings.spacing_m)))
        e = ball_means(w, out.pop("energy"))
        add_direct(e, centres, scene.receivers.radius_m, source_m, arrays["air"][:k], c, bins,
                   directions, None if gains is None else gains[:, :k])
        e *= src.power_w
        # The pressure: the centre's (the listener's ear is at one point).
        out["pressure_pa"] = out["pressure_pa"][::BALL_POINTS]
        energy = e if energy is None else energy + e
        # The impulse response (time 0 at emission) as long as an omni run's: a directional
        # run is longer by its pulse's delay.
        p = low_pressure(out, bands, cross.wave_bands, arrays["air"], c,
                         float(scene.settings.sample_rate_hz))[:, :int(settings.steps)]
        p = p * math.sqrt(src.power_w)
        pressure = p if pressure is None else pressure + p
        stats.append(dict(out["stats"]))
    assert energy is not None and pressure is not None
    return {"energy": energy.astype(np.float32), "pressure": pressure.astype(np.float32),
            "sample_rate_hz": float(out["sample_rate_hz"]), "stats": stats}


#: Receivers whose points are averaged at once by :func:`ball_means`: the float64 copy of
#: their points' energy is this many spheres' worth, not the whole grid's.
BALL_CHUNK = 32


def ball_means(weights: np.ndarray, points: np.ndarray) -> np.ndarray:
    """float64[receiver, direction, band, time]: each sphere's energy, the mean of its
    ``BALL_POINTS`` points' (``points`` float32[receiver·point, direction, band, time], [receiver]
    [point] in order) with ``weights`` float64[receiver, point]; in chunks of :data:`BALL_CHUNK`
    receivers, so that the float64 copy of the points' energy is small (each sum is over one
    receiver's points, so its bits do not depend on the chunks)."""
    n = weights.shape[0]
    per = points.reshape(n, BALL_POINTS, *points.shape[1:])
    out = np.empty((n, *points.shape[1:]), np.float64)
    for a in range(0, n, BALL_CHUNK):
        b = min(a + BALL_CHUNK, n)
        out[a:b] = np.einsum("rp,rp...->r...", weights[a:b], per[a:b].astype(np.float64))
    return out


def low_pressure(out: dict[str, Any], bands_hz: np.ndarray, wave_bands: int, air_per_m: np.ndarray,
                 c: float, output_rate_hz: float) -> np.ndarray:
    """float64[receiver, time]: a run's impulse responses below the crossover, air included, in
    √(W/m²) per √W of source power for a field at ``output_rate_hz``; time 0 at emission."""
    p = np.asarray(out["pressure_pa"], np.float64)
    fs = float(out["sample_rate_hz"])
    n = p.shape[1]
    n_fft = sfft.next_fast_len(2 * n, real=True)
    pulse = sfft.rfft(np.asarray(out["source_pressure_1m_pa"], np.float64), n_fft)
    keep = np.abs(pulse) > PULSE_FLOOR * np.abs(pulse).max()
    inverse = np.where(keep, 1.0 / np.where(keep, pulse, 1.0), 0.0)
    spectra = sfft.rfft(p, n_fft, axis=1) * inverse * low_edge_gain(n_fft, fs, bands_hz)
    # The wave bands' weights depend on their centres and the first ray band's alone; the bands
    # above it may lie beyond the wave rate's Nyquist frequency (an 8 kHz band over a 354 Hz
    # crossover, whose wave rate is 8.7 kHz), so they are left out here.
    weights = band_split_weights(n_fft, fs, np.asarray(bands_hz, float)[:wave_bands + 1])
    h_low = weights[:wave_bands].sum(axis=0)
    # Power-complementary to the synthesis' 1 − H_L: the two parts are incoherent.
    to_power = np.divide(np.sqrt(h_low * (2.0 - h_low)), h_low, out=np.zeros_like(h_low),
                         where=h_low > 1e-12)
    t = np.arange(n) / fs
    low = np.zeros_like(p)
    for b in range(wave_bands):
        band = sfft.irfft(spectra * (weights[b] * to_power), n_fft, axis=1)[:, :n]
        low += band * np.exp(-air_per_m[b] * c * t / 2.0)
    # h is δ(t − r/c)/r in free field: one sample of the wave rate, an impulse of area 1/(r·fs).
    # The synthesis writes a free-field arrival of energy E = 1/(4πr²) per joule as one sample
    # √(E·f_out) at the field's rate f_out: an impulse of area √(E/f_out), the same in every
    # band. So h·fs/√(4π·f_out) is that impulse at the wave rate, and it stays so when resampled.
    return low * fs / math.sqrt(4.0 * math.pi * output_rate_hz)


def low_edge_gain(n_fft: int, fs: float, bands_hz: np.ndarray) -> np.ndarray:
    """float64[n_fft // 2 + 1]: the energy field's lowest band edge, as ``bands.rs`` has it
    (f₀ over √(f₁/f₀), rising as sin(π(x + 1)/4) across a quarter of the band on either side),
    so that the wave pressure holds what the field's wave bands hold. Below it a closed room's
    response to a volume source has its compliance term, which grows as 1/f² to DC (pressure
    rises with the volume pushed in), and the deconvolution by the pulse, whose spectrum falls
    as f to DC, would amplify it without bound."""
    b = np.asarray(bands_hz, float)
    ratio = b[1] / b[0] if b.size > 1 else 2.0
    lo, width = b[0] / math.sqrt(ratio), 0.25 * math.log2(ratio)
    f = sfft.rfftfreq(n_fft, 1.0 / fs)
    with np.errstate(divide="ignore"):
        x = np.clip(np.log2(np.maximum(f, 1e-300) / lo) / width, -1.0, 1.0)
    return np.sin(0.25 * np.pi * (x + 1.0))


def keep_wave_bands(tracer: Any, waves: np.ndarray, wave_bands: int,
                    settings: dict[str, Any] | None = None) -> Any:
    """[receiver, direction, band, time] float32: the wave bands from the waves, the rest from
    the tracer. A dense tracer field gives a dense array; a compact one
    (:class:`sonolux.sound.compact.CompactArray`) a compact one: the joined field's late part
    summed back into the tracer's stored coarse bins (each shown bin is one of ``late_split``
    equal parts of one), its early part kept as cells, and reduced again as the bake's
    ``settings`` say when the tracer's was (``compact_arrivals``, ``compact_envelope_s``:
    every envelope bin keeps its sum)."""
    from sonolux.sound.compact import CompactArray, is_compact, reduced

    out = np.array(tracer, dtype=np.float32, order="C", copy=True)
    # The waves' record reaches the field's last bin (add_waves); should it not, nothing of
    # the waves is there.
    n = min(out.shape[-1], waves.shape[-1])
    out[:, :, :wave_bands, :n] = waves[:, :, :wave_bands, :n]
    out[:, :, :wave_bands, n:] = 0.0
    if not is_compact(tracer):
        return out
    eb, split = tracer.early_bins, tracer.late_split
    r, d, b, _ = out.shape
    late = out[..., eb:].reshape(r, d, b, -1, split).sum(axis=-1, dtype=np.float64)
    stored = np.concatenate([out[..., :eb], late.astype(np.float32)], axis=-1)
    joined = CompactArray.of(stored, eb, split)
    return joined if tracer.envelope is None or settings is None else reduced(joined, settings)


#: What a joined field's ``waves`` keeps (the pressure besides), and ``settings["waves"]``.
WAVE_KEYS = ("crossover_hz", "wave_bands", "max_frequency_hz", "schroeder_hz", "sample_rate_hz")


def with_wave_part(field: Any, part: dict[str, Any]) -> Any:
    """``field`` (the rays, whole) joined with the waves of ``part``
    (:func:`sonolux.sound.bake.wave_part`): its wave bands replaced (:func:`keep_wave_bands`),
    the waves' pressure and crossover kept. The same for a bake done at once and for the merge
    of its ray ranges, so both give the same bits."""
    from dataclasses import replace

    settings = {k: v for k, v in field.settings.items() if k != "with_waves"}
    energy = keep_wave_bands(field.energy, part["energy"], int(part["wave_bands"]), settings)
    waves = {k: part[k] for k in ("pressure", *WAVE_KEYS)}
    stats = dict(field.stats, waves={"runs": part.get("stats", []),
                                     "seconds": part.get("seconds")})
    settings["waves"] = {k: waves[k] for k in WAVE_KEYS}
    return replace(field, energy=energy, stats=stats, settings=settings, waves=waves)


def is_wave_part(waves: dict[str, Any] | None) -> bool:
    """Whether a field's ``waves`` is a part not yet joined (a ray range's, from ray 0)."""
    return waves is not None and "energy" in waves


# --- what every consumer of the field uses ---------------------------------------------------
def ray_bands(field: Any, energy_band_time: np.ndarray) -> np.ndarray:
    """float64[band, time]: a histogram with the wave bands zeroed (what the synthesis gets in a
    hybrid field, so that it makes 1 − H_L of the response); the histogram itself otherwise."""
    e = np.asarray(energy_band_time, np.float64)
    if field.waves is None:
        return e
    e = e.copy()
    e[: int(field.waves["wave_bands"])] = 0.0
    return e


def joined_response(field: Any, receiver: int, direction: int | None,
                    synthesized: np.ndarray) -> np.ndarray:
    """The synthesis of the ray bands (from :func:`ray_bands`) plus the waves' pressure below the
    crossover, resampled to the field's rate; for one direction the wave pressure is weighted by
    √(the direction's share of the wave bands' energy in each time bin)."""
    if field.waves is None:
        return synthesized
    w = field.waves
    fs, fw = float(field.sample_rate_hz), float(w["sample_rate_hz"])
    p = np.asarray(w["pressure"][receiver], np.float64)
    n_out = int(round(p.size * fs / fw))
    low = ssignal.resample(p, n_out) if n_out != p.size else p
    if direction is not None:
        k = int(w["wave_bands"])
        e = field.energy[receiver, :, :k, :].sum(axis=1, dtype=np.float64)  # [direction, time]
        total = e.sum(axis=0)
        # One-sample bins are finer than the wave rate: an empty bin takes the share of the
        # last bin that holds energy (the first one's before it).
        held = np.flatnonzero(total > 0)
        if held.size == 0:
            return synthesized
        source_bin = held[np.clip(np.searchsorted(held, np.arange(total.size), side="right") - 1,
                                  0, None)]
        share = e[direction, source_bin] / total[source_bin]
        ends = np.asarray(field.bin_start_s) + np.asarray(field.bin_width_s)
        bins = np.minimum(np.searchsorted(ends, np.arange(n_out) / fs, side="right"), share.size - 1)
        low = low * np.sqrt(share[bins])
    n = max(low.size, synthesized.size)
    out = np.zeros(n)
    out[: synthesized.size] += synthesized
    out[: low.size] += low
    return out


def memory_limit(given: int | None) -> int:
    return int(given) if given else budget_bytes()
