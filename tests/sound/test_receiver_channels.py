"""Directional receiver channels end to end: the core's per-deposit pattern weight, JLF/JLFC/LG
from a true figure-of-eight against their closed form, SOFA microphone arrays, scene keys."""

from __future__ import annotations

import numpy as np
import pytest
import sofar

import sonolux
from sonolux.analysis.decay import strength_g_db
from sonolux.analysis.params import _with_broadband, onsets_s, room_parameters, window_energy
from sonolux.errors import SonoluxError
from sonolux.fieldfile import open_field, save_fields
from sonolux.sound.bake import bake

pytestmark = pytest.mark.usefixtures("core")


def one_wall(channels, alpha=0.3):
    """A 10 × 8 × 6 m box whose surfaces absorb everything but the south wall (y = 0: α,
    specular), source and receiver 4 m apart on y = 3: the field is the direct sound and one
    lateral reflection from the image source (3, −3, 3), 9.4 ms later."""
    return sonolux.load_scene({
        "name": "one wall", "settings": {"bands_hz": [500, 1000]},
        "materials": {"dead": {"absorption": 1.0, "scattering": 0.0},
                      "wall": {"absorption": alpha, "scattering": 0.0}},
        "geometry": [{"type": "shoebox", "size_m": [10, 8, 6],
                      "materials": {"default": "dead", "south": "wall"}}],
        "sources": [{"position_m": [3, 3, 3]}],
        "receivers": {"type": "points", "positions_m": [[7, 3, 3]], "radius_m": 0.1,
                      "channels": channels},
        "early": {"max_order": 1}})


def test_jlf_jlfc_of_one_lateral_reflection_match_the_closed_form():
    # ISO 3382-1 A.2.4 with the figure-of-eight's null towards the source (axis ±y here): the
    # direct sound counts 0, the reflection from u = (−4, −6, 0)/√52 counts u_y² (JLF) or |u_y|
    # (JLFC) of its energy (1 − α)/d_r², against the omni's 1/d² + (1 − α)/d_r² in 0–80 ms.
    # Image sources (exact) and the rain estimator's exact direct sound: nothing random, so the
    # only difference is the direct sound's mean over the 0.1 m sphere instead of 1/d²
    # (relative r²/(5d²) ≈ 1e-4): tolerance 1e-3 relative.
    alpha = 0.3
    sc = one_wall(["omni", {"pattern": "figure-of-eight", "forward": "lateral"}], alpha)
    field = bake(sc, rays=500, estimator="rain", air_absorption=False)
    p = room_parameters(field, sti=False, theory=False)
    d2, dr2, uy2 = 16.0, 52.0, 36.0 / 52.0
    share = (1 - alpha) / dr2 / (1 / d2 + (1 - alpha) / dr2)
    np.testing.assert_allclose(p.values["jlf"][0], uy2 * share, rtol=1e-3)
    np.testing.assert_allclose(p.values["jlfc"][0], np.sqrt(uy2) * share, rtol=1e-3)
    # The direction bins' estimate (8 sectors, one elevation band) cannot resolve one
    # reflection; the true figure-of-eight is what the standard measures.
    assert np.all(np.isnan(p.values["jlf"][1:]))
    # Nothing arrives after 80 ms: no late lateral level.
    assert np.all(p.values["lg_db"][0] == -np.inf)


def test_lg_is_the_late_lateral_strength():
    # LG = 10 lg(E_L(80 ms..∞) / E_10m). In a diffuse late field the figure-of-eight records
    # 1/3 of the omni's late energy, so LG = G_late + 10 lg(1/3), G_late the omni channel's
    # late strength (same reference). The late field of this box is isotropic within 2.6 %
    # (the test below): tolerance 0.25 dB.
    sc = diffuse_room(["omni", {"pattern": "figure-of-eight", "forward": "lateral"}])
    field = bake(sc, rays=20000, max_time_s=0.6)
    p = room_parameters(field, sti=False, theory=False)
    omni = _with_broadband(np.asarray(field.energy[0], float).sum(axis=0))
    edges = np.append(field.bin_start_s, field.bin_start_s[-1] + field.bin_width_s[-1])
    onset = onsets_s(omni[-1], edges)
    g_late = strength_g_db(window_energy(omni, edges, onset + 0.080, np.inf), 1.0)
    np.testing.assert_allclose(p.values["lg_db"][0], g_late + 10 * np.log10(1 / 3), atol=0.25)


