"""``sonolux export FIELD --sofa OUT.sofa``: AES69 SingleRoomSRIR, read back with sofar."""

from __future__ import annotations

import os

import numpy as np
import pytest

import sonolux
from sonolux import cli, engine
from sonolux.errors import SonoluxError
from sonolux.sofa import direction_centres_deg, export_sofa

sofar = pytest.importorskip("sofar")


@pytest.fixture(scope="module")
def field_path(tmp_path_factory):
    """paper-small, sound only (1,000 rays): 15 receivers, 8 directions."""
    if not engine.core_available():
        pytest.skip("the compiled core is not built (SONOLUX_TESTS_WITHOUT_CORE=1)")
    path = tmp_path_factory.mktemp("sofa") / "small.h5"
    assert cli.main(["bake", "paper-small", "-o", str(path), "--rays", "1000", "--no-light", "-q"]) == 0
    return path


def test_all_receivers_read_back_as_the_library_synthesises_them(field_path, tmp_path):
    out = tmp_path / "room.sofa"
    old = os.umask(0o027)
    try:
        summary = export_sofa(field_path, out, seed=3)
    finally:
        os.umask(old)
    assert out.stat().st_mode & 0o777 == 0o640  # the umask's permissions, like every output
    assert [p.name for p in tmp_path.iterdir()] == ["room.sofa"]  # no temporary file left
    sofa = sofar.read_sofa(str(out))  # verifies the convention on reading
    sofa.verify(issue_handling="raise")
    assert (sofa.GLOBAL_SOFAConventions, sofa.GLOBAL_DataType) == ("SingleRoomSRIR", "FIR")
    field = sonolux.open(field_path)
    m, r, n = sofa.Data_IR.shape
    assert (m, r) == (field.n_receivers, 8) == (summary.receivers, summary.directions)
    assert sofa.Data_SamplingRate == field.sample_rate_hz
    # Every response is the library's, bit for bit, zero-padded to the longest.
    longest = 0
    for k in range(m):
        for d in range(r):
            ir = field.impulse_response(k, d, seed=3 + k * 8 + d)
            longest = max(longest, ir.size)
            assert np.array_equal(sofa.Data_IR[k, d, :ir.size], ir)
            assert not np.any(sofa.Data_IR[k, d, ir.size:])
    assert n == longest
    # Where: the listeners are the receivers; the "receivers" the direction sectors, at their
    # centres on the receiver's sphere, looking outward; the source where the scene has it.
    assert np.array_equal(sofa.ListenerPosition, field.positions_m)
    centres = np.asarray(sofa.ReceiverPosition).reshape(r, 3)
    assert centres[:, 0].tolist() == [0, 45, 90, 135, 180, 225, 270, 315]
    assert np.all(centres[:, 1] == 0) and np.all(centres[:, 2] == field.radius_m)
    view = np.asarray(sofa.ReceiverView).reshape(r, 3)
    assert view[2] == pytest.approx([0, 1, 0], abs=1e-12)  # "left" looks along +y
    assert [str(x) for x in np.asarray(sofa.ReceiverDescriptions).ravel()] == field.direction_names
    assert np.array_equal(sofa.SourcePosition, np.tile(field.source_positions_m[:1], (m, 1)))
    assert float(sofa.RoomVolume) == pytest.approx(field.theory["volume_m3"])


def test_one_receiver_from_the_command_line(field_path, tmp_path, capsys):
    out = tmp_path / "r7.sofa"
    code = cli.main(["export", str(field_path), "--sofa", str(out), "--receiver", "7"])
    assert code == 0, capsys.readouterr().err
    assert "1 receiver(s) × 8 directions" in capsys.readouterr().out
    sofa = sofar.read_sofa(str(out))
    field = sonolux.open(field_path)
    assert sofa.Data_IR.shape[:2] == (1, 8)
    assert np.array_equal(sofa.ListenerPosition[0], field.positions_m[7])
    ir = field.impulse_response(7, 5, seed=0 + 7 * 8 + 5)  # the web bundle's seeds
    assert np.array_equal(sofa.Data_IR[0, 5, :ir.size], ir)


@pytest.mark.parametrize("argv, words", [
    (["--sofa", "{tmp}/x.wav"], "must end in .sofa"),
    (["--sofa", "{tmp}/x.sofa", "--receiver", "15"], "receiver = 15"),
    (["--sofa", "{tmp}/x.sofa", "--receiver", "-1"], "--receiver"),
    (["--sofa", "{tmp}/x.sofa", "--receiver", "one"], "--receiver"),
    (["--web", "{tmp}/b", "--receiver", "2"], "give --sofa"),
    (["--sofa", "{tmp}/x.sofa", "--tail-db", "40"], "--tail-db shape the web bundle"),
    (["--sofa", "{tmp}/x.sofa", "--no-compress", "--max-length-s", "1"],
     "--max-length-s, --no-compress shape the web bundle"),
])
def test_bad_requests_are_usage_errors(field_path, tmp_path, capsys, argv, words):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    with pytest.raises(SystemExit) as exit_:
        code = cli.main(["export", str(field_path), *argv])
        raise SystemExit(code)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err
    assert not any(p.suffix == ".sofa" for p in tmp_path.iterdir())


def test_the_library_checks_at_its_edge(field_path, tmp_path):
    with pytest.raises(SonoluxError, match="must end in .sofa"):
        export_sofa(field_path, tmp_path / "x.h5")
    with pytest.raises(SonoluxError, match="seed"):
        export_sofa(field_path, tmp_path / "x.sofa", seed=-1)


def test_direction_centres_with_elevation_bands():
    c = direction_centres_deg(4, 3)
    assert c[:4, 0].tolist() == [0, 90, 180, 270]
    assert c[0, 1] == pytest.approx(-41.8103, abs=1e-4) and c[4, 1] == 0  # equal solid angle
