//! The wall fit (wave/fit.rs) on its own: what each band of a material absorbs once fitted, for
//! absorption from 0.01 to 0.99, against the fit's stated tolerance on absorption
//! (`fit::HALF_JND` of the absorption exponent −ln(1 − α), with the floor `fit::ABSORPTION_FLOOR`:
//! an error that moves a room's Eyring T30 by less than half a just noticeable difference).
//! Before session 12 the fit's tolerance was in decibels of reflected level, and a wall of α
//! 0.02–0.05 that varied across bands was fitted rigid (its level, −0.09 to −0.22 dB, within
//! 0.15 dB of nothing). The plane-wave check through the solver itself is wave_walls.rs (0.5 dB)
//! and the grid's oblique incidence wave_oblique.rs.

use sonolux_core::wave::admittance::{band_edges, Discretisation};
use sonolux_core::wave::fit::{band_decay_times, band_ripple, exponent, exponent_tolerance, fit_material, grid_random_absorption_in_band, HALF_JND};
use sonolux_core::wave::scheme::coefficients;
use sonolux_core::wave::{AbsorptionKind, WaveSettings};

mod common;

const OCTAVES: [f64; 4] = [125.0, 250.0, 500.0, 1000.0];

/// Materials across the range, flat and varying across bands (random-incidence coefficients
/// are at most 0.951, what a locally reacting wall can absorb; 0.99 is normal-incidence data).
fn materials() -> Vec<[f64; 4]> {
    vec![
        [0.01; 4],
        [0.01, 0.02, 0.03, 0.04],
        [0.02, 0.03, 0.04, 0.05],
        [0.05, 0.04, 0.03, 0.02],
        [0.05, 0.15, 0.45, 0.8],
        [0.3, 0.6, 0.25, 0.1],
        [0.4, 0.6, 0.7, 0.75],
        [0.9, 0.95, 0.95, 0.95],
    ]
}

/// The grid of a hybrid whose crossover is `crossover_hz` (f_max = crossover·√2), and its
/// discretisation as the solver builds it.
fn grid(crossover_hz: f64) -> (WaveSettings, Discretisation) {
    let f_max = crossover_hz * std::f64::consts::SQRT_2;
    let s = WaveSettings { absorption_kind: AbsorptionKind::RandomIncidence, ..common::wave_settings(343.0 / (10.0 * f_max), 0.1) };
    let (a2, _) = coefficients(s.courant);
    let d = Discretisation { time_step_s: s.time_step_s(), courant: (a2 as f64).sqrt() };
    (s, d)
}

/// Every random-incidence material, at two grids (the paper rooms' crossovers 177 and 354 Hz
/// and 707 Hz): in each wave band (centred below the crossover) the fitted wall's diffuse-field
/// absorption on the grid (`grid_random_absorption_in_band`, what a diffuse field in the waves
/// loses) has the coefficient's absorption exponent within the tolerance, plus 0.2 % of the
/// exponent for the quadrature (16 frequencies × 90 angles against the fit's own sampling, which
/// is the same: measured 0; the margin is for the clamp's and the bisection's last digits).
/// A wall of α 0.01–0.05 absorbs: the test fails on the fit of before (α_st 0.0000).
#[test]
fn fitted_walls_absorb_what_their_bands_ask_from_001_to_095() {
    let mut worst = 0.0f64;
    for crossover in [250.0, 707.0] {
        let (s, d) = grid(crossover);
        let edges = band_edges(&OCTAVES);
        for alpha in materials() {
            let fit = fit_material(&OCTAVES, &alpha, AbsorptionKind::RandomIncidence, s.max_frequency_hz, Some(d)).unwrap();
            for b in (0..fit.n_bands_fitted).filter(|&b| OCTAVES[b] < crossover) {
                let got = grid_random_absorption_in_band(&fit.admittance, edges[b], Some(d));
                let err = (exponent(got) - exponent(alpha[b])).abs();
                let rel = HALF_JND * err / exponent_tolerance(alpha[b]);
                println!("crossover {crossover:.0} Hz, α {alpha:?}, {:.0} Hz: α_st {got:.5}, exponent off {:+.3} % ({} branches, g {:.5})", OCTAVES[b], 100.0 * (exponent(got) / exponent(alpha[b]) - 1.0), fit.admittance.branches.len(), fit.admittance.conductance);
                // Up to 0.8 the tolerance; 0.9–0.95 lie near what a locally reacting wall can
                // absorb at all (0.951, where α_st stops growing with the admittance and a
                // reactive fit meets it only roughly): one JND there (measured −2.5 %).
                let allowed = if alpha[b] <= 0.8 { 1.0 } else { 2.0 };
                assert!(err <= allowed * exponent_tolerance(alpha[b]) + 0.002 * exponent(alpha[b]), "{alpha:?} at {} Hz: {got} for {}", OCTAVES[b], alpha[b]);
                worst = worst.max(rel);
            }
        }
    }
    println!("worst band: {:.3} of the tolerance's scale (tolerance {HALF_JND})", worst);
}

