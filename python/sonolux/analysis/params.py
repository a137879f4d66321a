"""Room-acoustic parameters of a sound field (ISO 3382-1:2009), per receiver, band and direction.

This module owns the step from a :class:`~sonolux.sound.field.SoundField` to the numbers a
consultant reads; the per-trace arithmetic (Schroeder curve, Lundeby truncation, fits, energy
ratios) is :mod:`sonolux.analysis.decay`.

Columns. Each parameter is given per octave band and ``broadband``. The tracer carries a ray's
whole energy in every band (a flat-spectrum source), so the broadband histogram is the *mean*
of the band histograms, not their sum: G broadband is then the strength of that flat source.

Onset. The times of C50, C80, D50, Ts and JLF count from the direct sound: the start of the first
bin whose broadband power is within 20 dB of the peak (ISO 3382-1 A.3.4), one onset per receiver
for all bands and directions.

Early lateral energy fraction. ISO 3382-1 A.2.4 measures JLF = E_L(5..80 ms) / E(0..80 ms) with
a figure-of-eight microphone whose null points at the source: an arrival from direction u counts
(u·n)² of its energy, n the horizontal axis perpendicular to the receiver-source line (JLFC, the
cos-weighted variant, counts |u·n|). The field knows only which direction *bin* an arrival fell
in, so each bin's energy is weighted by the mean of (u·n)² over the bin, as if arrivals spread
uniformly over it: over its azimuth sector (45° for 8 sectors) and over its elevation band (z =
sin(elevation) uniform; with one elevation band, the whole sphere, factor 2/3). Consequences,
stated plainly: a diffuse field gives exactly 1/3 (as the true figure-of-eight does); a single
reflection gets a smeared weight: with 8 sectors and one elevation band, a horizontal arrival
from exactly the side counts 0.54 to 0.63 instead of 1 (the sector's spread, 0.82 to 0.95,
times 2/3 for the unknown elevation) and one from the source's direction 0.03 to 0.12 instead
of 0, depending on where the sector edges fall. It maps where lateral energy is larger or
smaller; it is not a substitute for a measured JLF of single reflections: give the receivers a
figure-of-eight channel for that (then JLF, JLFC and LG come from it, :mod:`.lateral`). LG
(the late lateral level, 80 ms on, re the free field at 10 m) is estimated from the bins the
same way. Where
the source lies inside the receiver's sphere the receiver-source line is undefined: JLF is NaN.

Arrays. ``RoomParameters.values[name]`` is float64[receiver, column] with columns
``bands_hz`` then broadband; ``directional[name]`` (only when asked) float64[receiver,
direction, column].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sonolux.analysis import consistency, lateral
from sonolux.analysis.decay import (
    COMPENSATIONS,
    c50,
    c80,
    centre_time_s,
    d50,
    decay_times,
    slowest_decay_time_s,
    strength_g_db,
)
from sonolux.errors import AnalysisError
from sonolux.sound.field import SoundField

#: name: (label, unit, scale to the unit, ISO 3382-1 just-noticeable difference in that unit)
PARAMETERS: dict[str, tuple[str, str, float, float | None]] = {
    "edt_s": ("EDT", "s", 1.0, None),  # JND 5 % (relative)
    "t20_s": ("T20", "s", 1.0, None),
    "t30_s": ("T30", "s", 1.0, None),
    "c50_db": ("C50", "dB", 1.0, 1.0),
    "c80_db": ("C80", "dB", 1.0, 1.0),
    "d50": ("D50", "", 1.0, 0.05),
    "ts_s": ("Ts", "ms", 1000.0, 10.0),
    "g_db": ("G", "dB", 1.0, 1.0),
    "jlf": ("JLF", "", 1.0, 0.05),
    "jlfc": ("JLFC", "", 1.0, 0.05),
    "lg_db": ("LG", "dB", 1.0, None),
}
DECAY_NAMES = ("edt", "t20", "t30")
#: Quadrature points per direction bin for the lateral weights (error < 1e-4).
_QUADRATURE = 256
#: Receivers analysed at once: bounds the float64 copies of the histograms.
_CHUNK = 32


@dataclass
class RoomParameters:
    """Parameters of some receivers of a field; see the module docstring for the axes."""

    bands_hz: np.ndarray
    receivers: np.ndarray  # int[receiver]: indices into the field
    positions_m: np.ndarray  # float[receiver, 3]
    values: dict[str, np.ndarray]
    reasons: dict[str, np.ndarray]  # 'edt', 't20', 't30': str[receiver, column], '' when fitted
    compensation: str = "none"  # how the decay curves treat the record's end (decay.COMPENSATIONS)
    outliers: list[dict] = field(default_factory=list)  # see analysis.consistency
    directional: dict[str, np.ndarray] | None = None
    directional_reasons: dict[str, np.ndarray] | None = None  # like reasons, [receiver, dir, column]
    direction_names: list[str] = field(default_factory=list)
    theory: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    #: float[receiver]: STI (IEC 60268-16, :mod:`sonolux.analysis.sti`), None when the field
    #: lacks its octaves (the reason is in ``notes``); ``sti_method`` says with what talker
    #: and noise, ``speech`` holds them (speech_dba, noise_db).
    sti: np.ndarray | None = None
    sti_method: str = ""
    speech: dict[str, Any] = field(default_factory=dict)
    #: str[receiver]: each receiver's directional channel (empty without channels).
    channels: list[str] = field(default_factory=list)

    @property
    def columns(self) -> list[str]:
        return [f"{b:g}" for b in self.bands_hz] + ["broadband"]

    def summary(self) -> dict[str, dict[str, np.ndarray]]:
        """{name: {'mean', 'min', 'max': float[column], 'count': int[column]}} over receivers,
        ignoring receivers where the value is undefined (NaN)."""
        out = {}
        for name, v in self.values.items():
            ok = np.isfinite(v)
            count = ok.sum(axis=0)
            with np.errstate(invalid="ignore", divide="ignore"):
                mean = np.where(ok, v, 0.0).sum(axis=0) / count
            out[name] = {"mean": mean,
                         "min": np.where(count > 0, np.where(ok, v, np.inf).min(axis=0), np.nan),
                         "max": np.where(count > 0, np.where(ok, v, -np.inf).max(axis=0), np.nan),
                         "count": count}
        return out


# --- the lateral weights -------------------------------------------------------------------


def lateral_weights(azimuth_bands: int, elevation_bands: int, source_azimuth_rad,
                    power: int = 2) -> np.ndarray:
    """Mean figure-of-eight weight |u·n|^power of each direction bin: float[..., directions].

    ``source_azimuth_rad`` (shape (...)): the direction from the receiver to the source, 0
    along +x, counter-clockwise. The figure of eight's axis n is horizontal and perpendicular
    to it. power 2 gives JLF's energy weights, 1 JLFC's. Bins are ordered as in the field
    (index = elevation × azimuth_bands + azimuth; elevation bands of equal solid angle).
    """
    phi_s = np.asarray(source_azimuth_rad, dtype=np.float64)[..., None, None]
    width = 2 * math.pi / azimuth_bands
    # Midpoint quadrature over each azimuth sector, centred on k × width.
    u = (np.arange(_QUADRATURE) + 0.5) / _QUADRATURE - 0.5
    phi = width * (np.arange(azimuth_bands)[:, None] + u)  # (A, Q)
    az = np.mean(np.abs(np.sin(phi - phi_s)) ** power, axis=-1)  # |cos| to the lateral axis
    # Over each elevation band, z = sin(elevation) uniform in [z0, z1]: |cos el|^p = (1-z²)^(p/2).
    z_edges = np.linspace(-1.0, 1.0, elevation_bands + 1)
    z = z_edges[:-1, None] + (z_edges[1:] - z_edges[:-1])[:, None] * (u + 0.5)
    el = np.mean((1.0 - z * z) ** (power / 2), axis=-1)  # (E,)
    return (el[:, None] * az[..., None, :]).reshape(*az.shape[:-1], -1)


# --- windowed energies ----------------------------------------------------------------------


def _edges(field_: SoundField) -> np.ndarray:
    return np.append(field_.bin_start_s, field_.bin_start_s[-1] + field_.bin_width_s[-1])


def onsets_s(energy: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Start of the first bin within 20 dB of the peak power (ISO 3382-1 A.3.4): float[...]."""
    power = energy / np.diff(edges)
    first = np.argmax(power >= 0.01 * power.max(axis=-1, keepdims=True), axis=-1)
    return edges[first]


