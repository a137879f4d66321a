//! Physics checks of the sound tracer with closed-form answers.

use std::f64::consts::PI;

use glam::DVec3;
use sonolux_core::sound::{
    receivers::ball_mean_inverse_square, trace_sound, Acoustics, Directivity, Estimator, Receivers, SoundResult, SoundSettings, SoundSource,
};
use sonolux_core::{Bvh, Mesh};

mod common;

/// A shoebox [0,l]×[0,w]×[0,h]: material 0 floor, 1 ceiling, 2 walls.
fn shoebox(l: f32, w: f32, h: f32) -> Mesh {
    common::shoebox(l, w, h, [0, 1, 2, 2, 2, 2])
}

fn acoustics(alpha: [f64; 3], scattering: [f64; 3], bands: usize) -> Acoustics {
    let mut a = Vec::new();
    let mut s = Vec::new();
    for k in 0..3 {
        for b in 0..bands {
            a.push(alpha[k]);
            s.push((scattering[k] * (1.0 + 0.0 * b as f64)).min(1.0));
        }
    }
    Acoustics { n_bands: bands, absorption: a, scattering: s }
}

fn settings(rays: u64, estimator: Estimator, max_time_s: f64) -> SoundSettings {
    SoundSettings {
        rays,
        first_ray: 0,
        first_receiver: 0,
        only_source: None,
        end_ray: rays,
        seed: 7,
        threads: 2,
        estimator,
        speed_of_sound_m_s: 343.0,
        air_attenuation_per_m: vec![0.0, 0.001],
        energy_drop_db: 60.0,
        max_time_s,
        sample_rate_hz: 48_000.0,
        early_s: 0.08,
        late_bin_s: 0.001,
        n_azimuth: 8,
        n_elevation: 1,
        max_field_bytes: 1 << 32,
    }
}

fn run(mesh: &Mesh, ac: &Acoustics, src: &[SoundSource], rc: &Receivers, set: &SoundSettings) -> SoundResult {
    let bvh = Bvh::build(mesh).unwrap();
    trace_sound(mesh, &bvh, ac, src, rc, set, |_| true).unwrap()
}

fn omni(p: DVec3) -> SoundSource {
    SoundSource { position: p, power_w: 1.0, directivity: Directivity::Omni }
}

/// Energy of receiver r summed over directions, per band, in bins [t0, t1).
fn energy(res: &SoundResult, r: usize, band: usize, bins: std::ops::Range<usize>) -> f64 {
    let l = &res.layout;
    let mut e = 0.0;
    for t in bins {
        for d in 0..l.n_directions() {
            e += res.field.get(l.index(r, t, d) + band) as f64 * res.field.quantum;
        }
    }
    e
}

#[test]
fn energy_balance_closes() {
    let mesh = shoebox(6.0, 4.0, 3.0);
    for (scat, est) in [([0.1, 0.1, 0.1], Estimator::Paper), ([0.9, 0.2, 0.5], Estimator::Rain)] {
        let mut ac = acoustics([0.3, 0.05, 0.1], scat, 2);
        ac.scattering[1] = 0.7; // a band-dependent scattering exercises the re-weighting term
        let rc = Receivers::new(vec![DVec3::new(2.0, 2.0, 1.5)], 0.3);
        let res = run(&mesh, &ac, &[omni(DVec3::new(3.0, 2.0, 1.5))], &rc, &settings(20_000, est, 3.0));
        let st = &res.stats;
        let get = |w: &str| st.energy(w).unwrap();
        for b in 0..2 {
            let lhs = get("emitted")[b] + get("reweighted")[b];
            let rhs = get("absorbed_surfaces")[b] + get("absorbed_air")[b] + get("escaped")[b] + get("remaining")[b];
            assert!(((lhs - rhs) / get("emitted")[b]).abs() < 1e-9, "band {b}: {lhs} vs {rhs}");
        }
        assert_eq!(st.escaped_rays, 0);
        assert!((get("emitted")[0] - 1.0).abs() < 1e-12);
    }
}

