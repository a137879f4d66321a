"""Speech transmission index (IEC 60268-16:2020), the indirect method, from a sound field.

The modulation transfer function of a room is the normalised Fourier transform of its squared
impulse response (Schroeder, "Modulation transfer functions: definition and measurement",
Acustica 49, 1981; Houtgast and Steeneken, "A review of the MTF concept in room acoustics and
its use for estimating speech intelligibility in auditoria", JASA 77, 1985):

    m(F) = |∫ h²(t) e^(−j2πFt) dt| / ∫ h²(t) dt.

The field holds h² per octave band as energy per time bin, so the integral is a sum over bins;
a bin of width w whose energy is spread evenly over it contributes with the factor
sinc(F w) (exact for that spread; at 12.5 Hz and 10 ms bins the factor is 0.997).

Then IEC 60268-16:2020 Annex A, per octave band k (125 Hz ... 8 kHz) and modulation frequency
F (14 of them, 0.63 ... 12.5 Hz, third-octave steps):

- the speech level at the listener, L_k = the talker's octave level at 1 m (Table A.4's male
  spectrum on 60 dB(A), normal vocal effort, J.3) − 20 dB + G_k − 10 lg γ_k: G is the strength
  of the field (re 10 m in the free field, where the level is 20 dB below that at 1 m), γ_k the
  source's energy gain on its own axis (1 for omni). The standard's talker level is measured
  1 m *in front of* the mouth; a directional source of the same power is 10 lg γ_k louder
  there than an omni, so its power is lowered by that much to keep the talker's level. The
  field already carries the source's directivity (a talker facing the listener or away, with
  its reflections), so STI then follows the talker's orientation;
- background noise L_n,k (none by default: a quiet room);
- auditory masking by the band below (A.2.3: the masking slope amdB from its level:
  0.5 L − 65 below 63 dB, 1.8 L − 146.9 to 67 dB, 0.5 L − 59.8 to 100 dB, −10 dB above;
  I_am,k = I_(k−1) · 10^(amdB/10), I the band's speech-plus-noise intensity) and the absolute
  reception threshold (A.2.3, 46, 27, 12, 6.5, 7.5, 8, 12 dB):
  m'_k(F) = m_k(F) · I_s,k / (I_s,k + I_n,k + I_am,k + I_rt,k);
- effective SNR = 10 lg(m' / (1 − m')) limited to ±15 dB, TI = (SNR + 15) / 30, MTI_k the mean
  over F, STI = Σ α_k MTI_k − Σ β_k √(MTI_k MTI_(k+1)) with the male weights α and redundancy
  factors β (A.5, Table A.1).

Without ``level_corrections`` the masking, threshold and noise steps are left out (the pure
room's STI, as "electrical" measurements use).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

OCTAVES_HZ = (125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0, 8000.0)
MODULATION_HZ = (0.63, 0.8, 1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0, 10.0, 12.5)
#: IEC 60268-16:2020 Table A.1, male speech.
ALPHA = (0.085, 0.127, 0.230, 0.233, 0.309, 0.224, 0.173)
BETA = (0.085, 0.078, 0.065, 0.011, 0.047, 0.095)
#: Table A.4, male speech: octave levels re the A-weighted speech level, dB.
MALE_SPECTRUM_DB = (2.9, 2.9, -0.8, -6.8, -12.8, -18.8, -24.8)
#: J.3: normal vocal effort, dB(A) at 1 m on axis.
NORMAL_SPEECH_DBA = 60.0
#: A.2.3: absolute speech reception threshold per octave, dB.
RECEPTION_THRESHOLD_DB = (46.0, 27.0, 12.0, 6.5, 7.5, 8.0, 12.0)
SNR_LIMIT_DB = 15.0


@dataclass(frozen=True)
class SpeechSettings:
    """speech_dba: the talker's A-weighted level at 1 m (60 normal, 66 raised, 72 loud, J.3);
    noise_db: background noise per octave 125 Hz-8 kHz in dB SPL, or None (none);
    level_corrections: apply masking, threshold and noise (A.2.3)."""

    speech_dba: float = NORMAL_SPEECH_DBA
    noise_db: tuple[float, ...] | None = None
    level_corrections: bool = True

    def validate(self) -> SpeechSettings:
        from sonolux.errors import SonoluxError

        if not (isinstance(self.speech_dba, (int, float)) and 0 <= self.speech_dba <= 130):
            raise SonoluxError(f"speech_dba = {self.speech_dba!r} is not allowed: a level "
                               "from 0 to 130 dB(A) at 1 m (60 normal, 66 raised, 72 loud)")
        if self.noise_db is not None and not (
                np.shape(self.noise_db) == (7,)
                and np.all(np.isfinite(np.asarray(self.noise_db, float)))
                and np.all(np.abs(np.asarray(self.noise_db, float)) <= 150)):
            raise SonoluxError(f"noise_db = {self.noise_db!r} is not allowed: seven finite "
                               "octave levels (125 Hz to 8 kHz) in dB SPL, or none")
        return self


def speech_settings_of(field, speech_dba: float | None = None,
                       noise_db=None) -> SpeechSettings:
    """The talker and noise the scene gave (``[speech]``, recorded by the bake in the field's
    settings), with ``speech_dba`` / ``noise_db`` (seven levels or one) overriding them; the
    defaults (normal vocal effort, no noise) for fields baked without."""
    recorded = (getattr(field, "settings", None) or {}).get("speech") or {}
    level = recorded.get("speech_dba", NORMAL_SPEECH_DBA) if speech_dba is None else speech_dba
    noise = recorded.get("noise_db") if noise_db is None else noise_db
    if noise is not None:
        noise = tuple(float(x) for x in np.broadcast_to(np.asarray(noise, float), (7,)))
    return SpeechSettings(float(level), noise).validate()


def describe(settings: SpeechSettings) -> str:
    """One line saying what an STI was computed with."""
    noise = ("no background noise" if settings.noise_db is None else
             "background noise " + "/".join(f"{n:g}" for n in settings.noise_db)
             + " dB SPL (125 Hz … 8 kHz)")
    corrections = ("masking and reception threshold" if settings.level_corrections
                   else "no level corrections")
    return (f"IEC 60268-16:2020 indirect method, a male talker at {settings.speech_dba:g} dB(A) "
            f"at 1 m, {corrections}, {noise}")


def masking_slope_db(level_db: np.ndarray) -> np.ndarray:
    """amdB of IEC 60268-16:2020 A.2.3 for an octave band level (dB)."""
    L = np.asarray(level_db, float)
    return np.select([L < 63, L < 67, L < 100], [0.5 * L - 65, 1.8 * L - 146.9, 0.5 * L - 59.8],
                     -10.0)


def modulation_transfer(energy: np.ndarray, bin_start_s: np.ndarray,
                        bin_width_s: np.ndarray) -> np.ndarray:
    """float[..., 14]: m(F) of energy histograms float[..., time] at the 14 frequencies."""
    e = np.asarray(energy, np.float64)
    centre = np.asarray(bin_start_s, float) + 0.5 * np.asarray(bin_width_s, float)
    f = np.asarray(MODULATION_HZ)[:, None]
    kernel = np.exp(-2j * np.pi * f * centre) * np.sinc(f * np.asarray(bin_width_s, float))
    total = e.sum(axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.abs(e @ kernel.T) / total


def sti_from_mtf(m: np.ndarray) -> np.ndarray:
    """float[...]: STI of modulation transfer values float[..., 7 bands, 14] (A.5)."""
    m = np.clip(np.asarray(m, float), 1e-12, 1 - 1e-12)
    snr = np.clip(10 * np.log10(m / (1 - m)), -SNR_LIMIT_DB, SNR_LIMIT_DB)
    mti = ((snr + SNR_LIMIT_DB) / (2 * SNR_LIMIT_DB)).mean(axis=-1)
    sti = (mti * np.asarray(ALPHA)).sum(axis=-1) - (
        np.asarray(BETA) * np.sqrt(mti[..., :-1] * mti[..., 1:])).sum(axis=-1)
    return np.clip(sti, 0.0, 1.0)


def level_factors(speech_db: np.ndarray, noise_db: np.ndarray | None) -> np.ndarray:
    """float[..., 7]: I_s / (I_s + I_n + I_am + I_rt) per band (A.2.3), from the speech levels
    float[..., 7] at the listener and the noise levels (or None)."""
    i_s = 10 ** (np.asarray(speech_db, float) / 10)
    i_n = np.zeros_like(i_s) if noise_db is None else np.broadcast_to(
        10 ** (np.asarray(noise_db, float) / 10), i_s.shape)
    total = i_s + i_n
    level = 10 * np.log10(np.maximum(total, 1e-30))
    i_am = np.zeros_like(total)
    i_am[..., 1:] = total[..., :-1] * 10 ** (masking_slope_db(level[..., :-1]) / 10)
    i_rt = 10 ** (np.asarray(RECEPTION_THRESHOLD_DB) / 10)
    return i_s / (total + i_am + i_rt)


def speech_levels_db(g_db: np.ndarray, speech_dba: float = NORMAL_SPEECH_DBA) -> np.ndarray:
    """float[..., 7]: the talker's octave levels at the listener, L(1 m) − 20 dB + G."""
    return speech_dba + np.asarray(MALE_SPECTRUM_DB) - 20.0 + np.asarray(g_db, float)


