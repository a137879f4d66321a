"""The hybrid on a paper room (paper-small: hard walls over an absorbing floor, a field that is
not diffuse) against two independent models of the same locally reacting room, its exact modes
(the shoebox separates; Morse and Bolt 1944) and ISO 3382-2's noise of a decay measured at a few
points: is the hybrid's decay continuous across the crossover, and do the waves follow the room
they model? The wall model both sides share is docs/walls.md; the waves are docs/waves.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import sonolux
from sonolux.analysis.decay import decay_times
from sonolux.sound.bake import bake

pytestmark = pytest.mark.usefixtures("core")


def axis_wavenumbers(order, length_m, k, admittance):
    """The complex wavenumbers κ along one axis of a rectangular room whose two walls across it
    have real specific admittances ``admittance`` = (β₀, β_L), for modes of ``order`` (int
    array) at complex total wavenumbers ``k`` (time dependence e^{jωt}): the pressure
    cos κx + (jkβ₀/κ)·sin κx meets the locally reacting walls exactly when
    (κ² + k²β₀β_L)·sin κL = jkκ(β₀ + β_L)·cos κL (Morse and Bolt 1944; Morse and Ingard,
    *Theoretical Acoustics* 1968, §9.5; with equal walls the equation of
    crates/sonolux-core/tests/wave_walls.rs ``lossy_mode``). Newton's method from the rigid
    room's nπ/L, and from first-order perturbation's √(jk(β₀ + β_L)/L) for n = 0."""
    b0, b1 = admittance
    kap = np.where(order > 0, order * math.pi / length_m + 0j,
                   np.sqrt(1j * k * (b0 + b1) / length_m))
    for _ in range(60):
        s, co = np.sin(kap * length_m), np.cos(kap * length_m)
        a = kap**2 + k * k * b0 * b1
        f = a * s - 1j * k * kap * (b0 + b1) * co
        df = 2 * kap * s + a * length_m * co - 1j * k * (b0 + b1) * (co - kap * length_m * s)
        # A rigid pair of walls keeps κ = 0 for n = 0 (f = df = 0 there).
        step = np.divide(f, df, out=np.zeros_like(f), where=df != 0)
        kap = kap - step
        if np.all(np.abs(step) < 1e-12 * np.maximum(1.0, np.abs(kap))):
            break
    return kap


def locally_reacting_modes(size_m, admittance, top_hz, c=343.0):
    """The modes of a rectangular room ``size_m`` whose walls are locally reacting with real
    specific admittances ``admittance`` = {axis: (at 0, at L)}, up to ``top_hz``: orders
    int[M, 3], complex wavenumbers k[M] (ω = ck, the energy decaying as exp(−2c·Im k·t)) and
    κ[M, 3] per axis. The room separates exactly (Morse and Bolt 1944): each axis is solved
    at the mode's k (:func:`axis_wavenumbers`) and k² = Σκ², iterated to a fixed point. Not
    first-order perturbation: that gives a mode with no node along an axis the rate
    c(β₀ + β_L)/L, valid while k(β₀ + β_L)L ≪ 1, and paper-small's floor makes that 1.0 at
    500 Hz and 2.1 at 1 kHz (there such modes decay 5 % and 20 % slower than it says)."""
    size = np.asarray(size_m, float)
    n = np.stack(np.meshgrid(*[np.arange(int(2 * top_hz / c * L) + 2) for L in size],
                             indexing="ij"), -1).reshape(-1, 3)
    rigid = math.pi * np.sqrt(((n / size) ** 2).sum(1))
    n, k = n[(rigid > 0) & (rigid < 2 * math.pi * top_hz / c)], rigid + 0j
    k = k[(rigid > 0) & (rigid < 2 * math.pi * top_hz / c)]
    for _ in range(60):
        kap = np.stack([axis_wavenumbers(n[:, a], size[a], k, admittance[a])
                        for a in range(3)], 1)
        k, before = np.sqrt((kap**2).sum(1)), k
        if np.all(np.abs(k - before) < 1e-12 * np.abs(k)):
            break
    return n, k, kap


def mode_shapes(kap, k, admittance, size_m, points_m):
    """ψ[M, P] = Π_a (cos κ_a x_a + (jkβ₀/κ_a)·sin κ_a x_a) at ``points_m`` [P, 3], and the
    modes' norms Λ[M] = ∫ψ² dV / V (no conjugate: the modes of a lossy room are orthogonal in
    that product; Morse and Ingard ch. 9), in closed form per axis."""
    psi = np.ones((len(k), len(points_m)), complex)
    norm = np.ones(len(k), complex)
    for a in range(3):
        ka, length = kap[:, a], size_m[a]
        rigid = ka == 0  # n = 0 between two rigid walls: ψ = 1 along the axis
        safe = np.where(rigid, 1.0, ka)
        q = np.where(rigid, 0.0, 1j * k * admittance[a][0] / safe)
        x = np.asarray(points_m, float)[None, :, a]
        psi *= np.cos(ka[:, None] * x) + q[:, None] * np.sin(ka[:, None] * x)
        s2 = np.where(rigid, length / 2, np.sin(2 * ka * length) / (4 * safe))
        norm *= (length / 2 + s2 + q**2 * (length / 2 - s2)
                 + q * (1 - np.cos(2 * ka * length)) / (2 * safe)) / length
    return psi, norm


def band_power_gain(f_hz, centre_hz):
    """|H_b(f)|² of the waves' octave filters (crates/sonolux-core/src/wave/bands.rs): power
    complementary, each edge's transition a quarter octave wide on either side."""
    def transition(x):
        phase = math.pi / 4 * (np.clip(x, -1.0, 1.0) + 1.0)
        return np.cos(phase), np.sin(phase)
    rise = transition(np.log2(f_hz / (centre_hz / math.sqrt(2))) / 0.25)[1]
    fall = transition(np.log2(f_hz / (centre_hz * math.sqrt(2))) / 0.25)[0]
    return (rise * fall) ** 2


