//! The light tracer: particles leave the emitting triangles (cosine-distributed, RGB flux),
//! bounce by each material's optical properties (ideal diffuse, ideal specular, or glossy), end
//! by Russian roulette, and deposit the flux they carry on the patch where they land. Time is
//! ignored: this is the equilibrium of light, as the paper says.
//!
//! Besides the scene's Lambertian lights, [`trace_light_sources`] takes luminaires with an
//! intensity table, skies and the sun entering through windows ([`sources`]), glazing that
//! transmits a share of what lands on it straight through, and a virtual work plane that counts
//! the flux crossing it downwards ([`plane`]).
//!
//! It shares the BVH, the samplers, the random streams and the parallel driver with the sound
//! tracer; only the bounce and what is stored differ. Flux is summed in fixed point with atomic
//! adds, so a bake is the same bits on any number of threads.

pub mod patches;
pub mod plane;
pub mod sources;
pub mod table;

use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;

use crate::bvh::Bvh;
use crate::convex::{ConvexRoom, Surfaces};
use crate::error::CoreError;
use crate::mesh::Mesh;
use crate::parallel::{run_chunks, Progress};
use crate::rng::Stream;
use crate::sampling::{cosine_hemisphere, Discrete, Frame};
pub use patches::Patches;
pub use plane::WorkPlane;
pub use sources::LightSource;
pub use table::DirectionTable;

/// How each material reflects light: `rho` is the total reflectance per RGB channel, of which
/// the share `specular` leaves as a mirror (roughness 0) or glossy lobe (roughness > 0) and the
/// rest diffusely (Lambert).
#[derive(Clone, Debug)]
pub struct Optics {
    pub rho: Vec<[f64; 3]>,
    pub specular: Vec<f64>,
    pub roughness: Vec<f64>,
}

/// An emitting triangle, one-sided: it emits on the side of (b − a) × (c − a).
#[derive(Clone, Copy, Debug)]
pub struct Emitter {
    pub corners: [DVec3; 3],
    /// Radiant flux per channel, W.
    pub flux: [f64; 3],
}

#[derive(Clone, Debug)]
pub struct LightSettings {
    /// Particles in the whole bake, and the range of them this run traces (the sound tracer's
    /// names: a particle is a light ray).
    pub particles: u64,
    pub first_ray: u64,
    pub end_ray: u64,
    pub seed: u64,
    /// Worker threads, 0 = all cores, at most [`crate::sound::MAX_THREADS`].
    pub threads: usize,
    /// Particles bounce at most this often (a guard; Russian roulette ends them long before).
    pub max_bounces: u32,
}

impl LightSettings {
    /// Checks the counts and the range; called once, by [`trace_light`].
    pub fn validate(&self) -> Result<(), CoreError> {
        if !(self.first_ray < self.end_ray && self.end_ray <= self.particles) {
            return Err(CoreError::invalid("first_ray..end_ray", format!("{}..{} is not a non-empty part of 0..{}", self.first_ray, self.end_ray, self.particles)));
        }
        if self.threads > crate::sound::MAX_THREADS {
            return Err(CoreError::invalid("threads", format!("{} is more than {} (0 uses every core)", self.threads, crate::sound::MAX_THREADS)));
        }
        Ok(())
    }
}

/// Flux per patch and channel (W), how many particles landed on each, and the bake's tallies.
#[derive(Debug)]
pub struct LightResult {
    pub patches: Patches,
    pub flux: Vec<[f64; 3]>,
    pub hits: Vec<u64>,
    /// Flux crossing each work-plane cell downwards (W per channel; empty without a plane),
    /// and how many particle paths crossed it.
    pub plane_flux: Vec<[f64; 3]>,
    pub plane_hits: Vec<u64>,
    pub stats: LightStats,
    pub cancelled: bool,
}

/// Per channel, in W: emitted, absorbed by surfaces, escaped, and the net change from Russian
/// roulette (zero in expectation): emitted + roulette = absorbed + escaped, exactly.
#[derive(Clone, Debug, Default)]
pub struct LightStats {
    pub particles: u64,
    pub bounces: u64,
    pub escaped_particles: u64,
    pub emitted: [f64; 3],
    pub absorbed: [f64; 3],
    pub escaped: [f64; 3],
    pub roulette: [f64; 3],
}