/// Normal-incidence data, α_n from 0.01 to 0.99: the fitted wall's band-mean normal-incidence
/// level on the grid (the fit's own `fitted_normal`) within the tolerance of each band's
/// exponent. 0.99 asks a reflected level of −20 dB, within 2.5 % of it: 0.5 dB.
#[test]
fn normal_incidence_fits_meet_each_band_from_001_to_099() {
    let (s, d) = grid(707.0);
    let mut materials = materials();
    materials.push([0.99; 4]);
    materials.push([0.95, 0.97, 0.99, 0.99]);
    for alpha in materials {
        let fit = fit_material(&OCTAVES, &alpha, AbsorptionKind::NormalIncidence, s.max_frequency_hz, Some(d)).unwrap();
        for ((centre, &want), &got) in OCTAVES.iter().zip(&fit.target_normal).zip(&fit.fitted_normal) {
            println!("α_n {alpha:?}, {centre:.0} Hz: {got:.5} for {want:.5}, exponent off {:+.3} % ({} branches)", 100.0 * (exponent(got) / exponent(want) - 1.0), fit.admittance.branches.len());
            assert!((exponent(got) - exponent(want)).abs() <= exponent_tolerance(want), "{alpha:?} at {centre} Hz: {got} for {want}");
        }
    }
}

#[test]
fn a_flat_target_is_a_conductance() {
    let fit = fit_material(&OCTAVES, &[0.4; 4], AbsorptionKind::NormalIncidence, 1000.0, None).unwrap();
    assert!(fit.error_db.iter().all(|e| e.abs() < 0.01), "{:?}", fit.error_db);
    assert!(fit.admittance.branches.is_empty() && (fit.admittance.normal_absorption(333.0) - 0.4).abs() < 0.01);
}

#[test]
fn a_rigid_material_fits_to_a_rigid_wall() {
    let fit = fit_material(&[125.0, 250.0], &[0.0, 0.0], AbsorptionKind::RandomIncidence, 500.0, None).unwrap();
    assert!(fit.admittance.is_rigid(), "{:?}", fit.admittance);
}

/// Passivity by construction: every fitted branch has D, E, F ≥ 0 and the conductance is ≥ 0
/// (the boundary is then stable whatever their values: docs/waves-walls.md, "Frequency-dependent
/// walls"), for every material above.
#[test]
fn every_fit_is_passive() {
    let (s, d) = grid(707.0);
    for alpha in materials() {
        for kind in [AbsorptionKind::RandomIncidence, AbsorptionKind::NormalIncidence] {
            let y = fit_material(&OCTAVES, &alpha, kind, s.max_frequency_hz, Some(d)).unwrap().admittance;
            assert!(y.conductance >= 0.0 && y.branches.iter().all(|b| b.mass_s >= 0.0 && b.resistance >= 0.0 && b.stiffness_per_s >= 0.0), "{alpha:?}: {y:?}");
        }
    }
}

