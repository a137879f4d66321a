"""A receiver no energy reaches (sealed off behind a closed wall) is not waited for: the
progressive bake stops when the reachable receivers converge, names the unreached one (round
line, record, ``sonolux info``, the bake's end) and the reachable receiver's results keep their
bits. The statistics behind it (:mod:`sonolux.sound.reach`) are checked against the crossings a
reachable receiver really gets."""

from __future__ import annotations

import hashlib
import math
from dataclasses import replace

import numpy as np
import pytest

import sonolux
from sonolux import cli, engine
from sonolux.sound import progressive
from sonolux.sound import reach as reach_module
from sonolux.sound.info import listener_warnings, progressive_line
from sonolux.sound.reach import UNREACHED, reach

pytestmark = pytest.mark.usefixtures("core")

INSIDE = [1.8, 2.9, 1.2]
SEALED = [4.0, 2.0, 1.5]
ACCURACY = progressive.Accuracy(0.2)
PAPER = sonolux.SoundOptions(estimator="paper")


def wall(tmp_path) -> str:
    """A closed 0.1 m slab at x = 2.45..2.55 m through the whole 5 × 4 × 3 m room (it pokes
    0.1 m through the walls, floor and ceiling): the east part is sealed off from the source.
    It is an obstacle (closed, apart from the shell), so points on either side are in the air."""
    path = tmp_path / "wall.obj"
    corners = [(x, y, z) for x in (2.45, 2.55) for y in (-0.1, 4.1) for z in (-0.1, 3.1)]
    faces = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in corners)
                    + "".join("f " + " ".join(map(str, f)) + "\n" for f in faces))
    return str(path)


def room(wall_file: str | None, positions, **settings):
    geometry = [{"type": "shoebox", "size_m": [5, 4, 3], "materials": {"default": "wall"}}]
    if wall_file:
        geometry.append({"type": "mesh", "file": wall_file, "material": "wall"})
    return sonolux.load_scene({
        "name": "sealed-off",
        "settings": {"bands_hz": [250, 500, 1000, 2000], "max_time_s": 1.2, **settings},
        "materials": {"wall": {"absorption": 0.12, "scattering": 0.3}},
        "geometry": geometry, "sources": [{"position_m": [1.2, 1.1, 1.5]}],
        "receivers": {"type": "points", "positions_m": positions}})


def digest(energy) -> str:
    return hashlib.sha256(np.ascontiguousarray(energy).tobytes()).hexdigest()


@pytest.fixture(scope="module")
def sealed(tmp_path_factory):
    """The progressive bake (paper estimator) of the walled room with a receiver on each side,
    on two threads, and its log."""
    if not engine.core_available():
        pytest.skip("the compiled core is not built")
    scene = room(wall(tmp_path_factory.mktemp("wall")), [INSIDE, SEALED], threads=2)
    assert scene.receivers.count == 2, scene.warnings  # both in the air: none dropped
    lines: list[str] = []
    field, errors = progressive.bake(scene, PAPER, ACCURACY, log=lines.append)
    return scene, field, errors, lines


def test_a_sealed_off_receiver_is_not_waited_for_and_is_named(sealed):
    """The bake converges (not at its cap) with receiver #1 unreached; every parameter of it
    is left out as "no energy reached it"; the round lines, the end's warning, the record and
    ``sonolux info``'s line name it; ``sonolux ir`` at it warns that it is silent."""
    _, field, errors, lines = sealed
    record = field.settings["progressive"]
    assert record["stopped"] == "converged"
    assert field.settings["rays"] < progressive.DEFAULT_MAX_RAYS // 100
    assert [u["receiver"] for u in record["unreached"]] == [1]
    assert record["unreached"][0]["position_m"] == SEALED
    assert np.all(field.energy[1] == 0) and np.any(field.energy[0] > 0)
    for name in progressive.PARAMETERS:
        assert record["errors"][name]["left_out"][UNREACHED] == [[1, b] for b in range(4)]
        assert record["errors"][name]["undefined"] == 0
        assert not np.isnan(errors.value[name][0]).any()  # the reachable one: all defined
    assert all("no energy reached receiver #1" in line for line in lines if
               line.startswith("round "))
    assert any(line.startswith("warning: no energy reached receiver #1 at (4, 2, 1.5) m")
               for line in lines)
    assert "no energy reached receiver #1 at (4, 2, 1.5) m" in progressive_line(record)
    assert any("silent" in w for w in listener_warnings(field, 1))
    assert not any("silent" in w for w in listener_warnings(field, 0))


def test_without_the_reach_test_the_same_bake_runs_to_its_cap(sealed, monkeypatch):
    """What the test saves: the same scene, with the unreached receiver treated as noise (the
    reach test switched off), is waited for until the ray cap, NOT converged."""
    scene, field, _, _ = sealed
    nothing = reach_module.Reach(np.zeros(2, bool), np.zeros(2), np.zeros(2))
    monkeypatch.setattr(progressive, "reach", lambda *a, **k: nothing)
    cap = 4 * field.settings["rays"]
    waited, _ = progressive.bake(scene, PAPER, progressive.Accuracy(0.2, max_rays=cap))
    assert waited.settings["progressive"]["stopped"] == "max_rays"
    assert waited.settings["rays"] == progressive.Accuracy(0.2, max_rays=cap).ceiling


