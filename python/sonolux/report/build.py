"""``sonolux report``: one static HTML page of one or more sound fields.

The folder holds ``index.html``, its figures in ``img/`` and its sounds in ``audio/``, all by
relative path, no scripts and no external files: it opens offline in any browser. It is written
to a temporary folder beside the target and renamed into place, so a failed run leaves the
previous report as it was. Per field: the scene, the bake's statistics with its energy balance,
the ISO 3382-1 parameters over the grid and at one cell (with Sabine and Eyring), the cell's
echograms per direction and decay curves, parameter maps, the light view and auralizations.
"""

from __future__ import annotations

import math
import re
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.analysis.params import PARAMETERS, RoomParameters, room_parameters, scene_of
from sonolux.analysis.tables import (
    DIRECTIONAL_SHOWN,
    describe_undefined,
    format_value,
    label_of,
    undefined_reasons,
)
from sonolux.errors import SonoluxError
from sonolux.fieldfile import open_field
from sonolux.outputs import atomic_folder
from sonolux.report import extras
from sonolux.report import html as h
from sonolux.sound.field import SoundField
from sonolux.sound.info import info
from sonolux.sound.pick import pick_sources


@dataclass
class ReportOptions:
    """``at``: the cell shown in detail (default: the first source's cell). ``light_images``:
    rendered views, one per field in order (else rendered if the field has light).
    ``audio``: WAV files offered as players. ``auralize``: auralize a generated dry signal at
    the cell. ``texts`` and ``figures``: (heading, preformatted text) and (PNG, caption) shown
    before the fields, e.g. by the paper's experiment."""

    at: tuple[float, float] | None = None
    light_images: list[Path] = field(default_factory=list)
    audio: list[Path] = field(default_factory=list)
    auralize: bool = False
    #: Which sources of each field (:func:`sonolux.sound.pick.pick_sources`): specs such as
    #: "desk" or ("door", -6.0); empty: every source as baked.
    sources: list[Any] = field(default_factory=list)
    title: str | None = None
    texts: list[tuple[str, str]] = field(default_factory=list)
    figures: list[tuple[Path, str]] = field(default_factory=list)

    def validate(self) -> ReportOptions:
        for p in [*self.light_images, *self.audio, *(f for f, _ in self.figures)]:
            if not Path(p).is_file():
                raise SonoluxError(f"{p}: no such file for the report")
        return self


def build_report(field_paths: list[Path], out_dir: Path, options: ReportOptions | None = None,
                 *, log: Callable[[str], None] = lambda m: None) -> Path:
    """Writes the report folder and returns the path of its ``index.html``."""
    options = (options or ReportOptions()).validate()
    out_dir = Path(out_dir)
    _check_target(out_dir)
    # every error before anything is written
    fields = [pick_sources(open_field(p), options.sources) for p in field_paths]
    with atomic_folder(out_dir) as tmp:
        (tmp / "img").mkdir()
        (tmp / "audio").mkdir()
        title = options.title or ("sonolux report: " + ", ".join(f.scene_name for f in fields))
        body = [f"<h1>{h.esc(title)}</h1>"]
        if len(fields) > 1:
            body.append("<nav>" + "".join(f'<a href="#{_slug(k, f)}">{h.esc(f.scene_name)}</a>'
                                          for k, f in enumerate(fields)) + "</nav>")
        for heading, text in options.texts:
            body.append(f"<h3>{h.esc(heading)}</h3><pre>{h.esc(text)}</pre>")
        for k, (png, caption) in enumerate(options.figures):
            name = f"img/extra-{k}-{Path(png).name}"
            shutil.copyfile(png, tmp / name)
            body.append(h.figure(name, caption))
        if options.audio:
            body.append("<h2>Listening</h2>")
            for k, wav in enumerate(options.audio):
                name = f"audio/given-{k}-{Path(wav).stem}.wav"
                body.append(h.audio(name, f"{Path(wav).name} ({extras.browser_copy(wav, tmp / name)})"))
        for k, (f, path) in enumerate(zip(fields, field_paths)):
            log(f"report: {f.scene_name} ({f.n_receivers} receivers)")
            light = options.light_images[k] if k < len(options.light_images) else None
            body.append(_field_section(k, f, Path(path), tmp, options, light))
        body.append('<p class="muted">Written by sonolux. Parameters follow ISO 3382-1:2009; '
                    "just-noticeable differences: EDT 5 %, C80 1 dB, D50 0.05, Ts 10 ms, "
                    "G 1 dB.</p>")
        (tmp / "index.html").write_text(h.page(title, "\n".join(body)), encoding="utf-8")
    return out_dir / "index.html"