def locally_reacting_modal_decay(size_m, source_m, points_m, admittance, bands_hz, air_per_m,
                                 fit_limits=True, record_s=3.0, coherent_s=None):
    """T30, T20 and EDT per octave (and the decay's curvature, %) of a rectangular room whose
    walls are locally reacting with real specific admittances ``admittance`` = {axis: (at 0,
    at L)}, from its exact modes (:func:`locally_reacting_modes`), as a band of the waves
    measures it. The room's impulse response (per unit volume acceleration, the waves'
    normalisation: h = δ(t − r/c)/r in free field) is the modal expansion of the Green's function
    (Morse and Ingard ch. 9), h(t) = Re Σ_n −j·ψ_n(s)ψ_n(r)/(VΛ_n k_n)·exp(jck_n t) for t > 0
    (:func:`modal_responses`). The air adds m·c per band. ``fit_limits``: as decay_times'.
    ``record_s``: the modal decay's length (decay_times' truncation check wants the record to
    reach 20 dB below T30's lower end: 3 s holds T30 up to about 3 s).

    Incoherent (``coherent_s=None``): mode n counts in a band with |ψ_n(s)|²·mean|ψ_n(r)|²/
    (|Λ_n|²·|k_n|²) times the band filter's power gain at its frequency, and decays as
    exp(−2c·Im k_n·t): the cross terms of the modes are dropped. They vanish from the mean over
    points that fill the room (the modes are orthogonal, ∫ψ_nψ_m dV = 0), and late in the decay
    (they beat at the modes' differences); they do not vanish early at points that share one
    height with the source, as the paper rooms' receivers do: there the modes that differ only
    along the vertical add up coherently to the direct sound and the early reflections, which
    travel near the floor and are absorbed slowly. So the incoherent sum is right for T30 and
    wrong for EDT there (paper-large, 125 Hz: EDT 2.55 s incoherent, 3.04 s coherent; T30 3.25
    and 3.24). ``coherent_s``: the responses are then summed coherently (:func:`modal_responses`)
    over [0, coherent_s), band-filtered with the waves' zero-phase filters, squared and averaged
    over the points; the incoherent sum continues the decay after coherent_s (where the cross
    terms have died down; the EDC at coherent_s sets only the level the early decay falls to)."""
    c = 343.0
    size = np.asarray(size_m, float)
    top_hz = max(bands_hz) * 2 ** 0.75  # the top band filter's gain is 0 above it
    _, k, kap = locally_reacting_modes(size, admittance, top_hz * (1.25 if coherent_s else 1.0), c)
    at_source, norm = mode_shapes(kap, k, admittance, size, np.asarray(source_m, float)[None])
    at_points, _ = mode_shapes(kap, k, admittance, size, points_m)
    weight = (np.abs(at_source[:, 0]) ** 2 * np.mean(np.abs(at_points) ** 2, axis=1)
              / (np.abs(norm) ** 2 * np.abs(k) ** 2))
    f_hz, rate = c * k.real / (2 * math.pi), 2 * c * k.imag
    t = np.arange(0.0, record_s, 1e-3)
    widths = np.full(t.size, 1e-3)
    if coherent_s:
        fs = 2.5 * top_hz * 1.25  # above twice the highest mode summed: no aliasing
        coefficients = (at_source[:, 0] / (norm * k))[:, None] * at_points
        # 0.2 s more than kept: room for the zero-phase filters' ringing at the cut.
        early_t, responses = modal_responses(coefficients, c * k, coherent_s + 0.2, fs)
        n = int(np.searchsorted(early_t, coherent_s))
        late_t = np.arange(early_t[n], record_s, 1e-3)
        t = np.concatenate([early_t[:n], late_t])
        widths = np.concatenate([np.full(n, 1 / fs), np.full(late_t.size, 1e-3)])
        spectrum = np.fft.rfft(responses, 2 * early_t.size)
        spectrum_f = np.fft.rfftfreq(2 * early_t.size, 1 / fs)
    out = {"t30_s": [], "t20_s": [], "edt_s": [], "curvature_percent": []}
    for fc, m in zip(bands_hz, air_per_m):
        # Power: half each mode's squared amplitude (the mean of Re² over a period).
        energy = decaying_sum(0.5 * weight * band_power_gain(f_hz, fc), rate, t) * widths
        if coherent_s:
            banded = np.fft.irfft(spectrum * np.sqrt(band_power_gain(
                np.maximum(spectrum_f, 1e-9), fc)), 2 * early_t.size)[:, :n]
            energy[:n] = (banded**2).mean(0) / fs
        d = decay_times(energy * np.exp(-m * c * t), t, widths, fit_limits=fit_limits)
        for key in out:
            out[key].append(float(d[key]))
    return {key: np.array(v) for key, v in out.items()}


