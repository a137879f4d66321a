"""The low bands' modes: the spectrum of a hybrid field's wave pressure at one receiver.

Below the crossover a hybrid field keeps the wave solver's own pressure response
(:mod:`sonolux.sound.waves`); its magnitude spectrum shows the room's modes as peaks, which the
rays cannot give. For a box-shaped room the modes' frequencies are known,
f = (c/2)·√((l/L_x)² + (m/L_y)² + (n/L_z)²) (Rayleigh; Kuttruff, *Room Acoustics*, ch. 3), and
are marked so that the peaks can be told from them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import fft as sfft

from sonolux.outputs import write_atomically
from sonolux.plotting import pyplot
from sonolux.sound.field import SoundField


def box_modes_hz(size_m, speed_of_sound_m_s: float, up_to_hz: float) -> np.ndarray:
    """float64[mode]: the mode frequencies of a rigid box up to ``up_to_hz``, sorted."""
    lx, ly, lz = (float(v) for v in size_m)
    n = [int(2 * up_to_hz * length / speed_of_sound_m_s) + 1 for length in (lx, ly, lz)]
    i, j, k = np.meshgrid(*(np.arange(m + 1) for m in n), indexing="ij")
    f = 0.5 * speed_of_sound_m_s * np.sqrt((i / lx) ** 2 + (j / ly) ** 2 + (k / lz) ** 2)
    f = np.sort(f.ravel())
    return f[(f > 0) & (f <= up_to_hz)]


def wave_spectrum(field: SoundField, receiver: int) -> tuple[np.ndarray, np.ndarray]:
    """(frequency Hz, level dB re its peak) of the wave pressure at one receiver, up to the
    grid's maximum frequency."""
    if field.waves is None:
        raise ValueError("the field holds no wave part (bake with --waves)")
    w = field.waves
    p = np.asarray(w["pressure"][receiver], np.float64)
    n = sfft.next_fast_len(max(p.size, 1))
    spectrum = np.abs(sfft.rfft(p, n))
    f = sfft.rfftfreq(n, 1.0 / float(w["sample_rate_hz"]))
    keep = f <= float(w["max_frequency_hz"])
    with np.errstate(divide="ignore"):
        level = 20 * np.log10(spectrum[keep] / max(spectrum[keep].max(), 1e-300))
    return f[keep], level


def plot_wave_spectrum(field: SoundField, receiver: int, path: str | Path,
                       box_m=None) -> Path:
    """The wave pressure's magnitude spectrum at one receiver (dB re its peak), the crossover
    marked, and with ``box_m`` (the room's three sides, when it is a box) its rigid-box modes."""
    plt = pyplot()
    f, level = wave_spectrum(field, receiver)
    w = field.waves
    assert w is not None
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(f, level, lw=0.9, color="#1f78b4", label="wave pressure at the receiver")
    if box_m is not None:
        c = float(field.settings["speed_of_sound_m_s"])
        # Up to the Schroeder frequency, where modes stand apart; above it they overlap.
        top = min(float(w["schroeder_hz"]), float(w["crossover_hz"]))
        for k, fm in enumerate(box_modes_hz(box_m, c, top)):
            ax.axvline(fm, color="#999999", lw=0.6, alpha=0.8,
                       label=f"modes of the rigid box, up to f_S = {top:.0f} Hz" if k == 0
                       else None)
    ax.axvline(float(w["crossover_hz"]), color="#e7298a", lw=1.5,
               label=f"crossover {float(w['crossover_hz']):.0f} Hz (rays above)")
    low = float(field.bands_hz[0]) / np.sqrt(2)
    ax.set_xlim(0.5 * low, float(w["max_frequency_hz"]))
    ax.set_ylim(-50, 3)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("level (dB re peak)")
    pos = ", ".join(f"{v:g}" for v in np.round(field.positions_m[receiver], 2))
    ax.set_title(f"{field.scene_name}: the low bands' modes at ({pos}) m (wave solver)")
    ax.grid(alpha=0.3, lw=0.5)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    path = Path(path)
    write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
    plt.close(fig)
    return path
