//! Edge diffraction against the exact solution of a point source and an infinite rigid
//! half-plane: the closed-form impulse response of Biot and Tolstoy ("Formulation of wave
//! propagation in infinite media by normal coordinates with an application to diffraction",
//! JASA 29(3), 1957), in Medwin's form ("Shadowing by finite noise barriers", JASA 69(4), 1981):
//!
//!   h(τ) = −(c ν / 2π) β(η) / (r_S r_R sinh η),   τ > τ₀ = L / c,
//!   cosh η = (c²τ² − (r_S² + r_R² + (z_S − z_R)²)) / (2 r_S r_R),   ν = 1/2,
//!
//! plus the geometric direct and reflected waves where they are present. It is an independent
//! computation from the model's: no edge integral, no binning; its spectrum is a direct Fourier
//! integral (composite Gauss–Legendre in u = √(τ − τ₀), which removes the 1/√ singularity at
//! the onset), truncated at 0.5 s where h has fallen as 1/τ³.
//!
//! Note: the Fresnel-integral form U(R, σ) + U(R', σ') often quoted for this problem (with the
//! direct distance R as prefactor and σ = ±√(k(L − R))) is not exact for a point source: deep
//! in the shadow it stays 4–6 dB above Keller's diffraction coefficient even at 16 kHz, while
//! this reference and the model meet it within 0.01 dB. It was this test's first reference and
//! was replaced.

use std::f64::consts::PI;

use glam::{DVec3, Vec3};
use num_complex::Complex64;
use sonolux_core::early::{early_arrivals, EarlyResult, EarlySettings};
use sonolux_core::sound::{Acoustics, Directivity, SoundSource};
use sonolux_core::{Bvh, Mesh};

const C: f64 = 343.0;
const HALF: f64 = 30.0;

/// The screen: the half-plane y = 0, x ≤ 0, cut to 30 m × 60 m, its edge along z at x = 0.
fn screen() -> Mesh {
    let v = vec![Vec3::new(-HALF as f32, 0.0, -HALF as f32), Vec3::new(0.0, 0.0, -HALF as f32), Vec3::new(0.0, 0.0, HALF as f32), Vec3::new(-HALF as f32, 0.0, HALF as f32)];
    Mesh::new(v, vec![[0, 1, 2], [0, 2, 3]], vec![0, 0]).unwrap()
}

/// A point at radius r, angle θ from the screen's face at y = 0⁻ (going round the edge through
/// the air), height z.
fn at(r: f64, theta_deg: f64, z: f64) -> DVec3 {
    let a = theta_deg.to_radians() - PI;
    DVec3::new(r * a.cos(), r * a.sin(), z)
}

/// Gauss–Legendre 8-point nodes and weights on [−1, 1].
const GL_X: [f64; 4] = [0.183_434_642_495_649_8, 0.525_532_409_916_329, 0.796_666_477_413_626_7, 0.960_289_856_497_536_3];
const GL_W: [f64; 4] = [0.362_683_783_378_362, 0.313_706_645_877_887_3, 0.222_381_034_453_374_5, 0.101_228_536_290_376_3];