def diffuse_room(channels, threads=0):
    return sonolux.load_scene({
        "name": "diffuse", "settings": {"bands_hz": [500, 1000], "seed": 3, "threads": threads},
        "materials": {"m": {"absorption": 0.1, "scattering": 1.0}},
        "geometry": [{"type": "shoebox", "size_m": [8, 6, 4], "materials": {"default": "m"}}],
        "sources": [{"position_m": [2.0, 2.0, 1.5]}],
        "receivers": {"type": "points", "positions_m": [[6.0, 4.0, 2.2], [5.0, 2.5, 1.4]],
                      "radius_m": 0.4, "channels": channels}})


CHANNELS = ["omni", "cardioid", {"pattern": "hypercardioid", "forward": [0, 1, 1]},
            {"pattern": "figure-of-eight", "forward": [0, 0, 1]}]
#: Random-incidence energy response of each channel, a² + (1 − a)²/3 (the |cos| companion:
#: 1/2): Eargle, The Microphone Book, ch. 5.
DIFFUSE_GAIN = [1.0, 1 / 3, 1 / 4, 1 / 3, 1 / 2]


@pytest.mark.parametrize("estimator", ["paper", "rain"])
def test_each_pattern_records_its_random_incidence_share_of_a_diffuse_field(estimator):
    # The late field (after 50 ms) of a box with Lambert walls is close to isotropic, so a
    # channel records its pattern's mean gain over the sphere of the omni's energy. Measured:
    # within 2.6 % (paper) and 1.2 % (rain), from the field's residual anisotropy and the
    # rays' noise (channels share their rays, so the ratio's noise is small); tolerance 5 %.
    # A wrong weight (|cos| for cos², gains not squared, or no weight) misses by > 30 %.
    field = bake(diffuse_room(CHANNELS), rays=20000, estimator=estimator, max_time_s=0.6)
    energy = np.asarray(field.energy, float).sum(axis=1)[..., field.bin_start_s >= 0.05].sum(-1)
    ratio = energy / np.repeat(energy[::5], 5, axis=0)
    expected = np.tile(DIFFUSE_GAIN, 2)[:, None]
    np.testing.assert_allclose(ratio, np.broadcast_to(expected, ratio.shape), rtol=0.05)


@pytest.mark.parametrize("estimator", ["paper", "rain"])
def test_channels_give_the_same_bits_on_one_and_two_threads(estimator):
    one = bake(diffuse_room(CHANNELS, threads=1), rays=3000, estimator=estimator, max_time_s=0.3)
    two = bake(diffuse_room(CHANNELS, threads=2), rays=3000, estimator=estimator, max_time_s=0.3)
    assert np.array_equal(np.asarray(one.energy), np.asarray(two.energy))


def write_array(path, capsules):
    """A GeneralTF microphone array: SourcePosition on a 5° grid (spherical), one receiver per
    entry of ``capsules`` (|H|² of the local arrival direction [n, 3])."""
    az, el = np.meshgrid(np.arange(0, 360, 5.0), np.arange(-90, 91, 5.0))
    a, e = np.radians(az.ravel()), np.radians(el.ravel())
    local = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=1)
    f = np.geomspace(20, 20000, 200)
    s = sofar.Sofa("GeneralTF")
    s.SourcePosition = np.stack([az.ravel(), el.ravel(), np.ones(az.size)], axis=1)
    s.SourcePosition_Type = "spherical"
    s.SourcePosition_Units = "degree, degree, metre"
    s.ReceiverPosition = np.zeros((len(capsules), 3))
    s.N = f
    h = np.stack([np.sqrt(c(local)) for c in capsules], axis=1)  # [M, R]
    s.Data_Real = np.repeat(h[:, :, None], len(f), axis=2)
    s.Data_Imag = np.zeros_like(s.Data_Real)
    sofar.write_sofa(str(path), s)