def _check_target(out_dir: Path) -> None:
    if out_dir.exists() and (not out_dir.is_dir() or (any(out_dir.iterdir())
                                                       and not (out_dir / "index.html").exists())):
        raise SonoluxError(f"{out_dir}: exists and is not a report folder; choose another -o")


def _slug(k: int, f: SoundField) -> str:
    return f"f{k}-" + re.sub(r"[^a-z0-9]+", "-", f.scene_name.lower()).strip("-")


def _shown_cell(f: SoundField, at: tuple[float, float] | None) -> int:
    if at is not None:
        return f.cell_at(*at)
    d = np.linalg.norm(f.positions_m[:, :2] - f.source_positions_m[0, :2], axis=1)
    return int(np.argmin(d))


# --- one field ------------------------------------------------------------------------------


def _field_section(k: int, f: SoundField, path: Path, tmp: Path, options: ReportOptions,
                   light_image: Path | None) -> str:
    from sonolux.plotting.maps import plan_section, plot_parameter_maps
    from sonolux.plotting.responses import plot_azimuth_echograms, plot_decay_curves

    slug = _slug(k, f)
    grid = room_parameters(f)
    cell = _shown_cell(f, options.at)
    one = room_parameters(f, [cell], directional=True, theory=False)
    one.theory = grid.theory
    scene, why_no_scene = scene_of(f)
    xy = tuple(float(v) for v in f.positions_m[cell, :2])
    out = [f'<h2 id="{slug}">{h.esc(f.scene_name)}</h2>',
           f'<p class="muted">{h.esc(path)}</p>', "<h3>Scene</h3>", _scene_summary(f, scene)]
    if why_no_scene:
        out.append(h.note(f"No room outline and no Sabine/Eyring: {why_no_scene}."))

    out.append("<h3>Bake</h3>" + _bake_statistics(f))

    out.append("<h3>Light</h3>")
    view = f"img/{slug}-light.png"
    if light_image is not None:
        shutil.copyfile(light_image, tmp / view)
        out.append(h.figure(view, f"the lit room ({light_image.name})"))
    else:
        why = extras.render_light_view(path, tmp / view)
        out.append(h.note(f"No light view: {why}.") if why else
                   h.figure(view, "the lit room, rendered from the field's light (default camera)"))

    out.append("<h3>Room-acoustic parameters over the grid</h3>")
    out.append(f"<p>Mean over {grid.receivers.size} receivers, with the range (min–max) "
               "below each. Broadband is the mean of the bands' energies (a flat-spectrum "
               "source). Sabine and Eyring include air absorption.</p>")
    out.append(_parameter_table(grid, summary=True))
    if grid.sti is not None:
        ok = grid.sti[np.isfinite(grid.sti)]
        out.append(f"<p>STI over the receivers: mean {ok.mean():.2f}, range {ok.min():.2f}–"
                   f"{ok.max():.2f} ({h.esc(grid.sti_method)}).</p>" if ok.size else
                   h.note("STI is undefined at every receiver."))
    out += [h.note(n) for n in grid.notes]
    out.append(_outlier_list(grid))
    if f.band_set is not None and f.band_set.kind == "third-octave":
        from sonolux.analysis.octaves import octave_field

        octaves = room_parameters(octave_field(f), sti=False)
        out.append("<h3>The same in octaves, summed from the thirds</h3>")
        out.append("<p>Each octave's histogram is the sum of its three thirds' energies; the "
                   "parameters are computed from that sum, never averaged over thirds "
                   "(docs/bands.md).</p>")
        out.append(_parameter_table(octaves, summary=True))

    out.append(f"<h3>At the cell ({xy[0]:g}, {xy[1]:g}) m</h3>")
    out.append(_parameter_table(one, summary=False))
    out.append("<p>Per direction (broadband): the energy arriving from that direction only.</p>")
    rows = [[name] + [_direction_cell(one, n, d) for n in DIRECTIONAL_SHOWN]
            for d, name in enumerate(one.direction_names)]
    out.append(h.table(["direction"] + [label_of(n) for n in DIRECTIONAL_SHOWN], rows))

    echo = plot_azimuth_echograms(f, cell, tmp / f"img/{slug}-echograms.png")
    out.append(h.figure(f"img/{echo.name}", "Energy per millisecond from each azimuth sector, "
                        "laid out around a listener facing +x (front at the top, right on the "
                        "right); the paper's figure 7 shows the front and right panels."))
    edc = plot_decay_curves(f, cell, tmp / f"img/{slug}-decay.png")
    out.append(h.figure(f"img/{edc.name}", "Schroeder decay curves (the plain backward "
                        "integral of the simulated record) per band and broadband; T30 is "
                        "fitted over the shaded range."))
    if f.waves is not None:
        out.append(_modes_figure(f, scene, tmp, slug))
    outline = (plan_section(scene.vertices_m, scene.triangles, float(np.mean(f.positions_m[:, 2])))
               if scene is not None else None)
    for part, names in (("maps", ("t30_s", "c80_db", "d50", "g_db")),
                        ("maps-more", ("edt_s", "c50_db", "ts_s", "jlf"))):
        areas: list = []
        png = plot_parameter_maps(f, grid, tmp / f"img/{slug}-{part}.png", names=names,
                                  outline=outline, mark_m=xy, undefined_areas=areas)
        out.append(h.image_map(f"img/{png.name}", "Broadband parameters over the floor plan (x "
                               "along the width, y up); star: the source, circle: the cell above; "
                               "grey crosses: undefined values (hover for the reason). Cells whose "
                               "sphere holds the source are left out of the colour scale.",
                               f"{slug}-{part}", areas))

    out.append(_joint_section(f, grid, path, tmp, slug, outline))

    if options.auralize:
        out.append("<h3>Listening</h3>" + _auralizations(f, path, tmp, slug, xy))
    return "\n".join(out)


