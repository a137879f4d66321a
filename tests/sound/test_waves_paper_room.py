"""The hybrid on a paper room (paper-small: hard walls over an absorbing floor, a field that is
not diffuse) against two independent models of the same locally reacting room, its modes (Morse
and Bolt 1944) and ISO 3382-2's noise of a decay measured at a few points: is the hybrid's decay
continuous across the crossover, and do the waves follow the room they model? The wall model
both sides share is docs/walls.md; the waves are docs/waves.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import sonolux
from sonolux.analysis.decay import decay_times
from sonolux.sound.bake import bake

pytestmark = pytest.mark.usefixtures("core")


def locally_reacting_modal_decay(size_m, source_m, receivers_m, admittance, bands_hz, air_per_m):
    """T30 and EDT per octave of a rectangular room whose walls are locally reacting with real
    specific admittances ``admittance`` = {axis: (at 0, at L)}, from its modes (Morse and Bolt,
    "Sound waves in rooms", Rev. Mod. Phys. 16, 1944), to first order in the admittances: mode n
    decays in energy at c·Σ_w g_w·ε_w/L_w, ε = 2 when the mode has nodes along the wall's axis
    (n > 0) and 1 when not (the wall's share of the mode's energy). Each mode of an octave counts
    with ψ_n(source)²·mean ψ_n(receivers)² over its norm²: the receivers' mean decay, the modes'
    cross terms averaging out over the band and the points. The air adds m·c per band."""
    c = 343.0
    size, src = np.asarray(size_m, float), np.asarray(source_m, float)
    top = max(bands_hz) * math.sqrt(2)
    n = np.stack(np.meshgrid(*[np.arange(int(2 * top / c * L) + 2) for L in size],
                             indexing="ij"), -1).reshape(-1, 3)
    f = c / 2 * np.sqrt(((n / size) ** 2).sum(1))
    eps = np.where(n > 0, 2.0, 1.0)
    rate = c * sum(eps[:, i] * sum(admittance[i]) / size[i] for i in range(3))

    def psi(p):
        return np.prod(np.cos(np.pi * n * np.asarray(p) / size), axis=1)

    norm = np.prod(np.where(n > 0, 0.5, 1.0), axis=1)
    weight = psi(src) ** 2 * np.mean([psi(r) ** 2 for r in receivers_m], axis=0) / norm**2
    t = np.arange(0.0, 3.0, 1e-3)
    out = {"t30_s": [], "edt_s": []}
    for fc, m in zip(bands_hz, air_per_m):
        band = (f >= fc / math.sqrt(2)) & (f < fc * math.sqrt(2))
        d = decay_times((weight[band, None] * np.exp(-(rate[band, None] + m * c) * t)).sum(0), t,
                        np.full(t.size, 1e-3))
        for k in out:
            out[k].append(float(d[k]))
    return {k: np.array(v) for k, v in out.items()}


def iso_3382_2_sigma(key, t_s, bandwidth_hz, points):
    """Relative standard deviation of a reverberation time from ISO 3382-2:2008 annex A, one
    decay a point (n = 1, as a conservative reading of the integrated impulse response), over
    ``points`` independent points: T30 0.55·√((1 + 1.52)/(N·B·T)); EDT takes T20's
    0.88·√((1 + 1.90)/(N·B·T)) (the annex gives none for EDT, whose 10 dB range is shorter
    still)."""
    k, m = (0.55, 1.52) if key == "t30_s" else (0.88, 1.90)
    return k * math.sqrt((1 + m) / (points * bandwidth_hz * t_s))


@pytest.mark.slow
def test_paper_room_decay_continuous_across_the_crossover():
    """paper-small (6 × 2.5 × 2 m, walls 0.05, floor 0.3, scattering 0.1) baked with waves at
    a crossover of 707 Hz (125-500 Hz from the waves, 1 kHz up from the rays). The hybrid's
    rays use the waves' wall (locally reacting, each band's g from Paris' formula; docs/walls.md),
    chosen automatically. Receivers: the 14 that do not hold the source, mean decay times.

    What "continuous" means here. The materials are flat, but a locally reacting room's decay
    is not: in its modes (Morse and Bolt 1944; ``locally_reacting_modal_decay``, an independent
    model of the same room) those with no node along the floor's axis lose energy to the floor at
    half the rate of the others, and their share of a band halves every octave (12.5 % of the
    weight at 500 Hz, 5.8 % at 1 kHz, 2.7 % at 2 kHz), so the room's own T30 falls 12 % and its
    EDT 7 % from 500 Hz to 1 kHz. The hybrid is continuous when its change from the last wave
    band to the first ray band is the room's change, within the noise of a decay: ISO 3382-2
    annex A (``iso_3382_2_sigma``) at 500 Hz (B = 354 Hz), 4 independent points (the grid is
    mirror-symmetric), three σ; the rays' own noise at 20,000 rays is far below it. EDT: 15 %.
    T30: the same rule gives 7.9 % at 500 Hz and 6.0 % at 1 kHz, 3σ of the two combined 10 %.

    Measured (2026-11-27, this test's bakes): waves 500 Hz T30 0.832 / EDT 0.623 s; rays 1 kHz
    with locally reacting walls 0.645 / 0.607 s (with the angle-independent α of a plain bake:
    0.837 / 0.756); the modal model 0.768 / 0.629 at 500 Hz and 0.674 / 0.584 at 1 kHz.
    EDT: the hybrid's step −2.6 % against the room's −7.1 %, +4.9 % apart (with angle-independent
    walls +30.6 %, which the test asserts would fail). T30: the rays' 1 kHz is −4.3 % from the
    room's model (within 6.0 %; angle-independent walls: +24 %, asserted to fail), the waves'
    500 Hz +8.3 % (test_the_waves_follow_the_modes_of_the_locally_reacting_room), so the step
    across the crossover is −22 % against the room's −12 %, 11.7 % apart: outside the combined
    10 %. That last part is a strict xfail
    (``test_paper_room_t30_step_across_the_crossover_is_the_rooms``)."""
    h, plain, modal = _paper_room_decays()
    tol_edt = 3 * iso_3382_2_sigma("edt_s", modal["edt_s"][0], 354.0, 4)
    assert 0.14 < tol_edt < 0.16
    step = h["edt_s"][3] / h["edt_s"][2]
    room = modal["edt_s"][1] / modal["edt_s"][0]
    print("EDT step hybrid", step, "room", room, "tolerance", tol_edt)
    assert abs(step - 1) < tol_edt
    assert abs(step / room - 1) < tol_edt
    # The angle-independent walls (a plain bake's) put the rays' EDT 21 % above the waves'.
    assert abs(plain["edt_s"][3] / h["edt_s"][2] / room - 1) > tol_edt
    # T30: the rays' side against the room's model in its own band (the waves' side is
    # test_the_waves_follow_the_modes_of_the_locally_reacting_room).
    tol_rays = 3 * iso_3382_2_sigma("t30_s", modal["t30_s"][1], 707.0, 4)
    print("T30 waves/room", h["t30_s"][2] / modal["t30_s"][0],
          "rays/room", h["t30_s"][3] / modal["t30_s"][1], tol_rays)
    assert abs(h["t30_s"][3] / modal["t30_s"][1] - 1) < tol_rays
    # With angle-independent walls the rays' T30 is 24 % above the room's at 1 kHz.
    assert abs(plain["t30_s"][3] / modal["t30_s"][1] - 1) > tol_rays


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the T30 step across the crossover is 11.7 % from the "
                   "room's (3σ 10 %): the waves' 500 Hz lies +8 % and the rays' 1 kHz −4 % "
                   "from the modal model (issue 18, docs/walls.md)")
def test_paper_room_t30_step_across_the_crossover_is_the_rooms():
    """The hybrid's T30 step from 500 Hz (waves) to 1 kHz (rays) against the room's own step
    (the modal model), within 3σ of ISO 3382-2 annex A of both bands combined (see
    ``test_paper_room_decay_continuous_across_the_crossover``)."""
    h, _, modal = _paper_room_decays()
    tol = 3 * math.hypot(iso_3382_2_sigma("t30_s", modal["t30_s"][0], 354.0, 4),
                         iso_3382_2_sigma("t30_s", modal["t30_s"][1], 707.0, 4))
    step = (h["t30_s"][3] / h["t30_s"][2]) / (modal["t30_s"][1] / modal["t30_s"][0])
    print("T30 step against the room's", step, "tolerance", tol)
    assert abs(step - 1) < tol


_DECAYS: dict = {}


def _paper_room_decays():
    """paper-small's hybrid (crossover 707 Hz, its automatic wall model) and a plain bake's
    (angle-independent walls), mean T30 and EDT per band over the receivers that do not hold the
    source, and the modal model of the locally reacting room at 500 Hz and 1 kHz (computed once
    a session)."""
    if not _DECAYS:
        scene = sonolux.load_scene("paper-small")
        hybrid = bake(scene, rays=20_000, waves=True, crossover_hz=707)
        plain = bake(scene, rays=20_000)
        assert hybrid.settings["wall_model"] == "locally-reacting"
        assert plain.settings["wall_model"] == "random-incidence"
        assert hybrid.waves["wave_bands"] == 3
        far = np.linalg.norm(hybrid.positions_m - hybrid.source_positions_m[0], axis=1) > 0.5

        def mean_times(field):
            e = np.asarray(field.energy)[far].sum(axis=1, dtype=np.float64)
            d = decay_times(e, field.bin_start_s, field.bin_width_s)
            return {k: np.nanmean(d[k], axis=0) for k in ("t30_s", "edt_s")}

        walls, floor = (admittance_from_random(a) for a in (0.05, 0.30))
        modal = locally_reacting_modal_decay(
            (6.0, 2.5, 2.0), hybrid.source_positions_m[0], hybrid.positions_m[far],
            {0: (walls, walls), 1: (walls, walls), 2: (floor, walls)}, [500.0, 1000.0],
            hybrid.settings["air_attenuation_per_m"][2:4])
        h, p = mean_times(hybrid), mean_times(plain)
        print("T30 hybrid", h["t30_s"], "plain", p["t30_s"], "modal", modal["t30_s"])
        print("EDT hybrid", h["edt_s"], "plain", p["edt_s"], "modal", modal["edt_s"])
        _DECAYS.update(h=h, p=p, modal=modal)
    return _DECAYS["h"], _DECAYS["p"], _DECAYS["modal"]


@pytest.mark.slow
def test_the_waves_follow_the_modes_of_the_locally_reacting_room():
    """The waves against the modal model of the same locally reacting room (the check the
    continuity test used to carry): T30 and EDT per octave within three σ of the mean of 4
    independent points with no noise in the model, 11 % at 250-500 Hz (EDT as T20, 14 %) and
    15 % at 125 Hz (B = 88 Hz). Measured (2026-11-27): T30 -3.8/+0.1/+8.3 %, EDT
    -1.8/+1.7/-0.9 %."""
    scene = sonolux.load_scene("paper-small")
    hybrid = bake(scene, rays=2_000, waves=True, crossover_hz=707)
    far = np.linalg.norm(hybrid.positions_m - hybrid.source_positions_m[0], axis=1) > 0.5
    e = np.asarray(hybrid.energy)[far].sum(axis=1, dtype=np.float64)
    d = decay_times(e, hybrid.bin_start_s, hybrid.bin_width_s)
    h = {k: np.nanmean(d[k], axis=0) for k in ("t30_s", "edt_s")}
    walls, floor = (admittance_from_random(a) for a in (0.05, 0.30))
    modal = locally_reacting_modal_decay(
        (6.0, 2.5, 2.0), hybrid.source_positions_m[0], hybrid.positions_m[far],
        {0: (walls, walls), 1: (walls, walls), 2: (floor, walls)}, [125.0, 250.0, 500.0],
        hybrid.settings["air_attenuation_per_m"][:3])
    for key, tol in (("t30_s", (0.15, 0.11, 0.11)), ("edt_s", (0.15, 0.14, 0.14))):
        ratio = h[key][:3] / modal[key] - 1
        assert np.all(np.abs(ratio) < tol), (key, ratio)


def admittance_from_random(alpha):
    """The real specific admittance whose random-incidence absorption by Paris' formula,
    8g[1 + g/(1 + g) − 2g·ln((1 + g)/g)], is ``alpha`` (bisection; the smaller root)."""
    def paris(g):
        return 8 * g * (1 + g / (1 + g) - 2 * g * math.log((1 + g) / g))

    lo, hi = 1e-9, 0.64
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if paris(mid) < alpha else (lo, mid)
    return 0.5 * (lo + hi)
