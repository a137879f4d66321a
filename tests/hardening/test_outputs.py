"""Outputs: every command that writes, asked to write where it cannot (a file where a folder
should be, a folder where a file should be, a system folder, a name with a NUL byte), is exit
status 2 and one line naming the target, and leaves nothing behind; what it writes follows the
umask; a picture holds the format its name says."""

from __future__ import annotations

import os
import stat

import pytest

from .conftest import assert_usage_error, run

#: Each writing command, with {out} where its output goes.
WRITERS = {
    "bake": ["bake", "paper-small", "--rays", "500", "--particles", "2000", "-q", "-o", "{out}.h5"],
    "ir": ["ir", "{f}", "--at", "1,1", "-o", "{out}.wav"],
    "ir-filters": ["ir", "{f}", "--at", "1,1", "--paper-filters", "-o", "{out}.wav"],
    "auralize": ["auralize", "{f}", "builtin:clicks:0.3", "--at", "1,1", "-o", "{out}.wav"],
    "render": ["render", "{f}", "-o", "{out}.png", "--size", "32x16", "--samples", "1"],
    "render-hdr": ["render", "{f}", "-o", "{d}/ok.png", "--hdr", "{out}.pfm", "--size", "32x16"],
    "gltf": ["export", "{f}", "--gltf", "{out}.glb"],
    "web": ["export", "{f}", "--web", "{out}"],
    "report": ["report", "{f}", "-o", "{out}"],
}
FOLDER_OUTPUTS = {"web", "report"}


def targets(tmp_path, writer):
    blocker = tmp_path / "blocker"
    blocker.write_text("a file, not a folder")
    folder = tmp_path / "folder"
    folder.mkdir()
    out = {"under-a-file": blocker / "sub" / "x", "proc": "/proc/sonolux-cannot-write",
           "nul": str(tmp_path / "a\x00b")}
    if writer not in FOLDER_OUTPUTS:
        out["is-a-folder"] = folder / "x"
        (folder / "x.h5").mkdir()
        for suffix in (".wav", ".png", ".pfm", ".glb"):
            (folder / f"x{suffix}").mkdir()
    return out


CASES = [(w, t) for w in WRITERS for t in ("under-a-file", "proc", "nul", "is-a-folder")
         if not (w in FOLDER_OUTPUTS and t == "is-a-folder")]


@pytest.mark.parametrize(("writer", "target"), CASES, ids=[f"{w}-{t}" for w, t in CASES])
def test_an_unwritable_target_is_named(capsys, field_file, tmp_path, writer, target):
    out = targets(tmp_path, writer)[target]
    argv = [a.format(f=field_file, d=tmp_path, out=out) for a in WRITERS[writer]]
    before = sorted(p.name for p in tmp_path.rglob("*"))
    code, _, err = run(capsys, *argv)
    shown = str(out).split("\x00")[0]
    assert_usage_error(code, err, shown if target != "nul" else "")
    after = sorted(p.name for p in tmp_path.rglob("*"))
    assert [n for n in after if "partial" in n or n not in before and n != "ok.png"] == []


@pytest.mark.parametrize("umask", [0o027])
@pytest.mark.parametrize("writer", sorted(WRITERS))
def test_outputs_follow_the_umask(capsys, field_file, tmp_path, writer, umask):
    out = tmp_path / "out"
    argv = [a.format(f=field_file, d=tmp_path, out=out) for a in WRITERS[writer]]
    old = os.umask(umask)
    try:
        code, _, err = run(capsys, *argv)
    finally:
        os.umask(old)
    assert code == 0, err
    written = [p for p in tmp_path.iterdir() if p.name.startswith("out")]
    assert written, "nothing written"
    for top in written:
        for p in [top, *top.rglob("*")]:
            want = (0o777 if p.is_dir() else 0o666) & ~umask
            assert stat.S_IMODE(p.stat().st_mode) == want, (p, oct(p.stat().st_mode))
    assert not [p for p in tmp_path.rglob("*") if "partial" in p.name]


@pytest.mark.parametrize(("suffix", "magic"), [(".png", b"\x89PNG"), (".jpg", b"\xff\xd8"),
                                                (".jpeg", b"\xff\xd8"), (".PNG", b"\x89PNG")])
def test_a_picture_holds_the_format_its_name_says(capsys, field_file, tmp_path, suffix, magic):
    out = tmp_path / f"view{suffix}"
    code, _, err = run(capsys, "render", field_file, "-o", out, "--size", "32x16")
    assert code == 0, err
    assert out.read_bytes().startswith(magic)


@pytest.mark.parametrize("suffix", [".gif", ".tiff", "", ".exr"])
def test_a_picture_name_of_another_format_is_refused_before_rendering(capsys, field_file,
                                                                       tmp_path, suffix):
    out = tmp_path / f"view{suffix}"
    code, _, err = run(capsys, "render", field_file, "-o", out, "--size", "32x16")
    assert_usage_error(code, err, out.name or "view")
    assert list(tmp_path.iterdir()) == []


def test_a_leftover_of_a_killed_run_is_replaced(capsys, field_file, tmp_path):
    out = tmp_path / "ir.wav"
    dead = 2**22 + 7  # above any pid_max: no such process
    (tmp_path / f"ir.partial-{dead}.wav").write_bytes(b"half a file")
    (tmp_path / "ir.partial-1.wav").write_bytes(b"a live writer's (pid 1 is always running)")
    code, _, err = run(capsys, "ir", field_file, "--at", "1,1", "-o", out)
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ir.partial-1.wav", "ir.wav"]


def test_a_leftover_folder_of_a_killed_export_is_removed(capsys, field_file, tmp_path):
    dead = 2**22 + 7
    (tmp_path / f"web.partial-{dead}").mkdir()
    (tmp_path / f"web.old-{dead}").mkdir()
    code, _, err = run(capsys, "export", field_file, "--web", tmp_path / "web")
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["web"]


def test_a_failed_run_keeps_the_previous_output(capsys, field_file, tmp_path):
    out = tmp_path / "ir.wav"
    out.write_bytes(b"the previous output")
    code, _, err = run(capsys, "ir", field_file, "--at", "90,90", "-o", out)
    assert code == 2 and out.read_bytes() == b"the previous output"