def decaying_sum(amplitude, rate, t, chunk=512):
    """Σ_n amplitude_n·exp(−rate_n·t) at the times ``t``, a few hundred times at once (the
    modes × times matrix of paper-large's 250 Hz band would take gigabytes)."""
    return np.concatenate([np.exp(-np.outer(t[i:i + chunk], rate)) @ amplitude
                           for i in range(0, t.size, chunk)])


def modal_responses(coefficients, omega, record_s, sample_rate_hz, chunk=256):
    """h_p(t) = Re Σ_n −j·a_np·exp(jω_n t) at ``sample_rate_hz`` over [0, ``record_s``):
    ``coefficients`` a[M, P] (ψ_n(s)ψ_n(r_p)/(Λ_n k_n), the constant factors dropped),
    ``omega`` the modes' complex angular frequencies ω_n = ck_n [M] (Im > 0: decaying). Each mode
    of a lossy room with frequency-independent admittance is a pole of the Green's function at
    k_n and at −k_n*; with a rigid room's a_np = ψψ/(Λω) this is Σψψ/Λ·sin(ω_n t)/ω_n. The
    residue's correction for the modes' dependence on k through the walls, (k/K_n)·dK_n/dk − 1,
    is of order β/(kL) (below 0.2 % in the paper rooms) and is left out. Returns (t [T],
    h [P, T])."""
    t = np.arange(int(round(record_s * sample_rate_hz))) / sample_rate_hz
    h = np.empty((coefficients.shape[1], t.size))
    a = -1j * coefficients.T
    for i in range(0, t.size, chunk):
        h[:, i:i + chunk] = (a @ np.exp(1j * omega[:, None] * t[None, i:i + chunk])).real
    return t, h


