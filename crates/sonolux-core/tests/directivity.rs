//! Tabulated source directivity: normalisation, importance emission (chi-square against the
//! density it claims and, weighted, against each band's pattern), rotation, the exact direct
//! sound, determinism and the energy balance.

use std::f64::consts::PI;
use std::sync::Arc;

use glam::{DMat3, DVec3};
use sonolux_core::rng::Stream;
use sonolux_core::sound::receivers::ball_mean_inverse_square;
use sonolux_core::sound::{trace_sound, Acoustics, Directivity, Estimator, Pattern, Receivers, SoundResult, SoundSettings, SoundSource};
use sonolux_core::{Bvh, Mesh};
use statrs::distribution::{ChiSquared, ContinuousCDF};

mod common;

const BANDS: usize = 3;
const N_THETA: usize = 37;
const N_PHI: usize = 24;

/// An irregular, band-dependent, non-axisymmetric pattern: narrower with band, with a lobe
/// that turns with φ and a deep (not empty) rear.
fn raw_gain(theta: f64, phi: f64, b: usize) -> f64 {
    let front = 0.05 + (1.0 + theta.cos()) / 2.0;
    front.powi(b as i32 + 1) * (1.0 + 0.6 * (2.0 * phi).sin() * theta.sin()) + 0.02 * b as f64
}

fn pattern_on(n_theta: usize, n_phi: usize, forward: DVec3, up: DVec3) -> Pattern {
    let mut g = Vec::new();
    for i in 0..n_theta {
        for j in 0..n_phi {
            for b in 0..BANDS {
                g.push(raw_gain(i as f64 * PI / (n_theta - 1) as f64, j as f64 * 2.0 * PI / n_phi as f64, b));
            }
        }
    }
    Pattern::new(n_theta, n_phi, BANDS, &g, forward, up).unwrap()
}

fn pattern(forward: DVec3, up: DVec3) -> Pattern {
    pattern_on(N_THETA, N_PHI, forward, up)
}

/// A coarse grid (30° × 60° cells, larger than the test's bins), so that the chi-square tests
/// also see how directions are drawn within a cell.
fn coarse_pattern() -> Pattern {
    pattern_on(7, 6, DVec3::X, DVec3::Z)
}

fn default_pattern() -> Pattern {
    pattern(DVec3::X, DVec3::Z)
}

/// Directions at the midpoints of an `n` × `n` grid, equal in solid angle, in the frame
/// (x forward, y left, z up), with their (cos θ, φ) bin among `bins` × `bins`.
fn quadrature(n: usize, bins: usize) -> Vec<(DVec3, usize)> {
    let mut out = Vec::with_capacity(n * n);
    for a in 0..n {
        let z = 1.0 - 2.0 * (a as f64 + 0.5) / n as f64;
        for c in 0..n {
            let phi = 2.0 * PI * (c as f64 + 0.5) / n as f64;
            let s = (1.0 - z * z).sqrt();
            let local = DVec3::new(z, s * phi.sin(), s * phi.cos());
            out.push((local, bin_of(local, bins)));
        }
    }
    out
}

/// Bin of a direction (in the frame x forward, y left, z up) in a `bins` × `bins` grid of
/// (cos θ about forward, φ from up towards left).
fn bin_of(d: DVec3, bins: usize) -> usize {
    let z = d.x.clamp(-1.0, 1.0);
    let phi = d.y.atan2(d.z).rem_euclid(2.0 * PI);
    let a = (((1.0 - z) / 2.0 * bins as f64) as usize).min(bins - 1);
    let c = ((phi / (2.0 * PI) * bins as f64) as usize).min(bins - 1);
    a * bins + c
}

#[test]
fn each_band_has_mean_gain_one_over_the_sphere() {
    // Midpoint quadrature over 600 × 600 equal solid angles; the bilinear gain has kinks at
    // the grid lines, so the error is O(h) at them: 1e-3 is far above it and far below any
    // normalisation slip (a wrong sin θ weight moves the mean by percents).
    let p = default_pattern();
    let mut sum = [0.0; BANDS];
    let mut g = [0.0; BANDS];
    let q = quadrature(600, 1);
    for (d, _) in &q {
        p.gains(*d, &mut g);
        for b in 0..BANDS {
            sum[b] += g[b];
        }
    }
    for (b, total) in sum.iter().enumerate() {
        let mean = total / q.len() as f64;
        assert!((mean - 1.0).abs() < 1e-3, "band {b}: mean gain {mean}");
    }
}

fn draws(p: &Pattern, n: usize) -> Vec<(DVec3, [f64; BANDS])> {
    let mut rng = Stream::new(11, 0, 0);
    (0..n)
        .map(|_| {
            let mut w = [0.0; BANDS];
            let d = p.sample(rng.uniform(), rng.uniform(), rng.uniform(), &mut w);
            (d, w)
        })
        .collect()
}

const DRAWS: usize = 400_000;
const BINS: usize = 12;