/// The band's decay (fit_targets::band_decay_times) against its cumulant expansion. A band whose
/// components decay with relative rates r (each holding the steady-state energy ∝ 1/r of equal
/// power, Schroeder's integrated decay) has ln E(x) = −m·x + v·x²/2 + O(x³), m and v the mean
/// and variance of r under the weights 1/r; the regression line through the decay between
/// −5 and −35 dB (x₅ = 1.151, x₃₅ = 8.059 nepers of energy at rate m) then has the slope
/// −m + v·(x₅ + x₃₅)/2, so T30 = 1/(m − v·(x₅ + x₃₅)/2) in units of the decay time at rate 1.
/// A sinusoidal ripple of relative depth ε over whole periods: v ≈ ε²/2, T30 up by ≈ 2.3·ε².
/// Tolerance: the expansion's next terms, (κ₃x³/6, κ₄x⁴/24 with κ₃ ~ ε³, κ₄ ~ ε⁴: at ε = 0.1,
/// x ≈ 8, about 1.5 ‰ of T30): 0.3 % of T30, a sixth of the ripple's own effect at ε = 0.1
/// (a test that forgot the 1/r weights would be off by v ≈ 0.5 %). Equal rates give exactly 1.
#[test]
fn a_band_with_an_in_band_ripple_decays_as_its_cumulants_say() {
    let power = vec![1.0; 64];
    let (t30, edt) = band_decay_times(&[1.0; 64], &power);
    assert!((t30 - 1.0).abs() < 1e-9 && (edt - 1.0).abs() < 1e-9, "{t30} {edt}");
    for depth in [0.025, 0.05, 0.075, 0.1] {
        let r: Vec<f64> = (0..64).map(|i| 1.0 + depth * (std::f64::consts::TAU * (i as f64 + 0.5) / 64.0).sin()).collect();
        let q: Vec<f64> = r.iter().map(|r| 1.0 / r).collect();
        let m = r.iter().zip(&q).map(|(r, q)| r * q).sum::<f64>() / q.iter().sum::<f64>();
        let v = r.iter().zip(&q).map(|(r, q)| (r - m).powi(2) * q).sum::<f64>() / q.iter().sum::<f64>();
        let (x5, x35) = (5.0 / (10.0 / std::f64::consts::LN_10) / m, 35.0 / (10.0 / std::f64::consts::LN_10) / m);
        let predicted = 1.0 / (m - v * (x5 + x35) / 2.0);
        let (t30, edt) = band_decay_times(&r, &power);
        println!("ripple ±{:.1} % of the rate: T30 {:+.3} % (expansion {:+.3} %), EDT {:+.3} % of the mean rate's", 100.0 * depth, 100.0 * (t30 - 1.0), 100.0 * (predicted - 1.0), 100.0 * (edt - 1.0));
        assert!((t30 / predicted - 1.0).abs() < 0.003, "depth {depth}: T30 {t30} for {predicted}");
        assert!(edt > 1.0 && edt < t30, "depth {depth}: EDT {edt}, T30 {t30}");
    }
}

/// The fit's pruning holds each band's ripple (fit::band_ripple: the T30 and EDT its in-band
/// ripple moves, of a room all of this wall) within `HALF_JND`, or where the full dictionary's
/// own fit cannot, within that fit's ripple + half a tolerance (`ripple_tolerance`); the walls of
/// α ≤ 0.05 (the example scenes' plaster, concrete, whiteboard: what made the waves slow) are
/// held to `HALF_JND` itself. Measured: the steep materials (0.05 → 0.8 and 0.3, 0.6, 0.25, 0.1)
/// fall back, their full dictionary's fit being 5.1–5.4 % off in a band (the target curve's
/// kinks at the band centres, flat beyond the outer ones). Normal-incidence data at the 707 Hz
/// crossover's grid, every material above; the ripple recomputed here from the fitted wall's
/// branches (1e-6 for the fit's own sums in another order).
#[test]
fn every_fit_keeps_its_in_band_ripple_within_half_a_jnd_of_t30() {
    let (s, d) = grid(707.0);
    let mut worst = 0.0f64;
    for alpha in materials() {
        let fit = fit_material(&OCTAVES, &alpha, AbsorptionKind::NormalIncidence, s.max_frequency_hz, Some(d)).unwrap();
        let ripple = band_ripple(&OCTAVES, &fit.target_normal, Some(d), &fit.admittance);
        println!("α_n {alpha:?}: ripple's T30/EDT error per band {:?} %, tolerance {:.2} % ({} branches)", ripple.iter().map(|r| (1e3 * r).round() / 10.0).collect::<Vec<_>>(), 100.0 * fit.ripple_tolerance, fit.admittance.branches.len());
        worst = ripple.iter().fold(worst, |a, &b| a.max(b));
        assert!(ripple.iter().all(|&r| r <= fit.ripple_tolerance + 1e-6), "{alpha:?}: {ripple:?} (tolerance {})", fit.ripple_tolerance);
        assert!(fit.ripple_tolerance == HALF_JND || alpha.iter().any(|&a| a > 0.05), "{alpha:?}: tolerance {}", fit.ripple_tolerance);
    }
    println!("worst band: {:.2} % (half a JND {:.1} %)", 100.0 * worst, 100.0 * HALF_JND);
}