def iso_3382_2_sigma(key, t_s, bandwidth_hz, points):
    """Relative standard deviation of a reverberation time from ISO 3382-2:2008 annex A, one
    decay a point (n = 1, as a conservative reading of the integrated impulse response), over
    ``points`` independent points: T30 0.55·√((1 + 1.52)/(N·B·T)); EDT takes T20's
    0.88·√((1 + 1.90)/(N·B·T)) (the annex gives none for EDT, whose 10 dB range is shorter
    still)."""
    k, m = (0.55, 1.52) if key == "t30_s" else (0.88, 1.90)
    return k * math.sqrt((1 + m) / (points * bandwidth_hz * t_s))


WALLS, FLOOR = 0.05, 0.30  # paper-small's random-incidence absorption, walls and ceiling / floor


def paper_room_modes(scene, field, far, bands_hz, first_band, fit_limits=True, coherent_s=None):
    """:func:`locally_reacting_modal_decay` of paper-small as ``field`` was baked: its source,
    the cubature points of its receivers ``far`` (wave_spheres.ball_points, the points the waves
    average over), each band's g from Paris' formula and the field's air; ``coherent_s`` as
    there (the receivers share the source's height: EDT needs it)."""
    from sonolux.sound.wave_spheres import ball_points

    walls, floor = (admittance_from_random(a) for a in (WALLS, FLOOR))
    points = ball_points(scene.geometry, np.asarray(field.positions_m)[far],
                         scene.receivers.radius_m)
    air = field.settings["air_attenuation_per_m"][first_band:first_band + len(bands_hz)]
    return locally_reacting_modal_decay(
        (6.0, 2.5, 2.0), field.source_positions_m[0], points,
        {0: (walls, walls), 1: (walls, walls), 2: (floor, walls)}, bands_hz, air,
        fit_limits=fit_limits, coherent_s=coherent_s)


def mean_times(field, far, fit_limits=True):
    """Mean T30, T20 and EDT per band over the receivers ``far``."""
    e = np.asarray(field.energy)[far].sum(axis=1, dtype=np.float64)
    d = decay_times(e, field.bin_start_s, field.bin_width_s, fit_limits=fit_limits)
    return {k: np.nanmean(d[k], axis=0) for k in ("t30_s", "t20_s", "edt_s")}


