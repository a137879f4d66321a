"""``sonolux-web/3``: each cell its source fields' compact fields, synthesised in the browser.
What the files hold, that they decode to the field's own histogram, sizes against /2, and a
bundle written from two source fields."""

from __future__ import annotations

import json
import zlib
from dataclasses import replace

import numpy as np
import pytest

import sonolux
from sonolux.errors import SonoluxError
from sonolux.sound.compact import CompactArray
from sonolux.web import WebExportOptions, export_web
from sonolux.web.bundle import write_compact_bundle
from sonolux.web.compact_cells import (
    Axis,
    CompactCell,
    axis_of,
    cell_response,
    cut_bins,
    dense_histogram,
    fade_cut,
    pressure_energy,
)


def read(bundle):
    index = json.loads((bundle / "field.json").read_text())
    return index, (bundle / "responses.bin").read_bytes()


def parts_of(index, data, r):
    """The cell's parts as CompactCells, read as the viewer reads them (synth/client.ts)."""
    c = index["cells"][r]
    stored = data[c["byte_offset"]:c["byte_offset"] + c["byte_length"]]
    assert zlib.crc32(stored) == c["crc32"]
    block = zlib.decompress(stored)
    assert len(block) == c["raw_length"]
    s = index["synthesis"]
    db = len(index["directions"]) * len(s["bands_hz"])
    out = []
    for f in c["fields"]:
        at = f["byte_offset"]

        def take(dtype, n):
            nonlocal at
            v = np.frombuffer(block, dtype, n, at)
            at += 4 * n
            return v
        cell = take("<u4", f["arrivals"])
        value = take("<f4", f["arrivals"])
        env = take("<f4", db * f["envelope_bins"]).reshape(len(index["directions"]), -1,
                                                         f["envelope_bins"])
        late = take("<f4", db * f["late_bins"]).reshape(len(index["directions"]), -1,
                                                        f["late_bins"])
        out.append(CompactCell(f["onset"], cell, value, env, late))
    return out


def axis(index):
    s = index["synthesis"]
    return Axis(s["early_bins"], s["late_bin_samples"], s["late_split"], s["envelope_split"], 0)


def test_compact_bundle_decodes_to_the_fields_histogram(sound_field, tmp_path):
    """Every cell's block decodes to the field's own dense histogram (CompactArray.receiver)
    over the bins it keeps, bit for bit; the cut leaves out at most 10^-6 of the energy of the
    pressure (pressure_energy)."""
    summary = export_web(sound_field, tmp_path / "b")
    index, data = read(tmp_path / "b")
    field = sonolux.open(sound_field)
    assert index["format"] == "sonolux-web/3" and index["encoding"] == "deflate"
    assert "sample_format" not in index and summary.cells == 15
    assert [f["name"] for f in index["source_fields"]] == ["all"]
    assert index["synthesis"]["bands_hz"] == pytest.approx(list(field.synthesis_bands_hz))
    ax = axis(index)
    for r in (0, 7, 14):
        (part,) = parts_of(index, data, r)
        dense = dense_histogram(part, ax)
        whole = np.asarray(field.energy[r])
        n = dense.shape[-1] - ax.late_split  # the last kept stored bin is spread one-sided
        np.testing.assert_array_equal(dense[..., :n], whole[..., :n])
        length = index["cells"][r]["length_samples"]
        left = pressure_energy(whole.astype(np.float64).sum(axis=0), field.synthesis_bands_hz,
                               field.sample_rate_hz)
        bins_end = np.rint((field.bin_start_s + field.bin_width_s) * field.sample_rate_hz)
        after = left[bins_end > length].sum()
        assert after <= 1.01e-6 * left.sum()  # tail_db 60: at most 10^-6 is left out


def test_compact_bundle_is_smaller_than_responses(sound_field, tmp_path):
    export_web(sound_field, tmp_path / "c")
    export_web(sound_field, tmp_path / "p", WebExportOptions(responses="pcm"))
    c, p = read(tmp_path / "c")[0], read(tmp_path / "p")[0]
    assert p["format"] == "sonolux-web/2"
    assert c["responses_bytes"] < p["responses_bytes"]
    assert [x["length_samples"] for x in c["cells"]][0] > 0


def test_a_cells_response_follows_its_histogram(sound_field, tmp_path):
    """The synthesis the browser follows (cell_response): per direction, the energy of the
    response is what pressure_energy expects of its histogram (Parseval over the bank), within
    10 % (the random impulses' power spectrum is white only on average)."""
    export_web(sound_field, tmp_path / "b")
    index, data = read(tmp_path / "b")
    ax = axis(index)
    (part,) = parts_of(index, data, 3)
    dense = dense_histogram(part, ax)
    s = index["synthesis"]
    length = index["cells"][3]["length_samples"]
    for d in range(dense.shape[0]):
        p = cell_response(dense[d], ax, 10**9, 48000, s["volume_m3"], s["speed_of_sound_m_s"],
                          np.array(s["bands_hz"]), seed=d)
        e_hist = pressure_energy(dense[d].astype(np.float64), np.array(s["bands_hz"]),
                                 48000).sum()
        assert np.sum(p * p) / 48000 == pytest.approx(e_hist, rel=0.1)
        assert fade_cut(p, length, 48000).size <= length