#[test]
fn emitted_directions_follow_the_claimed_density() {
    // Chi-square of the direction counts in 12 × 12 (cos θ, φ) bins against the density the
    // sampler claims (pdf), integrated by quadrature; p < 1e-3 fails. With 400 000 draws a
    // wrong cell choice or a non-uniform draw within cells is off by hundreds of sigma.
    let p = coarse_pattern();
    let mut expected = vec![0.0; BINS * BINS];
    let q = quadrature(720, BINS);
    for (d, k) in &q {
        expected[*k] += p.pdf(*d) * 4.0 * PI / q.len() as f64;
    }
    let mut counts = vec![0.0; BINS * BINS];
    for (d, _) in draws(&p, DRAWS) {
        counts[bin_of(d, BINS)] += 1.0;
    }
    let stat: f64 = counts.iter().zip(&expected).map(|(o, e)| (o - e * DRAWS as f64).powi(2) / (e * DRAWS as f64)).sum();
    let pval = 1.0 - ChiSquared::new((BINS * BINS - 1) as f64).unwrap().cdf(stat);
    assert!(pval > 1e-3, "chi-square {stat:.1} on {} bins, p = {pval:.2e}", BINS * BINS);
}

#[test]
fn weighted_emission_reproduces_every_band_and_conserves_its_power() {
    // Per band, the weights summed in each bin over the draws estimate the bin's share of the
    // band's power, ∫ g_b dΩ / 4π. The statistic Σ (obs − exp)² / var (var from the weights'
    // own second moment) is compared with chi-square on 144 dof, p < 1e-3 fails. The total (the
    // radiated power per band, 1 by the normalisation) must lie within 4 standard errors.
    let p = coarse_pattern();
    let q = quadrature(720, BINS);
    let mut expected = vec![[0.0; BANDS]; BINS * BINS];
    let mut g = [0.0; BANDS];
    for (d, k) in &q {
        p.gains(*d, &mut g);
        for b in 0..BANDS {
            expected[*k][b] += g[b] / q.len() as f64;
        }
    }
    let (mut s1, mut s2) = (vec![[0.0; BANDS]; BINS * BINS], vec![[0.0; BANDS]; BINS * BINS]);
    let (mut t1, mut t2) = ([0.0; BANDS], [0.0; BANDS]);
    for (d, w) in draws(&p, DRAWS) {
        let k = bin_of(d, BINS);
        for b in 0..BANDS {
            s1[k][b] += w[b];
            s2[k][b] += w[b] * w[b];
            t1[b] += w[b];
            t2[b] += w[b] * w[b];
        }
    }
    let n = DRAWS as f64;
    for b in 0..BANDS {
        let mut stat = 0.0;
        for k in 0..BINS * BINS {
            let mean = s1[k][b] / n;
            let var = (s2[k][b] / n - mean * mean) / n;
            stat += (mean - expected[k][b]).powi(2) / var;
        }
        let pval = 1.0 - ChiSquared::new((BINS * BINS) as f64).unwrap().cdf(stat);
        assert!(pval > 1e-3, "band {b}: chi-square {stat:.1}, p = {pval:.2e}");
        let power = t1[b] / n;
        let se = ((t2[b] / n - power * power) / n).sqrt();
        assert!((power - 1.0).abs() < 4.0 * se, "band {b}: radiated power {power} ± {se}");
    }
}

#[test]
fn a_rotated_source_rotates_its_pattern_and_its_rays() {
    // Rotating forward and up by R must give gains(R d) = gains(d) and, for the same random
    // numbers, rays R·d with the same weights (to rounding: 1e-9).
    let r = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, -0.5).normalize(), 1.1);
    let a = default_pattern();
    let b = pattern(r * DVec3::X, r * DVec3::Z);
    let (mut ga, mut gb) = ([0.0; BANDS], [0.0; BANDS]);
    for (d, _) in quadrature(20, 1) {
        a.gains(d, &mut ga);
        b.gains(r * d, &mut gb);
        for k in 0..BANDS {
            assert!((ga[k] - gb[k]).abs() < 1e-9 * ga[k].max(1.0), "{d:?}: {ga:?} vs {gb:?}");
        }
    }
    let mut rng = Stream::new(3, 0, 0);
    for _ in 0..1000 {
        let u = (rng.uniform(), rng.uniform(), rng.uniform());
        let da = a.sample(u.0, u.1, u.2, &mut ga);
        let db = b.sample(u.0, u.1, u.2, &mut gb);
        assert!((r * da - db).length() < 1e-9, "{da:?} rotated is not {db:?}");
        assert!(ga.iter().zip(&gb).all(|(x, y)| (x - y).abs() < 1e-9 * x.max(1.0)));
    }
}

fn settings(rays: u64, threads: usize) -> SoundSettings {
    SoundSettings {
        rays,
        first_ray: 0,
        first_receiver: 0,
        only_source: None,
        end_ray: rays,
        seed: 5,
        threads,
        estimator: Estimator::Rain,
        speed_of_sound_m_s: 343.0,
        air_attenuation_per_m: vec![0.0, 0.001, 0.004],
        energy_drop_db: 60.0,
        max_time_s: 0.3,
        sample_rate_hz: 48_000.0,
        early_s: 0.05,
        late_bin_s: 0.001,
        n_azimuth: 8,
        n_elevation: 1,
        max_field_bytes: 1 << 32,
    }
}