@pytest.mark.slow
def test_paper_room_decay_continuous_across_the_crossover():
    """paper-small (6 × 2.5 × 2 m, walls 0.05, floor 0.3, scattering 0.1) baked with waves at
    a crossover of 707 Hz (125-500 Hz from the waves, 1 kHz up from the rays). The hybrid's
    rays use the waves' wall (locally reacting, each band's g from Paris' formula; docs/walls.md),
    chosen automatically. Receivers: the 14 that do not hold the source, mean decay times.

    What "continuous" means here. The materials are flat, but a locally reacting room's decay
    is not: in its exact modes (``locally_reacting_modal_decay``, an independent model of the
    same room) those with no node along the floor's axis lose energy to the floor more slowly
    than the others, so the room's own EDT falls 2.3 % from 500 Hz to 1 kHz. The hybrid is
    continuous when its change from the last wave band to the first ray band is the room's
    change, within the noise of a decay: ISO 3382-2 annex A (``iso_3382_2_sigma``) at 500 Hz
    (B = 354 Hz), 4 independent points (the grid is mirror-symmetric), three σ; the rays' own
    noise at 20,000 rays is far below it. EDT: 15 %.

    Measured (2026-11-27, this test's bakes): waves 500 Hz EDT 0.623 s, rays 1 kHz 0.607 s
    (with the angle-independent α of a plain bake 0.756); the room's exact modes, summed
    coherently (the receivers share the source's height), 0.650 and 0.588. The hybrid's step
    −2.7 % against the room's −9.4 %, 7.5 % apart (with angle-independent walls +34 % apart,
    which the test asserts would fail; their 1 kHz EDT is +28 % off the room's); the rays' 1 kHz
    EDT +3.1 % off the room's. (The modes summed incoherently gave 0.665 and 0.650: the room's
    step −2.3 %, the rays −6.6 % off it.) Session 9, the walls meeting the grid's diffuse-field
    absorption: the hybrid's step 4.3 % from the room's. Session 13, the grazing mode's profile in
    the rays: +4.4 % apart, the rays' 1 kHz EDT +3.2 % off the room's. T30 is
    ``test_paper_room_t30_step_across_the_crossover_is_the_rooms`` (a strict xfail) and
    ``test_the_rays_t30_in_this_room_is_their_scattering``."""
    h, plain, modal = _paper_room_decays()
    tol_edt = 3 * iso_3382_2_sigma("edt_s", modal["edt_s"][0], 354.0, 4)
    assert 0.14 < tol_edt < 0.16
    step = h["edt_s"][3] / h["edt_s"][2]
    room = modal["edt_s"][1] / modal["edt_s"][0]
    print("EDT step hybrid", step, "room", room, "tolerance", tol_edt)
    assert abs(step - 1) < tol_edt
    assert abs(step / room - 1) < tol_edt
    # The angle-independent walls (a plain bake's) would step +24 % off the room's.
    assert abs(plain["edt_s"][3] / h["edt_s"][2] / room - 1) > tol_edt
    # The rays' EDT at 1 kHz against the room's modes in their own band (11 %).
    tol_rays = 3 * iso_3382_2_sigma("edt_s", modal["edt_s"][1], 707.0, 4)
    print("EDT rays/room at 1 kHz", h["edt_s"][3] / modal["edt_s"][1], tol_rays)
    assert abs(h["edt_s"][3] / modal["edt_s"][1] - 1) < tol_rays


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="paper-small's T30 is set by near-grazing sound over its "
                   "absorbing floor, which the rays' scattering (0.1) removes and the waves' flat "
                   "walls keep: the room's exact modes step +9 % from 500 Hz to 1 kHz, the hybrid "
                   "−22 % (3σ 10 %); rays give the flat room's 1 kHz T30 at no scattering "
                   "coefficient but a fitted one (test_the_rays_t30_in_this_room_is_their_"
                   "scattering; issue 18, docs/waves-walls.md). A coefficient alone keeps the waves' "
                   "walls flat by decision (session 10: its angle dependence is not in the data); "
                   "described surfaces on both sides did not close it either (docs/waves-walls.md); "
                   "nor do the rays' grazing modes (wall_model 'locally-reacting-modes', the "
                   "hybrids' default since session 12: −32.3 % with the scene's scattering, "
                   "−30.2 % without them; −6.8 % with flat walls on both sides; session 13, the "
                   "grazing mode's profile: −31.9 %, and −1.8 % with flat walls on both sides, "
                   "test_waves_paper_rooms.py test_flat_paper_rooms_t30_step_across_the_crossover_"
                   "is_the_rooms)")
