//! Sound bakes of real mesh rooms (the BVH's path: the tracer's query, `offset_origin` at each
//! reflection, the visibility tests of rain and nee) give the same bits on 1 and 2 threads and
//! split into ray ranges merged, for each estimator. The other same-bits tests (sound.rs,
//! hero.rs, reflectance.rs, surface_profile.rs) bake shoeboxes, which are traced through their
//! planes, not the BVH.

mod common;
mod rooms;

use glam::DVec3;
use sonolux_core::sound::{Acoustics, Directivity, Estimator, Extras, Receivers, SoundResult, SoundSource};
use sonolux_core::Bvh;

/// Everything that can differ between two bakes of the same rays: the field's counts and the
/// statistics (the energy tallies are fixed point, so their sums do not depend on the order).
fn bits(r: &SoundResult) -> (Vec<u64>, [u64; 8], Vec<Vec<f64>>) {
    let s = &r.stats;
    let kinds = ["emitted", "absorbed_surfaces", "absorbed_air", "escaped", "remaining", "reweighted"];
    let counted = [s.rays, s.segments, s.surface_hits, s.escaped_rays, s.deposits, s.shadow_rays, s.draws, s.max_reflections];
    (r.counts(1), counted, kinds.iter().map(|k| s.energy(k).unwrap().to_vec()).collect())
}

/// A bake of `room` (the L-room's talker and its four listeners: examples/l-room/l-room.toml)
/// with materials that absorb and scatter unlike by group and band, `rays` rays split at a
/// third: one thread whole against two threads in two ranges merged.
fn assert_same_bits(room: &rooms::Room, rays: u64) {
    let mesh = &room.mesh;
    let bvh = Bvh::build(mesh).unwrap();
    let n_materials = *mesh.material.iter().max().unwrap() as usize + 1;
    let acoustics = Acoustics {
        n_bands: 2,
        absorption: (0..n_materials).flat_map(|m| [0.03 + 0.04 * m as f64, 0.08 + 0.05 * m as f64]).collect(),
        scattering: (0..n_materials).flat_map(|m| [0.1 + 0.1 * (m % 4) as f64, 0.6 - 0.1 * (m % 3) as f64]).collect(),
    };
    let talker = [SoundSource { position: DVec3::new(10.8, 3.0, 1.6), power_w: 1.0, directivity: Directivity::Omni }];
    let listeners = [(8.0, 1.2, 1.2), (2.0, 3.5, 1.2), (5.5, 8.0, 1.2), (1.2, 7.5, 1.2)];
    let receivers = Receivers::new(listeners.iter().map(|&(x, y, z)| DVec3::new(x, y, z)).collect(), 0.3);
    for estimator in [Estimator::Paper, Estimator::Rain, Estimator::Nee { connections: 2 }] {
        let settings = common::sound_settings(rays, estimator, 1);
        let (one, two) = common::whole_and_merged(mesh, &bvh, &acoustics, &talker, &receivers, &settings, rays / 3, Extras::default());
        assert!(one.stats.surface_hits > rays, "{}, {estimator:?}: {} reflections", room.name, one.stats.surface_hits);
        assert!(bits(&one) == bits(&two), "{} ({} hull slots), {estimator:?}: 1 thread and 2 threads in two ranges differ", room.name, bvh.hull_slots());
    }
}

/// The example L-room (652 triangles, its hull at the BVH's root): 6,000 rays an estimator.
#[test]
fn l_room_bakes_give_the_same_bits_whatever_threads_and_ranges() {
    assert_same_bits(&rooms::l_room(), 6_000);
}

/// The 100k-triangle L-room (tessellated walls, the sculpture): 6,000 rays an estimator.
#[test]
#[ignore = "slow: builds the 100k-triangle room (make test-all)"]
fn l_room_100k_bakes_give_the_same_bits_whatever_threads_and_ranges() {
    assert_same_bits(&rooms::l_room_100k(), 6_000);
}