/// The exact field (free field e^(−jkR)/R) at each of `freqs` of a source at (r, θ°, z) heard
/// at (r, θ°, z) beside the infinite rigid half-plane.
fn exact(freqs: &[f64], s: (f64, f64, f64), r: (f64, f64, f64)) -> Vec<Complex64> {
    let nu = 0.5;
    let (ts, tr) = (s.1.to_radians(), r.1.to_radians());
    let tau0 = ((s.0 + r.0).powi(2) + (s.2 - r.2).powi(2)).sqrt() / C;
    let (u_max, panels) = (0.5f64.sqrt(), 60_000usize);
    let h = u_max / panels as f64;
    let mut out = vec![Complex64::new(0.0, 0.0); freqs.len()];
    for p in 0..panels {
        let mid = (p as f64 + 0.5) * h;
        for (x, w) in GL_X.iter().flat_map(|x| [-x, *x]).zip(GL_W.iter().flat_map(|w| [*w, *w])) {
            let u = mid + 0.5 * h * x;
            let tau = tau0 + u * u;
            let ch = ((C * tau).powi(2) - (s.0 * s.0 + r.0 * r.0 + (s.2 - r.2).powi(2))) / (2.0 * s.0 * r.0);
            let eta = ch.max(1.0).acosh();
            let beta: f64 = [PI + ts + tr, PI + ts - tr, PI - ts + tr, PI - ts - tr].iter().map(|phi| (nu * phi).sin() / ((nu * eta).cosh() - (nu * phi).cos())).sum();
            let hv = -(C * nu / (2.0 * PI)) * beta / (s.0 * r.0 * eta.sinh()) * 2.0 * u * w * 0.5 * h;
            for (o, f) in out.iter_mut().zip(freqs) {
                *o += Complex64::from_polar(hv, -2.0 * PI * f * tau);
            }
        }
    }
    // The geometric waves where present: the direct one out of the shadow, the reflection in
    // the screen's face inside its zone.
    let (ps, pr) = (at(s.0, s.1, s.2), at(r.0, r.1, r.2));
    let image = DVec3::new(ps.x, -ps.y, ps.z);
    for (present, d) in [((r.1 - s.1).abs() < 180.0, (pr - ps).length()), (r.1 + s.1 < 180.0, (pr - image).length())] {
        if present {
            for (o, f) in out.iter_mut().zip(freqs) {
                *o += Complex64::from_polar(1.0 / d, -2.0 * PI * f * d / C);
            }
        }
    }
    out
}

fn settings() -> EarlySettings {
    let mut s = EarlySettings::octaves(6);
    s.max_order = 1;
    s.max_time_s = 0.5;
    s.speed_of_sound_m_s = C;
    s.diffraction = true;
    s.threads = 2;
    s
}

fn run(receivers: &[DVec3], source: DVec3) -> EarlyResult {
    let mesh = screen();
    let bvh = Bvh::build(&mesh).unwrap();
    let ac = Acoustics { n_bands: 6, absorption: vec![0.0; 6], scattering: vec![0.0; 6] };
    let src = [SoundSource { position: source, power_w: 1.0, directivity: Directivity::Omni }];
    early_arrivals(&mesh, &bvh, &ac, &src, receivers, &settings(), None).unwrap()
}

/// Total energy per band at receiver r, as a level re. free field at 1 m (dB).
fn level_db(res: &EarlyResult, r: usize) -> Vec<f64> {
    let mut e = vec![0.0; res.n_bands];
    for (i, a) in res.arrivals.iter().enumerate() {
        if a.receiver == r as u32 {
            for (eb, add) in e.iter_mut().zip(res.energy_of(i)) {
                *eb += add;
            }
        }
    }
    e.iter().map(|x| 10.0 * (x * 4.0 * PI).log10()).collect()
}

/// The exact level per band: |u|² averaged over the model's frequencies, re. 1 m.
fn exact_db(set: &EarlySettings, s: (f64, f64, f64), r: (f64, f64, f64)) -> Vec<f64> {
    let n = sonolux_core::early::diffraction::FREQUENCIES_PER_BAND;
    let edges: Vec<(f64, f64)> = (0..set.band_centres_hz.len()).map(|b| set.band_edges_hz(b)).collect();
    let freqs = sonolux_core::early::diffraction::band_frequencies(&edges);
    let u = exact(&freqs, s, r);
    (0..edges.len()).map(|b| 10.0 * (u[b * n..(b + 1) * n].iter().map(|x| x.norm_sqr()).sum::<f64>() / n as f64).log10()).collect()
}

const SOURCE: (f64, f64, f64) = (2.0, 60.0, 0.0);