def test_paper_room_t30_step_across_the_crossover_is_the_rooms():
    """The hybrid's T30 step from 500 Hz (waves) to 1 kHz (rays) against the room's own step
    (its exact modes; at 1 kHz the room's decay bends, curvature 12 %, so its T30 is the fitted
    line's, ``fit_limits=False``), within 3σ of ISO 3382-2 annex A of both bands combined (see
    ``test_paper_room_decay_continuous_across_the_crossover``). Measured (2026-11-27): waves
    0.832 s at 500 Hz against the modes' 0.848 (−1.8 %); rays 0.645 s at 1 kHz against 0.923
    (−30 %). Session 12, the grazing modes the hybrid's default: waves 0.848 s, rays 0.626 s,
    step −32.3 % against the room's. Session 13, the grazing mode's profile across the gap: rays
    0.630 s, step −31.9 %."""
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
    source, and the room's exact modes at 500 Hz and 1 kHz, T30 as fitted (computed once a
    session)."""
    if not _DECAYS:
        scene = sonolux.load_scene("paper-small")
        hybrid = bake(scene, rays=20_000, waves=True, crossover_hz=707)
        plain = bake(scene, rays=20_000)
        assert hybrid.settings["wall_model"] == "locally-reacting-modes"
        assert plain.settings["wall_model"] == "random-incidence"
        assert hybrid.waves["wave_bands"] == 3
        far = np.linalg.norm(hybrid.positions_m - hybrid.source_positions_m[0], axis=1) > 0.5
        modal = paper_room_modes(scene, hybrid, far, [500.0, 1000.0], 2, fit_limits=False,
                                 coherent_s=0.4)
        h, p = mean_times(hybrid, far), mean_times(plain, far)
        print("T30 hybrid", h["t30_s"], "plain", p["t30_s"], "modal", modal["t30_s"])
        print("EDT hybrid", h["edt_s"], "plain", p["edt_s"], "modal", modal["edt_s"])
        _DECAYS.update(h=h, p=p, modal=modal)
    return _DECAYS["h"], _DECAYS["p"], _DECAYS["modal"]


@pytest.mark.slow
def test_the_waves_follow_the_modes_of_the_locally_reacting_room():
    """The waves against the exact modes of the same locally reacting room, summed coherently
    (``coherent_s``: the receivers share the source's height), at the same cubature points
    through the same band filters: EDT per octave within 5 %, the just noticeable difference
    (ISO 3382-1:2009 table A.1), T30 within 2 % (``WAVES_MODES``: what the grid's wall leaves
    once its fit meets the grid's diffuse-field absorption). Both are deterministic models of one
    room at the same points, so no measurement noise applies; what separates them is the scheme's
    discretisation (walls rounded to cells, the boundary's numerical reflectance), which should
    not be audible. Measured (2026-11-27, session 9): T30 −0.7/−0.3/−0.7 %, EDT +1.5/+0.4/−1.1 %
    at 125/250/500 Hz; before the fit met the grid's diffuse field (session 8, its conductance
    fitted to the normal level up to f_max, the first ray band included): T30 −2.9/−2.5/−2.5 %,
    EDT −0.5/−1.4/−4.1 % (the incoherent modes, whose EDT is not this room's: EDT
    −1.3/−1.9/−6.2 %).
    First-order perturbation (the modes' rates c·Σ g·ε/L, Morse and Bolt's ε = 1 along an axis
    without a node) is not valid here for the floor's grazing modes (k(β₀ + β_L)L = 1.0 at
    500 Hz): it put the room's 500 Hz T30 at 0.769 s, the waves +8.3 % above it; the exact
    modes give 0.853. At twice the grid's resolution (crossover 1414 Hz) the waves' 500 Hz T30
    moves by 0.1 %: the grid has converged (docs/waves-hybrid.md, "Continuity")."""
    scene = sonolux.load_scene("paper-small")
    hybrid = bake(scene, rays=2_000, waves=True, crossover_hz=707)
    far = np.linalg.norm(hybrid.positions_m - hybrid.source_positions_m[0], axis=1) > 0.5
    h = mean_times(hybrid, far)
    modal = paper_room_modes(scene, hybrid, far, [125.0, 250.0, 500.0], 0, coherent_s=0.4)
    print("waves", h, "modes", modal)
    for key in ("t30_s", "edt_s"):
        ratio = h[key][:3] / modal[key] - 1
        assert np.all(np.abs(ratio) < WAVES_MODES[key]), (key, ratio)


#: Just noticeable differences, relative (ISO 3382-1:2009 table A.1).
JND = {"t30_s": 0.05, "edt_s": 0.05}

#: The waves against the exact modes, relative. EDT: one JND (above; no tighter bound is derived:
#: the early decay at a point follows the first reflections off walls rounded to cells). T30:
#: 2 %, what is left once the walls meet the grid's diffuse-field absorption (``fit.rs``, session
#: 9): (a) the grid's wall still depends on angle, and in the wave bands the conductance one
#: direction wants differs from the diffuse field's by at most 0.7 % (at f_max/2: grazing +0.4 %,
#: diffuse +1.1 %, normal +1.7 % over Paris' g; the paper rooms' T30 is set by sound grazing the
#: floor, T ∝ 1/g), and (b) ``mean_times`` averages the receivers' decay times where the modes
#: decay the points' summed energy (0.6-1 % on paper-large, i18low). 0.7 + 1 rounded up to 2 %.
#: Measured (2026-11-27): worst 0.8 % (paper-large 125 Hz, −0.8 %; before the fit met the grid's
#: diffuse field: 4.2 %).
WAVES_MODES = {"t30_s": 0.02, "edt_s": JND["edt_s"]}


@pytest.mark.slow
def test_the_rays_t30_in_this_room_is_their_scattering():
    """Why the T30 step is not the room's (the strict xfail above), with numbers. paper-small's
    late decay is sound travelling nearly parallel to its absorbing floor: it meets the floor
    rarely and at grazing angles, where a locally reacting wall hardly absorbs (α(θ) → 0). Rays
    reflected specularly keep their angle to the floor for ever; a scattered reflection
    (ISO 17497-1, s = 0.1 here) sends them anywhere. The waves' walls are flat: they carry no
    scattering coefficient, and their room is the exact modes'. So at 1 kHz, T30 (fitted,
    every decay here bends) of rays with locally reacting walls: s = 0.1 0.65 s, s = 0.03 0.91,
    s = 0.01 1.29, s = 0 1.57; the flat room's modes 0.92. With no scattering the rays overshoot
    it: a ray may graze the floor at any angle, a mode no closer than its lowest κ along the
    floor's axis (|κ| ≈ 0.7/m at 1 kHz, about 2° from grazing). No scattering coefficient from the
    scene gives the waves' room; one fitted to it (about 0.03) would. Asserted: the flat room's
    T30 lies outside three σ (5 %) of the rays' both with the scene's scattering and without."""
    source = sonolux.load_scene("paper-small")
    t30 = {}
    for s in (0.0, 0.1):
        scene = _with_scattering("paper-small", s)
        field = bake(scene, rays=20_000, wall_model="locally-reacting")
        far = np.linalg.norm(field.positions_m - field.source_positions_m[0], axis=1) > 0.5
        t30[s] = mean_times(field, far, fit_limits=False)["t30_s"][3]
    modal = paper_room_modes(source, field, far, [1000.0], 3, fit_limits=False)["t30_s"][0]
    tol = 3 * iso_3382_2_sigma("t30_s", modal, 707.0, 4)
    print("T30 1 kHz rays s=0.1", t30[0.1], "s=0", t30[0.0], "modes", modal, "tolerance", tol)
    assert t30[0.1] / modal - 1 < -tol
    assert t30[0.0] / modal - 1 > tol


def _with_scattering(name, scattering):
    """The built-in scene ``name`` with every material's scattering coefficient set to
    ``scattering``."""
    import tomllib

    from sonolux.scene import builtin

    data = tomllib.loads(builtin.path(name).read_text())
    for material in data["materials"].values():
        material["scattering"] = scattering
    return sonolux.load_scene(data)


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


def test_exact_modes_are_first_order_perturbation_for_small_admittance_only():
    """The reference the tests above use, checked on its own: with small admittances the exact
    modes' energy decay rates 2c·Im k equal first-order perturbation's c·Σ_w β_w·ε_w/L_w (Morse
    and Bolt; ε = 2 with a node count > 0 along the wall's axis, 1 without) within 0.1 %
    (the next order is k(β₀ + β_L)L ≈ 0.02 smaller here); with paper-small's floor (g 0.0506,
    walls 0.00665) the modes with no node along the floor's axis decay slower than first
    order says, by 2-8 % at 500 Hz and 7-27 % at 1 kHz (their rates' ratio to it 0.92-0.98 and
    0.73-0.93), the others within 2.1 % and 4.5 % (asserted within 2.5 % and 5 %): the
    perturbation is not valid for the former, k(β₀ + β_L)L being 1.0 and 2.1. A root not followed
    from the rigid mode would land on a neighbour's rate, far outside these."""
    c, size = 343.0, np.array([6.0, 2.5, 2.0])

    def rates(admittance, top_hz):
        n, k, _ = locally_reacting_modes(size, admittance, top_hz)
        eps = np.where(n > 0, 2.0, 1.0)
        first = c * sum(eps[:, a] * sum(admittance[a]) / size[a] for a in range(3))
        return n, c * k.real / (2 * math.pi), 2 * c * k.imag / first

    small = {a: (1e-4, 2e-4) for a in range(3)}
    _, _, ratio = rates(small, 300.0)
    assert np.all(np.abs(ratio - 1) < 1e-3), (ratio.min(), ratio.max())
    walls, floor = (admittance_from_random(a) for a in (WALLS, FLOOR))
    n, f, ratio = rates({0: (walls, walls), 1: (walls, walls), 2: (floor, walls)}, 1414.0)
    grazing = n[:, 2] == 0
    for fc, (lo, hi), others in ((500.0, (0.91, 0.99), 0.025), (1000.0, (0.72, 0.93), 0.05)):
        band = (f >= fc / math.sqrt(2)) & (f < fc * math.sqrt(2))
        print(fc, "grazing", ratio[band & grazing].min(), ratio[band & grazing].max(),
              "others", ratio[band & ~grazing].min(), ratio[band & ~grazing].max())
        assert lo < ratio[band & grazing].min() and ratio[band & grazing].max() < hi
        assert np.all(np.abs(ratio[band & ~grazing] - 1) < others)


