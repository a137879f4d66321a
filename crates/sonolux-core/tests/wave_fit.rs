//! The wall fit (wave/fit.rs) on its own: what each band of a material absorbs once fitted, for
//! absorption from 0.01 to 0.99, against the fit's stated tolerance on absorption
//! (`fit::HALF_JND` of the absorption exponent −ln(1 − α), with the floor `fit::ABSORPTION_FLOOR`:
//! an error that moves a room's Eyring T30 by less than half a just noticeable difference).
//! Before session 12 the fit's tolerance was in decibels of reflected level, and a wall of α
//! 0.02–0.05 that varied across bands was fitted rigid (its level, −0.09 to −0.22 dB, within
//! 0.15 dB of nothing). The plane-wave check through the solver itself is wave_walls.rs (0.5 dB)
//! and the grid's oblique incidence wave_oblique.rs.

use sonolux_core::wave::admittance::{band_edges, Discretisation};
use sonolux_core::wave::fit::{exponent, exponent_tolerance, fit_material, grid_random_absorption_in_band, HALF_JND};
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
