//! The grazing modes of parallel surface pairs in the tracer (sound/grazing.rs): the same bits
//! whatever the threads and ray ranges (with the modes' profiles across the gaps), in effect (a
//! bake with them differs from one without),
//! and a table of another band count refused.

use glam::DVec3;
use sonolux_core::sound::{trace_sound_with, Acoustics, Directivity, Estimator, Extras, GrazingModes, Receivers, SoundSettings, SoundSource, WallModel};
use sonolux_core::Bvh;

mod common;

#[test]
fn grazing_modes_keep_the_bits_whatever_threads_and_ranges() {
    // A shoebox 7 × 5 × 3 m, an absorbing floor (material 1) under a hard ceiling.
    let mesh = common::shoebox(7.0, 5.0, 3.0, [1, 0, 0, 0, 0, 0]);
    let bvh = Bvh::build(&mesh).unwrap();
    let ac = Acoustics { n_bands: 2, absorption: vec![0.05, 0.06, 0.3, 0.4], scattering: vec![0.05, 0.1, 0.1, 0.2] };
    let src = [SoundSource { position: DVec3::new(2.0, 2.5, 1.5), power_w: 1.0, directivity: Directivity::Omni }];
    let rc = Receivers::new(vec![DVec3::new(5.0, 3.0, 1.2), DVec3::new(1.5, 1.0, 1.7)], 0.4);
    // The three pairs, limits π/(kD) at 125 and 250 Hz, rates of the order of the paper rooms'.
    let k = |f: f64| 2.0 * std::f64::consts::PI * f / 343.0;
    let limits: Vec<f64> = [3.0, 7.0, 5.0].iter().flat_map(|d| [125.0, 250.0].map(|f| (std::f64::consts::PI / (k(f) * d)).min(1.0))).collect();
    let table = GrazingModes::new(2, &[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[[0.0, 3.0], [0.0, 7.0], [0.0, 5.0]], limits, vec![0.02, 0.018, 0.002, 0.002, 0.003, 0.003]).unwrap();
    // With the modes' profiles across each gap (5 nodes: lower by the floor, as a grazing mode
    // over an absorbing floor; uniform across the walls' gaps).
    let profile: Vec<f64> = (0..3).flat_map(|p| (0..2).flat_map(move |_| (0..5).map(move |i| if p == 0 { 0.7 + 0.15 * i as f64 } else { 1.0 }))).collect();
    let table = table.with_profiles(5, profile).unwrap();
    let with = Extras { wall_model: WallModel::LocallyReacting, grazing_modes: Some(&table), ..Extras::default() };
    let set = |threads: usize, first: u64, end: u64| SoundSettings { seed: 9, first_ray: first, end_ray: end, ..common::sound_settings(5000, Estimator::Paper, threads) };
    let one = trace_sound_with(&mesh, &bvh, &ac, &src, &rc, &set(1, 0, 5000), with, |_| true).unwrap();
    let mut two = trace_sound_with(&mesh, &bvh, &ac, &src, &rc, &set(2, 0, 2000), with, |_| true).unwrap();
    two.merge(&trace_sound_with(&mesh, &bvh, &ac, &src, &rc, &set(2, 2000, 5000), with, |_| true).unwrap()).unwrap();
    assert_eq!(one.counts(1), two.counts(2));
    // In effect: the same walls without the grazing modes give other bits.
    let without = Extras { wall_model: WallModel::LocallyReacting, ..Extras::default() };
    let plain = trace_sound_with(&mesh, &bvh, &ac, &src, &rc, &set(1, 0, 5000), without, |_| true).unwrap();
    assert_ne!(one.counts(1), plain.counts(1));
    // A table of another band count is refused.
    let short = GrazingModes::new(1, &[[0.0, 0.0, 1.0]], &[[0.0, 3.0]], vec![0.5], vec![0.01]).unwrap();
    let bad = Extras { grazing_modes: Some(&short), ..Extras::default() };
    assert!(trace_sound_with(&mesh, &bvh, &ac, &src, &rc, &set(1, 0, 10), bad, |_| true).is_err());
}