def window_energy(energy: np.ndarray, edges: np.ndarray, t0_s, t1_s) -> np.ndarray:
    """Energy between t0 and t1 (bins split in proportion to time): float[...].

    ``energy`` float[..., T]; ``t0_s``, ``t1_s`` broadcast against its leading shape.
    """
    lead = energy.shape[:-1]
    e = energy.reshape(-1, energy.shape[-1])
    cum = np.concatenate([np.zeros((e.shape[0], 1)), np.cumsum(e, axis=-1)], axis=-1)
    rows = np.arange(e.shape[0])

    def at(t):
        pos = np.interp(np.broadcast_to(t, lead).reshape(-1), edges, np.arange(edges.size))
        k = np.minimum(np.floor(pos).astype(np.int64), e.shape[1] - 1)
        return cum[rows, k] + (pos - k) * e[rows, k]

    return (at(t1_s) - at(t0_s)).reshape(lead)


# --- the parameters -------------------------------------------------------------------------


def _with_broadband(e: np.ndarray) -> np.ndarray:
    """float[..., band, T] -> float[..., band + 1, T]: the bands, then their mean."""
    return np.concatenate([e, e.mean(axis=-2, keepdims=True)], axis=-2)


def _ratios(e: np.ndarray, start: np.ndarray, width: np.ndarray, onset: np.ndarray,
            power_w: float, decay: dict[str, Any]) -> dict[str, np.ndarray]:
    """Every parameter but JLF of traces float[..., T] with onsets float[...]; ``decay``:
    keyword arguments of ``decay_times`` (compensation, slowest decay per column)."""
    out: dict[str, np.ndarray] = {}
    with np.errstate(invalid="ignore", divide="ignore"):
        times = decay_times(e, start, width, onset_s=onset, **decay)
        for name in DECAY_NAMES:
            out[f"{name}_s"] = np.asarray(times[f"{name}_s"], dtype=np.float64)
            out[f"{name}_reason"] = np.asarray(times[f"{name}_reason"])
            out[f"{name}_xi_permille"] = np.asarray(times[f"{name}_xi_permille"], dtype=np.float64)
        out["c50_db"] = np.asarray(c50(e, start, width, onset_s=onset), dtype=np.float64)
        out["c80_db"] = np.asarray(c80(e, start, width, onset_s=onset), dtype=np.float64)
        out["d50"] = np.asarray(d50(e, start, width, onset_s=onset), dtype=np.float64)
        out["ts_s"] = np.asarray(centre_time_s(e, start, width, onset_s=onset), dtype=np.float64)
        out["g_db"] = np.asarray(strength_g_db(e.sum(axis=-1), power_w), dtype=np.float64)
    return out


