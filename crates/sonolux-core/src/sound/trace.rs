//! The ray kernel of the sound tracer (the rain estimator's exact direct sound: sound/direct.rs).

use std::f64::consts::PI;

use glam::DVec3;

use super::field::{Accumulator, Deposits};
use super::stats::{self, Escape, SoundStats};
use super::{bounce, Estimator, Scene};
use super::emit::emit;
use super::leave::{leave, on_surface};
#[cfg(target_arch = "x86_64")]
use super::nearest::Inlined;
use super::nearest::{Called, Nearest, SurfaceHit};
use crate::rng::{keyed_uniform_of_ray, ray_key, Stream};
use crate::sampling::{cosine_hemisphere, Frame};

/// A ray that reflects this often is stopped whatever its energy (a guard, not a setting).
const MAX_REFLECTIONS: u64 = 1_000_000;

/// A ray's values per band: an array for the band counts the kernel is compiled for (held in the ray
/// itself, its length known to the compiler: no pointer to follow, no bounds check), a `Vec` for any other.
trait Bands: AsRef<[f64]> + AsMut<[f64]> {
    fn zeros(n_bands: usize) -> Self;
}

impl<const N: usize> Bands for [f64; N] {
    #[inline(always)]
    fn zeros(_: usize) -> Self {
        [0.0; N]
    }
}

impl Bands for Vec<f64> {
    fn zeros(n_bands: usize) -> Self {
        vec![0.0; n_bands]
    }
}

/// A ray being traced: everything that carries from one of its segments to the next. A batch of rays
/// reuses one (no allocation per ray; several in flight a worker measured no faster: docs/bvh-measured.md).
struct RayState<B: Bands> {
    source: usize,
    index: u64,
    /// [`ray_key`] of (seed, source, index): the deposits' rounding keys start from it.
    key: u64,
    rng: Stream,
    pos: DVec3,
    dir: DVec3,
    /// The ray's share of its source's energy (J): `energy` and `tally` are relative to it.
    share: f64,
    /// Distance travelled since the source.
    path: f64,
    /// Distance travelled since the last diffuse reflection (or the source): the radius of the
    /// wavefront the ray belongs to, whose centre is the (image) source it comes from.
    wave_radius: f64,
    reflections: u64,
    /// Segments of this ray so far: with the reflections, the key of each deposit's rounding.
    segments: u64,
    /// Free paths (surface to surface) of this ray: their number, sum and sum of squares.
    free_n: u64,
    free_sum: f64,
    free_sq: f64,
    /// Whether the spheres collect this segment: always in paper mode; in rain mode only after
    /// a specular reflection (direct sound and diffuse reflections are handled exactly).
    spheres: bool,
    /// Whether every reflection so far was specular: such segments may be the image sources'.
    specular_only: bool,
    /// The hybrid's early connections ([`super::nee::EarlyConnections`]): after a diffuse
    /// bounce, the spheres skip this segment's deposits arriving before this time (s), which
    /// the connections at the reflection counted; 0 otherwise (nothing skipped).
    connected_until_s: f64,
    /// With level of detail, the surface a specular bounce will meet, found at the reflection
    /// (its distance is the leg d₂ of Rindel's K) and kept for the next segment.
    next_known: bool,
    next: SurfaceHit,
    /// The pairs of parallel planes (sound/grazing.rs) whose planes the ray has met, a bit a pair.
    pairs_met: u32,
    /// Per band: the energy relative to `share`; the ray stops when all are below the floor.
    energy: B,
    /// When the bands scatter unlike ([`bounce::hero_sampled`]): the ray's hero band, and per
    /// band its bounces' product of probabilities over their mean (sound/bounce.rs).
    hero: usize,
    products: B,
    /// Per kind of tally ([`stats::EMITTED`]…) and band: the ray's energy balance (in units
    /// of its share), summed here and added to the fixed-point statistics once at its end: per
    /// segment that conversion would cost more than the tracing.
    tally: [B; stats::KINDS],
}