def _modes_figure(f: SoundField, scene, tmp: Path, slug: str) -> str:
    """The spectrum of the waves' pressure (a hybrid bake's low bands) at the receiver farthest
    from the first source, where the direct sound weighs least, with the rigid-box modes marked
    when the room is a box."""
    from sonolux.plotting.modes import plot_wave_spectrum

    cell = int(np.argmax(np.linalg.norm(f.positions_m - f.source_positions_m[0], axis=1)))
    box = None
    if scene is not None:
        sides = scene.mesh_report["bbox_max"] - scene.mesh_report["bbox_min"]
        if np.isclose(float(np.prod(sides)), scene.volume_m3, rtol=1e-6):
            box = sides
    png = plot_wave_spectrum(f, cell, tmp / f"img/{slug}-modes.png", box_m=box)
    w = f.waves or {}
    marked = ", marked where a rigid box has them" if box is not None else ""
    return h.figure(f"img/{png.name}", f"The low bands from the wave solver (below "
                    f"{w.get('crossover_hz', 0):.0f} Hz; Schroeder frequency "
                    f"{w.get('schroeder_hz', 0):.0f} Hz): the pressure response's spectrum at the "
                    f"receiver farthest from the source shows the room's modes{marked}.")


def _joint_section(f: SoundField, grid: RoomParameters, path: Path, tmp: Path, slug: str,
                   outline) -> str:
    """Light and sound over one floor plan (``sonolux maps``), when the file has a work plane."""
    from sonolux.analysis.joint import DEFAULT_CRITERIA, Criterion, joint_map
    from sonolux.fieldfile import contents, open_light_field
    from sonolux.plotting.joint import plot_joint_map

    out = ["<h3>Light and sound on one floor plan</h3>"]
    light = open_light_field(path) if contents(path)["light"] else None
    if light is None or light.workplane is None:
        return "\n".join(out + [h.note("No joint map: the file has no light baked on a work "
                                        "plane (add [workplane] to the scene and bake light "
                                        "and sound together).")])
    joint = joint_map(f, grid, light, [Criterion.parse(t) for t in DEFAULT_CRITERIA])
    png = plot_joint_map(joint, tmp / f"img/{slug}-joint.png", outline)
    wp = light.workplane.summary()
    out.append(f"<p>Work plane at {wp['height_m']:g} m: mean {wp['mean_lx']:.0f} lx, minimum "
               f"{wp['min_lx']:.0f} lx, uniformity U₀ = E_min/E_mean = "
               f"{wp['uniformity_min_over_mean']:.2f} (EN 12464-1).</p>")
    rows = [[text, c["pass"], c["fail"], c["undefined"]]
            for text, c in joint.summary()["criteria"].items()]
    if rows:
        out.append(h.table(["criterion", "pass", "fail", "undefined"], rows))
    out += [h.note(n) for n in joint.notes]
    out.append(h.figure(f"img/{png.name}", "Illuminance on the work plane beside the "
                        "room-acoustic single numbers at the receivers (ISO 3382-1: mean of "
                        "500 Hz and 1 kHz); red crosses fail a criterion."))
    return "\n".join(out)