#[test]
fn mean_free_path_is_4v_over_s_in_a_diffuse_room() {
    let (l, w, h) = (7.0, 5.0, 3.0);
    let mesh = shoebox(l as f32, w as f32, h as f32);
    let ac = acoustics([0.1; 3], [1.0; 3], 2);
    let rc = Receivers::new(vec![], 0.3);
    let res = run(&mesh, &ac, &[omni(DVec3::new(2.0, 2.0, 1.5))], &rc, &settings(20_000, Estimator::Paper, 5.0));
    let expect = 4.0 * l * w * h / (2.0 * (l * w + w * h + h * l));
    let got = res.stats.mean_free_path();
    // ~2.6 million segments: the statistical error is far below the 1% allowed.
    assert!((got / expect - 1.0).abs() < 0.01, "measured {got}, 4V/S = {expect}");
}

/// Direct sound of an omni source at distance d in a fully absorbing room, as a fraction of the
/// free-field energy W/(4πd²), and the first time bin that received anything.
fn direct(est: Estimator, radius: f64, d: f64, rays: u64) -> (f64, usize) {
    let mesh = shoebox(40.0, 40.0, 40.0);
    let ac = acoustics([1.0; 3], [0.0; 3], 2);
    let src = DVec3::new(5.0, 20.0, 20.0);
    let rc = Receivers::new(vec![src + DVec3::new(d, 0.0, 0.0)], radius);
    let mut set = settings(rays, est, 0.5);
    set.air_attenuation_per_m = vec![0.0, 0.0];
    let res = run(&mesh, &ac, &[omni(src)], &rc, &set);
    let total = energy(&res, 0, 0, 0..res.layout.n_time());
    let first = (0..res.layout.n_time()).find(|&t| energy(&res, 0, 0, t..t + 1) > 0.0).unwrap();
    (total * 4.0 * PI * d * d, first)
}

#[test]
fn direct_sound_is_free_field_energy_for_any_sphere_radius() {
    // The default (rain) estimator computes it exactly: the sphere mean of 1/(4πd²), which is
    // within (r/d)²/5 of the point value (0.14% at r = 0.5, d = 6).
    let d = 6.0;
    for radius in [0.1, 0.25, 0.5] {
        let (ratio, first) = direct(Estimator::Rain, radius, d, 100);
        assert!((ratio - 1.0).abs() < 0.02, "r = {radius}: {ratio}");
        let expect = d / 343.0 * 48_000.0;
        assert!((first as f64 - expect).abs() <= 1.0, "first bin {first}, expected {expect}");
    }
}

/// The paper's estimator is a Monte Carlo one: with n expected sphere crossings its relative
/// standard error is √((1 + 2/16)/n) (Poisson count × chord spread). At d = 15 r the sphere mean
/// is within 0.1% of W/(4πd²). Here n = 4000 (σ = 1.7%), tolerance 4σ.
#[test]
fn paper_estimator_direct_sound_is_unbiased() {
    for radius in [0.1, 0.25, 0.5] {
        let d = 15.0 * radius;
        let n = 4000.0;
        let rays = (n * 4.0 * d * d / (radius * radius)) as u64;
        let (ratio, first) = direct(Estimator::Paper, radius, d, rays);
        assert!((ratio - 1.0).abs() < 4.0 * (1.125f64 / n).sqrt(), "r = {radius}: {ratio}");
        let expect = d / 343.0 * 48_000.0;
        assert!((first as f64 - expect).abs() <= 1.0, "first bin {first}, expected {expect}");
    }
}

/// The same with 40 000 crossings (σ = 0.53%): within the 2% asked, at 3.8σ. Slow (`make test-all`).
#[test]
#[ignore]
fn paper_estimator_direct_sound_within_two_percent() {
    for radius in [0.1, 0.25, 0.5] {
        let d = 15.0 * radius;
        let rays = (40_000.0 * 4.0 * d * d / (radius * radius)) as u64;
        let (ratio, _) = direct(Estimator::Paper, radius, d, rays);
        assert!((ratio - 1.0).abs() < 0.02, "r = {radius}: {ratio}");
    }
}

#[test]
fn source_inside_the_receiver_gives_the_sphere_mean_whatever_the_ray_count() {
    let mesh = shoebox(20.0, 20.0, 20.0);
    let ac = acoustics([1.0; 3], [0.0; 3], 2);
    let c = DVec3::splat(10.0);
    let radius = 0.4;
    let expect = ball_mean_inverse_square(0.0, radius);
    for rays in [1_000, 100_000] {
        for est in [Estimator::Paper, Estimator::Rain] {
            let rc = Receivers::new(vec![c], radius);
            let mut set = settings(rays, est, 0.5);
            set.air_attenuation_per_m = vec![0.0, 0.0];
            let res = run(&mesh, &ac, &[omni(c)], &rc, &set);
            let got = energy(&res, 0, 0, 0..res.layout.n_time());
            assert!((got / expect - 1.0).abs() < 1e-6, "{est:?} {rays} rays: {got} vs {expect}");
        }
    }
}

