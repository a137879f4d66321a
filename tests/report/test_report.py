"""``sonolux report``: a self-contained folder that opens offline, written atomically, with
notes where the light or auralization halves are missing."""

from __future__ import annotations

import re

import h5py
import numpy as np
import pytest
import soundfile as sf

from sonolux import cli
from sonolux.audio import write_wav
from sonolux.errors import SonoluxError
from sonolux.fieldfile import save_fields
from sonolux.report import extras
from sonolux.report.build import ReportOptions, build_report
from tests.analysis.fields import decaying_grid
from tests.plots.test_plots import PNG


@pytest.fixture
def field_file(tmp_path):
    field, _, _ = decaying_grid((0.6, 1.3, 2.0), duration_s=2.5)
    return save_fields(tmp_path / "grid.h5", sound=field)


def references(index):
    """Every src and href of the page."""
    return re.findall(r'(?:src|href)="([^"]+)"', index.read_text(encoding="utf-8"))


def check_self_contained(index):
    refs = references(index)
    assert refs, "the page references its figures"
    for ref in refs:
        if ref.startswith("#"):
            continue
        assert "://" not in ref and not ref.startswith("/"), ref  # relative, offline
        assert (index.parent / ref).is_file(), ref
        if ref.endswith(".png"):
            assert (index.parent / ref).read_bytes()[:8] == PNG
    return refs


def test_report_of_a_field(tmp_path, field_file):
    out = tmp_path / "report"
    index = build_report([field_file], out)
    assert index == out / "index.html"
    refs = check_self_contained(index)
    assert sum(r.endswith(".png") for r in refs) == 4  # echograms, decay curves, two maps
    html = index.read_text(encoding="utf-8")
    for text in ("Room-acoustic parameters over the grid", "T30 s", "JLF", "balance error",
                 "No light view: this field file holds no light field", "<table>"):
        assert text in html, text
    assert "<script" not in html and "stylesheet" not in html
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".report")]  # no leftovers
    # A second run replaces the report; a folder that is not a report is refused.
    build_report([field_file], out, ReportOptions(title="again"))
    assert "<title>again</title>" in index.read_text(encoding="utf-8")
    other = tmp_path / "mine"
    other.mkdir()
    (other / "notes.txt").write_text("keep me")
    with pytest.raises(SonoluxError, match="not a report folder"):
        build_report([field_file], other)
    assert (other / "notes.txt").read_text() == "keep me"


def test_a_bad_field_writes_nothing(tmp_path, field_file):
    with pytest.raises(SonoluxError, match="no such file"):
        build_report([field_file, tmp_path / "missing.h5"], tmp_path / "report")
    assert not (tmp_path / "report").exists()
    with pytest.raises(SonoluxError, match="no such file"):
        build_report([field_file], tmp_path / "r2", ReportOptions(audio=[tmp_path / "x.wav"]))


def test_light_image_audio_and_extras(tmp_path, field_file, monkeypatch):
    light = tmp_path / "view.png"
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.imsave(light, np.random.default_rng(0).random((20, 30, 3)))
    given = write_wav(tmp_path / "ir.wav", np.linspace(0, 0.5, 4800), 48000)
    figure = tmp_path / "fig.png"
    plt.imsave(figure, np.zeros((5, 5, 3)))

    def fake_auralize(field_path, dry, at_m, out_dir, stem):
        data, rate = sf.read(dry)
        wav = write_wav(out_dir / f"{stem}-binaural.wav", np.stack([data, 0.5 * data], 1), rate)
        return [(wav, "binaural")], "cube8: not available in this test"

    monkeypatch.setattr(extras, "auralize", fake_auralize)
    options = ReportOptions(light_images=[light], audio=[given], auralize=True,
                            texts=[("A table", "a  b\n1  2")], figures=[(figure, "figure 7")])
    index = build_report([field_file], tmp_path / "report", options)
    refs = check_self_contained(index)
    html = index.read_text(encoding="utf-8")
    assert "the lit room (view.png)" in html and "A table" in html and "figure 7" in html
    assert "No auralization: cube8: not available in this test" in html
    wavs = [r for r in refs if r.endswith(".wav")]
    assert len(wavs) >= 3  # the given IR, the dry signal, the binaural (players and links)
    for ref in set(wavs):
        info = sf.info(str(index.parent / ref))
        assert info.subtype == "PCM_16", ref  # plays in every browser
    data, _ = sf.read(str(index.parent / "audio" / "given-0-ir.wav"))
    assert np.max(np.abs(data)) == pytest.approx(10 ** (-1 / 20), abs=1e-4)