impl<B: Bands> RayState<B> {
    fn new(n_bands: usize) -> RayState<B> {
        RayState {
            source: 0, index: 0, key: 0, rng: Stream::new(0, 0, 0), pos: DVec3::ZERO, dir: DVec3::X,
            share: 0.0, path: 0.0, wave_radius: 0.0, reflections: 0, segments: 0,
            free_n: 0, free_sum: 0.0, free_sq: 0.0,
            spheres: false, specular_only: true, connected_until_s: 0.0, next_known: false, next: None, pairs_met: 0,
            energy: B::zeros(n_bands),
            hero: 0,
            products: B::zeros(n_bands),
            tally: std::array::from_fn(|_| B::zeros(n_bands)),
        }
    }
}

/// A worker's scratch, shared by its rays (one segment is traced at a time), sized once.
pub(super) struct Scratch {
    /// One entry a receiver, for [`super::Receivers::crossings`].
    stamp: Vec<u64>,
    /// Per band: a deposit being built, and a receiver pattern's gains.
    deposit: Vec<f64>,
    gain: Vec<f64>,
    /// Per band, with level of detail: Rindel's K at a reflection, and the scattering s' it gives.
    shares: Vec<f64>,
    scattering: Vec<f64>,
    /// Per band: a described surface's scattering at the angle a ray meets it (scattering.rs).
    by_angle: Vec<f64>,
    /// Per band: a surface's absorption at the angle a ray meets it (locally reacting walls), and 1 − that.
    absorption: Vec<f64>,
    kept: Vec<f64>,
    pub(super) tail: Option<super::tail::RayTail>, // a progressive bake's late contributions (tail.rs)
}

/// What one worker thread owns while it traces: its statistics, its batch of deposits and its
/// scratch, sized once for the bake's bands and receivers.
pub(crate) struct Worker {
    pub stats: SoundStats,
    pub deposits: Deposits,
    pub(super) scratch: Scratch,
}

impl Worker {
    pub fn new(n_bands: usize, n_receivers: usize) -> Worker {
        Worker {
            stats: SoundStats::new(n_bands),
            deposits: Deposits::new(),
            scratch: Scratch {
                stamp: vec![0; n_receivers],
                deposit: vec![0.0; n_bands],
                gain: vec![0.0; n_bands],
                shares: vec![0.0; n_bands],
                scattering: vec![0.0; n_bands],
                by_angle: vec![0.0; n_bands],
                absorption: vec![0.0; n_bands],
                kept: vec![0.0; n_bands],
                tail: None,
            },
        }
    }
}

/// The bake's values every segment reads, computed once a batch of rays. `NB` is the number
/// of bands when the kernel was compiled for it (0: any, read from the scene): with the count
/// known to the compiler every band loop is unrolled and vectorised and its bounds checks go
/// (paper-large, one receiver, seven octaves: 578 → 506 instructions a segment, callgrind).
struct Limits<const NB: usize> {
    n_bands: usize,
    /// A ray stops when every band's relative energy is below this.
    floor: f64,
    max_path_m: f64,
    sphere_volume_m3: f64,
    /// The centre of the bake's one receiver (None: more or none), and its radius squared.
    one_receiver: Option<DVec3>,
    radius2_m2: f64,
}

impl<const NB: usize> Limits<NB> {
    fn new(scene: &Scene) -> Limits<NB> {
        let set = scene.settings;
        debug_assert!(NB == 0 || NB == scene.acoustics.n_bands);
        Limits {
            n_bands: scene.acoustics.n_bands,
            floor: 10f64.powf(-set.energy_drop_db / 10.0),
            max_path_m: set.max_time_s * set.speed_of_sound_m_s,
            sphere_volume_m3: 4.0 / 3.0 * PI * scene.receivers.radius_m.powi(3),
            one_receiver: (scene.receivers.centres.len() == 1).then(|| scene.receivers.centres[0]),
            radius2_m2: scene.receivers.radius_m * scene.receivers.radius_m,
        }
    }

    /// The number of bands: a constant in a kernel compiled for one count.
    #[inline(always)]
    fn nb(&self) -> usize {
        if NB > 0 { NB } else { self.n_bands }
    }
}

