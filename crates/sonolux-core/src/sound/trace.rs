//! The ray kernel of the sound tracer, and the exact direct sound of the rain estimator.

use std::f64::consts::PI;

use glam::DVec3;

use super::field::{Accumulator, Deposits};
use super::receivers::ball_mean_inverse_square;
use super::stats::{self, Escape, SoundStats};
use super::{Directivity, Estimator, Scene, SoundSource};
use crate::geometry::Ray;
use crate::rng::{keyed_uniform, Stream};
use crate::sampling::{cosine_hemisphere, uniform_cone, uniform_sphere, Frame};

/// A ray that reflects this often is stopped whatever its energy (a guard, not a setting).
const MAX_REFLECTIONS: u64 = 1_000_000;

/// The energy of one count of the field: small enough that a single ray's deposits keep their
/// precision (stochastic rounding keeps even smaller ones exact in expectation), large enough
/// that no bin can overflow: a bin's total never exceeds the total emitted energy times 16× the
/// largest geometric weight of a deposit, 4 · 3 / (4π r²).
pub(crate) fn quantum(sources: &[SoundSource], radius: f64, receiver_peak: f64) -> f64 {
    // A ray or a direct deposit carries at most `peak` times its even share (directivity),
    // and a receiver's pattern multiplies it by at most `receiver_peak` (≥ 1).
    let total: f64 = sources.iter().map(|s| s.power_w * s.directivity.peak()).sum::<f64>() * receiver_peak;
    let largest_weight = 4.0 * 3.0 / (4.0 * PI * radius * radius);
    total * largest_weight * 16.0 / 2f64.powi(63)
}

/// What one worker thread owns while it traces: its statistics, its batch of deposits and the
/// scratch of a ray, sized once for the bake's bands and receivers (no allocation per ray).
pub(crate) struct Worker {
    pub stats: SoundStats,
    pub deposits: Deposits,
    /// One entry a receiver, for [`super::Receivers::crossings`].
    stamp: Vec<u64>,
    /// Per band: the ray's energy relative to its share, and a deposit being built.
    energy: Vec<f64>,
    deposit: Vec<f64>,
    /// Per band: a receiver pattern's gains.
    gain: Vec<f64>,
    /// Per kind of tally and band, `[kind * bands + band]`: the ray's energy balance.
    tally: Vec<f64>,
    /// Per band, with level of detail: Rindel's K at a reflection, and the scattering s' it gives.
    shares: Vec<f64>,
    scattering: Vec<f64>,
    /// Per band: a surface's absorption at the angle a ray meets it (locally reacting walls).
    absorption: Vec<f64>,
}

impl Worker {
    pub fn new(n_bands: usize, n_receivers: usize) -> Worker {
        Worker {
            stats: SoundStats::new(n_bands),
            deposits: Deposits::new(),
            stamp: vec![0; n_receivers],
            energy: vec![0.0; n_bands],
            deposit: vec![0.0; n_bands],
            gain: vec![0.0; n_bands],
            tally: vec![0.0; stats::KINDS * n_bands],
            shares: vec![0.0; n_bands],
            scattering: vec![0.0; n_bands],
            absorption: vec![0.0; n_bands],
        }
    }
}

/// The first direction of ray `index`, and the ray's share of the source's energy; `weights`
/// receives the ray's energy per band relative to that share: 1 for the uniform emitters, the
/// importance weight g_b / (4π p) for a tabulated pattern (mean 1 in every band).
fn emit(source: &SoundSource, rays: u64, rng: &mut Stream, weights: &mut [f64]) -> (DVec3, f64) {
    let dir = match &source.directivity {
        Directivity::Omni => {
            weights.fill(1.0);
            uniform_sphere(rng.uniform(), rng.uniform())
        }
        Directivity::Cone { axis, cos_half_angle } => {
            weights.fill(1.0);
            uniform_cone(&Frame::from_normal(*axis), *cos_half_angle, rng.uniform(), rng.uniform())
        }
        Directivity::Pattern(p) => p.sample(rng.uniform(), rng.uniform(), rng.uniform(), weights),
    };
    (dir, source.power_w / rays as f64)
}