#[test]
fn reference_meets_keller_deep_in_the_shadow_at_high_frequency() {
    // Keller's diffraction coefficient of a rigid half-plane (2-D geometry, z_S = z_R):
    // |u| = |sec((θR − θS)/2) + sec((θR + θS)/2)| / (2 √(2πk) √(r_S r_R (r_S + r_R))).
    let (s, r, f): ((f64, f64, f64), (f64, f64, f64), f64) = ((2.0, 60.0, 0.0), (3.0, 300.0, 0.0), 8000.0);
    let k = 2.0 * PI * f / C;
    let (a, b) = (((r.1 - s.1) / 2.0f64).to_radians().cos(), ((r.1 + s.1) / 2.0f64).to_radians().cos());
    let keller = (1.0 / a + 1.0 / b).abs() / (2.0 * (2.0 * PI * k).sqrt() * (s.0 * r.0 * (s.0 + r.0)).sqrt());
    let u = exact(&[f], s, r)[0].norm();
    assert!((20.0 * (u / keller).log10()).abs() < 0.1, "{u} against Keller's {keller}");
}

#[test]
fn level_behind_a_half_plane_is_the_exact_solution_within_one_db_per_octave() {
    // Three shadow depths (10°, 20°, 40° past the shadow boundary at 240°), receivers 3 m from
    // the edge and 0.5 m above the source's height. 1 dB in each octave from 125 Hz to 4 kHz,
    // as the issue asks; the BTM is exact for the infinite rigid half-plane, so what remains is
    // the screen's finite size (30 m: its other edges add a little) and the discretisation.
    let set = settings();
    let depths = [250.0, 260.0, 280.0];
    let receivers: Vec<(f64, f64, f64)> = depths.iter().map(|&t| (3.0, t, 0.5)).collect();
    let pts: Vec<DVec3> = receivers.iter().map(|r| at(r.0, r.1, r.2)).collect();
    let res = run(&pts, at(SOURCE.0, SOURCE.1, SOURCE.2));
    for (i, r) in receivers.iter().enumerate() {
        let got = level_db(&res, i);
        let want = exact_db(&set, SOURCE, *r);
        for b in 0..6 {
            assert!((got[b] - want[b]).abs() < 1.0, "θ = {}°, band {b}: {:.2} dB, exact {:.2} dB", r.1, got[b], want[b]);
        }
        eprintln!("θ {}: got {:?} exact {:?}", r.1, got, want);
    }
}

#[test]
fn lit_and_reflection_zones_equal_the_exact_solution_within_one_db() {
    // Away from the boundaries (40° and 30° from them) the field is geometric + diffracted,
    // and the model's cross terms carry their interference per band.
    let set = settings();
    let receivers = [(3.0, 200.0, 0.5), (3.0, 90.0, 0.5)];
    let pts: Vec<DVec3> = receivers.iter().map(|r| at(r.0, r.1, r.2)).collect();
    let res = run(&pts, at(SOURCE.0, SOURCE.1, SOURCE.2));
    for (i, r) in receivers.iter().enumerate() {
        let (got, want) = (level_db(&res, i), exact_db(&set, SOURCE, *r));
        eprintln!("θ {}: got {:?} exact {:?}", r.1, got, want);
        for b in 0..6 {
            assert!((got[b] - want[b]).abs() < 1.0, "θ = {}°, band {b}: {:.2} dB, exact {:.2} dB", r.1, got[b], want[b]);
        }
    }
}

/// Integrand calls one receiver may cost here: 15 a bin of the longest edge part (the 60 m
/// edges, ~55 m of path a side at 90.5 kHz) for the four edges and both emitters that reach
/// them, plus the refinement budget of each part: what [`sonolux_core::early::btm`] promises.
fn call_bound(set: &EarlySettings) -> u64 {
    let edges: Vec<(f64, f64)> = (0..set.band_centres_hz.len()).map(|b| set.band_edges_hz(b)).collect();
    let step_m = C / sonolux_core::early::diffraction::internal_rate_hz(&edges);
    let bins_a_part = 2 * (2.0 * (2.0 * HALF).hypot(4.0) / step_m).ceil() as u64;
    4 * 2 * (15 * bins_a_part + sonolux_core::early::btm::REFINEMENT_CALLS)
}