/// What a scene's light comes from besides its materials: the sources, each material's
/// transmittance per channel (empty: nothing transmits; glazing passes this share straight
/// through, so reflectance + transmittance ≤ 1), and an optional work plane.
#[derive(Clone, Copy)]
pub struct Lighting<'a> {
    pub sources: &'a [LightSource],
    pub transmittance: &'a [[f64; 3]],
    pub work_plane: Option<&'a WorkPlane>,
}

/// Fixed point for flux: 2⁻⁵⁰ of the total emitted flux a count.
struct FluxSums {
    counts: Vec<AtomicU64>,
    hits: Vec<AtomicU64>,
    quantum: f64,
}

impl FluxSums {
    fn new(len: usize, quantum: f64) -> FluxSums {
        FluxSums { counts: (0..len * 3).map(|_| AtomicU64::new(0)).collect(), hits: (0..len).map(|_| AtomicU64::new(0)).collect(), quantum }
    }

    fn flux(&self) -> Vec<[f64; 3]> {
        (0..self.hits.len()).map(|p| std::array::from_fn(|c| self.counts[p * 3 + c].load(Ordering::Relaxed) as f64 * self.quantum)).collect()
    }

    fn add(&self, patch: usize, flux: [f64; 3], rng: &mut Stream) {
        let u = rng.uniform();
        for c in 0..3 {
            let x = flux[c] / self.quantum;
            let add = x.floor() as u64 + u64::from(u < x - x.floor());
            self.counts[patch * 3 + c].fetch_add(add, Ordering::Relaxed);
        }
        self.hits[patch].fetch_add(1, Ordering::Relaxed);
    }
}

/// Stats in fixed point (2⁻⁶⁴ W a count) so that they too are the same bits for any threads.
#[derive(Default)]
struct Tally {
    particles: u64,
    bounces: u64,
    escaped_particles: u64,
    energy: [[i128; 3]; 4],
}

const EMITTED: usize = 0;
const ABSORBED: usize = 1;
const ESCAPED: usize = 2;
const ROULETTE: usize = 3;
const TALLY_QUANTUM: f64 = 1.0 / 18_446_744_073_709_551_616.0;

impl Tally {
    fn add(&mut self, kind: usize, v: [f64; 3]) {
        for c in 0..3 {
            self.energy[kind][c] += (v[c] / TALLY_QUANTUM).round() as i128;
        }
    }
}

/// Traces the particles the settings name from Lambertian emitters and returns the flux on
/// every patch.
pub fn trace_light(
    mesh: &Mesh,
    bvh: &Bvh,
    optics: &Optics,
    emitters: &[Emitter],
    patches: Patches,
    settings: &LightSettings,
    progress: impl FnMut(&Progress) -> bool,
) -> Result<LightResult, CoreError> {
    let sources: Vec<LightSource> = emitters.iter().map(|e| LightSource::Lambert { corners: e.corners, flux: e.flux }).collect();
    let lighting = Lighting { sources: &sources, transmittance: &[], work_plane: None };
    trace_light_sources(mesh, bvh, optics, lighting, patches, settings, progress)
}