def test_light_and_auralization_that_fail_are_notes(tmp_path, field_file):
    assert "holds no light field" in extras.render_light_view(field_file, tmp_path / "v.png")
    with h5py.File(field_file, "a") as f:
        f.create_group("light")  # a light group with nothing in it
    why = extras.render_light_view(field_file, tmp_path / "v.png")
    assert "could not be rendered" in why and "incomplete" in why
    made, why = extras.auralize(field_file, tmp_path / "dry.wav", (1, 1), tmp_path, "x")
    assert made == [] and "auralization failed for binaural" in why and "dry.wav" in why


def test_dry_signal_is_deterministic_and_bounded():
    a, b = extras.dry_signal(48000), extras.dry_signal(48000)
    assert np.array_equal(a, b) and a.shape == (144000,) and np.max(np.abs(a)) < 1.0


def test_report_command(capsys, tmp_path, field_file):
    code = cli.main(["report", str(field_file), "-o", str(tmp_path / "r"), "--at", "2,1.25"])
    out, err = capsys.readouterr()
    assert code == 0 and "index.html" in out and "file://" in out
    assert "At the cell (2, 1.25) m" in (tmp_path / "r" / "index.html").read_text(encoding="utf-8")
    code = cli.main(["report", str(tmp_path / "nope.h5"), "-o", str(tmp_path / "r")])
    assert code == 2 and "no such file" in capsys.readouterr().err


def test_the_experiment_writes_its_report(tmp_path, field_file):
    import matplotlib.pyplot as plt

    from sonolux.experiment import write_report

    plt.imsave(tmp_path / "figure7.png", np.zeros((5, 5, 3)))
    write_wav(tmp_path / "paper-small-centre-front.wav", np.ones(100) * 0.1, 48000)
    results = {"paper-small": {"field": str(field_file), "bands_hz": [500.0, 1000.0],
                               "t30_s": [0.6, 0.6], "sabine_t60_s": [0.5, 0.5],
                               "eyring_t60_s": [0.45, 0.45]}}
    index = write_report(results, tmp_path, log=lambda m: None)
    check_self_contained(index)
    html = index.read_text(encoding="utf-8")
    assert "Reverberation at the central cell" in html and "paper-small-centre-front" in html


def test_undefined_values_show_their_reason_on_hover(tmp_path):
    # Records of 0.5 s: T30 of the slower decays cannot be measured. The table shows
    # 'undefined' (or a mean over the defined receivers, starred) with the reasons in a
    # title, and the maps mark the cells, with the reason on hover (an image map).
    field, _, _ = decaying_grid((0.6, 1.3, 2.0), duration_s=0.5)
    path = save_fields(tmp_path / "short.h5", sound=field)
    index = build_report([path], tmp_path / "report")
    page = index.read_text(encoding="utf-8")
    cells = re.findall(r'<td class="undefined" title="([^"]+)">([^<]+)</td>', page)
    assert cells, "undefined cells carry their reason"
    assert any("range not reached" in t or "record too short" in t for t, _ in cells)
    assert all(text in ("undefined",) or text.endswith("*") for _, text in cells)
    areas = re.findall(r'<area shape="rect" coords="(\d+),(\d+),(\d+),(\d+)" title="([^"]+)"', page)
    assert areas and all("undefined at #" in a[-1] for a in areas)
    assert all(int(x0) < int(x1) and int(y0) < int(y1) for x0, y0, x1, y1, _ in areas)
    check_self_contained(index)


def test_a_third_octave_field_reports_thirds_octaves_summed_from_them_and_sti(tmp_path):
    # 21 thirds, 100 Hz … 10 kHz: the table has a column per third, a second table the octaves
    # 125 Hz … 8 kHz summed from them, and STI (which needs those octaves) is reported.
    thirds = (100, 125, 160, 200, 250, 315, 400, 500, 630, 800, 1000, 1250, 1600, 2000, 2500,
              3150, 4000, 5000, 6300, 8000, 10000)
    field, _, _ = decaying_grid((0.6, 1.3, 2.0), duration_s=2.5, bands=len(thirds))
    field.bands_hz = np.asarray(thirds, float)
    field.settings["bands"] = "third-octave"
    path = save_fields(tmp_path / "thirds.h5", sound=field)
    page = build_report([path], tmp_path / "report").read_text(encoding="utf-8")
    assert "<th>10000 Hz</th>" in page and "<th>6300 Hz</th>" in page
    assert "The same in octaves, summed from the thirds" in page
    assert "STI over the receivers: mean" in page
