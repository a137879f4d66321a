"""Whether a measured (SOFA) source's wave bands share one acoustic centre
(``sonolux.sound.wave_centre``: each band's own centre from its measured phase, after Ben Hagai,
Pollow, Vorländer and Rafaely, JASA 2011; the cost of one shared centre in the fit's orders, from
the plane wave's expansion in spherical Bessel functions), on synthetic sources: one displaced
alike in every band (they share: nothing is flagged, the fit is the one of before) and one whose
centre moves with frequency (as a loudspeaker's does: Jacobsen, Barrera-Figueroa and
Rasmussen, JASA 2004), whose bands' centres are found each where it is and flagged."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import fft as sfft

import sonolux
from sonolux.sound import wave_sources
from sonolux.sound.wave_centre import translation_spill
from tests.sound.test_wave_sources_centre import (
    OFFSET_M,
    TO_WORLD,
    as_read,
    cluster_error,
    displaced,
)
from tests.sound.test_wave_sources_order2 import BANDS, C, ring_and_elevations

pytestmark = pytest.mark.usefixtures("core")


def moving(n: int = 500):
    """A cardioid (its frame: x forward) whose centre lies at OFFSET_M·f/125 Hz from the array's
    centre at frequency f (half of it at 63 Hz, twice at 250 Hz), far field: H = D(u)·e^{ik
    u·d(f)}; read as a SOFA directivity is (power and relative phase)."""
    mics = wave_sources.fibonacci_directions(n)
    freqs = np.linspace(20.0, 2000.0, 100)
    k = 2.0 * np.pi * freqs / C
    along = mics @ OFFSET_M
    h = (0.5 + 0.5 * mics[:, 0])[:, None] * np.exp(1j * along[:, None] * (k * freqs / 125.0)[None])
    return as_read("moving.sofa", mics, freqs, h)


def test_the_spill_of_a_translation_is_what_a_quadrature_of_the_moved_monopole_gives():
    """1 − Σ_{n≤L}(2n + 1) j_n(kδ)² against the energy of e^{ik u·δ} above orders 0 and 1
    projected on 4,096 Fibonacci directions (its orders 0 and 1 are ⟨f⟩ and 3⟨f u⟩): within
    1e-6 (the lattice's quadrature error for these smooth functions)."""
    u = wave_sources.fibonacci_directions(4096)
    for x in (0.05, 0.3, 1.0, 2.5):
        f = np.exp(1j * x * u[:, 2])
        order0 = abs(f.mean()) ** 2
        order1 = 3.0 * float(np.sum(np.abs((f[:, None] * u).mean(axis=0)) ** 2))
        spill = translation_spill(np.array([x, x]), np.array([1.0, 1.0]), np.array([0, 1]))
        assert spill[0] == pytest.approx(1.0 - order0, abs=1e-6)
        assert spill[1] == pytest.approx(1.0 - order0 - order1, abs=1e-6)


@pytest.mark.parametrize("pattern", ["omni", "cardioid"])
def test_a_source_displaced_alike_in_every_band_shares_one_centre(pattern):
    """Every wave band's own centre is the offset (2% of it, the centre's tested tolerance), and
    none is flagged: one shared centre costs nothing measurable."""
    source, d = displaced(pattern)
    fit = wave_sources.fit(source, d, len(BANDS), bands_hz=BANDS, centre_bands=3)
    assert fit.band_centres_m.shape == (3, 3)
    offset = TO_WORLD @ OFFSET_M
    assert np.all(np.linalg.norm(fit.band_centres_m - offset[None], axis=1)
                  < 0.02 * np.linalg.norm(offset)), fit.band_centres_m
    assert not np.any(fit.centres_differ)
    assert "own centres" not in wave_sources.centred(fit)


def test_a_source_whose_centre_moves_with_frequency_is_found_band_by_band():
    """Each wave band's centre is where the phase puts it at the band's centre frequency,
    OFFSET_M·f_b/125 Hz (within 3% of it: the centre's 2% and the linear interpolation of a
    phase growing as f² between the file's 20 Hz steps, (Δf)²/(8 f²) ≤ 1.3% at 63 Hz).

    Whether they must differ is the fit's to say. With the orders the fit radiates (0-2 here)
    the shared centre, 0.12 m from the 63 Hz band's own, leaves 2.6·10⁻⁶ of that band above its
    orders (a translation by δ reaches above order L only as j_n(kδ), n > L: kδ = 0.14 there),
    less than the 4·10⁻⁴ for which the fit radiates an order at all: they share one, nothing
    is flagged. With order 1 only (a cluster capped by a near wall)
    the same translation leaves a few per mille, far more than at the band's own centre: the
    bands are flagged, the log names how far apart their centres lie, and each is radiated
    from its own (below)."""
    source, d = moving()
    fit = wave_sources.fit(source, d, len(BANDS), bands_hz=BANDS, centre_bands=3)
    for b in range(3):
        want = TO_WORLD @ OFFSET_M * (BANDS[b] / 125.0)
        assert np.linalg.norm(fit.band_centres_m[b] - want) < 0.03 * np.linalg.norm(want), (
            b, fit.band_centres_m[b], want)
    assert not np.any(fit.centres_differ), (fit.residual, fit.orders)
    assert np.all(fit.residual[:3] < 1e-4)
    capped = wave_sources.fit(source, d, len(BANDS), np.ones(len(BANDS), int), bands_hz=BANDS,
                              centre_bands=3)
    np.testing.assert_array_equal(capped.band_centres_m, fit.band_centres_m)
    assert capped.centres_differ[0], (capped.residual, capped.band_centres_m)
    # Each flagged band is radiated from its own centre, so what the fit reports it leaves out
    # is what it leaves there (a cardioid about its own centre is order 1: ≈ 10⁻⁶, the
    # centre's error), not the shared centre's 1.2·10⁻³.
    assert np.all(capped.residual[:3] < 1e-4), capped.residual
    assert "own centres lie" in wave_sources.centred(capped)


def capped_moving():
    """The moving cardioid (:func:`moving`) fitted to order 1 in every band (a cluster capped by
    a near wall), its centre found from the three wave bands: (source, directivity, the fit
    with each flagged band radiated from its own centre, the same fit from the shared one)."""
    source, d = moving()
    fit = wave_sources.fit(source, d, len(BANDS), np.ones(len(BANDS), int), bands_hz=BANDS,
                           centre_bands=3)
    shared = dataclasses.replace(fit, apart=np.zeros(0, bool))
    return source, d, fit, shared


def test_a_flagged_band_radiates_the_measured_field_from_its_own_centre():
    """The capped moving cardioid's three wave bands are flagged and each gets a cluster of its
    own at its own centre (the shared cluster then carries only the 500 Hz band). Their terms,
    summed in closed form as free-field monopoles (far field, over the reference pulse), give
    the measured complex field at 63, 125 and 250 Hz within 0.01 of its peak (measured 0.003:
    each band's centre is found within 3% of where it is, k·3%·|d_b| ≤ 0.016 rad; a cardioid
    referred to its own centre is order 1 exactly, so the cap costs nothing); radiated from the
    shared centre, 26-121 mm off the bands' own, the same order-1 fits miss by more than 0.04
    (measured 0.061: the translation's energy above order 1, ≈ 10⁻³, in amplitude). The
    clusters' weights are the edge blends' partition of unity: at each wave band's centre only
    that band's cluster sounds (the blends are exactly 0 or 1 half a band from an edge; the
    others' spectra there are what is left of their filters' tails once the signals are cut to
    the run's length: measured ≤ 1.4·10⁻³ of the band's own, asserted ≤ 3·10⁻³, the same
    order as the 10⁻³ test_wave_sources_order2 allows the blends' tails)."""
    source, d, fit, shared = capped_moving()
    np.testing.assert_array_equal(fit.apart, [True, True, True, False])
    clusters = fit.clusters()
    assert len(clusters) == 4
    for b, (offset, components) in enumerate(clusters[1:]):
        np.testing.assert_array_equal(offset, fit.band_centres_m[b])
        assert np.flatnonzero(np.any(components != 0.0, axis=1)).tolist() == [b]
    assert np.flatnonzero(np.any(clusters[0][1] != 0.0, axis=1)).tolist() == [3]
    u = wave_sources.fibonacci_directions(800)
    assert cluster_error(fit, source, d, u, bands=(0, 1, 2)) < 0.01
    assert cluster_error(shared, source, d, u, bands=(0, 1, 2)) > 0.04
    # Which cluster sounds where: the terms come cluster by cluster, each as many as the
    # distinct node offsets of its components' stencils.
    f_max, fs, steps = 500.0, 500.0 * 10 * math.sqrt(3.0), 8000
    spacing = C / (f_max * 10)
    pos, sig, _ = wave_sources.terms(np.zeros(3), fit, BANDS, f_max, spacing, fs, steps, C)
    sizes = [len({o for k in np.flatnonzero(np.any(c != 0.0, axis=0))
                  for o, _ in wave_sources.stencil(int(k))}) for _, c in clusters]
    assert sum(sizes) == len(pos)
    n_fft = sfft.next_fast_len(2 * steps, real=True)
    freqs = sfft.rfftfreq(n_fft, 1.0 / fs)
    spectra = np.abs(sfft.rfft(sig, n_fft, axis=1))
    starts = np.cumsum([0] + sizes)
    for b in range(3):
        i = int(np.argmin(np.abs(freqs - BANDS[b])))
        level = [spectra[starts[j]:starts[j + 1], i].max() for j in range(len(sizes))]
        own = level[b + 1]
        assert all(x <= 3e-3 * own for j, x in enumerate(level) if j != b + 1), (b, level)


def test_held_bands_go_with_the_last_wave_band_s_own_centre_and_reach_covers_every_centre():
    """On a grid (``fit_on_grid`` with three wave bands, order 1 for a wall 0.3 m away), the
    500 Hz band copies the 250 Hz band's fit and goes with its cluster; ``reach_m`` is the
    farthest any cluster's terms reach from the source's position (each centre's distance
    plus its stencil's 2 cells), which is more than the shared cluster alone would need here
    (the 250 Hz band's centre is 197 mm out, the shared one 173 mm), and the clearance check
    refuses on it."""
    source, d = moving()
    spacing = C / (10 * 354.0)
    fit = wave_sources.fit_on_grid(source, d, BANDS, spacing, C, clearance_m=0.3, wave_bands=3)
    assert np.all(fit.orders == 1), fit.orders
    np.testing.assert_array_equal(fit.apart, [True, True, True, True])
    np.testing.assert_array_equal(fit.own_centres_m[3], fit.own_centres_m[2])
    clusters = fit.clusters()
    assert len(clusters) == 4 and not np.any(clusters[0][1])  # the shared centre carries nothing
    assert np.flatnonzero(np.any(clusters[3][1] != 0.0, axis=1)).tolist() == [2, 3]
    want = max(np.linalg.norm(fit.band_centres_m, axis=1)) + 2.0 * spacing
    assert wave_sources.reach_m(fit, spacing) == pytest.approx(want, rel=1e-12)
    shared = dataclasses.replace(fit, apart=np.zeros(0, bool))
    assert wave_sources.reach_m(fit, spacing) > wave_sources.reach_m(shared, spacing) + 0.01
    assert "each radiate from its own centre" in wave_sources.centred(fit)


def test_an_unflagged_source_s_cluster_is_the_shared_one():
    """Orders 0-2 (nothing flagged): one cluster, the fit's own components at the shared
    centre, so its terms are those of before (the bits of unflagged sources do not move)."""
    source, d = moving()
    fit = wave_sources.fit(source, d, len(BANDS), bands_hz=BANDS, centre_bands=3)
    assert not np.any(fit.apart)
    (offset, components), = fit.clusters()
    assert components is fit.components and offset is fit.centre_offset_m


def test_on_the_grid_each_flagged_band_radiates_the_measured_field_from_its_own_centre():
    """The capped moving cardioid injected on a grid to 250 Hz (12 m box with absorbing walls,
    18 receivers 2 m around the source, in and ±40° off its horizontal plane), its own-centre
    clusters and the shared one, against the field the measured source radiates there: a
    cardioid at the frequency's own centre d(f) (the synthetic source is one exactly),
    e^{−ikρ}/ρ·(½ + ½·cos θ'·(1 + 1/(ikρ))) over the omni run's e^{−ikr}/r (ρ, θ' from d(f);
    the dipole's near-field factor: kr = 2.3 at 63 Hz), each run's complex spectrum at the band
    centre windowed ±22 ms about the direct sound (before the box's first reflection, ≥ 23 ms
    later), up to one complex scale per band (the fit's power normalisation and the pulse).
    Largest error over the receivers, of the largest value: measured own 0.41 / 0.94 / 1.97%,
    shared 5.4 / 5.2 / 3.3% at 63 / 125 / 250 Hz. Asserted: own ≤ 1.5% at 63 and 125 Hz (the
    centre found within 3%: k·3%·|d_b| ≤ 0.7% at 125 Hz; the window's resolution, ≈ 45 Hz), ≤
    3% at 250 Hz (the grid's f_max: the stencils lose ≤ 0.5% there and the scheme's
    direction-dependent dispersion shifts the arrival by ≤ 1.1% of a period at 2 m); shared ≥
    4% at 63 and 125 Hz (the energy the translation puts above order 1, 1.2 / 1.7·10⁻³, as
    amplitude). At 250 Hz the band's own centre is 26 mm from the shared one (kδ = 0.12): the
    grid's own error there is as large as what sharing costs, so only the bound is asserted."""
    from tests.sound.test_wave_sources import anechoic_box, cluster_runs

    source, d, fit, shared = capped_moving()
    scene, src = anechoic_box()
    u = ring_and_elevations()
    r, f_max = 2.0, 250.0
    omni, runs = cluster_runs(scene, src, src + r * u, [fit, shared], f_max)
    delay = wave_sources.pulse_delay_s(BANDS, f_max, fit)
    h_omni, f = windowed_spectrum(omni, r / C)
    forward = TO_WORLD[:, 0]
    errors = []
    for out, _ in runs:
        h_dir, _ = windowed_spectrum(out, delay + r / C)
        worst = []
        for b in range(3):
            i = int(np.argmin(np.abs(f - BANDS[b])))
            k = 2.0 * math.pi * f[i] / C
            ratio = h_dir[:, i] / h_omni[:, i] * np.exp(1j * k * C * delay)
            rho_v = r * u - TO_WORLD @ OFFSET_M * (f[i] / 125.0)
            rho = np.linalg.norm(rho_v, axis=1)
            cos = rho_v @ forward / rho
            exact = (np.exp(-1j * k * (rho - r)) * r / rho
                     * (0.5 + 0.5 * cos * (1.0 + 1.0 / (1j * k * rho))))
            scale = np.vdot(exact, ratio) / np.vdot(exact, exact)
            worst.append(np.abs(ratio - scale * exact).max() / np.abs(scale * exact).max())
        errors.append(worst)
    own, one = errors
    assert own[0] < 0.015 and own[1] < 0.015 and own[2] < 0.03, errors
    assert one[0] > 0.04 and one[1] > 0.04, errors


def windowed_spectrum(out, arrival_s, half_s=0.022):
    """(complex spectra [receiver, frequency] of a run's pressure, windowed about the direct
    sound's ``arrival_s`` by a Tukey window flat over ±half_s/2 and zero beyond ±half_s; the
    frequencies)."""
    p = np.asarray(out["pressure_pa"], np.float64)
    fs = float(out["sample_rate_hz"])
    x = np.abs(np.arange(p.shape[1]) / fs - arrival_s) / half_s
    window = np.where(x < 0.5, 1.0, np.where(x < 1.0, 0.5 * (1 + np.cos(2 * np.pi * (x - 0.5))),
                                             0.0))
    n_fft = sfft.next_fast_len(4 * p.shape[1], real=True)
    return sfft.rfft(p * window, n_fft, axis=1), sfft.rfftfreq(n_fft, 1 / fs)


def test_own_clusters_that_do_not_fit_fall_back_to_the_shared_centre():
    """A wall between the shared order-1 cluster's reach (its centre 173 mm out plus 2 cells)
    and the own clusters' (the 250 Hz band's 197 mm plus 2 cells): the bands are radiated from
    the shared centre, said in the note, rather than the source refused; with more room they
    radiate from their own."""
    source, d = moving()
    spacing = C / (10 * 354.0)
    own = wave_sources.fit_on_grid(source, d, BANDS, spacing, C, clearance_m=0.3, wave_bands=3)
    shared = dataclasses.replace(own, apart=np.zeros(0, bool))
    between = 0.5 * (wave_sources.reach_m(own, spacing) + wave_sources.reach_m(shared, spacing))
    fitted = wave_sources.fit_on_grid(source, d, BANDS, spacing, C, clearance_m=between,
                                      wave_bands=3)
    assert not np.any(fitted.apart) and np.all(fitted.orders == 1)
    assert np.all(fitted.centres_differ)
    assert wave_sources.reach_m(fitted, spacing) < between
    assert "radiated from the shared centre" in fitted.note, fitted.note
    assert "orders above 1 left out" in fitted.note, fitted.note


def test_a_sofa_file_with_a_moving_centre_bakes_its_own_clusters_with_the_same_bits(tmp_path):
    """The moving cardioid written as a SOFA file (10° grid, complex transfer functions) 350 mm
    from a wall in a hybrid bake at a 354 Hz crossover (68.6 mm grid): orders 0-2 from the
    shared centre would reach 372 mm, so the fit is capped at order 1, where both wave bands'
    own centres (79 / 20 mm from the shared one) are flagged and each radiates from its own
    cluster (reach 335 mm); the log says so, and energy and wave pressure are the same bits on
    1 and 2 threads. 25 mm nearer the wall the own clusters do not fit and the bands fall back
    to the shared centre (reach 316 mm), said in the log."""
    import sofar

    from sonolux.sound.bake import bake

    az, el = np.meshgrid(np.arange(0, 360, 10.0), np.arange(-90, 91, 10.0))
    a, e = np.radians(az.ravel()), np.radians(el.ravel())
    local = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=1)
    freqs = np.linspace(20.0, 2000.0, 100)
    k = 2 * np.pi * freqs / C
    h = (0.5 + 0.5 * local[:, 0])[:, None] * np.exp(
        1j * (local @ OFFSET_M)[:, None] * (k * freqs / 125.0)[None])
    s = sofar.Sofa("FreeFieldDirectivityTF")
    s.delete("EmitterDescriptions")
    s.delete("Description")
    s.ReceiverPosition = np.stack([az.ravel(), el.ravel(), np.ones(az.size)], axis=1)
    s.N = freqs
    s.Data_Real, s.Data_Imag = h.real[None], h.imag[None]
    sofar.write_sofa(str(tmp_path / "moving.sofa"), s)

    def room(x_m, threads):
        return sonolux.load_scene({
            "name": "sofa-box", "settings": {"bands_hz": [125, 250, 500, 1000], "seed": 3,
                                             "threads": threads},
            "materials": {"m": {"absorption": 0.15, "scattering": 0.7}},
            "geometry": [{"type": "shoebox", "size_m": [5.0, 4.0, 3.0],
                          "materials": {"default": "m"}}],
            "sources": [{"name": "spk", "position_m": [x_m, 2.0, 1.5],
                         "directivity": {"sofa": "moving.sofa"}, "forward": [1.0, 0.0, 0.0],
                         "up": [0.0, 0.0, 1.0]}],
            "receivers": {"type": "points", "positions_m": [[3.9, 2.1, 1.4], [2.5, 0.7, 1.6]],
                          "radius_m": 0.3},
        }, base_dir=tmp_path)

    options = dict(rays=3_000, waves=True, crossover_hz=354, max_time_s=0.2)
    lines: list[str] = []
    out = [bake(room(0.35, t), **options, log=lines.append if t == 1 else None) for t in (1, 2)]
    line = next(s for s in lines if "monopoles" in s)
    assert "order 0-1/0-1 per wave band" in line, line
    assert "wave bands 1/2 each radiate from its own centre" in line, line
    assert "its shared acoustic centre" in line, line  # which radiates none of them
    np.testing.assert_array_equal(out[0].energy, out[1].energy)
    np.testing.assert_array_equal(out[0].waves["pressure"], out[1].waves["pressure"])
    lines.clear()
    bake(room(0.325, 1), **options, log=lines.append)
    line = next(s for s in lines if "monopoles" in s)
    assert "radiated from the shared centre" in line and "each radiate" not in line, line
