//! Described surfaces in the tracer and the image sources (sound/scattering.rs): a table of
//! α(θ) and s(θ) per material that is constant in θ gives the bits of the plain coefficients;
//! a varying one the same bits whatever the threads and ray ranges; an image source's
//! reflection keeps (1 − α(θ))(1 − s(θ)) at its own angle of incidence.

use glam::{DVec3, Vec3};
use sonolux_core::early::{early_arrivals, ArrivalKind, EarlySettings};
use sonolux_core::sound::{trace_sound_with, Acoustics, Directivity, Estimator, Extras, Receivers, ScatteringByAngle, SoundSettings, SoundSource};
use sonolux_core::{Bvh, Mesh};

mod common;

const C: f64 = 343.0;
const N_COS: usize = 17;

fn settings(rays: u64, estimator: Estimator, threads: usize) -> SoundSettings {
    SoundSettings { seed: 5, ..common::sound_settings(rays, estimator, threads) }
}

/// A shoebox of three materials, two bands.
fn scene() -> (Mesh, Acoustics, Vec<SoundSource>, Receivers) {
    let mesh = common::shoebox(7.0, 5.0, 3.0, [1, 0, 2, 0, 0, 2]);
    let ac = Acoustics { n_bands: 2, absorption: vec![0.05, 0.08, 0.3, 0.5, 0.2, 0.4], scattering: vec![0.1, 0.2, 0.3, 0.3, 0.6, 0.7] };
    let rc = Receivers::new(vec![DVec3::new(5.0, 3.0, 1.2), DVec3::new(1.5, 1.0, 1.7)], 0.4);
    (mesh, ac, vec![SoundSource { position: DVec3::new(2.0, 2.5, 1.5), power_w: 1.0, directivity: Directivity::Omni }], rc)
}

/// The profiled floor of the image-source and diffraction-leg tests: α(cos θ) and s(cos θ) per
/// band, both varying with the angle.
fn floor_alpha(c: f64, b: usize) -> f64 {
    0.2 + 0.3 * c * c + 0.1 * b as f64
}

fn floor_scattering(c: f64, b: usize) -> f64 {
    0.4 * (1.0 - c) + 0.05 * b as f64
}

/// Early settings for first-order paths in two octave bands up to 0.2 s.
fn first_order_settings() -> EarlySettings {
    let mut set = EarlySettings::octaves(2);
    set.max_order = 1;
    set.max_time_s = 0.2;
    set.speed_of_sound_m_s = C;
    set
}

/// What a specular reflection keeps at cos θ in band `b`, (1 − α)(1 − s), each read from the
/// table's nodes by linear interpolation in cos θ as the core reads it.
fn kept_at(cos: f64, alpha: &dyn Fn(f64, usize) -> f64, scat: &dyn Fn(f64, usize) -> f64, b: usize) -> f64 {
    let x = cos * (N_COS - 1) as f64;
    let (i, t) = (x.floor(), x - x.floor());
    let (c0, c1) = (i / (N_COS - 1) as f64, (i + 1.0) / (N_COS - 1) as f64);
    let lerp = |f: &dyn Fn(f64, usize) -> f64| f(c0, b) + (f(c1, b) - f(c0, b)) * t;
    (1.0 - lerp(alpha)) * (1.0 - lerp(scat))
}

/// Material `m`'s rows: α(c) and s(c) per band at N_COS nodes c = i/(N_COS − 1).
fn rows(alpha: impl Fn(f64, usize) -> f64, scattering: impl Fn(f64, usize) -> f64) -> Vec<f64> {
    let mut out = Vec::new();
    for f in [&alpha as &dyn Fn(f64, usize) -> f64, &scattering] {
        for i in 0..N_COS {
            let c = i as f64 / (N_COS - 1) as f64;
            out.extend((0..2).map(|b| f(c, b)));
        }
    }
    out
}

