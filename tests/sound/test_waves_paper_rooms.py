"""Issue 18 on the paper's other two rooms: paper-medium (12 × 5 × 4 m, automatic crossover
354 Hz) and paper-large (24 × 10 × 8 m, 177 Hz), the same walls and floor as paper-small
(tests/sound/test_waves_paper_room.py, whose reference and tolerances these tests reuse). Is the
hybrid's EDT and T30 continuous across the crossover, measured as the room's own step between the
last wave band and the first ray band (the room's exact modes, Morse and Bolt 1944) within three
σ of ISO 3382-2 annex A? EDT is; T30 is not, for paper-small's reason (docs/waves-hybrid.md,
"Continuity of T30 across the crossover").

The rooms are paper-small scaled by 2 and 4 with the same materials and scattering, and their
automatic crossovers scale by 1/2 and 1/4: the floor's k(β₀ + β_L)L at each room's first ray
band is paper-small's at 1 kHz, so the grazing late decay the rays' scattering removes is the
same physics at a lower frequency. The source and the receivers stay 1.5 m high, so the rooms are
not exact copies.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import tomllib

import sonolux
from sonolux.scene import builtin
from sonolux.sound.bake import bake
from tests.sound.test_waves_paper_room import (
    FLOOR,
    WALLS,
    WAVES_MODES,
    admittance_from_random,
    iso_3382_2_sigma,
    locally_reacting_modal_decay,
    mean_times,
)

pytestmark = pytest.mark.usefixtures("core")

# paper-large's full grid (207 receivers, 1,449 cubature points) asks the waves' binning for a
# dense field of 18 GB at 1 ms late bins: its receivers here are every 2 m and its late bins 4 ms
# (54 receivers off the source, like paper-medium's).
ROOMS = {"paper-medium": {}, "paper-large": {"spacing_m": 2.0, "late_bin_s": 0.004}}
#: The three rooms with flat surfaces on both sides; paper-small at the crossover, record and
#: coherent span its own tests use (test_waves_paper_room.py), the others as above.
FLAT_ROOMS = {"paper-small": {"crossover_hz": 707.0, "record_s": 3.0, "coherent_s": 0.4}, **ROOMS}

_DECAYS: dict = {}


def room_decays(name, scattering=None):
    """The hybrid of the built-in room ``name`` (automatic crossover, its automatic wall model;
    with ``scattering``, every material's scattering coefficient set to it),
    mean T30 and EDT per band over the receivers that do not hold the source, and the room's
    exact modes at its wave bands and its first ray band (T30 the fitted line; record 8 s, for
    paper-large's 3 s decays; summed coherently over the first second, which EDT needs: the
    receivers share the source's height, see ``locally_reacting_modal_decay``), computed once a
    session: (hybrid, modes, wave bands, bandwidths of the last wave band and the first ray
    band, Hz)."""
    if (name, scattering) not in _DECAYS:
        from sonolux.sound.wave_spheres import ball_points

        extra = FLAT_ROOMS[name]
        data = tomllib.loads(builtin.path(name).read_text())
        if "spacing_m" in extra:
            data["receivers"]["spacing_m"] = extra["spacing_m"]
        if scattering is not None:
            for material in data["materials"].values():
                material["scattering"] = scattering
        scene = sonolux.load_scene(data)
        hybrid = bake(scene, rays=20_000, waves=True,
                      **{k: extra[k] for k in ("late_bin_s", "crossover_hz") if k in extra})
        assert hybrid.settings["wall_model"] == "locally-reacting-modes"
        nb = hybrid.waves["wave_bands"]
        far = np.linalg.norm(hybrid.positions_m - hybrid.source_positions_m[0], axis=1) > 0.5
        walls, floor = (admittance_from_random(a) for a in (WALLS, FLOOR))
        points = ball_points(scene.geometry, np.asarray(hybrid.positions_m)[far],
                             scene.receivers.radius_m)
        bands = [float(b) for b in scene.settings.bands_hz[:nb + 1]]
        modes = locally_reacting_modal_decay(
            data["geometry"][0]["size_m"], hybrid.source_positions_m[0], points,
            {0: (walls, walls), 1: (walls, walls), 2: (floor, walls)}, bands,
            hybrid.settings["air_attenuation_per_m"][:nb + 1], fit_limits=False,
            record_s=extra.get("record_s", 8.0), coherent_s=extra.get("coherent_s", 1.0))
        h = mean_times(hybrid, far)
        print(name, scattering, "crossover", hybrid.waves["crossover_hz"], "hybrid", h,
              "modes", modes)
        widths = [b * (2**0.5 - 2**-0.5) for b in bands[nb - 1:nb + 1]]
        _DECAYS[name, scattering] = (h, modes, nb, widths)
    return _DECAYS[name, scattering]


@pytest.mark.slow
@pytest.mark.parametrize("name", list(ROOMS))
def test_paper_rooms_edt_continuous_across_the_crossover(name):
    """The hybrid's EDT step from its last wave band to its first ray band against the room's
    (its exact modes), within three σ of ISO 3382-2 annex A at the wave band (4 independent
    points, as paper-small's test: a conservative count of the 54 receivers, mirror-symmetric
    about the source in plan), 15 %; and the rays' EDT in their first band against the modes',
    three σ in that band (11 %). Measured (2026-11-27, the modes summed coherently): paper-medium
    (250 → 500 Hz) hybrid −8.5 %, room −8.7 %, +0.2 % apart; rays −1.7 % off the modes.
    paper-large (125 → 250 Hz) hybrid −13.2 %, room −21.3 %, +10.2 % apart (3σ 13.7 %); rays
    +5.7 % off the modes. (With the modes summed incoherently, whose EDT is not this room's at
    receivers on the source's height, the room's steps were −6.6 % and −8.4 %.) Session 9, the
    walls meeting the grid's diffuse-field absorption: paper-medium −2.2 % apart, paper-large
    +6.9 % (the waves' EDT rose to the modes'). Session 12, the rays' grazing modes the hybrid's
    default: paper-medium −3.7 % apart (rays −3.2 % off the modes), paper-large +4.1 % (rays
    +3.0 %); without them −2.2 % (−1.7 %) and +6.9 % (+5.7 %). Session 13, the grazing mode's
    profile: −4.4 % (−3.9 %) and +2.9 % (+1.8 %)."""
    h, modes, nb, (b_wave, b_ray) = room_decays(name)
    tol = 3 * iso_3382_2_sigma("edt_s", modes["edt_s"][nb - 1], b_wave, 4)
    assert 0.13 < tol < 0.16
    step = h["edt_s"][nb] / h["edt_s"][nb - 1]
    room = modes["edt_s"][nb] / modes["edt_s"][nb - 1]
    print(name, "EDT step hybrid", step, "room", room, "tolerance", tol)
    assert abs(step / room - 1) < tol
    tol_rays = 3 * iso_3382_2_sigma("edt_s", modes["edt_s"][nb], b_ray, 4)
    print(name, "EDT rays/room", h["edt_s"][nb] / modes["edt_s"][nb], tol_rays)
    assert abs(h["edt_s"][nb] / modes["edt_s"][nb] - 1) < tol_rays


@pytest.mark.slow
@pytest.mark.parametrize("name", list(ROOMS))
def test_paper_rooms_waves_follow_the_exact_modes(name):
    """The waves' T30 and EDT in every wave band against the room's exact modes summed
    coherently at the same points through the same band filters: EDT within one just noticeable
    difference (5 %, ISO 3382-1 table A.1), T30 within 2 % (``WAVES_MODES``, as in
    paper-small's ``test_the_waves_follow_the_modes_of_the_locally_reacting_room``). Measured
    (2026-11-27, session 9, the walls meeting the grid's diffuse-field absorption):
    paper-medium T30 +0.1/−0.7 %, EDT +2.6/+0.5 % at 125/250 Hz; paper-large T30 −0.8 %, EDT
    −1.1 % at 125 Hz (session 8: T30 −2.5/−3.5 % and −4.2 %, EDT −0.7/−1.9 % and −4.1 %).
    The modes summed incoherently put paper-large's EDT at
    2.55 s, the waves +14.6 % above it: that was the reference's, not the waves' (the coherent
    modes give 3.05 s; tests/sound/test_waves_paper_room.py
    ``test_coherent_modes_are_incoherent_over_the_volume_but_not_at_one_height``)."""
    h, modes, nb, _ = room_decays(name)
    for key in ("t30_s", "edt_s"):
        ratio = h[key][:nb] / modes[key][:nb] - 1
        print(name, key, "waves/modes - 1", ratio)
        assert np.all(np.abs(ratio) < WAVES_MODES[key]), (key, ratio)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(ROOMS))
@pytest.mark.xfail(strict=True, reason="as in paper-small: the rays' scattering (0.1) removes the "
                   "floor-grazing late decay that the waves' flat walls and the room's exact modes "
                   "keep; paper-medium steps −20 % against the room's, paper-large −12.5 % (3σ "
                   "9.4 % and 9.6 %; issue 18, docs/waves-hybrid.md: a coefficient alone keeps the "
                   "waves' walls flat by decision, session 10). The rays' grazing modes "
                   "(wall_model 'locally-reacting-modes', the hybrids' default since session 12) "
                   "do not change that: −24.5 % / −16.8 % with them, −21.9 % / −15.6 % without; "
                   "nor their profile across the gap (session 13): −24.7 % / −17.5 %; with flat "
                   "walls on both sides −0.8 % / +2.6 % (test_flat_paper_rooms_t30_step_across_"
                   "the_crossover_is_the_rooms)")
def test_paper_rooms_t30_step_across_the_crossover_is_the_rooms(name):
    """The hybrid's T30 step from its last wave band to its first ray band against the room's
    (exact modes, fitted line), within three σ of both bands combined (ISO 3382-2 annex A, 4
    points). Measured (2026-11-27, modes summed coherently over the first second): paper-medium
    250 → 500 Hz hybrid 1.606 → 1.290 s (−19.7 %), modes 1.664 → 1.662 (−0.1 %), −19.6 % apart;
    paper-large 125 → 250 Hz hybrid 3.107 → 2.539 (−18.3 %), modes 3.243 → 3.029 (−6.6 %),
    −12.5 % apart. Session 9 (the waves' T30 within 1 % of the modes): −21.9 % and −15.5 % apart:
    the step is the rays' scattering, not the waves'. Session 12, the rays' grazing modes the
    hybrid's default: −24.5 % and −16.8 % (rays 1.247 s at 500 Hz, 2.501 s at 250 Hz). Session
    13, the grazing mode's profile across the gap: −24.7 % and −17.5 % (rays 1.243 s, 2.479 s)."""
    h, modes, nb, (b_wave, b_ray) = room_decays(name)
    tol = 3 * math.hypot(iso_3382_2_sigma("t30_s", modes["t30_s"][nb - 1], b_wave, 4),
                         iso_3382_2_sigma("t30_s", modes["t30_s"][nb], b_ray, 4))
    step = (h["t30_s"][nb] / h["t30_s"][nb - 1]) / (modes["t30_s"][nb] / modes["t30_s"][nb - 1])
    print(name, "T30 step against the room's", step, "tolerance", tol)
    assert abs(step - 1) < tol


@pytest.mark.slow
@pytest.mark.parametrize("name", list(FLAT_ROOMS))
def test_flat_paper_rooms_t30_step_across_the_crossover_is_the_rooms(name):
    """The strict xfails' own measurement (``test_paper_rooms_t30_step_across_the_crossover_is_
    the_rooms``, paper-small's ``test_paper_room_t30_step_across_the_crossover_is_the_rooms``)
    with the same surfaces on both sides of the crossover: every material's scattering
    coefficient set to 0, so the rays' walls are the waves' flat locally reacting walls, and the
    exact modes are the room both model. The hybrid's T30 step from its last wave band to its
    first ray band against the room's, within three σ of both bands combined (ISO 3382-2 annex A,
    4 points; 9.1 / 9.4 / 9.6 %).

    The receivers share the talker's height (1.5 m), where the room's modes are not weighed as
    a diffuse field weighs them: the gap's grazing mode over the absorbing floor is weaker there
    (|ψ₀|² 0.78 of its mean at paper-large's 250 Hz, 1.18 at paper-small's 1 kHz, 2 m high), which
    the rays carry (the grazing mode's profile, sonolux_core::sound::grazing; docs/waves-grazing.md,
    "Where the grazing mode's energy is"). What they do not carry, the interference of the modes
    with a node across the gap at points on the source's own height (their weight there 1.4-1.7
    where the volume's is 1: T30 6-9 % shorter), is left inside the tolerance. Measured
    (2026-11-28, session 13, load 6-7): −1.8 / −0.8 / +2.6 % (rays 0.908 / 1.637 / 3.084 s against
    the modes' 0.931 / 1.662 / 3.029); without the profile −6.8 / +2.1 / +11.9 %."""
    h, modes, nb, (b_wave, b_ray) = room_decays(name, scattering=0.0)
    tol = 3 * math.hypot(iso_3382_2_sigma("t30_s", modes["t30_s"][nb - 1], b_wave, 4),
                         iso_3382_2_sigma("t30_s", modes["t30_s"][nb], b_ray, 4))
    step = (h["t30_s"][nb] / h["t30_s"][nb - 1]) / (modes["t30_s"][nb] / modes["t30_s"][nb - 1])
    print(name, "flat: T30 step against the room's", step, "tolerance", tol)
    assert 0.09 < tol < 0.1
    assert abs(step - 1) < tol
