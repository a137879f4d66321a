//! Edge diffraction against the exact solution of a point source and a rigid half-plane
//! (Macdonald 1915; in the form of Bowman, Senior and Uslenghi, "Electromagnetic and acoustic
//! scattering by simple shapes", 1969, §8.2):
//!
//!   u = U(R, σ) + U(R', σ'),   U(R, σ) = e^(−jkR)/R · e^(jπ/4)/√π · ∫_(−∞)^σ e^(−jμ²) dμ,
//!   σ = ±√(k (L − R)),
//!
//! R the distance from the source (R' from its image in the screen's plane), L the shortest path
//! over the edge, the sign + where that wave is geometrically present (lit), − where not.

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

/// ∫_a^∞ e^(−jμ²) dμ for a ≥ 0, along the path of steepest descent μ² = a² − j v²:
/// −j e^(−ja²) ∫_0^∞ e^(−v²) v / √(a² − j v²) dv (Simpson, 20,000 panels to v = 8).
fn tail(a: f64) -> Complex64 {
    let n = 20_000;
    let h = 8.0 / n as f64;
    let f = |v: f64| Complex64::new((-v * v).exp() * v, 0.0) / Complex64::new(a * a, -v * v).sqrt();
    let f0 = if a == 0.0 { Complex64::from_polar(1.0, PI / 4.0) } else { f(0.0) };
    let mut s = f0 + f(8.0);
    for i in 1..n {
        s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    -Complex64::i() * Complex64::from_polar(1.0, -a * a) * s * (h / 3.0)
}

/// U(R, σ) of Macdonald's solution.
fn wave(k: f64, r: f64, sigma: f64) -> Complex64 {
    let whole = Complex64::from_polar(PI.sqrt(), -PI / 4.0);
    let integral = if sigma >= 0.0 { whole - tail(sigma) } else { tail(-sigma) };
    Complex64::from_polar(1.0 / r, -k * r) * Complex64::from_polar(1.0 / PI.sqrt(), PI / 4.0) * integral
}

/// The exact field (free field e^(−jkR)/R) of a source at (r_s, θ_s, z_s) at (r_r, θ_r, z_r).
fn macdonald(f: f64, s: (f64, f64, f64), r: (f64, f64, f64)) -> Complex64 {
    let k = 2.0 * PI * f / C;
    let (ps, pr) = (at(s.0, s.1, s.2), at(r.0, r.1, r.2));
    let image = DVec3::new(ps.x, -ps.y, ps.z);
    let l = ((s.0 + r.0).powi(2) + (s.2 - r.2).powi(2)).sqrt();
    let (d, d_img) = ((pr - ps).length(), (pr - image).length());
    let lit = (r.1 - s.1).abs() < 180.0;
    let reflected = r.1 + s.1 < 180.0;
    let sign = |b: bool| if b { 1.0 } else { -1.0 };
    wave(k, d, sign(lit) * (k * (l - d)).max(0.0).sqrt()) + wave(k, d_img, sign(reflected) * (k * (l - d_img)).max(0.0).sqrt())
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
            for b in 0..res.n_bands {
                e[b] += res.energy_of(i)[b];
            }
        }
    }
    e.iter().map(|x| 10.0 * (x * 4.0 * PI).log10()).collect()
}

/// The exact level per octave band: |u|² averaged over the same frequencies, re. 1 m.
fn exact_db(set: &EarlySettings, s: (f64, f64, f64), r: (f64, f64, f64)) -> Vec<f64> {
    let n = sonolux_core::early::diffraction::FREQUENCIES_PER_BAND;
    (0..set.band_centres_hz.len())
        .map(|b| {
            let (lo, hi) = set.band_edges_hz(b);
            let mean: f64 = (0..n).map(|k| macdonald(lo + (k as f64 + 0.5) * (hi - lo) / n as f64, s, r).norm_sqr()).sum::<f64>() / n as f64;
            10.0 * mean.log10()
        })
        .collect()
}

const SOURCE: (f64, f64, f64) = (2.0, 60.0, 0.0);

#[test]
fn reference_is_the_free_field_far_in_the_light_and_half_at_the_boundary() {
    // Checks of the reference itself: the tail integral's limits, and |u| = 1/(2R) on the
    // shadow boundary (where only the direct wave's half survives, the image wave being deep in
    // its shadow at this geometry up to a small diffracted part).
    assert!((tail(0.0) - Complex64::from_polar(PI.sqrt() / 2.0, -PI / 4.0)).norm() < 1e-6);
    assert!(tail(30.0).norm() < 0.02);
    let boundary = (3.0, 240.0, 0.0);
    let d = (at(3.0, 240.0, 0.0) - at(2.0, 60.0, 0.0)).length();
    let u = macdonald(500.0, SOURCE, boundary);
    assert!((u.norm() * d - 0.5).abs() < 0.03, "{}", u.norm() * d);
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
fn no_jump_across_the_shadow_and_reflection_boundaries() {
    // Receivers 0.05° either side of the shadow boundary (240°) and of the reflection boundary
    // (120°): the sum of the arrivals (geometric + diffracted) moves by less than 0.5 dB per
    // band, and equals the exact solution within 1 dB.
    let set = settings();
    for boundary in [240.0, 120.0] {
        let receivers = [(3.0, boundary - 0.05, 0.5), (3.0, boundary + 0.05, 0.5)];
        let pts: Vec<DVec3> = receivers.iter().map(|r| at(r.0, r.1, r.2)).collect();
        let res = run(&pts, at(SOURCE.0, SOURCE.1, SOURCE.2));
        let (a, b) = (level_db(&res, 0), level_db(&res, 1));
        for k in 0..6 {
            assert!((a[k] - b[k]).abs() < 0.5, "boundary {boundary}°, band {k}: {:.2} against {:.2} dB", a[k], b[k]);
            for (r, got) in receivers.iter().zip([&a, &b]) {
                let want = exact_db(&set, SOURCE, *r);
                assert!((got[k] - want[k]).abs() < 1.0, "θ = {}°, band {k}: {:.2} dB, exact {:.2} dB", r.1, got[k], want[k]);
            }
        }
    }
}