#[test]
fn a_table_constant_in_angle_gives_the_plain_bits() {
    let (mesh, ac, src, rc) = scene();
    let bvh = Bvh::build(&mesh).unwrap();
    // Materials 0 and 2 described, each by its own coefficients at every angle.
    let constant = |m: usize| rows(|_, b| ac.absorption[2 * m + b], |_, b| ac.scattering[2 * m + b]);
    let table = ScatteringByAngle::new(2, N_COS, &[Some(constant(0)), None, Some(constant(2))]).unwrap();
    for estimator in [Estimator::Paper, Estimator::Rain, Estimator::Nee { connections: 2 }] {
        let set = settings(4000, estimator, 2);
        let plain = trace_sound_with(&mesh, &bvh, &ac, &src, &rc, &set, Extras::default(), |_| true).unwrap();
        let extras = Extras { scattering_by_angle: Some(&table), ..Extras::default() };
        let with = trace_sound_with(&mesh, &bvh, &ac, &src, &rc, &set, extras, |_| true).unwrap();
        assert_eq!(plain.counts(1), with.counts(1), "{estimator:?}");
    }
}

#[test]
fn a_varying_table_has_the_same_bits_whatever_threads_and_ranges() {
    let (mesh, ac, src, rc) = scene();
    let bvh = Bvh::build(&mesh).unwrap();
    // The floor (material 1): absorption falling towards grazing, scattering peaking near it.
    let floor = rows(|c, b| (0.3 + 0.2 * b as f64) * c.sqrt(), |c, b| (0.05 + 0.3 * b as f64) * (1.0 + 4.0 * c * (1.0 - c)).min(2.0) / 2.0);
    let table = ScatteringByAngle::new(2, N_COS, &[None, Some(floor), None]).unwrap();
    let extras = Extras { scattering_by_angle: Some(&table), ..Extras::default() };
    for estimator in [Estimator::Paper, Estimator::Rain, Estimator::Nee { connections: 2 }] {
        let (one, two) = common::whole_and_merged(&mesh, &bvh, &ac, &src, &rc, &settings(5000, estimator, 1), 2000, extras);
        assert_eq!(one.counts(1), two.counts(2), "{estimator:?}");
        // And the table is in effect.
        let plain = trace_sound_with(&mesh, &bvh, &ac, &src, &rc, &settings(5000, estimator, 1), Extras::default(), |_| true).unwrap();
        assert_ne!(one.counts(1), plain.counts(1), "{estimator:?}");
    }
    // A table for fewer materials than the mesh names is refused.
    let short = ScatteringByAngle::new(2, N_COS, &[None]).unwrap();
    let extras = Extras { scattering_by_angle: Some(&short), ..Extras::default() };
    assert!(trace_sound_with(&mesh, &bvh, &ac, &src, &rc, &settings(10, Estimator::Paper, 1), extras, |_| true).is_err());
}

#[test]
fn an_image_source_keeps_what_the_table_gives_at_its_angle() {
    // An open floor at z = 0 (material 0) and one first-order reflection: its energy with a
    // table against the same path off a rigid, specular floor is (1 − α(cos θ))(1 − s(cos θ)),
    // the table read at the reflection's own cos θ (linear between nodes: 1e-12, rounding).
    let s = 200.0f32;
    let v = vec![Vec3::new(-s, -s, 0.0), Vec3::new(s, -s, 0.0), Vec3::new(s, s, 0.0), Vec3::new(-s, s, 0.0)];
    let mesh = Mesh::new(v, vec![[0, 1, 2], [0, 2, 3]], vec![0, 0]).unwrap();
    let bvh = Bvh::build(&mesh).unwrap();
    let rigid = Acoustics { n_bands: 2, absorption: vec![0.0; 2], scattering: vec![0.0; 2] };
    let src = [SoundSource { position: DVec3::new(0.0, 0.0, 1.5), power_w: 1.0, directivity: Directivity::Omni }];
    let receivers = [DVec3::new(6.0, 1.0, 1.2)];
    let (alpha, scat) = (floor_alpha, floor_scattering);
    let mut set = first_order_settings();
    let first_order = |settings: &EarlySettings| {
        let r = early_arrivals(&mesh, &bvh, &rigid, &src, &receivers, settings, None).unwrap();
        let k = r.arrivals.iter().position(|a| a.kind == ArrivalKind::Specular { order: 1 }).unwrap();
        [r.energy[2 * k], r.energy[2 * k + 1]]
    };
    let flat = first_order(&set);
    set.by_angle = Some(ScatteringByAngle::new(2, N_COS, &[Some(rows(alpha, scat))]).unwrap());
    let profiled = first_order(&set);
    // The image is at z = −1.5; cos θ is the path's vertical share.
    let d = receivers[0] - DVec3::new(0.0, 0.0, -1.5);
    let cos = d.z.abs() / d.length();
    for b in 0..2 {
        let kept = kept_at(cos, &alpha, &scat, b);
        assert!((profiled[b] / flat[b] - kept).abs() < 1e-12, "band {b}: {} vs {kept}", profiled[b] / flat[b]);
    }
}