def anechoic(channels, positions, base_dir=None):
    return sonolux.load_scene({
        "name": "anechoic", "settings": {"bands_hz": [250, 500, 1000, 2000, 4000]},
        "materials": {"black": {"absorption": 1.0, "scattering": 0.0}},
        "geometry": [{"type": "shoebox", "size_m": [10, 10, 10], "materials": {"default": "black"}}],
        "sources": [{"position_m": [5.0, 5.0, 5.0]}],
        "receivers": {"type": "points", "positions_m": positions, "radius_m": 0.1,
                      "channels": channels}}, base_dir=base_dir)


def test_a_sofa_array_and_the_built_in_cardioid_weigh_the_direct_sound_by_the_pattern(tmp_path):
    # 20 receivers 3 m from the source, each with an omni, the built-in cardioid and a SOFA
    # array of two capsules (an ideal omni, |H| = 1, and a cardioid), all facing +x. The
    # direct sound arrives from u = (source − receiver)/|…|: each channel's energy over the
    # omni's is the pattern's gain ((1 + u_x)/2)², exactly for the built-in (1e-9) and within
    # 0.2 dB for the SOFA capsule (band means, interpolation on the 5° data and the engine's
    # 2.5° × 5° grid), checked where the gain is above −12 dB (near the null the relative
    # interpolation error grows without bound, as for a source's pattern).
    write_array(tmp_path / "array.sofa", [lambda u: np.ones(len(u)),
                                          lambda u: ((1 + u[:, 0]) / 2) ** 2])
    k = np.arange(20)
    z = 1 - 2 * (k + 0.5) / 20
    phi = k * np.pi * (3 - np.sqrt(5))
    dirs = np.stack([np.sqrt(1 - z**2) * np.cos(phi), np.sqrt(1 - z**2) * np.sin(phi), z], 1)
    positions = (5.0 + 3.0 * dirs).tolist()
    sc = anechoic(["omni", "cardioid", {"sofa": "array.sofa", "name": "mic"}], positions,
                  base_dir=tmp_path)
    assert [c.name for c in sc.receivers.channels] == ["omni", "cardioid", "mic:0", "mic:1"]
    field = bake(sc, rays=200, estimator="rain", air_absorption=False, max_time_s=0.05)
    e = np.asarray(field.energy, float).sum(axis=(1, 3)).reshape(20, 4, -1)
    gain = ((1 - dirs[:, 0]) / 2) ** 2  # arrival from −dirs
    np.testing.assert_allclose(e[:, 1] / e[:, 0], gain[:, None] * np.ones((1, 5)), rtol=1e-6,
                               atol=1e-9)
    np.testing.assert_allclose(e[:, 2] / e[:, 0], 1.0, rtol=1e-6)
    loud = gain > 10 ** (-1.2)
    err_db = 10 * np.log10(e[loud, 3] / e[loud, 0] / gain[loud, None])
    assert np.max(np.abs(err_db)) < 0.2, err_db


@pytest.mark.parametrize("channels, message", [
    (["shotgun"], "pattern"),
    ([{"pattern": "cardioid", "forward": [0, 0, 0]}], "forward"),
    ([{"pattern": "cardioid", "colour": 1}], "colour"),
    (["omni", "omni"], "distinct names"),
    ([{"sofa": "missing.sofa"}], "sofa"),
    ([], "channels"),
])
def test_channel_keys_are_checked(tmp_path, channels, message):
    with pytest.raises(SonoluxError, match=message):
        anechoic(channels, [[2.0, 2.0, 2.0]], base_dir=tmp_path)


def test_a_grid_refuses_channels():
    with pytest.raises(SonoluxError, match="points"):
        sonolux.load_scene({
            "geometry": [{"type": "shoebox", "size_m": [5, 4, 3]}],
            "sources": [{"position_m": [1, 1, 1]}],
            "receivers": {"type": "grid", "channels": ["cardioid"]}})


def test_the_field_file_records_the_channels(tmp_path):
    sc = one_wall(["omni", {"pattern": "figure-of-eight", "forward": "lateral", "name": "lat"}])
    field = bake(sc, rays=200, estimator="rain")
    path = tmp_path / "f.h5"
    save_fields(path, sound=field)
    back = open_field(str(path))
    rec = back.settings["receiver_channels"]
    assert [c["name"] for c in rec["channels"]] == ["omni", "lat", "lat|cos|"]
    assert rec["channel_of"] == [0, 1, 2] and rec["point_of"] == [0, 0, 0]
    np.testing.assert_allclose(room_parameters(back, sti=False).values["jlf"][0],
                               room_parameters(field, sti=False).values["jlf"][0])