/// Traces the rays `jobs` names, (source, ray index) each, to their ends, depositing into
/// `acc` (through the worker's batch, flushed by the caller) and tallying into the worker's
/// statistics, one ray after another. Which rays a worker traces, and in what order, changes no
/// bit: every random number is the ray's own (its stream, or keyed by the ray and the event),
/// every per-ray sum is summed by the ray alone, and the field and the statistics add integers
/// (fixed point), whose sums do not depend on order.
pub(crate) fn trace_rays(scene: &Scene, jobs: impl Iterator<Item = (usize, u64)>, acc: &Accumulator, w: &mut Worker) {
    // Where the BVH runs on AVX2, the whole kernel is compiled for AVX2 too (the same IEEE
    // operations, no fused multiply-add, so the same bits): on a mesh the query is inlined into
    // it (no call, and no spilling of every live value around one, a segment: docs/bvh.md,
    // "Leaving a surface"); in a convex room traced through its planes the planes' query, the
    // band loops and the sphere tests compiled into it take AVX2's lanes and three-operand
    // forms: −4 % a segment on paper-large's grid (docs/convex.md, session 13).
    #[cfg(target_arch = "x86_64")]
    if let Some(v3) = scene.bvh.avx2() {
        let planes = scene.surfaces.traces_planes();
        return if planes { v3.vectorize(Kernel { scene, jobs, acc, w, q: Called }) } else { v3.vectorize(Kernel { scene, jobs, acc, w, q: Inlined(v3) }) };
    }
    trace_rays_by_bands(scene, jobs, acc, w, Called)
}

/// [`trace_rays`]' arguments, handed to `V3::vectorize`: a struct whose `call` is always
/// inlined (not a closure, which the compiler may keep apart and outside the AVX2 features,
/// leaving every SIMD operation of the inlined query a call).
#[cfg(target_arch = "x86_64")]
struct Kernel<'s, 'a, 'w, I, Q> {
    scene: &'s Scene<'a>,
    jobs: I,
    acc: &'s Accumulator,
    w: &'w mut Worker,
    q: Q,
}

#[cfg(target_arch = "x86_64")]
impl<I: Iterator<Item = (usize, u64)>, Q: Nearest> pulp::NullaryFnOnce for Kernel<'_, '_, '_, I, Q> {
    type Output = ();
    #[inline(always)]
    fn call(self) {
        trace_rays_by_bands(self.scene, self.jobs, self.acc, self.w, self.q);
    }
}

/// [`trace_rays`]' kernel for the scene's band count and plainness.
#[inline(always)]
fn trace_rays_by_bands<Q: Nearest>(scene: &Scene, jobs: impl Iterator<Item = (usize, u64)>, acc: &Accumulator, w: &mut Worker, q: Q) {
    // The kernel compiled for the usual band counts (octaves 125 Hz–4 kHz or –8 kHz, the
    // default third octaves), any other count read at run time: the same operations in the
    // same order, so the same bits.
    // A plain bake (below) gets a kernel without the branches it would never take.
    match (scene.acoustics.n_bands, plain(scene)) {
        (6, true) => trace_rays_for::<6, [f64; 6], true, Q>(scene, jobs, acc, w, q),
        (6, false) => trace_rays_for::<6, [f64; 6], false, Q>(scene, jobs, acc, w, q),
        (7, true) => trace_rays_for::<7, [f64; 7], true, Q>(scene, jobs, acc, w, q),
        (7, false) => trace_rays_for::<7, [f64; 7], false, Q>(scene, jobs, acc, w, q),
        (18, true) => trace_rays_for::<18, [f64; 18], true, Q>(scene, jobs, acc, w, q),
        (18, false) => trace_rays_for::<18, [f64; 18], false, Q>(scene, jobs, acc, w, q),
        _ => trace_rays_for::<0, Vec<f64>, false, Q>(scene, jobs, acc, w, q),
    }
}