def octave_columns(field) -> tuple[list[list[int]], str]:
    """For each STI octave 125 Hz … 8 kHz, the field's band indices whose energies add up to
    it: the octave itself, or its three thirds in a third-octave field (energy adds,
    docs/bands.md); ([], why not) when the field lacks some."""
    bands = [float(b) for b in field.bands_hz]
    band_set = getattr(field, "band_set", None)
    if band_set is not None and band_set.kind == "third-octave":
        from sonolux.acoustics.bands import octave_grouping

        try:
            octaves, groups = octave_grouping(band_set)
        except ValueError:
            octaves, groups = None, []
        have = {float(f): g.tolist() for f, g in zip(octaves.nominal_hz, groups)} if octaves else {}
        missing = [f"{b:g}" for b in OCTAVES_HZ if b not in have]
        if missing:
            return [], (f"STI needs the octaves 125 Hz to 8 kHz (the thirds 100 Hz to 10 kHz); "
                        f"this field's thirds do not make whole {', '.join(missing)} Hz")
        return [have[b] for b in OCTAVES_HZ], ""
    missing = [f"{b:g}" for b in OCTAVES_HZ if b not in bands]
    if missing:
        return [], (f"STI needs the octaves 125 Hz to 8 kHz; this field lacks "
                    f"{', '.join(missing)} Hz")
    return [[bands.index(b)] for b in OCTAVES_HZ], ""