def _scene_summary(f: SoundField, scene) -> str:
    s, st = f.settings, f.stats
    src = "; ".join(f"{w:g} W at ({', '.join(f'{v:g}' for v in p)}) m"
                    for p, w in zip(f.source_positions_m, f.source_powers_w))
    items = [("scene", f"{f.scene_name} ({f.scene_origin})"),
             ("volume, surface", f"{s['volume_m3']:.4g} m³, {s['area_m2']:.4g} m²"),
             ("sources", src),
             ("receivers", f"{f.n_receivers}" + (f", a grid every {f.grid_spacing_m:g} m"
                                                  if f.grid_spacing_m else " points")
              + f", spheres of radius {f.radius_m:g} m"),
             ("bands", ", ".join(f"{b:g}" for b in f.bands_hz) + " Hz"),
             ("directions", f"{f.azimuth_bands} azimuth sectors × {f.elevation_bands} "
                            "elevation band(s)"),
             ("air", f"{s['air']['temperature_c']:g} °C, {s['air']['humidity_percent']:g} % RH, "
                     f"c = {s['speed_of_sound_m_s']:.1f} m/s"),
             ("bake", f"{s['estimator']} estimator, {s['rays']:,} rays, seed {s['seed']}, "
                      f"{s['max_time_s']:.2f} s recorded at {s['sample_rate_hz']} Hz"),
             ("time", f"{st.get('seconds', float('nan')):.1f} s "
                      f"({st.get('rays_per_second') or 0:,.0f} rays/s)")]
    if scene is not None:
        items.insert(1, ("geometry", f"{scene.triangles.shape[0]} triangles, "
                                     f"{len(scene.materials)} materials"))
    return h.definitions(items)


def _bake_statistics(f: SoundField) -> str:
    st = f.stats
    d = info(f)
    emitted = np.asarray(st["energy_emitted_j"], float)
    shares = {k: np.asarray(st[f"energy_{k}_j"], float) / emitted
              for k in ("absorbed_surfaces", "absorbed_air", "escaped", "remaining")}
    rows = [[f"{b:g}", f"{emitted[i]:.4g}"] + [f"{100 * shares[k][i]:.3f}" for k in shares]
            + [f"{d['energy_balance_relative_error'][i]:.1e}"] for i, b in enumerate(f.bands_hz)]
    mfp = st["mean_free_path_m"]
    theory = st.get("mean_free_path_theory_m", float("nan"))
    text = (f"<p>{st['segments']:,} ray segments, {st['surface_hits']:,} surface hits, "
            f"{st['escaped_rays']:,} escaped rays ({d['escaped_share']:.2%}). Mean free path "
            f"{mfp:.3f} m measured against 4V/S = {theory:.3f} m "
            f"({100 * (mfp / theory - 1):+.2f} %).</p>")
    return text + h.table(["band Hz", "emitted J", "surfaces %", "air %", "escaped %",
                           "remaining %", "balance error"], rows)


def _value_cell(p: RoomParameters, name: str, value: float, column: int, receiver=None):
    """A formatted value, or 'undefined' with the reasons on hover where it is not finite."""
    if math.isfinite(value):
        return format_value(name, value)
    if receiver is not None and name.removesuffix("_s") in p.reasons:
        why = p.reasons[name.removesuffix("_s")][receiver, column] or "not defined here"
        return h.undefined("undefined", why)
    reasons = undefined_reasons(p, name, column)
    if not reasons:
        return h.undefined("undefined", "not defined at any receiver (e.g. no receiver-source "
                                        "line, or no energy)")
    return h.undefined("undefined", describe_undefined(reasons))