/// Whether the bake is plain: the paper estimator (every segment collects into the spheres,
/// no connections), no level of detail, no specular paths counted elsewhere, every material
/// scattering its bands alike (no re-weighting) and the random-incidence walls. A kernel
/// compiled for it (`PLAIN`) skips those tests, and takes the same branches.
fn plain(scene: &Scene) -> bool {
    matches!(scene.settings.estimator, Estimator::Paper) && scene.lod.is_none() && scene.covered.is_none() && scene.uniform_scattering && scene.walls.random_incidence() && scene.by_angle.is_none() && scene.early_connections.is_none() && scene.grazing.is_none()
}

/// [`trace_rays`] for `NB` bands (0: any), the ray's band values held in `B` (`[f64; NB]`,
/// or a `Vec` for any count); `PLAIN` for a [`plain`] bake.
#[inline(always)]
fn trace_rays_for<const NB: usize, B: Bands, const PLAIN: bool, Q: Nearest>(scene: &Scene, jobs: impl Iterator<Item = (usize, u64)>, acc: &Accumulator, w: &mut Worker, q: Q) {
    debug_assert!(!PLAIN || plain(scene));
    let limits = Limits::<NB>::new(scene);
    let Worker { stats: st, deposits: buf, scratch } = w;
    let mut ray = RayState::<B>::new(limits.nb());
    for (s, index) in jobs {
        start_ray(scene, &limits, s, index, &mut ray, acc, st, buf);
        loop {
            let hit = find_surface::<B, PLAIN, Q>(scene, &mut ray, q);
            if !advance::<NB, B, PLAIN>(scene, &limits, &mut ray, hit, acc, scratch, st, buf) {
                break;
            }
        }
        finish_ray(&ray, &limits, st);
        if let Some(t) = &mut scratch.tail { t.end_ray(s, index) } // tail.rs: off unless asked for
    }
}

/// Starts ray `index` of source `s` in `ray`: its stream, first direction and energy; the
/// rains' share of the exact direct sound when the ray starts a block.
#[allow(clippy::too_many_arguments)]
fn start_ray<const NB: usize, B: Bands>(scene: &Scene, limits: &Limits<NB>, s: usize, index: u64, ray: &mut RayState<B>, acc: &Accumulator, st: &mut SoundStats, buf: &mut Deposits) {
    let set = scene.settings;
    let nb = limits.nb();
    ray.rng = Stream::new(set.seed, s as u64, index);
    let (dir, share) = emit(&scene.sources[s], set.rays, &mut ray.rng, &mut ray.energy.as_mut()[..nb]);
    ray.source = s;
    ray.index = index;
    ray.key = ray_key(set.seed, s as u64, index);
    if bounce::hero_sampled(scene) {
        ray.hero = bounce::hero_band(ray.key, nb);
        ray.products.as_mut()[..nb].fill(1.0);
    }
    ray.dir = dir;
    ray.share = share;
    ray.pos = scene.sources[s].position;
    ray.path = 0.0;
    ray.wave_radius = 0.0;
    ray.reflections = 0;
    ray.segments = 0;
    (ray.free_n, ray.free_sum, ray.free_sq) = (0, 0.0, 0.0);
    ray.spheres = !set.estimator.rains();
    ray.specular_only = true;
    ray.connected_until_s = 0.0;
    ray.next_known = false;
    ray.pairs_met = 0;
    for t in &mut ray.tally {
        t.as_mut()[..nb].fill(0.0);
    }
    ray.tally[stats::EMITTED].as_mut()[..nb].copy_from_slice(&ray.energy.as_ref()[..nb]);
    st.rays += 1;
    if set.estimator.rains() {
        super::direct::direct_share(scene, s, index, acc, buf);
    }
}

/// Find the nearest surface along the ray (or the one level of detail found already).
#[inline(always)]
fn find_surface<B: Bands, const PLAIN: bool, Q: Nearest>(scene: &Scene, ray: &mut RayState<B>, q: Q) -> SurfaceHit {
    if !PLAIN && ray.next_known {
        ray.next_known = false;
        return ray.next;
    }
    q.nearest(scene, ray.pos, ray.dir)
}