#[test]
fn a_diffracted_legs_reflection_keeps_what_the_table_gives_at_its_angle() {
    // A screen 2 m high (y = 0, material 1, rigid) standing on a floor (z = 0, material 0), the
    // source in front of it and the receiver in the shadow behind it, where neither the direct
    // nor the floor's reflection arrives (no geometric wave to cross the diffracted ones). The
    // wave of the source's image in the floor diffracts at the screen's top edge after
    // reflecting on the floor: with a table its energy against the rigid, specular floor's is
    // (1 − α(cos θ))(1 − s(cos θ)), read at that leg's own angle, from the image to the apex
    // (linear between nodes: 1e-12, rounding); the source's own diffracted waves do not reflect
    // and keep their energy exactly.
    let (w, top) = (30.0f32, 2.0f32);
    let v = vec![
        Vec3::new(-w, -w, 0.0), Vec3::new(w, -w, 0.0), Vec3::new(w, w, 0.0), Vec3::new(-w, w, 0.0),
        Vec3::new(-w, 0.0, 0.0), Vec3::new(w, 0.0, 0.0), Vec3::new(w, 0.0, top), Vec3::new(-w, 0.0, top),
    ];
    let mesh = Mesh::new(v, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]], vec![0, 0, 1, 1]).unwrap();
    let bvh = Bvh::build(&mesh).unwrap();
    let rigid = Acoustics { n_bands: 2, absorption: vec![0.0; 4], scattering: vec![0.0; 4] };
    let source = DVec3::new(0.0, -2.0, 1.0);
    let src = [SoundSource { position: source, power_w: 1.0, directivity: Directivity::Omni }];
    let receiver = DVec3::new(0.0, 3.0, 1.0);
    let image = DVec3::new(source.x, source.y, -source.z);
    let (alpha, scat) = (floor_alpha, floor_scattering);
    let mut set = first_order_settings();
    set.diffraction = true;
    // Each diffracted arrival: (image, apex on the screen's plane, band energies), in a fixed order.
    let diffracted = |settings: &EarlySettings| {
        let r = early_arrivals(&mesh, &bvh, &rigid, &src, &[receiver], settings, None).unwrap();
        let mut out: Vec<(u32, DVec3, [f64; 2])> = r
            .arrivals
            .iter()
            .enumerate()
            .filter(|(_, a)| matches!(a.kind, ArrivalKind::Diffracted { .. }))
            .map(|(k, a)| {
                let d = a.from_direction;
                (a.image, receiver + d * (-receiver.y / d.y), [r.energy[2 * k], r.energy[2 * k + 1]])
            })
            .collect();
        out.sort_by(|x, y| (x.0, x.1.x, x.1.z).partial_cmp(&(y.0, y.1.x, y.1.z)).unwrap());
        out
    };
    let flat = diffracted(&set);
    set.by_angle = Some(ScatteringByAngle::new(2, N_COS, &[Some(rows(alpha, scat)), None]).unwrap());
    let profiled = diffracted(&set);
    assert_eq!(flat.len(), profiled.len());
    let mut reflected = 0;
    for (f, p) in flat.iter().zip(&profiled) {
        assert_eq!((f.0, f.1), (p.0, p.1));
        if f.0 == 0 {
            assert_eq!(f.2, p.2, "the source's own diffracted wave at {:?}", f.1);
            continue;
        }
        if (f.1.z - top as f64).abs() > 1e-6 {
            continue; // a side edge's, 30 m away
        }
        reflected += 1;
        let cos = (f.1 - image).normalize().z.abs();
        for b in 0..2 {
            let kept = kept_at(cos, &alpha, &scat, b);
            let ratio = p.2[b] / f.2[b];
            assert!((ratio - kept).abs() < 1e-12, "band {b}, cos θ {cos}: {ratio} vs {kept}");
        }
    }
    assert_eq!(reflected, 1, "the image's wave over the top edge: {flat:?}");
}
