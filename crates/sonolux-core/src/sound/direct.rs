//! The rain estimator's exact direct sound, deposited by the rays in shares (moved out of
//! sound/trace.rs, unchanged, to keep that file readable in one sitting).

use super::field::{Accumulator, Deposits};
use super::receivers::ball_mean_inverse_square;
use super::Scene;
use crate::geometry::Ray;
use crate::rng::keyed_uniform;

/// Rays that carry one share of the exact direct sound ([`direct_share`]): a ray whose index is
/// a multiple of this deposits the share of the block of rays it starts.
pub const DIRECT_BLOCK_RAYS: u64 = 256;

/// The exact direct sound of source `s` at every receiver it can see, deposited in shares by the
/// rays: ray `index`, when it starts a block of [`DIRECT_BLOCK_RAYS`] rays, deposits (rays of its
/// block) / (rays of the bake) of it. The whole bake deposits it once; any ray range, its
/// share, so a bake of n rays scaled by rays / n (the progressive bake) holds the direct sound
/// once, not rays / n times, and each ray group of a progressive round (whole blocks) holds its
/// own share: the leave-out estimates of the jackknife all see the same direct sound (it has
/// no noise). It was deposited whole by the range holding ray 0: in a progressive bake that is
/// group 0 of round 1, whose leave-out lost the direct sound entirely (docs/progressive.md).
///
/// The share: power × directivity (per band, towards the receiver's centre) × the sphere mean
/// of 1/(4π d²) × air attenuation, at d / c, from the source's direction. A source at a
/// receiver's centre has no direction to it: its mean gain over the sphere, 1, is used. A source
/// inside a receiver's sphere is heard from all directions equally.
pub(crate) fn direct_share(scene: &Scene, s: usize, index: u64, acc: &Accumulator, buf: &mut Deposits) {
    let set = scene.settings;
    if index % DIRECT_BLOCK_RAYS != 0 {
        return;
    }
    let share = ((index + DIRECT_BLOCK_RAYS).min(set.rays) - index) as f64 / set.rays as f64;
    let nb = scene.acoustics.n_bands;
    // Scratch on the stack for the usual band counts (once a block: no allocation per ray).
    const STACK_BANDS: usize = 64;
    if nb <= STACK_BANDS {
        let (mut deposit, mut gain, mut receiver_gain) = ([0.0f64; STACK_BANDS], [1.0f64; STACK_BANDS], [1.0f64; STACK_BANDS]);
        direct_deposits(scene, s, index, share, acc, buf, (&mut deposit[..nb], &mut gain[..nb], &mut receiver_gain[..nb]));
    } else {
        let (mut deposit, mut gain, mut receiver_gain) = (vec![0.0; nb], vec![1.0; nb], vec![1.0; nb]);
        direct_deposits(scene, s, index, share, acc, buf, (&mut deposit, &mut gain, &mut receiver_gain));
    }
}

/// The deposits of [`direct_share`]: `share` of source `s`'s direct sound at every receiver;
/// `scratch` is (deposit, source gain, receiver gain), one value a band each.
#[allow(clippy::too_many_arguments)]
fn direct_deposits(scene: &Scene, s: usize, index: u64, share: f64, acc: &Accumulator, buf: &mut Deposits, scratch: (&mut [f64], &mut [f64], &mut [f64])) {
    let (deposit, gain, receiver_gain) = scratch;
    let set = scene.settings;
    let lay = &scene.layout;
    let nb = deposit.len();
    let radius = scene.receivers.radius_m;
    let src = &scene.sources[s];
    for (r, c) in scene.receivers.centres.iter().enumerate() {
        let receiver_key = set.first_receiver + r as u64;
        let to = *c - src.position;
        let d = to.length();
        if d > 0.0 {
            src.directivity.gains(to / d, gain);
        } else {
            gain.fill(1.0);
        }
        if gain.iter().all(|&g| g == 0.0) {
            continue;
        }
        if d > radius {
            let ray = Ray::new(src.position.as_vec3(), to.as_vec3());
            if scene.bvh.occluded(&ray, 0.0, 1.0) {
                continue;
            }
        }
        if scene.covered.is_some_and(|c| c.covers(0, d / set.speed_of_sound_m_s)) {
            continue;
        }
        let Some(tb) = lay.time_bin(d / set.speed_of_sound_m_s) else { continue };
        let energy = src.power_w * share * ball_mean_inverse_square(d, radius);
        let (first_dir, n_dirs) = if d > radius { (lay.direction_bin(-to / d), 1) } else { (0, lay.n_directions()) };
        for b in 0..nb {
            deposit[b] = energy * gain[b];
        }
        // The air over the path (sound/air.rs: the kernel's factors; × 1 exactly without air).
        if scene.air {
            scene.air_lanes.attenuate(d, &mut deposit[..nb]);
        }
        for b in 0..nb {
            deposit[b] /= n_dirs as f64;
        }
        // The receiver's pattern towards the source (or its mean, for a source inside).
        if d > radius {
            scene.receivers.weigh(r, -to / d, deposit, receiver_gain);
        } else {
            scene.receivers.weigh_mean(r, deposit);
        }
        for dir in first_dir..first_dir + n_dirs {
            // Apart from the ray's own events (2 × segment, 2 × reflection + 1).
            let u = keyed_uniform(set.seed, s as u64, index, receiver_key, u64::MAX - dir as u64);
            acc.deposit(buf, lay.cell(r, tb, dir), deposit, u);
        }
    }
}