/// One segment of `ray`, up to the nearest surface `hit`: deposit into the receivers it
/// crosses, absorb in the air, then at the surface absorb, connect (rain, nee) and choose the
/// bounce. Returns whether the ray goes on.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn advance<const NB: usize, B: Bands, const PLAIN: bool>(scene: &Scene, limits: &Limits<NB>, ray: &mut RayState<B>, hit: SurfaceHit, acc: &Accumulator, scratch: &mut Scratch, st: &mut SoundStats, buf: &mut Deposits) -> bool {
    let set = scene.settings;
    let nb = limits.nb();
    let length = hit.map_or(f64::INFINITY, |h| h.0);
    st.segments += 1;
    ray.segments += 1;

    // Deposit into the receiver spheres this segment crosses, the segments that pass beside
    // their box rejected first (most of them with one receiver), as `crossings` would: before
    // the deposit's closure is built.
    let reaches = match limits.one_receiver {
        Some(centre) => crosses_the_one(scene, limits, centre, ray.pos, ray.dir, length),
        None => !beside_receivers(scene, ray.pos, ray.dir, length),
    };
    if (PLAIN || ray.spheres) && reaches {
        deposit_crossings::<NB, B, PLAIN>(scene, limits, ray, length, acc, scratch, st, buf);
    }

    let Some((length, tri, normal)) = hit else {
        // The ray left the scene: a leak, unless the scene is open on purpose.
        let (e, escaped) = (&ray.energy.as_ref()[..nb], &mut ray.tally[stats::ESCAPED].as_mut()[..nb]);
        for b in 0..nb {
            escaped[b] += e[b];
        }
        st.add_escape(Escape { source: ray.source as u32, ray: ray.index, from: ray.pos.to_array(), dir: ray.dir.to_array() });
        return false;
    };

    // Air absorption over the segment.
    if scene.air {
        scene.air_lanes.absorb(length, &mut ray.energy.as_mut()[..nb], &mut ray.tally[stats::ABSORBED_AIR].as_mut()[..nb]);
    }
    if let Some(g) = scene.grazing.filter(|_| !PLAIN) {
        g.attenuate(ray.dir, length, &mut ray.energy.as_mut()[..nb], &mut ray.tally[stats::ABSORBED_SURFACES].as_mut()[..nb]);
    }
    if ray.reflections > 0 {
        ray.free_n += 1;
        ray.free_sum += length;
        ray.free_sq += length * length;
    }
    ray.path += length;
    ray.wave_radius += length;
    if ray.path > limits.max_path_m || ray.reflections >= MAX_REFLECTIONS {
        keep_remaining(ray, nb);
        return false;
    }

    // Surface: absorb, then reflect from the side the ray came from (`normal` faces it).
    ray.reflections += 1;
    let point = on_surface(scene, ray.pos + ray.dir * length, normal, tri);
    let material = super::leave::material(scene, tri);
    let m = material * nb;
    if let Some(g) = scene.grazing.filter(|_| !PLAIN) {
        // The grazing mode's coupling to the source, at the ray's first meeting with a pair.
        g.meet(point, normal, ray.dir, ray.specular_only, scene.sources[ray.source].position, &mut ray.pairs_met, &mut ray.energy.as_mut()[..nb], &mut ray.tally[stats::REWEIGHTED].as_mut()[..nb]);
    }
    absorb_at_surface(scene, m, point, ray.dir, normal, &mut ray.energy.as_mut()[..nb], &mut ray.tally[stats::ABSORBED_SURFACES].as_mut()[..nb], (&mut scratch.absorption[..nb], &mut scratch.kept[..nb]));
    let mut scat = &scene.acoustics.scattering[m..m + nb];
    let mut p_diffuse = scene.p_diffuse[material];
    if let Some(table) = scene.by_angle.filter(|_| !PLAIN) {
        // A described surface (a profile) scatters its s(θ) at this angle of incidence
        // (scattering.rs); level of detail below then adds the panel's diffraction to it.
        if table.scattering(material, -ray.dir.dot(normal), &mut scratch.by_angle[..nb]) {
            scat = &scratch.by_angle[..nb];
            p_diffuse = scat[0]; // used only when the bands scatter alike (bounce::alike)
        }
    }
    if let Some(lod) = scene.lod.filter(|_| !PLAIN) {
        // Level of detail (early/lod.rs): the surface's scattering s and the panel's
        // diffraction combine to s' = 1 − (1 − s) K, K from the legs before (this segment)
        // and after (along the specular direction) the reflection, as the image sources do.
        let mirror = ray.dir - 2.0 * ray.dir.dot(normal) * normal;
        let next = scene.surfaces.nearest_facing(leave(scene, point, normal, ray.pos), mirror);
        lod.specular_shares(tri, ray.dir, length, next.map_or(f64::INFINITY, |h| h.0), &mut scratch.shares[..nb]);
        for b in 0..nb {
            scratch.scattering[b] = crate::early::lod::effective_scattering(scat[b], scratch.shares[b]);
        }
        scat = &scratch.scattering[..nb];
        (ray.next_known, ray.next) = (true, next);
    }

    // Rain: send the diffusely reflected energy to every receiver that sees this point.
    if !PLAIN && !matches!(set.estimator, Estimator::Paper) {
        let (s, index, e) = (ray.source, ray.index, &ray.energy.as_ref()[..nb]);
        let key = [s as u64, index, 2 * ray.reflections + 1];
        let scratch_pair = (&mut scratch.deposit[..nb], &mut scratch.gain[..nb]);
        match set.estimator {
            Estimator::Rain => super::nee::rain(scene, point, normal, ray.path, e, scat, ray.share, acc, buf, st, key, scratch_pair),
            Estimator::Nee { connections } => super::nee::connect(scene, connections, point, normal, ray.path, e, scat, ray.share, acc, buf, st, key, scratch_pair, f64::INFINITY),
            Estimator::Paper => {}
        }
    }
    // The hybrid's early connections (sphere estimator): the same connection for the arrivals
    // before the window's end; none can arrive before it once the ray's path is past it.
    let early = scene.early_connections.filter(|_| !PLAIN && matches!(set.estimator, Estimator::Paper));
    if let Some(ec) = early.filter(|ec| ray.path < ec.until_s * set.speed_of_sound_m_s) {
        let key = [ray.source as u64, ray.index, 2 * ray.reflections + 1];
        let scratch_pair = (&mut scratch.deposit[..nb], &mut scratch.gain[..nb]);
        super::nee::connect(scene, ec.connections, point, normal, ray.path, &ray.energy.as_ref()[..nb], scat, ray.share, acc, buf, st, key, scratch_pair, ec.until_s);
    }

    // Choose the bounce: by the material's scattering when the bands scatter alike, else by
    // the ray's hero band's, the bands re-weighted (sound/bounce.rs).
    let diffuse = if !PLAIN && bounce::hero_sampled(scene) {
        let (e, reweighted) = (&mut ray.energy.as_mut()[..nb], &mut ray.tally[stats::REWEIGHTED].as_mut()[..nb]);
        bounce::hero(&mut ray.rng, ray.hero, scat, &mut ray.products.as_mut()[..nb], e, reweighted)
    } else {
        bounce::alike(&mut ray.rng, p_diffuse)
    };
    if diffuse {
        ray.dir = cosine_hemisphere(&Frame::from_normal(normal), ray.rng.uniform(), ray.rng.uniform());
        ray.wave_radius = 0.0;
        ray.spheres = !set.estimator.rains();
        ray.specular_only = false;
        ray.connected_until_s = early.map_or(0.0, |ec| ec.until_s);
        ray.next_known = false;
    } else {
        ray.dir = ray.dir - 2.0 * ray.dir.dot(normal) * normal;
        ray.spheres = true;
        ray.connected_until_s = 0.0;
    }
    ray.pos = leave(scene, point, normal, ray.pos);

    if ray.energy.as_ref()[..nb].iter().all(|&x| x < limits.floor) {
        keep_remaining(ray, nb);
        return false;
    }
    true
}

