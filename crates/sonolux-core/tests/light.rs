//! Physics checks of the light tracer: conservation, the furnace, Monte Carlo convergence,
//! determinism.

use std::f64::consts::PI;

use glam::DVec3;
use sonolux_core::light::{trace_light, Emitter, LightResult, LightSettings, Optics, Patches};
use sonolux_core::{Bvh, Mesh};

mod common;

/// A box [0,l]×[0,w]×[0,h] with normals facing in; material 0 floor, 1 the rest.
fn room(l: f32, w: f32, h: f32) -> Mesh {
    common::shoebox(l, w, h, [0, 1, 1, 1, 1, 1])
}

fn patches(mesh: &Mesh, size: f64) -> Patches {
    Patches::new((0..mesh.triangles.len()).map(|t| mesh.corners(t).map(|v| v.as_dvec3())), size, 4096)
}

fn run(mesh: &Mesh, optics: &Optics, emitters: &[Emitter], size: f64, particles: u64, threads: usize) -> LightResult {
    let bvh = Bvh::build(mesh).unwrap();
    let settings = LightSettings { particles, first_ray: 0, end_ray: particles, seed: 5, threads, max_bounces: 100_000 };
    trace_light(mesh, &bvh, optics, emitters, patches(mesh, size), &settings, |_| true).unwrap()
}

fn strip_light(y: f64) -> Emitter {
    // A 1 m × 0.1 m strip 1 mm below a 3 m ceiling, facing down.
    let (a, b, c) = (DVec3::new(1.0, y, 2.999), DVec3::new(2.0, y, 2.999), DVec3::new(1.0, y + 0.1, 2.999));
    Emitter { corners: [a, c, b], flux: [60.0, 50.0, 40.0] }
}

#[test]
fn flux_is_conserved() {
    let mesh = room(4.0, 3.0, 3.0);
    let optics = Optics { rho: vec![[0.3, 0.3, 0.3], [0.9, 0.8, 0.7]], specular: vec![0.0, 0.3], roughness: vec![0.5, 0.2] };
    let res = run(&mesh, &optics, &[strip_light(1.0), strip_light(2.0)], 0.5, 200_000, 2);
    let s = &res.stats;
    for c in 0..3 {
        let lhs = s.emitted[c] + s.roulette[c];
        let rhs = s.absorbed[c] + s.escaped[c];
        assert!(((lhs - rhs) / s.emitted[c]).abs() < 1e-9, "channel {c}: {lhs} vs {rhs}");
    }
    assert!((s.emitted[0] - 120.0).abs() < 1e-9 && (s.emitted[2] - 80.0).abs() < 1e-9);
    assert_eq!(s.escaped_particles, 0);
    // And the flux landing on patches equals what the particles brought, bounce by bounce.
    let landed: f64 = res.flux.iter().map(|f| f[0]).sum();
    assert!(landed > s.emitted[0], "light is reflected more than once");
}

#[test]
fn furnace_radiance_is_le_over_one_minus_rho_everywhere() {
    // Every wall emits radiance Le and reflects ρ diffusely: the incident radiance is then
    // Le / (1 − ρ) everywhere, so every patch's irradiance is π Le / (1 − ρ).
    let mesh = room(3.0, 2.0, 2.5);
    let rho = 0.7;
    let le = 2.0;
    let optics = Optics { rho: vec![[rho; 3]; 2], specular: vec![0.0; 2], roughness: vec![0.5; 2] };
    let emitters: Vec<Emitter> = (0..mesh.triangles.len())
        .map(|t| {
            let corners = mesh.corners(t).map(|v| v.as_dvec3());
            let area = mesh.area(t);
            Emitter { corners, flux: [PI * le * area; 3] }
        })
        .collect();
    let res = run(&mesh, &optics, &emitters, 0.5, 2_000_000, 2);
    let expect = PI * le / (1.0 - rho);
    let mut worst: f64 = 0.0;
    for (p, f) in res.flux.iter().enumerate() {
        let e = f[1] / res.patches.area[p];
        // Each patch gets ~ 2e6 × 3.3 bounces / 60 patches ≈ 10⁵ hits: about 1% noise (the
        // weights vary with roulette); 5% is a safe bound for the worst of 60 patches.
        worst = worst.max((e / expect - 1.0).abs());
    }
    assert!(worst < 0.05, "worst patch off by {worst}");
    assert_eq!(res.stats.escaped_particles, 0);
    let mean: f64 = res.flux.iter().map(|f| f[1]).sum::<f64>() / res.patches.area.iter().sum::<f64>();
    assert!((mean / expect - 1.0).abs() < 0.005, "mean irradiance {mean} vs {expect}");
}

#[test]
fn doubling_the_particles_halves_a_patch_variance() {
    let mesh = room(4.0, 3.0, 3.0);
    let optics = Optics { rho: vec![[0.3; 3], [0.8; 3]], specular: vec![0.0; 2], roughness: vec![0.5; 2] };
    let light = [strip_light(1.5)];
    // Variance over independent runs (different seeds) of one floor patch's flux.
    let variance = |particles: u64| {
        let bvh = Bvh::build(&mesh).unwrap();
        let values: Vec<f64> = (0..40)
            .map(|seed| {
                let s = LightSettings { particles, first_ray: 0, end_ray: particles, seed, threads: 2, max_bounces: 10_000 };
                trace_light(&mesh, &bvh, &optics, &light, patches(&mesh, 0.5), &s, |_| true).unwrap().flux[3][1]
            })
            .collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (values.len() - 1) as f64
    };
    let ratio = variance(20_000) / variance(40_000);
    // The ratio of two sample variances of 40 runs each has a spread of about ±45% (F(39, 39)
    // at 2σ); it must be near 2, not 1 or 4.
    assert!((1.2..3.3).contains(&ratio), "variance ratio {ratio}");
}

#[test]
fn same_bits_on_one_and_two_threads() {
    let mesh = room(4.0, 3.0, 3.0);
    let optics = Optics { rho: vec![[0.3, 0.4, 0.5], [0.9, 0.8, 0.7]], specular: vec![0.1, 0.3], roughness: vec![0.0, 0.3] };
    let a = run(&mesh, &optics, &[strip_light(1.0)], 0.4, 50_000, 1);
    let b = run(&mesh, &optics, &[strip_light(1.0)], 0.4, 50_000, 2);
    assert_eq!(a.flux, b.flux);
    assert_eq!(a.hits, b.hits);
    assert_eq!(a.stats.absorbed, b.stats.absorbed);
}
