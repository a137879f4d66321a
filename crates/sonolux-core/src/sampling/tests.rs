//! Chi-square tests of each sampler against the density it claims. Bins are a grid in
//! (cos θ, φ) or barycentric space; the expected count of each bin is the integral of the
//! claimed density over it, in closed form, so the test does not reuse the sampler's mapping.
//! With a fixed seed the outcome is deterministic; the threshold p < 1e-3 would flag a wrong
//! density (a missing sqrt, a factor 2 in φ) at these sample counts by hundreds of sigma.

use super::*;
use crate::rng::Stream;
use statrs::distribution::{ChiSquared, ContinuousCDF};

const N: usize = 400_000;

/// p-value of observed counts against expected probabilities (bins with tiny expectation are
/// pooled into one, as the test needs about five expected samples a bin).
fn chi_square_p(observed: &[f64], expected_p: &[f64], n: usize) -> f64 {
    let (mut stat, mut dof) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (o, p) in observed.iter().zip(expected_p) {
        let e = p * n as f64;
        if e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            stat += (o - e).powi(2) / e;
            dof += 1;
        }
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e).powi(2) / pool_e.max(1e-300);
        dof += 1;
    }
    1.0 - ChiSquared::new((dof - 1) as f64).unwrap().cdf(stat)
}

/// Counts directions in a grid of `nz` bins of cos θ (about the frame's normal) from `z_lo` to 1
/// and `nphi` bins of φ.
fn bin_directions(dirs: impl Iterator<Item = DVec3>, frame: &Frame, z_lo: f64, nz: usize, nphi: usize) -> Vec<f64> {
    let mut counts = vec![0.0; nz * nphi];
    for d in dirs {
        let (x, y, z) = (d.dot(frame.t), d.dot(frame.b), d.dot(frame.n));
        assert!((d.length() - 1.0).abs() < 1e-9, "not a unit vector: {d}");
        assert!(z >= z_lo - 1e-12, "sample outside the support: cos θ = {z}");
        let iz = (((z - z_lo) / (1.0 - z_lo)) * nz as f64).clamp(0.0, nz as f64 - 1.0) as usize;
        let phi = y.atan2(x).rem_euclid(2.0 * PI);
        let ip = ((phi / (2.0 * PI)) * nphi as f64).min(nphi as f64 - 1.0) as usize;
        counts[iz * nphi + ip] += 1.0;
    }
    counts
}

/// Expected probability of each (cos θ, φ) bin for a density that is a function of θ only,
/// given its cumulative distribution in cos θ.
fn expected(cdf_of_z: impl Fn(f64) -> f64, z_lo: f64, nz: usize, nphi: usize) -> Vec<f64> {
    let mut p = Vec::with_capacity(nz * nphi);
    for iz in 0..nz {
        let z0 = z_lo + (1.0 - z_lo) * iz as f64 / nz as f64;
        let z1 = z_lo + (1.0 - z_lo) * (iz + 1) as f64 / nz as f64;
        for _ in 0..nphi {
            p.push((cdf_of_z(z1) - cdf_of_z(z0)) / nphi as f64);
        }
    }
    p
}

fn uniforms(key: u64) -> impl Iterator<Item = (f64, f64)> {
    let mut s = Stream::new(key, 0, 0);
    (0..N).map(move |_| (s.uniform(), s.uniform()))
}

#[test]
fn uniform_sphere_matches_its_density() {
    let frame = Frame::from_normal(DVec3::Z);
    let counts = bin_directions(uniforms(1).map(|(a, b)| uniform_sphere(a, b)), &frame, -1.0, 20, 24);
    // P(cos θ < z) for density 1/(4π): (z + 1) / 2.
    let p = chi_square_p(&counts, &expected(|z| (z + 1.0) / 2.0, -1.0, 20, 24), N);
    assert!(p > 1e-3, "p = {p}");
}