/// Deposits into every receiver sphere the ray's current segment (of `length`, from `ray.pos`
/// along `ray.dir`) crosses: energy × chord / sphere volume, at the time the wavefront reaches
/// the sphere's centre, attenuated by the air on the way to it, weighed by the receiver's pattern.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn deposit_crossings<const NB: usize, B: Bands, const PLAIN: bool>(scene: &Scene, limits: &Limits<NB>, ray: &RayState<B>, length: f64, acc: &Accumulator, scratch: &mut Scratch, st: &mut SoundStats, buf: &mut Deposits) {
    let set = scene.settings;
    let lay = &scene.layout;
    let nb = limits.nb();
    let (e, dir, share) = (&ray.energy.as_ref()[..nb], ray.dir, ray.share);
    let Scratch { stamp, deposit, gain, tail, .. } = scratch;
    let deposit = &mut deposit[..nb];
    let seg_id = st.segments;
    let mut deposits = 0u64;
    // Every deposit of a segment arrives from −dir: its direction bin (an atan2) is found at
    // the segment's first deposit and kept for the others.
    let mut direction = None;
    let profiled = scene.grazing.filter(|g| !PLAIN && g.profiled(dir, ray.pairs_met));
    let early_s = lay.early_s();
    scene.receivers.crossings(ray.pos, dir, length, stamp, seg_id, |c| {
        // The wavefront reaches the sphere's centre at its distance from the image source,
        // not where this ray passes nearest: exact times for specular paths.
        let to_centre = ((ray.wave_radius + c.t_nearest).powi(2) + c.miss2).sqrt() - ray.wave_radius;
        let time_s = (ray.path + to_centre) / set.speed_of_sound_m_s;
        if !PLAIN && ray.specular_only && scene.covered.is_some_and(|c| c.covers(ray.reflections, time_s)) {
            return;
        }
        // The leg from a diffuse reflection that the early connections counted.
        if !PLAIN && time_s < ray.connected_until_s {
            return;
        }
        let Some(tb) = lay.time_bin_after(time_s, early_s) else { return };
        let weight = share * c.chord / limits.sphere_volume_m3;
        if scene.air {
            // The air's factors land in `deposit` first (all bands at once: sound/air.rs).
            scene.air_lanes.factors(to_centre, deposit);
            for b in 0..nb {
                deposit[b] *= e[b] * weight;
            }
        } else {
            for b in 0..nb {
                deposit[b] = e[b] * weight;
            }
        }
        if let Some(g) = profiled {
            g.weigh(dir, ray.pairs_met, ray.pos + dir * c.t_nearest, &mut deposit[..nb]); // the grazing mode's profile
        }
        scene.receivers.weigh(c.receiver as usize, -dir, &mut deposit[..nb], gain);
        let cell = lay.cell(c.receiver as usize, tb, *direction.get_or_insert_with(|| lay.direction_bin(-dir)));
        let u = keyed_uniform_of_ray(ray.key, set.first_receiver + c.receiver as u64, 2 * ray.segments);
        acc.deposit(buf, cell, &deposit[..nb], u);
        if let Some(t) = tail.as_mut() { t.deposit(c.receiver, time_s, &deposit[..nb]) }
        deposits += 1;
    });
    st.deposits += deposits;
}