def source_azimuths_rad(field_: SoundField, positions_m: np.ndarray) -> np.ndarray:
    """Azimuth from each receiver to the first source (NaN where the source is inside the
    receiver's sphere): float[receiver]."""
    d = field_.source_positions_m[0, :2] - positions_m[:, :2]
    inside = np.linalg.norm(field_.source_positions_m[0] - positions_m, axis=1) <= field_.radius_m
    return np.where(inside, np.nan, np.arctan2(d[:, 1], d[:, 0]))


def _lateral_fractions(field_, energy, edges, onset, phi_s, power_w):
    """JLF, JLFC and LG: float[receiver, column] from energy float32[receiver, dir, band, T],
    by the direction bins' mean figure-of-eight weights (see the module docstring)."""
    omni = _with_broadband(energy.sum(axis=1, dtype=np.float64))
    early = window_energy(omni, edges, onset[:, None], onset[:, None] + 0.080)
    out = {}
    for name, power in (("jlf", 2), ("jlfc", 1)):
        w = lateral_weights(field_.azimuth_bands, field_.elevation_bands,
                            np.nan_to_num(phi_s), power)  # (R, D)
        lateral = _with_broadband(np.einsum("rd,rdbt->rbt", w, energy, dtype=np.float64))
        lat = window_energy(lateral, edges, onset[:, None] + 0.005, onset[:, None] + 0.080)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[name] = np.where(np.isnan(phi_s)[:, None], np.nan, lat / early)
        if power == 2:  # LG: the late lateral energy against the free field at 10 m
            late = window_energy(lateral, edges, onset[:, None] + 0.080, np.inf)
            g = np.asarray(strength_g_db(late, power_w), dtype=np.float64)
            out["lg_db"] = np.where(np.isnan(phi_s)[:, None], np.nan, g)
    return out