/// Traces the particles the settings name from any kind of source, through glazing, and
/// returns the flux on every patch and work-plane cell.
pub fn trace_light_sources(
    mesh: &Mesh,
    bvh: &Bvh,
    optics: &Optics,
    lighting: Lighting,
    patches: Patches,
    settings: &LightSettings,
    progress: impl FnMut(&Progress) -> bool,
) -> Result<LightResult, CoreError> {
    settings.validate()?;
    let emitters = lighting.sources;
    let n_mat = mesh.material.iter().map(|&m| m as usize + 1).max().unwrap_or(0);
    if optics.rho.len() < n_mat || optics.specular.len() < n_mat || optics.roughness.len() < n_mat {
        return Err(CoreError::invalid("optics", format!("need values for {n_mat} materials")));
    }
    if optics.rho.iter().flatten().chain(&optics.specular).chain(&optics.roughness).any(|v| !(0.0..=1.0).contains(v)) {
        return Err(CoreError::invalid("optics", "reflectance, specular share and roughness must lie in [0, 1]"));
    }
    let tau = lighting.transmittance;
    if !tau.is_empty() && (tau.len() < n_mat || tau.iter().flatten().any(|v| !(0.0..=1.0).contains(v))) {
        return Err(CoreError::invalid("transmittance", format!("need values in [0, 1] for {n_mat} materials")));
    }
    if let Some(m) = (0..tau.len().min(optics.rho.len())).find(|&m| (0..3).any(|c| optics.rho[m][c] + tau[m][c] > 1.0 + 1e-12)) {
        return Err(CoreError::invalid("transmittance", format!("material {m}: reflectance + transmittance exceeds 1")));
    }
    for (i, e) in emitters.iter().enumerate() {
        e.validate(i)?;
    }
    if let Some(p) = lighting.work_plane {
        p.validate()?;
    }
    if patches.resolution.len() != mesh.triangles.len() {
        return Err(CoreError::invalid("patches", "one patch resolution per triangle"));
    }
    let power: Vec<f64> = emitters.iter().map(|e| e.flux().iter().sum::<f64>()).collect();
    let choose = Discrete::new(&power).ok_or_else(|| CoreError::invalid("lights", "no light emits any flux"))?;
    let total: f64 = power.iter().sum();
    // Independent of the particle count, so that ranges of one bake merge exactly; a patch
    // can take 16 000 × the emitted flux before its sum would wrap.
    let quantum = total / (1u64 << 50) as f64;
    let sums = FluxSums::new(patches.len(), quantum);
    let plane_sums = FluxSums::new(lighting.work_plane.map_or(0, |p| p.len()), quantum);
    let epsilon = 1e-5 * (bvh.bounds().extent().length() as f64).max(1.0);
    // A closed convex room whose lights lie inside it (or on its walls) and shine into it is
    // traced through its planes, as the sound tracer does.
    // Glazing lets particles out of the room, where the planes cannot follow them.
    let shines_in = |r: &ConvexRoom, e: &LightSource| {
        e.corners().is_none_or(|cs| cs.iter().all(|&p| r.holds(p, epsilon))) && r.contains(e.inward_point(epsilon))
    };
    let opaque = tau.iter().flatten().all(|&v| v == 0.0);
    let surfaces = Surfaces::new(mesh, bvh, opaque && mesh.is_closed_convex(), |r| emitters.iter().all(|e| shines_in(r, e)));
    let scene = LightScene {
        mesh, surfaces, optics, transmittance: tau, emitters, choose: &choose, patches: &patches, sums: &sums,
        plane: lighting.work_plane.map(|p| (p, &plane_sums)), settings, epsilon,
    };
    let (tallies, cancelled) = run_chunks(
        settings.end_ray - settings.first_ray,
        4096,
        settings.threads,
        Tally::default,
        |tally, range| {
            for i in range {
                trace_particle(&scene, settings.first_ray + i, tally);
            }
        },
        progress,
    );
    let mut stats = LightStats::default();
    let mut energy = [[0i128; 3]; 4];
    for t in &tallies {
        stats.particles += t.particles;
        stats.bounces += t.bounces;
        stats.escaped_particles += t.escaped_particles;
        for k in 0..4 {
            for c in 0..3 {
                energy[k][c] += t.energy[k][c];
            }
        }
    }
    let w = |k: usize| energy[k].map(|v| v as f64 * TALLY_QUANTUM);
    (stats.emitted, stats.absorbed, stats.escaped, stats.roulette) = (w(EMITTED), w(ABSORBED), w(ESCAPED), w(ROULETTE));
    let flux = sums.flux();
    let hits = sums.hits.iter().map(|h| h.load(Ordering::Relaxed)).collect();
    let plane_flux = plane_sums.flux();
    let plane_hits = plane_sums.hits.iter().map(|h| h.load(Ordering::Relaxed)).collect();
    Ok(LightResult { patches, flux, hits, plane_flux, plane_hits, stats, cancelled })
}

struct LightScene<'a> {
    mesh: &'a Mesh,
    surfaces: Surfaces<'a>,
    optics: &'a Optics,
    transmittance: &'a [[f64; 3]],
    emitters: &'a [LightSource],
    choose: &'a Discrete,
    patches: &'a Patches,
    sums: &'a FluxSums,
    plane: Option<(&'a WorkPlane, &'a FluxSums)>,
    settings: &'a LightSettings,
    epsilon: f64,
}