/// Traces ray `index` of source `s` to its end, depositing into `acc` (through the worker's
/// batch, flushed by the caller) and tallying into the worker's statistics.
pub(crate) fn trace_ray(scene: &Scene, s: usize, index: u64, acc: &Accumulator, w: &mut Worker) {
    let set = scene.settings;
    let lay = &scene.layout;
    let nb = scene.acoustics.n_bands;
    let air = &set.air_attenuation_per_m[..nb];
    let Worker { stats: st, deposits: buf, stamp, energy, deposit, gain, tally, shares, scattering, absorption } = w;
    let mut rng = Stream::new(set.seed, s as u64, index);
    // Energy per band relative to the ray's share; the ray stops when all are below `floor`.
    let e = &mut energy[..nb];
    let (mut dir, share) = emit(&scene.sources[s], set.rays, &mut rng, e);
    let mut pos = scene.sources[s].position;
    let deposit = &mut deposit[..nb];
    let floor = 10f64.powf(-set.energy_drop_db / 10.0);
    let max_path = set.max_time_s * set.speed_of_sound_m_s;
    let mut path = 0.0f64;
    // Distance travelled since the last diffuse reflection (or the source): the radius of the
    // wavefront the ray belongs to, whose centre is the (image) source it comes from.
    let mut wave_radius = 0.0f64;
    let mut reflections = 0u64;
    // Segments of this ray so far: with the reflections, the key of each deposit's rounding.
    let mut ray_segments = 0u64;
    let first_receiver = set.first_receiver;
    // Free paths (surface to surface) of this ray: their sum and sum of squares.
    let (mut free_n, mut free_sum, mut free_sq) = (0u64, 0.0f64, 0.0f64);
    // Whether the spheres collect this segment: always in paper mode; in rain mode only after a
    // specular reflection (direct sound and diffuse reflections are handled exactly).
    let mut spheres = !set.estimator.rains();
    // Whether every reflection so far was specular: such segments may be the image sources'.
    let mut specular_only = true;
    let radius = scene.receivers.radius_m;
    let sphere_volume = 4.0 / 3.0 * PI * radius.powi(3);
    // This ray's energy tallies (in units of its share), summed here and added to the
    // fixed-point statistics once at the end: per segment that conversion would cost more than
    // the tracing.
    let tally = &mut tally[..stats::KINDS * nb];
    tally.fill(0.0);
    tally[stats::EMITTED * nb..(stats::EMITTED + 1) * nb].copy_from_slice(e);
    st.rays += 1;
    if set.estimator.rains() {
        direct_share(scene, s, index, acc, buf);
    }
    // With level of detail, the surface a specular bounce will meet is found at the reflection
    // (its distance is the leg d₂ of Rindel's K) and kept for the next segment.
    let mut found_next: Option<Option<(f64, usize, DVec3)>> = None;
    loop {
        // Find the nearest surface along the ray.
        let hit = found_next.take().unwrap_or_else(|| scene.surfaces.nearest(pos, dir));
        let length = hit.map_or(f64::INFINITY, |h| h.0);
        st.segments += 1;
        ray_segments += 1;

        // Deposit into the receiver spheres this segment crosses.
        if spheres {
            let seg_id = st.segments;
            scene.receivers.crossings(pos, dir, length, stamp, seg_id, |c| {
                // The wavefront reaches the sphere's centre at its distance from the image
                // source, not where this ray passes nearest: exact times for specular paths.
                let to_centre = ((wave_radius + c.t_nearest).powi(2) + c.miss2).sqrt() - wave_radius;
                let time_s = (path + to_centre) / set.speed_of_sound_m_s;
                if specular_only && scene.covered.is_some_and(|c| c.covers(reflections, time_s)) {
                    return;
                }
                let Some(tb) = lay.time_bin(time_s) else { return };
                let weight = share * c.chord / sphere_volume;
                if scene.air {
                    for b in 0..nb {
                        deposit[b] = e[b] * weight * (-air[b] * to_centre).exp();
                    }
                } else {
                    for b in 0..nb {
                        deposit[b] = e[b] * weight;
                    }
                }
                scene.receivers.weigh(c.receiver as usize, -dir, &mut deposit[..nb], gain);
                let base = lay.index(c.receiver as usize, tb, lay.direction_bin(-dir));
                let u = keyed_uniform(set.seed, s as u64, index, first_receiver + c.receiver as u64, 2 * ray_segments);
                acc.deposit(buf, base, &deposit[..nb], u);
                st.deposits += 1;
            });
        }

        let Some((length, tri, mut normal)) = hit else {
            // The ray left the scene: a leak, unless the scene is open on purpose.
            for b in 0..nb {
                tally[stats::ESCAPED * nb + b] += e[b];
            }
            st.add_escape(Escape { source: s as u32, ray: index, from: pos.to_array(), dir: dir.to_array() });
            break;
        };

        // Air absorption over the segment.
        if scene.air {
            for b in 0..nb {
                let kept = e[b] * (-air[b] * length).exp();
                tally[stats::ABSORBED_AIR * nb + b] += e[b] - kept;
                e[b] = kept;
            }
        }
        if reflections > 0 {
            free_n += 1;
            free_sum += length;
            free_sq += length * length;
        }
        path += length;
        wave_radius += length;
        if path > max_path || reflections >= MAX_REFLECTIONS {
            for b in 0..nb {
                tally[stats::REMAINING * nb + b] += e[b];
            }
            break;
        }

        // Surface: absorb, then reflect from the side the ray came from.
        reflections += 1;
        if normal.dot(dir) > 0.0 {
            normal = -normal;
        }
        let point = pos + dir * length;
        let material = scene.mesh.material[tri] as usize;
        let m = material * nb;
        // The absorption at this angle of incidence (sound/reflectance.rs): on incidence, so
        // it acts on the whole reflection, specular and scattered parts alike.
        let alpha = scene.walls.absorption(&scene.acoustics.absorption, m, -dir.dot(normal), &mut absorption[..nb]);
        let mut scat = &scene.acoustics.scattering[m..m + nb];
        for b in 0..nb {
            tally[stats::ABSORBED_SURFACES * nb + b] += e[b] * alpha[b];
            e[b] *= 1.0 - alpha[b];
        }
        let mut p_diffuse = scene.p_diffuse[material];
        if let Some(lod) = scene.lod {
            // Level of detail (early/lod.rs): the surface's scattering s and the panel's
            // diffraction combine to s' = 1 − (1 − s) K, K from the legs before (this segment)
            // and after (along the specular direction) the reflection, as the image sources do.
            let mirror = dir - 2.0 * dir.dot(normal) * normal;
            let next = scene.surfaces.nearest(point + normal * scene.epsilon, mirror);
            lod.specular_shares(tri, dir, length, next.map_or(f64::INFINITY, |h| h.0), &mut shares[..nb]);
            for b in 0..nb {
                scattering[b] = crate::early::lod::effective_scattering(scat[b], shares[b]);
            }
            scat = &scattering[..nb];
            p_diffuse = scat.iter().sum::<f64>() / nb as f64;
            found_next = Some(next);
        }

        // Rain: send the diffusely reflected energy to every receiver that sees this point.
        match set.estimator {
            Estimator::Rain => rain(scene, point, normal, path, e, scat, share, acc, buf, st, [s as u64, index, 2 * reflections + 1], (deposit, gain)),
            Estimator::Nee { connections } => super::nee::connect(scene, connections, point, normal, path, e, scat, share, acc, buf, st, [s as u64, index, 2 * reflections + 1], (deposit, gain)),
            Estimator::Paper => {}
        }

        // Choose the bounce by the mean scattering, re-weighting bands whose scattering differs.
        let diffuse = p_diffuse >= 1.0 || (p_diffuse > 0.0 && rng.uniform() < p_diffuse);
        if !scene.uniform_scattering || scene.lod.is_some() {
            for b in 0..nb {
                let w = if diffuse { scat[b] / p_diffuse } else { (1.0 - scat[b]) / (1.0 - p_diffuse) };
                let before = e[b];
                e[b] *= w;
                tally[stats::REWEIGHTED * nb + b] += e[b] - before;
            }
        }
        if diffuse {
            dir = cosine_hemisphere(&Frame::from_normal(normal), rng.uniform(), rng.uniform());
            wave_radius = 0.0;
            spheres = !set.estimator.rains();
            specular_only = false;
            found_next = None;
        } else {
            dir = dir - 2.0 * dir.dot(normal) * normal;
            spheres = true;
        }
        pos = point + normal * scene.epsilon;

        if e[..nb].iter().all(|&x| x < floor) {
            for b in 0..nb {
                tally[stats::REMAINING * nb + b] += e[b];
            }
            break;
        }
    }
    st.surface_hits += reflections;
    st.max_reflections = st.max_reflections.max(reflections);
    st.add_free_paths(free_n, free_sum, free_sq);
    for (kind, t) in tally.chunks(nb).enumerate() {
        for b in 0..nb {
            st.add_energy(kind, b, t[b] * share);
        }
    }
}