/// Whether the segment from `origin` along unit `dir` for `length` lies wholly beside the
/// receivers' box: [`super::Receivers::crossings`]' own first test, the same expression, so
/// that it rejects exactly the same segments. Its six outcomes are or-ed into one bit mask,
/// one branch: `any() || any()` branches on each axis, and which axis rejects a segment is as
/// good as random (0.6 mispredicted branches a segment with one receiver, cachegrind).
#[inline(always)]
fn beside_receivers(scene: &Scene, origin: DVec3, dir: DVec3, length: f64) -> bool {
    let (lo, hi) = (scene.receivers.lo, scene.receivers.hi);
    let end = origin + dir * length;
    ((origin.cmplt(lo) & end.cmplt(lo)).bitmask() | (origin.cmpgt(hi) & end.cmpgt(hi)).bitmask()) != 0
}

/// Whether the segment crosses the sphere of a bake's one receiver (at `centre`): the box test
/// and the sphere's chord test of [`super::Receivers::crossings`], the same expressions, so the
/// same answer, computed without a branch. Whether a segment passes beside the receiver's box
/// is as good as random, a crossing is rare (0.09 a ray in paper-large): one branch on the
/// crossing is predicted, a branch on the box was not.
#[inline(always)]
fn crosses_the_one<const NB: usize>(scene: &Scene, limits: &Limits<NB>, centre: DVec3, origin: DVec3, dir: DVec3, length: f64) -> bool {
    let beside = beside_receivers(scene, origin, dir, length);
    let r2 = limits.radius2_m2;
    let oc = centre - origin;
    let tc = oc.dot(dir);
    let d2 = oc.length_squared() - tc * tc;
    let half = (r2 - d2).sqrt();
    let (a, b) = ((tc - half).max(0.0), (tc + half).min(length));
    !beside & !(d2 >= r2) & (b > a)
}