fn room(alpha: f64) -> (Mesh, Acoustics) {
    let mesh = common::shoebox(20.0, 20.0, 20.0, [0, 0, 0, 0, 0, 0]);
    (mesh, Acoustics { n_bands: BANDS, absorption: vec![alpha; BANDS], scattering: vec![0.3; BANDS] })
}

fn bake(alpha: f64, rays: u64, threads: usize, receivers: &Receivers, forward: DVec3, up: DVec3) -> SoundResult {
    let (mesh, ac) = room(alpha);
    let bvh = Bvh::build(&mesh).unwrap();
    let src = [SoundSource { position: DVec3::splat(10.0), power_w: 2.0, directivity: Directivity::Pattern(Arc::new(pattern(forward, up))) }];
    trace_sound(&mesh, &bvh, &ac, &src, receivers, &settings(rays, threads), |_| true).unwrap()
}

fn total(res: &SoundResult, r: usize, b: usize) -> f64 {
    let l = &res.layout;
    (0..l.n_time()).flat_map(|t| (0..l.n_directions()).map(move |d| (t, d))).map(|(t, d)| res.field.get(l.index(r, t, d) + b) as f64 * res.field.quantum).sum()
}

/// 20 receivers 4 m from the source, spread over the sphere (a Fibonacci spiral).
fn ring() -> Vec<DVec3> {
    (0..20)
        .map(|k| {
            let z = 1.0 - (2.0 * k as f64 + 1.0) / 20.0;
            let phi = k as f64 * PI * (3.0 - 5f64.sqrt());
            let s = (1.0 - z * z).sqrt();
            DVec3::splat(10.0) + 4.0 * DVec3::new(s * phi.cos(), s * phi.sin(), z)
        })
        .collect()
}

#[test]
fn direct_sound_carries_the_gain_towards_each_receiver() {
    // In a fully absorbing room only the rain estimator's exact direct sound arrives: power ×
    // g_b(towards the receiver) × sphere mean of 1/(4πd²) × air, to the field's fixed-point
    // precision (1e-9 relative). The pattern is turned, so its frame is exercised too.
    let (fwd, up) = (DVec3::new(0.3, -1.0, 0.2), DVec3::new(0.0, 0.1, 1.0));
    let p = pattern(fwd, up);
    let rc = Receivers::new(ring(), 0.2);
    let res = bake(1.0, 64, 2, &rc, fwd, up);
    let air = settings(1, 1).air_attenuation_per_m;
    let mut g = [0.0; BANDS];
    for (r, c) in rc.centres.iter().enumerate() {
        let to = *c - DVec3::splat(10.0);
        p.gains(to.normalize(), &mut g);
        for b in 0..BANDS {
            let want = 2.0 * g[b] * ball_mean_inverse_square(to.length(), 0.2) * (-air[b] * to.length()).exp();
            let got = total(&res, r, b);
            assert!((got / want - 1.0).abs() < 1e-9, "receiver {r} band {b}: {got} vs {want}");
        }
    }
}

#[test]
fn same_bits_on_one_and_two_threads_and_the_energy_balance_closes() {
    // Determinism with importance emission; and the tally per band: what was emitted (the
    // weights, 2 W expected) equals what was absorbed, escaped or left, to 1e-9; the emitted
    // power lies within 3% of 2 W (the weights' spread at 20 000 rays gives σ ≈ 0.5%).
    let rc = Receivers::new(ring(), 0.3);
    let one = bake(0.2, 20_000, 1, &rc, DVec3::X, DVec3::Z);
    let two = bake(0.2, 20_000, 2, &rc, DVec3::X, DVec3::Z);
    assert_eq!(one.counts(1), two.counts(2));
    let get = |w: &str| one.stats.energy(w).unwrap();
    for b in 0..BANDS {
        let lhs = get("emitted")[b] + get("reweighted")[b];
        let rhs = get("absorbed_surfaces")[b] + get("absorbed_air")[b] + get("escaped")[b] + get("remaining")[b];
        assert!(((lhs - rhs) / lhs).abs() < 1e-9, "band {b}: {lhs} vs {rhs}");
        assert!((get("emitted")[b] / 2.0 - 1.0).abs() < 0.03, "band {b}: emitted {}", get("emitted")[b]);
    }
}

#[test]
fn a_pattern_of_other_bands_is_refused() {
    let (mesh, _) = room(0.5);
    let ac = Acoustics { n_bands: 2, absorption: vec![0.5; 2], scattering: vec![0.3; 2] };
    let bvh = Bvh::build(&mesh).unwrap();
    let src = [SoundSource { position: DVec3::splat(10.0), power_w: 1.0, directivity: Directivity::Pattern(Arc::new(default_pattern())) }];
    let mut set = settings(10, 1);
    set.air_attenuation_per_m = vec![0.0; 2];
    let err = trace_sound(&mesh, &bvh, &ac, &src, &Receivers::new(ring(), 0.3), &set, |_| true).unwrap_err();
    assert!(err.to_string().contains("3 bands"), "{err}");
}