def _lateral_from_channels(field_, idx: np.ndarray, power_w: float) -> dict | None:
    """JLF, JLFC and LG float64[receiver, column] from a point's true figure-of-eight and its
    |cos| companion (:mod:`sonolux.analysis.lateral`); None when the field has no channels."""
    if lateral.channel_record(field_) is None:
        return None
    edges = _edges(field_)
    out = {k: np.full((len(idx), len(field_.bands_hz) + 1), np.nan)
           for k in ("jlf", "jlfc", "lg_db")}
    for i, r in enumerate(idx):
        pair = lateral.companions(field_, int(r))
        if pair is None:
            continue
        e = _with_broadband(np.stack([np.asarray(field_.energy[k], np.float64).sum(axis=0)
                                      for k in (int(r), *pair)]))  # [3, column, T]
        onset = float(onsets_s(e[0, -1], edges))
        early = window_energy(e[0], edges, onset, onset + 0.080)
        with np.errstate(invalid="ignore", divide="ignore"):
            out["jlf"][i] = window_energy(e[1], edges, onset + 0.005, onset + 0.080) / early
            out["jlfc"][i] = window_energy(e[2], edges, onset + 0.005, onset + 0.080) / early
            late = window_energy(e[1], edges, onset + 0.080, np.inf)
            out["lg_db"][i] = strength_g_db(late, power_w)
    return out


def slowest_decay_s(field_: SoundField) -> np.ndarray | None:
    """The slowest decay the baked room allows, s, per column (bands, then broadband: the
    slowest band's); from the field's theory (``decay.slowest_decay_time_s``). Files without
    the room's least absorption and extent are bounded by the air alone; None without theory."""
    t = field_.theory
    if not t or t.get("air_attenuation_per_m") is None:
        return None
    bands = len(field_.bands_hz)
    alpha = t.get("min_absorption") or [0.0] * bands
    chord = t.get("max_chord_m") or np.inf
    c = float(t.get("speed_of_sound_m_s") or field_.settings["speed_of_sound_m_s"])
    bound = slowest_decay_time_s(alpha, chord, t["air_attenuation_per_m"], c)
    return np.append(bound, bound.max())