def test_params_prints_a_table_per_channel(tmp_path, capsys):
    import json

    from sonolux.cli import main

    sc = one_wall(["omni", {"pattern": "figure-of-eight", "forward": "lateral", "name": "lat"}])
    path = tmp_path / "f.h5"
    save_fields(path, sound=bake(sc, rays=200, estimator="rain"))
    assert main(["params", str(path)]) == 0
    out = capsys.readouterr().out
    assert "channel 'omni'" in out and "channel 'lat'" in out and "channel 'lat|cos|'" in out
    assert main(["params", str(path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["channels"] == ["omni", "lat", "lat|cos|"]
    assert data["parameters"]["jlf"]["per_receiver"][1] == [None, None, None]


ODD_VALUES = [float("nan"), float("inf"), "12", True, None, [], {}, 10**40, -1]


@pytest.mark.parametrize("key", ["pattern", "name", "forward", "up", "forward.0", "up.2"])
@pytest.mark.parametrize("value", ODD_VALUES, ids=[repr(v) for v in ODD_VALUES])
def test_any_odd_channel_value_loads_or_names_its_key(tmp_path, key, value):
    channel = {"pattern": "figure-of-eight", "name": "f8", "forward": [0.0, 1.0, 0.0],
               "up": [0.0, 0.0, 1.0]}
    if "." in key:
        k, i = key.split(".")
        channel[k] = list(channel[k])
        channel[k][int(i)] = value
        key = k
    elif value is None:
        channel.pop(key)
    else:
        channel[key] = value
    try:
        anechoic(["omni", channel], [[2.0, 2.0, 2.0]], base_dir=tmp_path)
    except SonoluxError as exc:
        assert "\n" not in str(exc) and "receivers.channels[1]" in str(exc), str(exc)


def test_a_damaged_channel_record_is_refused_by_name(tmp_path):
    from sonolux.errors import AnalysisError

    sc = one_wall(["omni", {"pattern": "figure-of-eight", "forward": "lateral"}])
    field = bake(sc, rays=100, estimator="rain")
    field.settings["receiver_channels"]["channel_of"] = [0, 7, 1]
    with pytest.raises(AnalysisError, match="receiver_channels"):
        room_parameters(field, sti=False)


def test_an_impulse_response_array_is_read_by_its_spectrum(tmp_path):
    # GeneralFIR: capsule 0 a delta of amplitude 0.5 (|H|² = 0.25 at every frequency),
    # capsule 1 a delta of 2 delayed by 3 samples (|H|² = 4): each channel records that share
    # of the omni's direct sound, whatever the direction (1e-6).
    az, el = np.meshgrid(np.arange(0, 360, 30.0), np.arange(-90, 91, 30.0))
    s = sofar.Sofa("GeneralFIR")
    s.SourcePosition = np.stack([az.ravel(), el.ravel(), np.ones(az.size)], axis=1)
    s.SourcePosition_Type = "spherical"
    s.SourcePosition_Units = "degree, degree, metre"
    s.ReceiverPosition = np.zeros((2, 3))
    ir = np.zeros((az.size, 2, 256))
    ir[:, 0, 0], ir[:, 1, 3] = 0.5, 2.0
    s.Data_IR = ir
    s.Data_SamplingRate = 48000.0
    s.Data_Delay = np.zeros((1, 2))
    sofar.write_sofa(str(tmp_path / "ir.sofa"), s)
    sc = anechoic(["omni", {"sofa": "ir.sofa", "name": "ir"}], [[2.0, 3.0, 4.0], [8.0, 7.0, 6.0]],
                  base_dir=tmp_path)
    field = bake(sc, rays=100, estimator="rain", air_absorption=False, max_time_s=0.05)
    e = np.asarray(field.energy, float).sum(axis=(1, 3)).reshape(2, 3, -1)
    np.testing.assert_allclose(e[:, 1] / e[:, 0], 0.25, rtol=1e-6)
    np.testing.assert_allclose(e[:, 2] / e[:, 0], 4.0, rtol=1e-6)