def test_the_reachable_receiver_keeps_its_bits(sealed, tmp_path):
    """Its energy, to the bit, and the bake's rounds are those of the same bake without the
    sealed-off receiver (deposits are rounded by keys of (seed, source, ray, receiver,
    segment), the rays' paths do not depend on the receivers, and the unreached one counts in
    no stopping decision), and of the same bake on one thread in other ranges."""
    scene, field, _, _ = sealed
    # The field's time axis keeps one-sample bins to the mixing time after the farthest
    # receiver's direct sound, and the compact late part is stored apart: both depend on the
    # receivers, so the comparison fixes the axis (early_s past that time, full storage).
    fixed = replace(PAPER, early_s=0.5, storage="full")
    both, _ = progressive.bake(room(wall(tmp_path), [INSIDE, SEALED], threads=2), fixed,
                               ACCURACY)
    alone, _ = progressive.bake(room(wall(tmp_path), [INSIDE], threads=2), fixed, ACCURACY)
    assert ([r["rays"] for r in alone.settings["progressive"]["rounds"]]
            == [r["rays"] for r in both.settings["progressive"]["rounds"]])
    assert both.energy.shape[1:] == alone.energy.shape[1:]
    assert digest(alone.energy[0]) == digest(both.energy[0])
    one, _ = progressive.bake(room(wall(tmp_path), [INSIDE, SEALED], threads=1), PAPER,
                              ACCURACY, range_rays=3001)
    assert digest(one.energy) == digest(field.energy)
    assert one.settings["progressive"]["unreached"] == field.settings["progressive"]["unreached"]


def test_in_a_field_per_source_each_source_is_tested_apart(tmp_path):
    """A source on each side of the wall: each receiver is reached by one source only. The rows
    (source by source) of the other are left out, named with their source, and ``sonolux ir``
    says which source's response is silent."""
    if not engine.core_available():
        pytest.skip("the compiled core is not built")
    scene = room(wall(tmp_path), [INSIDE, SEALED], threads=2)
    two = replace(scene, sources=[*scene.sources, replace(scene.sources[0], name="east",
                                                          position_m=np.array([4.2, 1.1, 1.5]))])
    lines: list[str] = []
    field, _ = progressive.bake(two, PAPER, ACCURACY, log=lines.append)
    record = field.settings["progressive"]
    assert record["stopped"] == "converged"
    assert [(u["row"], u["receiver"], u["source"]) for u in record["unreached"]] == [
        (1, 1, 0), (2, 0, 1)]
    assert any("no energy from source 1 (east) reached receiver #0" in line for line in lines)
    assert "receiver #0 from source 1 at (1.8, 2.9, 1.2) m" in progressive_line(record)
    assert any("from source east" in w for w in listener_warnings(field, 0))


def test_a_receiver_with_any_energy_is_waited_for_and_few_rays_decide_nothing():
    """The decision itself: a row with one count anywhere is reached (noise, waited for); a row
    with none is unreached only once its expected hits μ = hits × 4πr²/S exceed
    ln(R / 0.05) (P(0 hits) = e^(−μ) below 5 % shared by R receivers), and its level bound is
    10 log10(ln(R / 0.05) / μ)."""
    groups = np.zeros((8, 3, 2, 5), np.uint64)
    groups[3, 0, 1, 4] = 1  # receiver 0: a single count
    area, radius = 100.0, 0.25
    per_hit = 4 * math.pi * radius**2 / area
    threshold = math.log(3 / 0.05)
    barely = reach(groups, math.floor(threshold / per_hit), 3, radius, area)
    assert not barely.unreached.any()  # μ just below the threshold: not yet
    enough = reach(groups, math.ceil(threshold / per_hit), 3, radius, area)
    assert enough.rows() == [1, 2]  # receiver 0 has its count: waited for
    assert enough.level_below_db[1] == pytest.approx(
        10 * math.log10(threshold / enough.expected_hits[1]))
    # A field per source (rows source by source): each row holds its source's share of the hits.
    per_source = reach(np.zeros((8, 6, 2, 5), np.uint64), 1000, 3, radius, area)
    assert per_source.expected_hits[0] == pytest.approx(500 * per_hit)


def test_the_expected_hits_are_what_a_reachable_receiver_gets():
    """Against the tracer: in the shoebox alone (no wall) with the paper estimator, whose every
    deposit is one sphere crossing, the crossings of four receivers average μ = hits × 4πr²/S
    (the diffuse field's track length hits × 4V/S through the sphere's projected area πr² over
    V) within 5 %: the rays' noise is about 0.5 % at these counts (√ of some 6 × 10⁴ crossings),
    the rest is the field's unevenness and the measured free path against 4V/S."""
    if not engine.core_available():
        pytest.skip("the compiled core is not built")
    positions = [INSIDE, SEALED, [2.5, 1.0, 1.0], [4.2, 3.3, 2.2]]
    scene = room(None, positions, threads=2)
    field = sonolux.bake(scene, sonolux.SoundOptions(estimator="paper", rays=16_384))
    got = reach(np.zeros((1, 4, 1, 1), np.uint64), field.stats["surface_hits"], 4,
                scene.receivers.radius_m, scene.area_m2)
    ratio = field.stats["deposits"] / 4 / got.expected_hits[0]
    assert abs(ratio - 1.0) <= 0.05, ratio