def test_two_source_fields(sound_field, tmp_path):
    """A bundle of two source fields: a part each per cell, their own positions, the second
    (half the energy) decoding to half the first."""
    field = sonolux.open(sound_field)
    assert isinstance(field.energy, CompactArray)
    half = replace(field, energy=field.energy.map_values(lambda v: np.asarray(v) * 0.5,
                                                         np.float32),
                   source_positions_m=np.atleast_2d(field.source_positions_m) + [0.5, 0.0, 0.0])
    write_compact_bundle([("talker", field), ("second", half)], sound_field, tmp_path / "b")
    index, data = read(tmp_path / "b")
    assert [f["name"] for f in index["source_fields"]] == ["talker", "second"]
    assert index["source_fields"][1]["positions_m"][0][0] == pytest.approx(
        np.atleast_2d(field.source_positions_m)[0][0] + 0.5)
    ax = axis(index)
    for r in (0, 9):
        a, b = parts_of(index, data, r)
        assert len(index["cells"][r]["fields"]) == 2
        np.testing.assert_allclose(dense_histogram(b, ax), 0.5 * dense_histogram(a, ax),
                                   rtol=1e-6)
    with pytest.raises(SonoluxError, match="distinct"):
        write_compact_bundle([("a", field), ("a", half)], sound_field, tmp_path / "c")


def test_cut_bins_rule():
    ax = Axis(early_bins=4, late_bin_samples=2, late_split=1, envelope_split=1, late_stored=3)
    per = np.array([1.0, 0, 0, 0, 1e-3, 1e-7, 0])
    # to come from bin 5 on: 1e-7 <= 1.001 × 1e-6: the cut is at bin 5's start (sample 6),
    # one more late bin kept for the spread.
    assert cut_bins(per, ax, 60.0) == (2, 6)
    assert cut_bins(per, ax, None) == (3, 10)
    assert axis_of  # the axis check runs in every export above


def test_responses_option_is_checked():
    with pytest.raises(SonoluxError, match="responses"):
        WebExportOptions(responses="mp3").validate()


def test_a_full_resolution_field_is_made_compact_per_receiver(tmp_path):
    """A field stored at full resolution (--storage full) is reduced a receiver at a time as
    the bake reduces a compact one (128 arrivals, 1 ms envelope), its late bins as they are:
    each cell decodes to that reduction of the receiver's histogram, and keeps its energy."""
    from sonolux import cli

    full = tmp_path / "full.h5"
    assert cli.main(["bake", "paper-small", "-o", str(full), "--rays", "1500", "--no-light",
                     "-q", "--storage", "full"]) == 0
    export_web(full, tmp_path / "f")
    index, data = read(tmp_path / "f")
    field = sonolux.open(full)
    assert index["format"] == "sonolux-web/3" and index["synthesis"]["late_split"] == 1
    eb = index["synthesis"]["early_bins"]
    for r in (0, 14):
        (part,) = parts_of(index, data, r)
        dense = dense_histogram(part, axis(index))
        want = CompactArray.of(np.asarray(field.energy[r:r + 1]), eb).reduce(128, 48).receiver(0)
        n = dense.shape[-1]
        np.testing.assert_array_equal(dense, want[..., :n])
        total = np.asarray(field.energy[r], np.float64)[..., :eb].sum()
        assert dense[..., :eb].astype(np.float64).sum() == pytest.approx(total, rel=1e-5)


def test_cli_responses_flag(sound_field, tmp_path, capsys):
    """export --web writes /3 by default and /2 with --responses pcm, and says which."""
    from sonolux import cli

    assert cli.main(["export", str(sound_field), "--web", str(tmp_path / "c")]) == 0
    assert "(sonolux-web/3)" in capsys.readouterr().out
    assert cli.main(["export", str(sound_field), "--web", str(tmp_path / "p"), "--responses",
                     "pcm"]) == 0
    assert "(sonolux-web/2)" in capsys.readouterr().out
    assert read(tmp_path / "p")[0]["format"] == "sonolux-web/2"
    code = cli.main(["export", str(sound_field), "--web", str(tmp_path / "x"), "--responses",
                     "mp3"])
    assert code == 2 and "--responses" in capsys.readouterr().err


def test_a_field_with_late_groups_is_ungrouped_in_its_cells(tmp_path):
    """A bake whose late bins are grouped per band (each band's own T60/100: the sum in a
    group's first stored bin, docs/fieldfile.md) is written with each group spread over its
    bins, as the field shows it: the browser knows one late resolution. Found on merging: the
    cells carried the groups raw, a staircase of 45 ms steps at 125 Hz in the mesh room.
    Measured: sums per band equal, Schroeder curves within 0.14 dB down to -40 dB."""
    from sonolux import cli

    path = tmp_path / "mesh.h5"
    assert cli.main(["bake", "examples/scenes/mesh_room.toml", "-o", str(path), "--rays",
                     "3000", "--no-light", "-q"]) == 0
    field = sonolux.open(path)
    assert field.energy.late_groups is not None and field.energy.late_groups.max() > 1
    export_web(path, tmp_path / "b")
    index, data = read(tmp_path / "b")
    ax = axis(index)
    for r in (3, 20):
        (part,) = parts_of(index, data, r)
        got = dense_histogram(part, ax).sum(axis=0).astype(np.float64)
        want = np.asarray(field.energy[r], np.float64).sum(axis=0)[:, :got.shape[-1]]
        np.testing.assert_allclose(got.sum(axis=-1), want.sum(axis=-1), rtol=1e-5)
        for b in range(got.shape[0]):
            g, w = (np.cumsum(x[b][::-1])[::-1] for x in (got, want))
            keep = w > w[0] * 1e-4
            assert np.abs(10 * np.log10(g[keep] / w[keep])).max() < 0.3, (r, b)
