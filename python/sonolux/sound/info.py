"""What `sonolux info` and `sonolux bake` print about a sound field."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from sonolux.sound.field import SoundField
from sonolux.sound.tail import describe as describe_tail

#: Share of rays that may escape before a bake warns of a leak.
LEAK_WARNING_SHARE = 0.001


def info(field: SoundField) -> dict[str, Any]:
    st, se = field.stats, field.settings
    emitted = np.asarray(st["energy_emitted_j"], float)
    accounted = sum(np.asarray(st[f"energy_{k}_j"], float) for k in
                    ("absorbed_surfaces", "absorbed_air", "escaped", "remaining"))
    balance = (accounted - emitted - np.asarray(st["energy_reweighted_j"], float)) / emitted
    return {
        "scene": field.scene_name, "origin": field.scene_origin, "path": field.path,
        "receivers": field.n_receivers, "radius_m": field.radius_m,
        "sources": field.source_names, "mix": se.get("mix"),
        "directions": field.direction_names, "bands_hz": field.bands_hz.tolist(),
        "bands": None if field.band_set is None else field.band_set.kind,
        "duration_s": float(field.bin_start_s[-1] + field.bin_width_s[-1]) if field.bin_start_s.size else 0.0,
        "time_bins": int(field.bin_start_s.size), "early_bins": se["early_bins"],
        "late_bin_s": se["late_bin_s"], "bytes_per_receiver": field.bytes_per_receiver,
        "storage": "compact" if field.compact else "full",
        "file_bytes_per_receiver": _file_bytes_per_receiver(field),
        "settings": se, "stats": {k: v for k, v in st.items() if not k.startswith("energy_")},
        "energy_balance_relative_error": balance.tolist(),
        "escaped_share": st["escaped_rays"] / max(st["rays"], 1),
    }


def _sources_line(field: SoundField) -> str:
    names = field.source_names
    mix = field.settings.get("mix")
    if mix:
        return "a mix: " + ", ".join(f"{n} {10 * np.log10(g):+.1f} dB" for n, g in mix.items()
                                     if g > 0)
    if names == ["all"]:
        return f"{field.source_positions_m.shape[0]}, one field of their sum"
    if len(names) == 1:
        return f"{names[0]}"
    return (f"{len(names)}, a field each: " + ", ".join(f"{k} = {n}" for k, n in enumerate(names))
            + " (pick one with --source NAME, mix with --source NAME=DB ...)")


def format_info(field: SoundField, path: str | Path | None = None) -> str:
    d = info(field)
    st, se = field.stats, field.settings
    rate = st.get("rays_per_second") or 0.0
    seg_rate = st.get("segments_per_second") or 0.0
    theory = st.get("mean_free_path_theory_m", float("nan"))
    balance = max(abs(v) for v in d["energy_balance_relative_error"])
    first, end = se["ray_range"]
    lines = [
        f"sound field of {d['scene']}" + (f"  ({path})" if path else ""),
        f"  receivers   {d['receivers']}, spheres of radius {d['radius_m']:g} m",
        f"  sources     {_sources_line(field)}",
        f"  directions  {len(d['directions'])}: {', '.join(d['directions'])}",
        f"  bands       {', '.join(f'{b:g}' for b in d['bands_hz'])} Hz"
        + (f" ({len(d['bands_hz'])} {d['bands']}s)" if d["bands"] else ""),
        f"  time        {d['duration_s']:.3f} s: {d['early_bins']} one-sample bins at "
        f"{se['sample_rate_hz']} Hz, then {d['late_bin_s'] * 1e3:g} ms bins",
        f"  storage     {_storage_line(field, d)}",
        f"  bake        {se['estimator']} estimator, {se['rays']:,} rays per source"
        f" (range {first:,}..{end:,}), seed {se['seed']}, walls "
        f"{se.get('wall_model', 'random-incidence')}",
        f"  traced      {st['segments']:,} segments, {st['surface_hits']:,} surface hits, "
        f"{st['escaped_rays']:,} escaped, in {st.get('seconds', float('nan')):.2f} s "
        f"({rate:,.0f} rays/s, {seg_rate:,.0f} segments/s)",
        f"  free path   {st['mean_free_path_m']:.3f} m measured, 4V/S = {theory:.3f} m",
        f"  balance     emitted = absorbed + air + escaped + remaining, to {balance:.1e} relative",
    ]
    if se.get("progressive"):
        lines.append(progressive_line(se["progressive"]))
    if field.waves is not None:
        w, runs = field.waves, st.get("waves", {}).get("runs", [])
        lines.append(
            f"  waves       bands {', '.join(f'{b:g}' for b in field.bands_hz[:w['wave_bands']])} Hz "
            f"from the wave solver (crossover {w['crossover_hz']:.0f} Hz, Schroeder frequency "
            f"{w['schroeder_hz']:.0f} Hz), grid up to {w['max_frequency_hz']:.0f} Hz"
            + (f" ({runs[0]['spacing_m'] * 1e3:.1f} mm, {runs[0]['cells']:,} cells × "
               f"{runs[0]['steps']:,} steps × {len(runs)} source(s), "
               f"{st['waves']['seconds']:.2f} s)" if runs else ""))
    if d["escaped_share"] > LEAK_WARNING_SHARE:
        where = "; ".join(f"from ({', '.join(f'{v:.2f}' for v in e[2])})" for e in st["escapes"][:4])
        lines.append(f"  WARNING     {d['escaped_share']:.2%} of rays escaped: the geometry leaks "
                     f"({where})")
    return "\n".join(lines)


def progressive_line(p: dict[str, Any]) -> str:
    """One line on how a progressive bake ended and the standard errors it reached."""
    errors = []
    for name, e in p["errors"].items():
        if "max" not in e:
            errors.append(f"{name.upper()} undefined")
            continue
        scale, unit = (100.0, "%") if e["unit"] == "relative" else (1.0, " dB")
        errors.append(f"{name.upper()} ≤ {e['max'] * scale:.2g}{unit}"
                      + (f" (undefined at {e['undefined']}: more rays needed)"
                         if e.get("undefined") else "")
                      + (" (onset uncertain at receiver "
                         + ", ".join(f"#{r}" for r in e["onset_uncertain"])
                         + ": counted)" if e.get("onset_uncertain") else "")
                      + "".join(f" (left out at {len(at)}: {kind})"
                                for kind, at in e.get("left_out", {}).items()))
    ended = {"converged": f"converged to {p['accuracy_jnd']:g} JND",
             "max_rays": "stopped at --max-rays, not converged",
             "max_seconds": "stopped at --max-seconds, not converged",
             "cancelled": "cancelled, not converged"}.get(p["stopped"], p["stopped"])
    unreached = "".join(f"; no energy reached receiver {u.get('label', u['receiver'])} at ("
                        + ", ".join(f"{v:g}" for v in u["position_m"]) + ") m (left out)"
                        for u in p.get("unreached", []))
    late = describe_tail(p["errors"].get("t30", {}).get("tail"))
    return (f"  accuracy    {ended} in {len(p['rounds'])} rounds; standard error at the worst "
            f"receiver and band: {', '.join(errors)}{unreached}" + (f"; {late}" if late else ""))


def _file_bytes_per_receiver(field: SoundField) -> int | None:
    """Bytes per receiver of the sound field in its file (gzip included), if it has one."""
    if not field.path or not field.n_receivers:
        return None
    try:
        import h5py

        with h5py.File(field.path, "r") as f:
            sizes: list[int] = []
            f["sound"].visititems(lambda _, obj: sizes.append(obj.id.get_storage_size())
                                  if isinstance(obj, h5py.Dataset) else None)
        return sum(sizes) // field.n_receivers
    except (OSError, KeyError):
        return None


def _storage_line(field: SoundField, d: dict[str, Any]) -> str:
    se = field.settings
    if field.compact:
        what = (f"compact: early arrivals exact ({se.get('compact_arrivals')} strongest) over a "
                f"{float(se.get('compact_envelope_s', 0)) * 1e3:g} ms envelope to "
                f"{float(se.get('early_s', 0)) * 1e3:g} ms, late bins of "
                f"{float(se.get('stored_late_bin_s', 0)) * 1e3:g} ms")
    else:
        what = "full: every bin dense"
    size = f"{d['bytes_per_receiver'] / 1e3:,.1f} KB per receiver in memory"
    if d["file_bytes_per_receiver"] is not None:
        size += f", {d['file_bytes_per_receiver'] / 1e3:,.1f} KB in the file"
    return f"{what}; {size}"


def listener_warnings(field: SoundField, receiver: int) -> list[str]:
    """Warnings about listening at ``receiver``: a source inside its sphere makes its direct
    sound and early decay meaningless (the response is not that of a listener in the room)."""
    pos = np.asarray(field.positions_m[receiver], float)
    out = []
    for k, src in enumerate(np.asarray(field.source_positions_m, float).reshape(-1, 3)):
        d = float(np.linalg.norm(src - pos))
        if d <= field.radius_m:
            out.append(f"warning: receiver #{receiver} at ({', '.join(f'{v:g}' for v in pos)}) m "
                       f"holds source {k} ({d:.2f} m away, inside its {field.radius_m:g} m "
                       "sphere): its direct sound is not that of a listener; listen further "
                       "away")
    unreached = [u for u in (field.settings.get("progressive") or {}).get("unreached", [])
                 if u.get("receiver") == receiver]
    if unreached:
        apart = [u["source_name"] for u in unreached if u.get("source") is not None]
        out.append(f"warning: no energy reached receiver #{receiver} in its bake (sealed off "
                   + (f"from source{'s' if len(apart) > 1 else ''} {', '.join(apart)}"
                      if apart else "from the sources")
                   + ", or joined only through an opening too small for the bake's rays): its "
                   + ("response from there is silent" if apart else "response is silent"))
    return out