def _direction_cell(p: RoomParameters, name: str, d: int):
    value = p.directional[name][0, d, -1]
    if math.isfinite(value):
        return format_value(name, value)
    why = (p.directional_reasons or {}).get(name.removesuffix("_s"))
    return h.undefined("undefined", (why[0, d, -1] if why is not None else "") or "not defined")


def _outlier_list(p: RoomParameters, shown: int = 12) -> str:
    """The receivers that stand out from their neighbours (analysis.consistency)."""
    if not p.outliers:
        return ("<p>No receiver's EDT, T20 or T30 stands out from its neighbours beyond the "
                "Monte Carlo scatter (4σ) and the just-noticeable difference (5 %).</p>")
    rows = []
    for o in p.outliers[:shown]:
        label, unit, scale, _ = PARAMETERS[o["parameter"]]
        rows.append([f"#{o['receiver']} ({o['position_m'][0]:g}, {o['position_m'][1]:g})",
                     f"{label} {o['column']}", f"{o['value'] * scale:.2f} {unit}",
                     f"{o['neighbours_median'] * scale:.2f} {unit}",
                     f"{o['monte_carlo_sigma'] * scale:.3f} {unit}", o["cause"]])
    more = f" ({len(p.outliers) - shown} more in sonolux params --json)" \
        if len(p.outliers) > shown else ""
    return ("<p>Receivers whose decay times stand out from their neighbours beyond the Monte "
            f"Carlo scatter (4σ, estimated from all neighbour differences){more}:</p>"
            + h.table(["receiver (x, y) m", "parameter", "value", "neighbours", "σ", "likely cause"],
                      rows))


def _partly(p: RoomParameters, name: str, text: str, column: int):
    """A summary cell: its text, with the reasons on hover where some receivers are undefined."""
    reasons = undefined_reasons(p, name, column)
    if not reasons:
        return text
    return h.undefined(text + "*", "mean over the defined receivers; undefined at "
                       + describe_undefined(reasons))


def _parameter_table(p: RoomParameters, *, summary: bool) -> str:
    header = ["parameter"] + [c if c == "broadband" else f"{c} Hz" for c in p.columns]
    rows, classes = [], []
    s = p.summary() if summary else None
    for name in PARAMETERS:
        if summary:
            rows.append([label_of(name)] + [
                _partly(p, name, format_value(name, v), c) if math.isfinite(v)
                else _value_cell(p, name, v, c) for c, v in enumerate(s[name]["mean"])])
            rows.append([""] + [f"{format_value(name, a)}–{format_value(name, b)}"
                                if math.isfinite(a) else "–"
                                for a, b in zip(s[name]["min"], s[name]["max"])])
            classes += ["", "sub"]
        else:
            rows.append([label_of(name)] + [_value_cell(p, name, v, c, receiver=0)
                                            for c, v in enumerate(p.values[name][0])])
            classes.append("")
    for label, key in (("Sabine T60 s", "sabine_t60_s"), ("Eyring T60 s", "eyring_t60_s")):
        if key in p.theory:
            rows.append([label] + [h.number(v) for v in p.theory[key]] + ["–"])
            classes.append("theory")
    return h.table(header, rows, classes=classes)


def _auralizations(f: SoundField, path: Path, tmp: Path, slug: str,
                   xy: tuple[float, float]) -> str:
    from sonolux.audio import write_wav

    dry = tmp / "audio" / f"dry-{f.sample_rate_hz}.wav"
    if not dry.exists():
        write_wav(dry, extras.dry_signal(f.sample_rate_hz), f.sample_rate_hz, subtype="PCM_16")
    out = [h.audio(f"audio/{dry.name}", "the dry signal (clicks, plucked notes, a noise burst)")]
    made, why = extras.auralize(path, dry, xy, tmp / "audio", slug)
    for wav, caption in made:
        out.append(h.audio(f"audio/{wav.name}", f"{caption} ({extras.browser_copy(wav, wav)})"))
    if why:
        out.append(h.note(f"No auralization: {why}."))
    return "\n".join(out)