#[test]
fn a_source_to_the_right_lands_in_the_right_sector() {
    let mesh = shoebox(20.0, 20.0, 20.0);
    let ac = acoustics([1.0; 3], [0.0; 3], 2);
    let rc = Receivers::new(vec![DVec3::new(10.0, 10.0, 10.0)], 0.3);
    let res = run(&mesh, &ac, &[omni(DVec3::new(10.0, 5.0, 10.0))], &rc, &settings(1_000_000, Estimator::Paper, 0.5));
    let l = &res.layout;
    let by_dir: Vec<f64> = (0..l.n_directions())
        .map(|d| (0..l.n_time()).map(|t| res.field.get(l.index(0, t, d)) as f64).sum())
        .collect();
    let total: f64 = by_dir.iter().sum();
    assert!(by_dir[6] / total >= 0.95, "right sector (−90°) holds {:.3}: {by_dir:?}", by_dir[6] / total);
}

#[test]
fn same_bits_for_any_thread_count_and_any_split_into_ranges() {
    let mesh = shoebox(6.0, 4.0, 3.0);
    let ac = acoustics([0.3, 0.05, 0.1], [0.2, 0.5, 0.3], 2);
    let rc = Receivers::new(vec![DVec3::new(2.0, 2.0, 1.5), DVec3::new(4.5, 1.0, 1.5)], 0.3);
    let src = [omni(DVec3::new(3.0, 2.0, 1.5))];
    for est in [Estimator::Paper, Estimator::Rain] {
        let mut set = settings(5_000, est, 1.0);
        set.threads = 1;
        let one = run(&mesh, &ac, &src, &rc, &set);
        set.threads = 2;
        let two = run(&mesh, &ac, &src, &rc, &set);
        assert_eq!(one.field.to_vec(), two.field.to_vec());
        assert_eq!(one.stats.energy("absorbed_air"), two.stats.energy("absorbed_air"));
        // Three ranges, merged in another order.
        let mut parts: Vec<SoundResult> = [(0, 1234), (1234, 4000), (4000, 5000)]
            .iter()
            .map(|&(a, b)| {
                let mut s = set.clone();
                s.first_ray = a;
                s.end_ray = b;
                run(&mesh, &ac, &src, &rc, &s)
            })
            .collect();
        let mut merged = parts.pop().unwrap();
        for p in parts.iter().rev() {
            merged.merge(p).unwrap();
        }
        assert_eq!(merged.field.to_vec(), one.field.to_vec(), "{est:?}");
        assert_eq!(merged.stats.energy("remaining"), one.stats.energy("remaining"));
        assert_eq!(merged.stats.surface_hits, one.stats.surface_hits);
    }
}

#[test]
fn the_two_estimators_agree_in_expectation() {
    let mesh = shoebox(8.0, 5.0, 3.0);
    let ac = acoustics([0.2, 0.1, 0.15], [0.3, 0.6, 0.5], 2);
    let rc = Receivers::new(vec![DVec3::new(2.0, 2.0, 1.5), DVec3::new(6.0, 3.5, 1.2)], 0.5);
    let src = [omni(DVec3::new(4.0, 2.5, 1.5))];
    let paper = run(&mesh, &ac, &src, &rc, &settings(1_500_000, Estimator::Paper, 1.0));
    let rain = run(&mesh, &ac, &src, &rc, &settings(300_000, Estimator::Rain, 1.0));
    // Compare energies in windows of the decay. The paper estimator's noise is largest in the
    // first window, where the direct sound (about 1.5M × (0.5 / 2·2.3 m)² ≈ 18 000 crossings for
    // the nearer receiver, σ ≈ 0.8%) dominates: 3% is over 3.5σ there and more elsewhere. The
    // rain estimator still collects specular reflections with its spheres, so it needs rays too.
    let l = &paper.layout;
    let ms = |t: f64| l.time_bin(t).unwrap();
    for r in 0..2 {
        for (a, b) in [(0.0, 0.05), (0.05, 0.15), (0.15, 0.4)] {
            let (p, q) = (energy(&paper, r, 0, ms(a)..ms(b)), energy(&rain, r, 0, ms(a)..ms(b)));
            assert!((p / q - 1.0).abs() < 0.03, "receiver {r}, {a}–{b} s: paper {p} rain {q}");
        }
    }
}