def axis_gain_db(field, cols: list[list[int]]) -> np.ndarray:
    """float[7]: 10 lg γ of the first source's on-axis gain per STI octave (the mean of an
    octave's thirds' gains: each third radiates the same power), recorded by the bake; zeros
    for an omnidirectional source or a field baked before it was recorded."""
    gains = (getattr(field, "settings", None) or {}).get("source_axis_gain")
    if not gains:
        return np.zeros(len(cols))
    g = np.asarray(gains[0], float)
    return 10 * np.log10(np.array([g[c].mean() for c in cols]))


def field_sti(field, receivers: np.ndarray, g_db: np.ndarray | None = None,
              settings: SpeechSettings | None = None) -> tuple[np.ndarray, str]:
    """(STI float[receiver], '' or why it is undefined) of the field's receivers. The octave
    histograms are the field's octaves 125 Hz … 8 kHz, or the sums of their thirds in a
    third-octave field. ``g_db`` float[receiver, 7]: the strength G per octave; None computes
    it from the same histograms. The energy of all directions counts (an omnidirectional
    listener, as the indirect method measures)."""
    from sonolux.analysis.decay import strength_g_db

    s = (settings or SpeechSettings()).validate()
    receivers = np.asarray(receivers, dtype=np.int64)
    cols, why = octave_columns(field)
    if why:
        return np.full(len(receivers), np.nan), why
    power_w = float(np.sum(field.source_powers_w))
    axis_db = axis_gain_db(field, cols)
    out = np.empty(len(receivers))
    for lo in range(0, len(receivers), 32):
        sel = receivers[lo:lo + 32]
        energy = field.energy[sel]  # [r, dir, band, T]
        omni = np.stack([energy[:, :, c].sum(axis=(1, 2), dtype=np.float64) for c in cols],
                        axis=1)  # [r, 7, T]
        m = modulation_transfer(omni, field.bin_start_s, field.bin_width_s)
        if s.level_corrections:
            g = (strength_g_db(omni.sum(axis=-1), power_w) if g_db is None
                 else np.asarray(g_db, float)[lo:lo + 32])
            speech = speech_levels_db(g, s.speech_dba) - axis_db
            m = m * level_factors(speech, s.noise_db)[..., None]
        out[lo:lo + 32] = sti_from_mtf(m)
    return out, ""