#[test]
fn cone_matches_its_density_and_support() {
    let axis = DVec3::new(1.0, -2.0, 0.5).normalize();
    let frame = Frame::from_normal(axis);
    let cos_max = (50f64).to_radians().cos();
    let counts = bin_directions(uniforms(2).map(|(a, b)| uniform_cone(&frame, cos_max, a, b)), &frame, cos_max, 16, 16);
    let p = chi_square_p(&counts, &expected(|z| (z - cos_max) / (1.0 - cos_max), cos_max, 16, 16), N);
    assert!(p > 1e-3, "p = {p}");
}

#[test]
fn cosine_hemisphere_matches_lambert() {
    let frame = Frame::from_normal(DVec3::new(-0.3, 0.9, -0.2).normalize());
    let counts = bin_directions(uniforms(3).map(|(a, b)| cosine_hemisphere(&frame, a, b)), &frame, 0.0, 20, 16);
    // Density cos θ / π: P(cos θ < z) = 1 − (1 − z²) = z².
    let p = chi_square_p(&counts, &expected(|z| z * z, 0.0, 20, 16), N);
    assert!(p > 1e-3, "p = {p}");
}

#[test]
fn wrong_density_is_rejected() {
    // The test must be able to fail: uniform-sphere samples are not Lambertian.
    let frame = Frame::from_normal(DVec3::Z);
    let counts = bin_directions(uniforms(4).map(|(a, b)| { let d = uniform_sphere(a, b); DVec3::new(d.x, d.y, d.z.abs()) }), &frame, 0.0, 20, 16);
    let p = chi_square_p(&counts, &expected(|z| z * z, 0.0, 20, 16), N);
    assert!(p < 1e-9, "p = {p}");
}

#[test]
fn triangle_points_are_uniform_in_area() {
    let (a, b, c) = (DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 3.0, 1.0), DVec3::new(-2.0, -1.0, 0.5));
    // Bin by barycentric coordinates into the k² congruent sub-triangles of a regular subdivision.
    let k = 12usize;
    let mut counts = vec![0.0; k * k];
    let (e1, e2) = (b - a, c - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let det = d11 * d22 - d12 * d12;
    for (u1, u2) in uniforms(5) {
        let p = triangle_point(a, b, c, u1, u2) - a;
        let (d1, d2) = (p.dot(e1), p.dot(e2));
        let s = (d22 * d1 - d12 * d2) / det;
        let t = (d11 * d2 - d12 * d1) / det;
        assert!(s >= -1e-9 && t >= -1e-9 && s + t <= 1.0 + 1e-9, "outside: {s} {t}");
        let (fs, ft) = (s * k as f64, t * k as f64);
        let (i, j) = ((fs.floor() as usize).min(k - 1), (ft.floor() as usize).min(k - 1));
        let upper = (fs - i as f64) + (ft - j as f64) > 1.0;
        let slot = sub_triangle_index(i, j, upper, k);
        counts[slot] += 1.0;
    }
    let p = chi_square_p(&counts, &vec![1.0 / (k * k) as f64; k * k], N);
    assert!(p > 1e-3, "p = {p}");
}

/// Index of a sub-triangle among the k² of a regular subdivision: row i holds 2(k − i) − 1.
fn sub_triangle_index(i: usize, j: usize, upper: bool, k: usize) -> usize {
    let before: usize = (0..i).map(|r| 2 * (k - r) - 1).sum();
    (before + 2 * j + usize::from(upper)).min(k * k - 1)
}

#[test]
fn discrete_follows_its_weights() {
    let w = [1.0, 0.0, 3.0, 6.0];
    let d = Discrete::new(&w).unwrap();
    let mut counts = [0.0; 4];
    for (u, _) in uniforms(6) {
        counts[d.sample(u)] += 1.0;
    }
    assert_eq!(counts[1], 0.0, "a zero weight is never chosen");
    let p = chi_square_p(&[counts[0], counts[2], counts[3]], &[0.1, 0.3, 0.6], N);
    assert!(p > 1e-3, "p = {p}");
    assert!(Discrete::new(&[0.0, 0.0]).is_none() && Discrete::new(&[1.0, f64::NAN]).is_none());
}