/// A closed room (with a box standing in it, so that the tracer uses the BVH) 6 km from the
/// origin, where f32 coordinates are 0.49 mm apart: no ray may leave it, and the energy balance
/// closes. With the offset the tracer used before (1e-5 of the scene's size, 0.15 mm here) the
/// next ray's origin rounded back onto the wall it left, and rays leaked out through it; the
/// offset of Wächter and Binder 2019 counts in ulps of the coordinates (`geometry::offset_origin`).
#[test]
fn a_room_far_from_the_origin_does_not_leak() {
    let far = glam::Vec3::new(6000.0, -6000.0, 0.0);
    let room = common::transformed(&shoebox(10.0, 8.0, 3.0), |v| v + far);
    let obstacle = common::cuboid(far + glam::Vec3::new(4.0, 3.0, 0.0), far + glam::Vec3::new(5.0, 4.0, 1.0), [2; 6], false);
    let mesh = common::merge(&[room, obstacle]);
    assert!(!mesh.is_closed_convex());
    let ac = acoustics([0.05, 0.02, 0.05], [0.3, 0.3, 0.3], 2);
    let at = |x: f64, y: f64, z: f64| far.as_dvec3() + DVec3::new(x, y, z);
    let rc = Receivers::new(vec![at(7.0, 5.0, 1.5)], 0.5);
    let res = run(&mesh, &ac, &[omni(at(2.0, 2.0, 1.5))], &rc, &settings(2_000, Estimator::Paper, 1.0));
    let st = &res.stats;
    assert_eq!(st.escaped_rays, 0, "rays left a closed room");
    let get = |w: &str| st.energy(w).unwrap();
    for b in 0..2 {
        let lhs = get("emitted")[b] + get("reweighted")[b];
        let rhs = get("absorbed_surfaces")[b] + get("absorbed_air")[b] + get("escaped")[b] + get("remaining")[b];
        assert!(((lhs - rhs) / get("emitted")[b]).abs() < 1e-9, "band {b}: {lhs} vs {rhs}");
    }
}

/// On a mesh whose BVH runs on AVX2 the kernel is compiled under that token with the query
/// inlined (sound/nearest.rs); with the portable BVH it calls the query. Same arithmetic, so
/// the same bits: field and statistics, with one receiver and with several, in both the plain
/// kernel (bands alike) and the general one (bands unlike: hero sampling).
#[test]
fn the_inlined_avx2_query_gives_the_bits_of_the_portable_one() {
    let room = shoebox(9.0, 7.0, 3.0);
    let obstacle = common::cuboid(glam::Vec3::new(4.0, 3.0, 0.0), glam::Vec3::new(5.0, 4.5, 1.0), [2; 6], false);
    let mesh = common::merge(&[room, obstacle]);
    assert!(!mesh.is_closed_convex());
    let bvh = Bvh::build(&mesh).unwrap();
    let portable = bvh.clone().portable();
    let mut unlike = acoustics([0.05, 0.3, 0.1], [0.1, 0.1, 0.1], 2);
    unlike.scattering.iter_mut().enumerate().for_each(|(i, s)| *s = 0.05 + 0.5 * (i % 2) as f64);
    for ac in [acoustics([0.05, 0.3, 0.1], [0.1, 0.1, 0.1], 2), unlike] {
        for centres in [vec![DVec3::new(7.0, 5.0, 1.5)], vec![DVec3::new(7.0, 5.0, 1.5), DVec3::new(2.0, 5.5, 1.2), DVec3::new(6.5, 1.5, 2.0)]] {
            let rc = Receivers::new(centres, 0.4);
            let set = settings(1_500, Estimator::Paper, 0.5);
            let src = [omni(DVec3::new(2.0, 2.0, 1.5))];
            let a = trace_sound(&mesh, &bvh, &ac, &src, &rc, &set, |_| true).unwrap();
            let b = trace_sound(&mesh, &portable, &ac, &src, &rc, &set, |_| true).unwrap();
            assert_eq!(a.field.to_vec(), b.field.to_vec());
            assert_eq!((a.stats.segments, a.stats.deposits, a.stats.free_paths), (b.stats.segments, b.stats.deposits, b.stats.free_paths));
            assert_eq!(a.stats.energy("absorbed_surfaces"), b.stats.energy("absorbed_surfaces"));
        }
    }
}