/// One particle from its light to its end.
fn trace_particle(sc: &LightScene, index: u64, tally: &mut Tally) {
    let mut rng = Stream::new(sc.settings.seed, u64::MAX - 1, index);
    // Emit: a light by its power, then a point and a direction as the light's kind says.
    let k = sc.choose.sample(rng.uniform());
    let emission = sc.emitters[k].emit(&mut rng, sc.epsilon);
    let (mut pos, mut dir) = (emission.origin, emission.direction);
    // Each particle carries its value / density at a share of the particle count (for a
    // Lambertian light the same power for every particle).
    let p_k = sc.choose.probability(k);
    let n_particles = sc.settings.particles as f64;
    let mut w = emission.flux.map(|f| f / (p_k * n_particles));
    tally.particles += 1;
    tally.add(EMITTED, w);

    for _ in 0..sc.settings.max_bounces {
        // Find where the particle lands.
        let nearest = sc.surfaces.nearest(pos, dir);
        // Count it on the work plane if this path crosses it downwards.
        if let Some((plane, sums)) = sc.plane {
            if let Some(cell) = plane.crossing(pos, dir, nearest.map_or(f64::INFINITY, |h| h.0)) {
                sums.add(cell, w, &mut rng);
            }
        }
        let Some((t, tri, _)) = nearest else {
            tally.escaped_particles += 1;
            tally.add(ESCAPED, w);
            return;
        };
        tally.bounces += 1;
        let [v0, v1, v2] = sc.mesh.corners(tri).map(|v| v.as_dvec3());
        let point = pos + dir * t;
        // Deposit the incident flux on the patch it lands on.
        let (s, t) = patches::barycentric(point, v0, v1, v2);
        sc.sums.add(sc.patches.index(tri, s, t), w, &mut rng);

        // Absorb; Russian roulette on the largest reflectance (and transmittance) decides
        // whether it goes on, and whether it is reflected or passes through.
        let m = sc.mesh.material[tri] as usize;
        let rho = sc.optics.rho[m];
        let tau = sc.transmittance.get(m).copied().unwrap_or([0.0; 3]);
        let reflected = [w[0] * rho[0], w[1] * rho[1], w[2] * rho[2]];
        let passed = [w[0] * tau[0], w[1] * tau[1], w[2] * tau[2]];
        let kept: [f64; 3] = std::array::from_fn(|c| reflected[c] + passed[c]);
        tally.add(ABSORBED, [w[0] - kept[0], w[1] - kept[1], w[2] - kept[2]]);
        let (p_reflect, p_pass) = (rho[0].max(rho[1]).max(rho[2]), tau[0].max(tau[1]).max(tau[2]));
        let scale = (p_reflect + p_pass).max(1.0);
        let (p_reflect, p_pass) = (p_reflect / scale, p_pass / scale);
        let u = rng.uniform();
        if u >= p_reflect + p_pass {
            tally.add(ROULETTE, kept.map(|x| -x));
            return;
        }
        let through = u >= p_reflect;
        let next = if through { passed.map(|x| x / p_pass) } else { reflected.map(|x| x / p_reflect) };
        tally.add(ROULETTE, [next[0] - kept[0], next[1] - kept[1], next[2] - kept[2]]);
        w = next;
        if through {
            // Glazing: on along the same line, from just past the surface.
            pos = point + dir * sc.epsilon;
            continue;
        }

        // Bounce from the side it came from.
        let mut normal = (v1 - v0).cross(v2 - v0).normalize();
        if normal.dot(dir) > 0.0 {
            normal = -normal;
        }
        dir = if rng.uniform() < sc.optics.specular[m] {
            glossy(dir, normal, sc.optics.roughness[m], &mut rng)
        } else {
            cosine_hemisphere(&Frame::from_normal(normal), rng.uniform(), rng.uniform())
        };
        pos = point + normal * sc.epsilon;
    }
    // The bounce guard stopped it: what it carried is absorbed here.
    tally.add(ABSORBED, w);
}

/// The mirror direction, spread for a rough surface by a Phong lobe of exponent
/// 2 / roughness² − 2 around it; a direction that falls below the surface is mirrored back
/// above it, which keeps the energy.
fn glossy(dir: DVec3, normal: DVec3, roughness: f64, rng: &mut Stream) -> DVec3 {
    let mirror = dir - 2.0 * dir.dot(normal) * normal;
    if roughness <= 1e-4 {
        return mirror;
    }
    let exponent = (2.0 / (roughness * roughness) - 2.0).max(0.0);
    let cos = rng.uniform().powf(1.0 / (exponent + 1.0));
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = std::f64::consts::TAU * rng.uniform();
    let d = Frame::from_normal(mirror).to_world(DVec3::new(sin * phi.cos(), sin * phi.sin(), cos));
    let below = d.dot(normal);
    if below < 0.0 { d - 2.0 * below * normal } else { d }
}