#[test]
fn a_walker_crossing_the_shadow_and_reflection_boundaries_hears_no_jump() {
    walk_across_the_boundaries(10);
}

#[test]
#[ignore = "slow: 162 receivers (make test-all)"]
fn a_walker_crossing_the_boundaries_over_four_degrees_hears_no_jump() {
    walk_across_the_boundaries(40);
}

/// The walk of `half_steps` steps either side of each boundary.
fn walk_across_the_boundaries(half_steps: i32) {
    // Receivers in steps of 0.05° from before to after the shadow boundary (240°) and the
    // reflection boundary (120°), 3 m from the edge and 0.5 m above the source: each costs a
    // bounded number of integrand calls, and the sum of the arrivals (geometric + diffracted)
    // moves by less than 0.5 dB per octave band from one step to the next (the issue's
    // criterion; the exact solution moves by at most ~0.1 dB a step here). Next to the
    // boundaries the level is also the exact one within 1 dB, as away from them.
    let set = settings();
    let bound = call_bound(&set);
    for boundary in [240.0, 120.0] {
        let thetas: Vec<f64> = (-half_steps..=half_steps).map(|k| boundary + 0.05 * k as f64).collect();
        let mut levels = Vec::new();
        let mut max_calls = 0;
        for &t in &thetas {
            let res = run(&[at(3.0, t, 0.5)], at(SOURCE.0, SOURCE.1, SOURCE.2));
            assert!(res.stats.integrand_calls <= bound, "θ = {t}°: {} integrand calls, more than {bound}", res.stats.integrand_calls);
            max_calls = max_calls.max(res.stats.integrand_calls);
            levels.push(level_db(&res, 0));
        }
        let mut worst = 0.0f64;
        for k in 1..thetas.len() {
            for (b, (now, before)) in levels[k].iter().zip(&levels[k - 1]).enumerate().take(6) {
                let step = (now - before).abs();
                worst = worst.max(step);
                assert!(step < 0.5, "boundary {boundary}°, {}° → {}°, band {b}: {:.2} → {:.2} dB", thetas[k - 1], thetas[k], before, now);
            }
        }
        for k in [half_steps as usize - 1, half_steps as usize + 1] {
            let want = exact_db(&set, SOURCE, (3.0, thetas[k], 0.5));
            for b in 0..6 {
                assert!((levels[k][b] - want[b]).abs() < 1.0, "θ = {}°, band {b}: {:.2} dB, exact {:.2} dB", thetas[k], levels[k][b], want[b]);
            }
        }
        eprintln!("boundary {boundary}°: largest step {worst:.3} dB, at most {max_calls} integrand calls a receiver (bound {bound})");
    }
}


#[test]
fn diffraction_is_the_same_on_one_and_two_threads() {
    // Receivers near both boundaries and deep in the shadow: the same arrivals, the same bits.
    let mesh = screen();
    let bvh = Bvh::build(&mesh).unwrap();
    let ac = Acoustics { n_bands: 6, absorption: vec![0.0; 6], scattering: vec![0.0; 6] };
    let src = [SoundSource { position: at(SOURCE.0, SOURCE.1, SOURCE.2), power_w: 1.0, directivity: Directivity::Omni }];
    let receivers = [at(3.0, 239.95, 0.5), at(3.0, 120.05, 0.5), at(3.0, 260.0, 0.5)];
    let results: Vec<EarlyResult> = [1, 2]
        .iter()
        .map(|&threads| {
            let mut set = settings();
            set.threads = threads;
            early_arrivals(&mesh, &bvh, &ac, &src, &receivers, &set, None).unwrap()
        })
        .collect();
    assert_eq!(results[0].arrivals, results[1].arrivals);
    assert_eq!(results[0].energy.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), results[1].energy.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
    assert_eq!(results[0].stats, results[1].stats);
}
