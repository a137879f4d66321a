"""One receiver's responses: echograms per azimuth sector and energy decay curves per band.

The echograms are the paper's figure 7 for one cell: energy arriving per millisecond from each
sector, in dB, laid out as seen by a listener facing +x ("front" at the top, "left" on the
left), with all directions together in the middle.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sonolux.analysis.decay import decay_times
from sonolux.outputs import write_atomically
from sonolux.plotting import pyplot
from sonolux.sound.field import SoundField

#: (row, column) of each of eight sectors in a 3 × 3 layout, the listener facing up.
COMPASS = {"front-left": (0, 0), "front": (0, 1), "front-right": (0, 2), "left": (1, 0),
           "right": (1, 2), "back-left": (2, 0), "back": (2, 1), "back-right": (2, 2)}
FLOOR_DB = -70.0
_BAND_COLOURS = ("#3b0f70", "#5c3c9c", "#1f78b4", "#33a02c", "#e6ab02", "#e7298a", "#a6761d",
                 "#666666")


def per_millisecond(energy: np.ndarray, bin_start_s: np.ndarray) -> np.ndarray:
    """Energy float[..., T] summed into 1 ms bins float[..., ms] (bins by their start)."""
    ms = np.floor(bin_start_s * 1000 + 1e-9).astype(np.int64)
    out = np.zeros((*energy.shape[:-1], int(ms.max()) + 1))
    np.add.at(out, (..., ms), energy)
    return out


def azimuth_echograms(field: SoundField, receiver: int) -> np.ndarray:
    """float64[azimuth, ms]: energy per ms from each azimuth sector (elevations and bands
    summed; the bands each carry the source's full energy, so their mean is taken)."""
    e = field.energy[receiver].astype(np.float64).mean(axis=1)  # [direction, T]
    e = e.reshape(field.elevation_bands, field.azimuth_bands, -1).sum(axis=0)
    return per_millisecond(e, field.bin_start_s)


def _end_ms(field: SoundField, receiver: int) -> float:
    """Where the omni decay curve reaches -65 dB (or the record ends), ms."""
    omni = field.omni_energy(receiver).mean(axis=0)
    edc = np.cumsum(omni[::-1])[::-1]
    below = np.nonzero(edc < edc[0] * 10 ** (-6.5))[0]
    t = field.bin_start_s[below[0]] if below.size else field.bin_start_s[-1]
    return float(np.ceil(t * 10) * 100)


def plot_azimuth_echograms(field: SoundField, receiver: int, path: str | Path, *,
                           title: str | None = None) -> Path:
    """Echograms of every azimuth sector of one receiver, in dB re the strongest millisecond
    of all directions after the direct sound (its millisecond and the next), so that the
    reflections fill the scale even where the direct sound towers over them."""
    plt = pyplot()
    sectors = azimuth_echograms(field, receiver)
    omni = sectors.sum(axis=0)
    onset = int(np.argmax(omni >= 0.01 * omni.max()))
    later = omni[onset + 2:]
    ref = later.max() if later.size and later.max() > 0 else omni.max()
    names = field.direction_names[: field.azimuth_bands]
    names = [n.split("@")[0] for n in names]
    compass = field.azimuth_bands == 8
    rows, cols = (3, 3) if compass else (int(np.ceil((len(names) + 1) / 4)), 4)
    fig, axes = plt.subplots(rows, cols, figsize=(12, 2.2 * rows + 0.6), sharex=True, sharey=True,
                             squeeze=False)
    t_end = _end_ms(field, receiver)
    panels = [(n, sectors[k]) for k, n in enumerate(names)] + [("all directions", omni)]
    for k, (name, e) in enumerate(panels):
        if compass:
            r, c = COMPASS.get(name, (1, 1))
        else:
            r, c = divmod(k, cols)
        ax = axes[r, c]
        db = 10 * np.log10(np.maximum(e / ref, 10 ** (FLOOR_DB / 10)))
        colour = "#7f2704" if name == "all directions" else "#1f4e79"
        ax.fill_between(np.arange(e.size), FLOOR_DB, db, step="post", color=colour, lw=0)
        ax.set_title(name, fontsize=9)
        ax.set_xlim(0, t_end)
        ax.set_ylim(FLOOR_DB, 5)
        ax.grid(alpha=0.3, lw=0.5)
    for ax in axes.flat[len(panels):] if not compass else []:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel("dB")
    for ax in axes[-1]:
        ax.set_xlabel("time (ms)")
    pos = ", ".join(f"{v:g}" for v in np.round(field.positions_m[receiver], 2))
    fig.suptitle(title or f"{field.scene_name}: energy per millisecond arriving at ({pos}) m from "
                 "each direction (listener facing +x),\ndB re the strongest millisecond after the "
                 "direct sound (which may rise above the top)")
    fig.tight_layout()
    path = Path(path)
    write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
    plt.close(fig)
    return path


def plot_decay_curves(field: SoundField, receiver: int, path: str | Path) -> Path:
    """Schroeder decay curves of one receiver per band and broadband, with T30 in the legend
    (or why it is undefined) and the T30 evaluation range (-5 to -35 dB) shaded. The curves
    and fits are those of ``sonolux params`` (plain integral, the room's slowest decay)."""
    from sonolux.analysis.params import onsets_s, slowest_decay_s

    plt = pyplot()
    omni = field.omni_energy(receiver)
    e = np.concatenate([omni, omni.mean(axis=0, keepdims=True)])
    edges = np.append(field.bin_start_s, field.bin_start_s[-1] + field.bin_width_s[-1])
    with np.errstate(invalid="ignore", divide="ignore"):
        d = decay_times(e, field.bin_start_s, field.bin_width_s, onset_s=onsets_s(e[-1], edges),
                        max_decay_time_s=slowest_decay_s(field))
    many = len(field.bands_hz) > len(_BAND_COLOURS)  # thirds: a spectrum of colours, legend beside
    fig, ax = plt.subplots(figsize=(10.5 if many else 8, 5.5 if many else 4.5))
    t = field.bin_start_s
    labels = [f"{b:g} Hz" for b in field.bands_hz] + ["broadband"]
    spectrum = plt.get_cmap("viridis")
    for k, label in enumerate(labels):
        t30 = d["t30_s"][k]
        broadband = k == len(labels) - 1
        colour = ("black" if broadband else
                  spectrum(k / max(1, len(labels) - 2)) if many else
                  _BAND_COLOURS[k % len(_BAND_COLOURS)])
        ax.plot(t, d["edc_db"][k], lw=2.2 if broadband else 1.1, color=colour,
                label=f"{label}: T30 {t30:.2f} s" if np.isfinite(t30) else
                f"{label}: T30 undefined ({d['t30_reason'][k].split(': ')[0]})")
    ax.axhspan(-35, -5, color="#dddddd", alpha=0.5, lw=0, label="T30 range (-5 to -35 dB)")
    ax.set_xlim(0, _end_ms(field, receiver) / 1000)
    ax.set_ylim(-70, 2)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("energy decay curve (dB)")
    pos = ", ".join(f"{v:g}" for v in np.round(field.positions_m[receiver], 2))
    ax.set_title(f"{field.scene_name}: energy decay curves at ({pos}) m")
    ax.grid(alpha=0.3, lw=0.5)
    if many:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    else:
        ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    path = Path(path)
    write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
    plt.close(fig)
    return path