def room_parameters(field_: SoundField, receivers=None, *, directional: bool = False,
                    theory: bool = True, compensation: str = "none", sti: bool = True,
                    speech: Any = None) -> RoomParameters:
    """ISO 3382-1 parameters of the field's receivers (all, or the given indices).

    ``directional=True`` adds every parameter but JLF per direction bin (energy arriving from
    that bin only; G per direction is that bin's share of the strength). ``theory=True`` adds
    Sabine's and Eyring's T60 from the scene, when the scene can still be loaded.
    ``compensation``: how decay curves treat the record's end, ``"none"`` (a simulated field:
    the plain backward integral) or ``"lundeby"`` (a field with a real noise floor, e.g.
    synthesised with noise); see :mod:`sonolux.analysis.decay`. Every decay time is checked
    (undefined with its reason in ``reasons``), and receivers that stand out from their
    neighbours are listed in ``outliers`` (:mod:`sonolux.analysis.consistency`).
    A field with directional channels takes JLF, JLFC and LG from its true figure-of-eight
    (:mod:`sonolux.analysis.lateral`); every other parameter is each channel's own.
    ``sti=True`` adds the speech transmission index per receiver, with the talker and noise of
    ``speech`` (a :class:`sonolux.analysis.sti.SpeechSettings`; default: what the scene gave,
    recorded in the field). A third-octave field's STI uses octaves summed from its thirds.
    """
    if compensation not in COMPENSATIONS:
        raise AnalysisError(f"compensation must be one of {sorted(COMPENSATIONS)}, "
                            f"got {compensation!r}")
    decay = {"compensation": compensation, "max_decay_time_s": slowest_decay_s(field_)}
    idx = np.arange(field_.n_receivers) if receivers is None else np.atleast_1d(
        np.asarray(receivers, dtype=np.int64))
    if idx.size == 0:
        raise AnalysisError("no receivers to analyse")
    start, width, edges = field_.bin_start_s, field_.bin_width_s, _edges(field_)
    power_w = float(np.sum(field_.source_powers_w))
    positions = field_.positions_m[idx]
    phi_s = source_azimuths_rad(field_, positions)
    parts: list[dict[str, np.ndarray]] = []
    dir_parts: list[dict[str, np.ndarray]] = []
    for lo in range(0, idx.size, _CHUNK):
        sel = idx[lo:lo + _CHUNK]
        energy = field_.energy[sel]  # float32[r, dir, band, T]
        omni = _with_broadband(energy.sum(axis=1, dtype=np.float64))  # [r, column, T]
        onset = onsets_s(omni[:, -1], edges)  # [r]
        part = _ratios(omni, start, width, np.repeat(onset[:, None], omni.shape[1], 1), power_w,
                       decay)
        part.update(_lateral_fractions(field_, energy, edges, onset, phi_s[lo:lo + _CHUNK],
                                       power_w))
        parts.append(part)
        if directional:
            e = _with_broadband(energy.astype(np.float64))  # [r, dir, column, T]
            on = np.broadcast_to(onset[:, None, None], e.shape[:-1])
            dir_parts.append(_ratios(e, start, width, on, power_w, decay))
    merged = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    true_lateral = _lateral_from_channels(field_, idx, power_w)
    if true_lateral is not None:
        merged.update(true_lateral)
    result = RoomParameters(
        bands_hz=np.asarray(field_.bands_hz, dtype=np.float64), receivers=idx,
        positions_m=positions,
        values={k: merged[k] for k in PARAMETERS},
        reasons={n: merged[f"{n}_reason"] for n in DECAY_NAMES},
        compensation=compensation, direction_names=field_.direction_names)
    inside = (np.linalg.norm(positions[:, None, :] - field_.source_positions_m[None], axis=2)
              <= field_.radius_m).any(axis=1)
    result.outliers = consistency.outliers(
        result.values, {f"{n}_s": merged[f"{n}_xi_permille"] for n in DECAY_NAMES}, positions,
        idx, result.columns, field_.grid_spacing_m, inside)
    undefined = {n: int((merged[f"{n}_reason"] != "").sum()) for n in DECAY_NAMES}
    if any(undefined.values()):
        result.notes.append("undefined decay times (a fit failed a check; the reasons are listed "
                            "per receiver): " + ", ".join(f"{n.upper()} {k}" for n, k in
                                                          undefined.items() if k))
    if directional:
        result.directional = {k: np.concatenate([p[k] for p in dir_parts])
                              for k in PARAMETERS if k in dir_parts[0]}
        result.directional_reasons = {n: np.concatenate([p[f"{n}_reason"] for p in dir_parts])
                                      for n in DECAY_NAMES}
    names = lateral.channel_names(field_)
    result.channels = [names[int(r)] for r in idx] if names else []
    if true_lateral is not None:
        result.notes.append("JLF, JLFC and LG from the figure-of-eight channel of each point "
                            "(ISO 3382-1 A.2.4), shown on its omni channel")
    elif np.isnan(phi_s).any():
        result.notes.append(f"JLF is undefined at {int(np.isnan(phi_s).sum())} receiver(s) "
                            "whose sphere holds the source (no receiver-source line)")
    if field_.source_positions_m.shape[0] > 1:
        result.notes.append("several sources: energies are summed; JLF uses the first source's "
                            "direction and G the sum of the powers")
    if sti:
        _add_sti(result, field_, idx, speech)
    if theory:
        result.theory, note = theory_of(field_)
        if note:
            result.notes.append(note)
    return result