@pytest.mark.parametrize("rays", ["auto", "20000"])
def test_sonolux_bake_names_the_sealed_receiver_once_and_drops_one_outside(capsys, tmp_path,
                                                                            rays):
    """From the command line, with a third receiver outside the room: the scene drops that one
    before tracing (its own warning); the sealed one is named once, by the progressive bake or,
    for a fixed ray count, after it; a receiver in the room is never named."""
    if not engine.core_available():
        pytest.skip("the compiled core is not built")
    scene = tmp_path / "sealed.toml"
    scene.write_text(
        'name = "sealed"\n[settings]\nbands_hz = [250, 500, 1000, 2000]\nmax_time_s = 1.2\n'
        '[materials.wall]\nabsorption = 0.12\nscattering = 0.3\n'
        '[[geometry]]\ntype = "shoebox"\nsize_m = [5, 4, 3]\nmaterials = { default = "wall" }\n'
        f'[[geometry]]\ntype = "mesh"\nfile = "{wall(tmp_path)}"\nmaterial = "wall"\n'
        '[[sources]]\nposition_m = [1.2, 1.1, 1.5]\n[receivers]\ntype = "points"\n'
        'positions_m = [[1.8, 2.9, 1.2], [4.0, 2.0, 1.5], [7.0, 2.0, 1.5]]\n')
    out = tmp_path / "sealed.h5"
    coarse = ["--accuracy", "0.5"] if rays == "auto" else []
    assert cli.main(["bake", str(scene), "--no-light", "-q", "--rays", rays, *coarse,
                     "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "positions_m[2] = [7.0, 2.0, 1.5] is dropped: outside the room" in err
    assert err.count("warning: no energy reached receiver #1 at (4, 2, 1.5) m") == 1
    assert "receiver #0" not in err


def wall_with_hole(tmp_path, side_m: float) -> str:
    """:func:`wall`'s slab with a square hole of ``side_m`` at (y, z) = (2, 1.5) m: four closed
    boxes around it (below, above, south, north of the hole), so the two parts share the air."""
    def box(x0, x1, y0, y1, z0, z1, k):
        corners = [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
        faces = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
        return ("".join(f"v {x} {y} {z}\n" for x, y, z in corners)
                + "".join("f " + " ".join(str(i + 8 * k) for i in f) + "\n" for f in faces))
    y0, y1, z0, z1 = 2.0 - side_m / 2, 2.0 + side_m / 2, 1.5 - side_m / 2, 1.5 + side_m / 2
    parts = [(-0.1, 4.1, -0.1, z0), (-0.1, 4.1, z1, 3.1), (-0.1, y0, z0, z1), (y1, 4.1, z0, z1)]
    path = tmp_path / "holed.obj"
    path.write_text("".join(box(2.45, 2.55, *p, k) for k, p in enumerate(parts)))
    return str(path)


def test_a_space_joined_through_a_small_opening_is_not_called_sealed(tmp_path):
    """Issue 15's question: a receiver in a space joined to the source's through a 1 cm² hole
    (a coupled space; its energy density about 1e-4 / 7 m² of absorption area below the room's,
    Kuttruff's coupled rooms) is crossed by about 0.7 of 16,384 rays (measured: no hit in 3 of
    6 seeds), while its expected hits in the room's diffuse field are 11,000: the test declares
    it unreached. Here: 2,048 rays (about 0.09 crossings: no hit with probability 0.91) in three
    seeds, at least one declared (the chance that none is: 7e-4); with 131,072 rays (about 5.6
    crossings; measured: reached in 6 of 6 seeds) it is reached. So the test may declare such a
    receiver early (re-taken every round); the warning says it is sealed off *or* joined through
    an opening too small for the rays so far, with the bound on its level, which holds either
    way."""
    from sonolux.sound.bake import bake
    from sonolux.sound.reach import silent_receivers

    hole = wall_with_hole(tmp_path, 0.01)
    scenes = [room(hole, [INSIDE, SEALED], seed=seed) for seed in (1, 2, 3)]
    assert scenes[0].receivers.count == 2, scenes[0].warnings
    few = [w for sc in scenes
           for w in silent_receivers(bake(sc, rays=2_048, estimator="paper"), sc.area_m2)]
    assert few and all("receiver #1" in w for w in few), few
    assert "joined to them only through an opening too small for the rays so far" in few[0]
    many = bake(scenes[0], rays=131_072, estimator="paper")
    assert silent_receivers(many, scenes[0].area_m2) == []