/// Next-event estimation at a reflection: the diffusely scattered part s·E leaves the point as
/// a Lambert source, so a receiver at distance d and angle θ from the normal receives
/// s·E·cos θ / (π d²) per unit area, taken here as the mean over its sphere, 4 cos θ ×
/// [`ball_mean_inverse_square`], and attenuated by the air on the way.
#[allow(clippy::too_many_arguments)]
/// `scratch` is the worker's (deposit, receiver gain), one value a band each; `key` is
/// (source, ray, event), the rounding's key with the receiver.
fn rain(scene: &Scene, point: DVec3, normal: DVec3, path: f64, e: &[f64], scat: &[f64], share: f64, acc: &Accumulator, buf: &mut Deposits, st: &mut SoundStats, key: [u64; 3], scratch: (&mut [f64], &mut [f64])) {
    let (deposit, gain) = scratch;
    for r in 0..scene.receivers.centres.len() {
        connect(scene, r, 1.0, point, normal, path, e, scat, share, acc, buf, st, key, (&mut *deposit, &mut *gain));
    }
}

/// One next-event connection of the rain and nee estimators: the diffusely reflected energy at
/// `point` sent to receiver `r` (Lambert's cosine, the sphere's mean 1/(4πd²), air, the
/// receiver's pattern) with an extra `weight` (1 for rain; 1/(M p) for a sampled receiver),
/// if the receiver is in front of the surface and sees the point.
#[allow(clippy::too_many_arguments)]
pub(crate) fn connect(scene: &Scene, r: usize, weight: f64, point: DVec3, normal: DVec3, path: f64, e: &[f64], scat: &[f64], share: f64, acc: &Accumulator, buf: &mut Deposits, st: &mut SoundStats, key: [u64; 3], scratch: (&mut [f64], &mut [f64])) {
    let (deposit, gain) = scratch;
    let set = scene.settings;
    let lay = &scene.layout;
    let nb = e.len();
    let c = scene.receivers.centres[r];
    let to = c - point;
    let d = to.length();
    let cos = normal.dot(to) / d;
    if !(cos > 0.0) {
        return;
    }
    let Some(tb) = lay.time_bin((path + d) / set.speed_of_sound_m_s) else { return };
    if !scene.convex {
        let from = point + normal * scene.epsilon;
        let ray = Ray::new(from.as_vec3(), (c - from).as_vec3());
        st.shadow_rays += 1;
        if scene.bvh.occluded(&ray, 0.0, 1.0) {
            return;
        }
    }
    // weight × share: the same bits as share alone for rain's weight 1.
    let g = weight * share * 4.0 * cos * ball_mean_inverse_square(d, scene.receivers.radius_m);
    for b in 0..nb {
        deposit[b] = e[b] * scat[b] * g * (-set.air_attenuation_per_m[b] * d).exp();
    }
    scene.receivers.weigh(r, -to / d, &mut deposit[..nb], gain);
    let u = keyed_uniform(set.seed, key[0], key[1], set.first_receiver + r as u64, key[2]);
    acc.deposit(buf, lay.index(r, tb, lay.direction_bin(-to / d)), &deposit[..nb], u);
    st.deposits += 1;
}

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
            deposit[b] = energy * gain[b] * (-set.air_attenuation_per_m[b] * d).exp() / n_dirs as f64;
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
            acc.deposit(buf, lay.index(r, tb, dir), deposit, u);
        }
    }
}
