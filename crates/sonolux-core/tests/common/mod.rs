//! What the integration tests share: rooms, sound and wave settings, a spectrum.

use glam::Vec3;
use sonolux_core::Mesh;

/// A box [0,l]×[0,w]×[0,h] wound so that every normal (b − a) × (c − a) faces into it; the
/// material ids of its faces in the order floor, ceiling, south (y=0), north, west (x=0), east.
pub fn shoebox(l: f32, w: f32, h: f32, materials: [u32; 6]) -> Mesh {
    let v: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new(if i & 1 == 1 { l } else { 0.0 }, if i & 2 == 2 { w } else { 0.0 }, if i & 4 == 4 { h } else { 0.0 }))
        .collect();
    let quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
    let (mut t, mut m) = (Vec::new(), Vec::new());
    for (q, mat) in quads.into_iter().zip(materials) {
        t.push([q[0], q[1], q[2]]);
        t.push([q[0], q[2], q[3]]);
        m.extend([mat, mat]);
    }
    Mesh::new(v, t, m).unwrap()
}

/// A box [lo, hi] with the material ids of its faces in the order of [`shoebox`]; its normals
/// face into it when `facing_in` (a room), out of it otherwise (an obstacle standing in a room
/// whose normals face the air).
#[allow(dead_code)]
pub fn cuboid(lo: Vec3, hi: Vec3, materials: [u32; 6], facing_in: bool) -> Mesh {
    let e = hi - lo;
    let mut m = shoebox(e.x, e.y, e.z, materials);
    for v in &mut m.vertices {
        *v += lo;
    }
    if !facing_in {
        for t in &mut m.triangles {
            t.swap(1, 2);
        }
    }
    m
}

/// One mesh of several.
#[allow(dead_code)]
pub fn merge(parts: &[Mesh]) -> Mesh {
    let (mut v, mut t, mut m) = (Vec::new(), Vec::new(), Vec::new());
    for p in parts {
        let base = v.len() as u32;
        v.extend(&p.vertices);
        t.extend(p.triangles.iter().map(|tri| tri.map(|i| i + base)));
        m.extend(&p.material);
    }
    Mesh::new(v, t, m).unwrap()
}

/// The mesh with every vertex moved by `f`.
#[allow(dead_code)]
pub fn transformed(mesh: &Mesh, f: impl Fn(Vec3) -> Vec3) -> Mesh {
    Mesh::new(mesh.vertices.iter().map(|&v| f(v)).collect(), mesh.triangles.clone(), mesh.material.clone()).unwrap()
}

/// Wave settings whose grid spacing is `h` m (10 points per wavelength at the maximum frequency,
/// c = 343 m/s) for `duration_s`, with normal-incidence absorption.
#[allow(dead_code)]
pub fn wave_settings(h: f64, duration_s: f64) -> sonolux_core::wave::WaveSettings {
    sonolux_core::wave::WaveSettings {
        max_frequency_hz: 343.0 / (10.0 * h),
        points_per_wavelength: 10.0,
        duration_s,
        speed_of_sound_m_s: 343.0,
        absorption_kind: sonolux_core::wave::AbsorptionKind::NormalIncidence,
        ..Default::default()
    }
}

/// The complex spectrum (realfft's half spectrum) of `x` zero-padded to `len` samples.
#[allow(dead_code)]
pub fn spectrum(x: &[f64], len: usize) -> Vec<num_complex::Complex64> {
    let mut buf = vec![0.0; len];
    buf[..x.len()].copy_from_slice(x);
    let fft = realfft::RealFftPlanner::<f64>::new().plan_fft_forward(len);
    let mut out = fft.make_output_vec();
    fft.process(&mut buf, &mut out).unwrap();
    out.iter().map(|c| num_complex::Complex64::new(c.re, c.im)).collect()
}

/// A sound bake's settings as the wall, surface and bounce tests start from them: rays
/// 0..`rays`, seed 11, 343 m/s, two bands without air, stopped 60 dB down or at 0.3 s, all of
/// it one-sample bins at 48 kHz (1 ms late bins), 4 × 1 directions. A test changes what it
/// needs with `SoundSettings { field: …, ..sound_settings(…) }`.
#[allow(dead_code)]
pub fn sound_settings(rays: u64, estimator: sonolux_core::sound::Estimator, threads: usize) -> sonolux_core::sound::SoundSettings {
    sonolux_core::sound::SoundSettings {
        rays,
        first_ray: 0,
        end_ray: rays,
        first_receiver: 0,
        only_source: None,
        seed: 11,
        threads,
        estimator,
        speed_of_sound_m_s: 343.0,
        air_attenuation_per_m: vec![0.0, 0.0],
        energy_drop_db: 60.0,
        max_time_s: 0.3,
        sample_rate_hz: 48_000.0,
        early_s: 0.3,
        late_bin_s: 0.001,
        n_azimuth: 4,
        n_elevation: 1,
        max_field_bytes: 1 << 32,
    }
}

/// The same rays traced two ways, for a test to assert they give the same bits: one bake of
/// `settings` on one thread, and on two threads as the ranges `0..split_ray` and
/// `split_ray..settings.rays` merged.
#[allow(dead_code, clippy::too_many_arguments)]
pub fn whole_and_merged(
    mesh: &Mesh,
    bvh: &sonolux_core::Bvh,
    acoustics: &sonolux_core::sound::Acoustics,
    sources: &[sonolux_core::sound::SoundSource],
    receivers: &sonolux_core::sound::Receivers,
    settings: &sonolux_core::sound::SoundSettings,
    split_ray: u64,
    extras: sonolux_core::sound::Extras,
) -> (sonolux_core::sound::SoundResult, sonolux_core::sound::SoundResult) {
    use sonolux_core::sound::{trace_sound_with, SoundSettings};
    let trace = |s: &SoundSettings| trace_sound_with(mesh, bvh, acoustics, sources, receivers, s, extras, |_| true).unwrap();
    let whole = trace(&SoundSettings { threads: 1, ..settings.clone() });
    let first = SoundSettings { threads: 2, first_ray: 0, end_ray: split_ray, ..settings.clone() };
    let mut merged = trace(&first);
    merged.merge(&trace(&SoundSettings { first_ray: split_ray, end_ray: settings.rays, ..first })).unwrap();
    (whole, merged)
}