def test_coherent_modes_are_incoherent_over_the_volume_but_not_at_one_height():
    """The coherent reference (``coherent_s``) checked on its own. Averaged over points that
    fill the room (a midpoint grid finer than the highest mode's half wavelength on each axis,
    on which the rigid modes are exactly orthogonal), the modes' cross terms cancel and the
    coherent decay is the incoherent one: paper-small at 250 Hz, EDT and T30 within 1 % (the
    residue: the lossy modes are orthogonal without the conjugate, and |h|² takes it; measured
    −0.2 % and 0.0 %). At receivers that share the source's height (paper-large, 125 Hz, 1.5 m
    as the scene's, every 2 m) the modes differing only along the vertical stay coherent early:
    EDT 17 % longer coherent (asserted > 10 %), while T30 agrees within 1 % (measured −0.6 %).
    That was paper-large's "+14.6 %" of the waves' EDT (docs/waves-hybrid.md, "Continuity")."""
    walls, floor = (admittance_from_random(a) for a in (WALLS, FLOOR))
    admittance = {0: (walls, walls), 1: (walls, walls), 2: (floor, walls)}

    def points(size, counts, height=None):
        axes = [(np.arange(n) + 0.5) / n * length for n, length in zip(counts, size)]
        if height is not None:
            axes[2] = np.array([height])
        return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)

    for size, source, grid, height, band, record_s, coherent_s in (
            ((6.0, 2.5, 2.0), (1.5, 1.1, 1.5), (20, 9, 7), None, 250.0, 3.0, 0.5),
            ((24.0, 10.0, 8.0), (6.1, 4.3, 1.5), (12, 5, 1), 1.5, 125.0, 8.0, 1.0)):
        at = points(size, grid, height)
        incoherent, coherent = (
            locally_reacting_modal_decay(size, source, at, admittance, [band], [0.0],
                                         fit_limits=False, record_s=record_s, coherent_s=s)
            for s in (None, coherent_s))
        edt = coherent["edt_s"][0] / incoherent["edt_s"][0] - 1
        t30 = coherent["t30_s"][0] / incoherent["t30_s"][0] - 1
        print(size, band, "EDT coherent/incoherent", edt, "T30", t30)
        assert abs(t30) < 0.01
        assert (abs(edt) < 0.01) if height is None else (edt > 0.10)