/// The surface's absorption (material `m`'s first band index) at the angle the ray meets it
/// (sound/reflectance.rs): on incidence, so it acts on the whole reflection, specular and
/// scattered parts alike, what it takes tallied into `absorbed`; `scratch` two values a band.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn absorb_at_surface(scene: &Scene, m: usize, point: DVec3, dir: DVec3, normal: DVec3, e: &mut [f64], absorbed: &mut [f64], scratch: (&mut [f64], &mut [f64])) {
    let nb = e.len();
    let cos_incidence = -dir.dot(normal);
    let (alpha, kept) = match scene.by_angle {
        // A described surface absorbs its α(θ) (scattering.rs), whatever the wall model.
        Some(t) if t.absorption(m / nb, cos_incidence, scratch.0) => {
            for b in 0..nb {
                scratch.1[b] = 1.0 - scratch.0[b];
            }
            (&scratch.0[..nb], &scratch.1[..nb])
        }
        _ => scene.walls.absorption_and_kept(&scene.acoustics.absorption, m, cos_incidence, scratch.0, scratch.1),
    };
    let (alpha, kept) = (&alpha[..nb], &kept[..nb]);
    // A grazing mode's loss is taken along its path (grazing.rs), not at its pair's planes.
    let grazing = scene.grazing.and_then(|g| g.pair_limits(point, normal));
    for b in (0..nb).filter(|&b| grazing.is_none_or(|lim| cos_incidence >= lim[b])) {
        absorbed[b] += e[b] * alpha[b];
        e[b] *= kept[b];
    }
}

/// The ray stops with energy left: tallied as remaining.
fn keep_remaining<B: Bands>(ray: &mut RayState<B>, nb: usize) {
    let (e, remaining) = (&ray.energy.as_ref()[..nb], &mut ray.tally[stats::REMAINING].as_mut()[..nb]);
    for b in 0..nb {
        remaining[b] += e[b];
    }
}

/// Adds an ended ray's counts, free paths and energy balance to the worker's statistics.
/// A kind of tally the ray left at zero in every band (the air's without air, the
/// re-weighting's with uniform scattering, the escapes' in a closed room) is skipped: a zero
/// adds nothing to the fixed-point sum, so the bits are the same.
fn finish_ray<const NB: usize, B: Bands>(ray: &RayState<B>, limits: &Limits<NB>, st: &mut SoundStats) {
    let nb = limits.nb();
    st.surface_hits += ray.reflections;
    st.max_reflections = st.max_reflections.max(ray.reflections);
    st.add_free_paths(ray.free_n, ray.free_sum, ray.free_sq);
    for (kind, t) in ray.tally.iter().enumerate() {
        let t = &t.as_ref()[..nb];
        if t.iter().all(|&x| x == 0.0) {
            continue;
        }
        for b in 0..nb {
            st.add_energy(kind, b, t[b] * ray.share);
        }
    }
}