def _add_sti(result: RoomParameters, field_: SoundField, idx: np.ndarray, speech: Any) -> None:
    from sonolux.analysis.sti import describe, field_sti, speech_settings_of

    settings = speech if speech is not None else speech_settings_of(field_)
    values, why = field_sti(field_, idx, settings=settings)
    result.speech = {"speech_dba": settings.speech_dba,
                     "noise_db": None if settings.noise_db is None else list(settings.noise_db)}
    if why:
        result.notes.append(f"STI left out: {why}")
    else:
        result.sti = values
        result.sti_method = describe(settings)
        talker = (field_.settings.get("source_directivity") or ["omni"])[0]
        if talker != "omni":
            result.sti_method += (f"; the talker's directivity ({talker}) as baked, its level "
                                  "on its own axis")


def scene_of(field_: SoundField):
    """The field's scene, loaded again from where it was baked: (Scene, '') or (None, why not).
    A scene whose volume differs from the baked one has changed since: also None."""
    from sonolux.errors import SonoluxError
    from sonolux.scene import load_scene

    builtin = field_.scene_origin.startswith("built-in")
    where = field_.scene_name if builtin else field_.scene_origin
    try:
        scene = load_scene(where)
    except (SonoluxError, OSError) as exc:
        return None, f"the scene {where!r} could not be loaded ({exc})"
    if not math.isclose(scene.volume_m3, field_.settings["volume_m3"], rel_tol=1e-6):
        return None, (f"the scene {where!r} has changed since the bake (volume "
                      f"{scene.volume_m3:.4g} m³, baked {field_.settings['volume_m3']:.4g} m³)")
    return scene, ""


def theory_of(field_: SoundField) -> tuple[dict[str, Any], str]:
    """Sabine and Eyring T60 per band as the bake stored them in the field file: ({...}, '')
    or ({}, why not). Files of format 1 carry none: then the scene file named in the field
    is loaded again, if it is still there and unchanged."""
    keys = ("sabine_t60_s", "eyring_t60_s", "mean_absorption", "volume_m3", "area_m2",
            "mean_free_path_m")
    if field_.theory is not None:
        return {k: field_.theory[k] for k in keys}, ""
    from sonolux.scene.summary import theory

    scene, why = scene_of(field_)
    if scene is None:
        return {}, f"Sabine/Eyring left out: {why}"
    s = theory(scene)
    if [float(b) for b in s["bands_hz"]] != [float(b) for b in field_.bands_hz]:
        return {}, "Sabine/Eyring left out: the scene has other bands than the bake"
    return {k: s[k] for k in keys}, ""
