//! The sound tracer: an impulse leaves each source as many rays, which travel in straight lines,
//! lose energy to the air (ISO 9613-1 coefficients, handed in per band) and to surfaces
//! (absorption per band), reflect specularly or diffusely (Lambert) by the surface's scattering,
//! and end when every band has dropped by the set amount or at the maximum time.
//!
//! Two estimators fill the field (see [`trace`]):
//! - `Paper`: the method of Pope and Chalmers, literally: receivers are spheres and a ray that
//!   crosses one deposits its energy × chord / sphere volume at its arrival time.
//! - `Rain`: the direct sound is computed exactly, and at each reflection the diffusely
//!   scattered energy is sent to every visible receiver at once ("diffuse rain", next-event
//!   estimation); the spheres then only collect energy whose last reflection was specular.
//! - `Nee { connections }`: the rain estimator with each diffuse reflection connected to a
//!   bounded number of receivers drawn by importance and weighted by 1/(M p) ([`nee`]).
//!   All three estimate the same mean over each receiver's sphere.

pub(crate) mod air;
mod accumulator;
mod bounce;
mod direct;
mod emit;
pub mod field;
pub mod grazing;
pub mod nee;
pub mod pattern;
pub mod receiver_pattern;
pub mod receivers;
pub mod reflectance;
pub mod scattering;
pub mod stats;
mod leave;
mod nearest;
mod settings;
pub mod tail;
mod trace;

use std::sync::Arc;

use glam::DVec3;

use crate::bvh::Bvh;
use crate::convex::Surfaces;
use crate::early::lod::LevelOfDetail;
use crate::error::CoreError;
use crate::mesh::Mesh;
use crate::parallel::{fill_blocks, run_chunks, Progress};
pub use field::{Accumulator, Deposits, Layout};
pub use grazing::GrazingModes;
pub use pattern::Pattern;
pub use receivers::{ReceiverPattern, Receivers};
pub use reflectance::{WallModel, Walls};
pub use scattering::ScatteringByAngle;
pub use settings::{field_bytes_per_cell, SoundSettings, FIELD_BYTES_PER_CELL, MAX_THREADS};
pub use stats::SoundStats;
pub use tail::{Tail, TailSettings};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    Paper,
    Rain,
    /// Rain through `connections` receivers a diffuse reflection, drawn by importance.
    Nee { connections: u32 },
}

impl Estimator {
    /// Whether the direct sound is exact and diffuse reflections connect to receivers (rain
    /// and its sampled form): the spheres then collect only specularly reflected energy.
    pub fn rains(self) -> bool {
        self != Estimator::Paper
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Directivity {
    Omni,
    /// Rays uniformly within `cos_half_angle` of the unit `axis`, as the paper's directional source.
    Cone { axis: DVec3, cos_half_angle: f64 },
    /// A tabulated gain per band, emitted by importance (see [`pattern`]).
    Pattern(Arc<Pattern>),
}

impl Directivity {
    /// The energy gain of every band towards the unit direction `dir`, relative to an
    /// omnidirectional source of the same power (mean 1 over the sphere), written into `out`.
    pub fn gains(&self, dir: DVec3, out: &mut [f64]) {
        match self {
            Directivity::Omni => out.fill(1.0),
            Directivity::Cone { axis, cos_half_angle } => out.fill(if axis.dot(dir) < *cos_half_angle { 0.0 } else { 2.0 / (1.0 - cos_half_angle) }),
            Directivity::Pattern(p) => p.gains(dir, out),
        }
    }

    /// The largest energy a ray or a direct deposit can carry, relative to the source's power
    /// shared evenly: bounds the field's fixed-point range.
    pub fn peak(&self) -> f64 {
        match self {
            Directivity::Omni => 1.0,
            Directivity::Cone { cos_half_angle, .. } => 2.0 / (1.0 - cos_half_angle),
            Directivity::Pattern(p) => p.max_weight().max(p.max_gain()).max(1.0),
        }
    }

    /// Checks that the directivity fits a bake of `n_bands` bands.
    pub fn check(&self, n_bands: usize) -> Result<(), String> {
        match self {
            Directivity::Cone { axis, cos_half_angle } if !(axis.is_finite() && (axis.length() - 1.0).abs() < 1e-6 && (-1.0..1.0).contains(cos_half_angle)) => Err("a cone needs a unit axis and a half-angle in (0°, 180°]".into()),
            Directivity::Pattern(p) if p.n_bands() != n_bands => Err(format!("its directivity pattern has {} bands, the bake {n_bands}", p.n_bands())),
            _ => Ok(()),
        }
    }
}

#[derive(Clone, Debug)]
pub struct SoundSource {
    pub position: DVec3,
    /// Energy of the impulse in joules (a source of power W for one second: W).
    pub power_w: f64,
    pub directivity: Directivity,
}

/// Absorption and scattering of each material: `[material][band]`, flattened.
#[derive(Clone, Debug)]
pub struct Acoustics {
    pub n_bands: usize,
    pub absorption: Vec<f64>,
    pub scattering: Vec<f64>,
}

/// The specular-only paths that another method already counts (the image sources of
/// [`crate::early`]), which the tracer must then leave out so that nothing is counted twice.
///
/// A ray is "specular only" until its first diffuse bounce. A segment of such a ray after
/// `k` reflections is exactly a path of an image source of order `k`; its deposits (into the
/// spheres; and, for `k` = 0, the rain estimator's exact direct sound) are skipped when
/// `k ≤ max_order` and the deposit's time is at most `max_time_s`: the same set of paths the
/// image sources enumerate. Every reflection still splits the energy into its specular share
/// (1 − s) and its diffuse share s (the tracer's choice of bounce and re-weighting), so what is
/// left out has, in expectation, exactly the image sources' energy Π(1 − α)(1 − s), band by band;
/// everything with at least one diffuse bounce (all rain connections included) is kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularCoverage {
    pub max_order: u32,
    pub max_time_s: f64,
}

impl SpecularCoverage {
    /// Whether a deposit of a ray that has only reflected specularly, `reflections` times, at
    /// `time_s`, is already counted.
    #[inline]
    pub fn covers(&self, reflections: u64, time_s: f64) -> bool {
        reflections <= self.max_order as u64 && time_s <= self.max_time_s
    }
}

/// The result of a bake (or of one range of it).
#[derive(Debug)]
pub struct SoundResult {
    pub layout: Layout,
    /// Fixed-point energies, `[time][receiver][direction][band]` (see [`Layout::index`]).
    pub field: Accumulator,
    pub stats: SoundStats,
    pub cancelled: bool,
    /// The largest per-ray late contributions, when [`Extras::tail`] asked for them.
    pub tail: Option<Tail>,
}

impl SoundResult {
    /// Adds the result of another range of the same bake: exact, so ranges merge to the bits of
    /// one bake.
    pub fn merge(&mut self, other: &SoundResult) -> Result<(), CoreError> {
        if self.layout != other.layout || self.field.quantum != other.field.quantum {
            return Err(CoreError::invalid("merge", "the two results come from different bakes"));
        }
        self.field.merge(&other.field);
        self.stats.merge(&other.stats);
        self.cancelled |= other.cancelled;
        Ok(())
    }

    /// Writes the field in the public order, `[receiver][direction][band][time]` (the order of
    /// the field file and of every array sonolux hands out), each count through `convert`, on
    /// `threads` workers (0 = all cores): one receiver's block a task. The accumulator keeps its
    /// own time-major order while tracing (see [`Layout::index`]).
    pub fn write_public<T: Send>(&self, out: &mut [T], threads: usize, convert: impl Fn(u64) -> T + Sync) -> Result<(), CoreError> {
        let l = &self.layout;
        if out.len() != l.len() {
            return Err(CoreError::invalid("out", format!("{} values for a field of {}", out.len(), l.len())));
        }
        let (nt, nd, nb) = (l.n_time(), l.n_directions(), l.n_bands);
        self.field.read(|counts| {
            fill_blocks(out, nd * nb * nt, threads, |r, block| {
                for t in 0..nt {
                    for d in 0..nd {
                        let cell = l.cell(r, t, d);
                        for b in 0..nb {
                            block[(d * nb + b) * nt + t] = convert(counts.at(cell, b));
                        }
                    }
                }
            })
        });
        Ok(())
    }

    /// The energies in J/m², float32 in the public order (see [`SoundResult::write_public`]).
    pub fn energy(&self, threads: usize) -> Vec<f32> {
        let q = self.field.quantum;
        let mut out = vec![0f32; self.layout.len()];
        self.write_public(&mut out, threads, |c| (c as f64 * q) as f32).expect("sized to the layout");
        out
    }

    /// The exact fixed-point counts (energy = count × quantum) in the public order.
    pub fn counts(&self, threads: usize) -> Vec<u64> {
        let mut out = vec![0u64; self.layout.len()];
        self.write_public(&mut out, threads, |c| c).expect("sized to the layout");
        out
    }
}

/// Everything the ray kernel reads, bundled.
pub(crate) struct Scene<'a> {
    pub mesh: &'a Mesh,
    pub bvh: &'a Bvh,
    pub acoustics: &'a Acoustics,
    pub sources: &'a [SoundSource],
    pub receivers: &'a Receivers,
    pub settings: &'a SoundSettings,
    pub layout: Layout,
    /// Whether the room is one closed convex volume: then nothing can block a rain connection.
    pub convex: bool,
    /// The nearest surface of a ray: the room's planes when it is convex, small and holds every
    /// source, else the BVH.
    pub surfaces: Surfaces<'a>,
    /// Whether the air absorbs at all (its exponentials are skipped when not).
    pub air: bool,
    /// The air's factors exp(−m_b · d) for all bands at once (sound/air.rs).
    pub air_lanes: air::Air,
    /// Probability of a diffuse bounce on each material whose bands scatter alike: its
    /// scattering (as the mean over its bands, the expression the bits were made with).
    pub p_diffuse: Vec<f64>,
    /// Whether every material scatters every band alike (then no hero band, no re-weighting:
    /// sound/bounce.rs).
    pub uniform_scattering: bool,
    /// Specular-only paths counted elsewhere (None: the tracer counts everything).
    pub covered: Option<SpecularCoverage>,
    /// The receivers' tree of the sampled rain estimator (None for the others), over
    /// `tree_centres`: the whole bake's receivers, of which this run's are `first_receiver..`
    /// when it traces a tile ([`Extras::bake_receivers`]), else this run's (offset 0).
    pub receiver_tree: Option<&'a nee::ReceiverTree>,
    pub tree_centres: &'a [DVec3],
    pub tree_offset: usize,
    /// Level of detail: Rindel's K turns part of each specular reflection into scattering.
    pub lod: Option<&'a LevelOfDetail>,
    /// How each surface's absorption depends on the angle of incidence ([`reflectance`]).
    pub walls: Walls,
    /// The hybrid's early diffuse connections (sphere estimator only; None: none).
    pub early_connections: Option<nee::EarlyConnections>,
    /// The absorption α(θ) and scattering s(θ) of materials with a surface profile
    /// ([`scattering`]); None: every material keeps its coefficients.
    pub by_angle: Option<&'a ScatteringByAngle>,
    /// The grazing modes of parallel surface pairs ([`grazing`]); None: rays only.
    pub grazing: Option<&'a GrazingModes>,
}

/// Rays traced per work item; small for the rain estimator, whose rays cost more.
fn chunk_size(estimator: Estimator, receivers: usize) -> u64 {
    match estimator {
        Estimator::Paper => 1024,
        Estimator::Rain => (65_536 / (receivers as u64 + 1)).clamp(8, 1024),
        Estimator::Nee { connections } => (65_536 / (receivers.min(connections as usize) as u64 + 1)).clamp(8, 1024),
    }
}

/// Traces a bake (or the range of it the settings name) into a sound field: the plain tracer,
/// [`trace_sound_with`] and no [`Extras`].
pub fn trace_sound(
    mesh: &Mesh,
    bvh: &Bvh,
    acoustics: &Acoustics,
    sources: &[SoundSource],
    receivers: &Receivers,
    settings: &SoundSettings,
    progress: impl FnMut(&Progress) -> bool,
) -> Result<SoundResult, CoreError> {
    trace_sound_with(mesh, bvh, acoustics, sources, receivers, settings, Extras::default(), progress)
}

/// What a bake may add to the plain tracer.
#[derive(Clone, Copy, Debug, Default)]
pub struct Extras<'a> {
    /// Specular-only paths another method counts (the hybrid's image sources).
    pub covered: Option<SpecularCoverage>,
    /// Level of detail ([`crate::early::lod`]): each reflection's scattering becomes
    /// s' = 1 − (1 − s) K, K computed exactly as the image sources compute it.
    pub level_of_detail: Option<&'a LevelOfDetail>,
    /// How a surface's absorption depends on the angle of incidence ([`reflectance`]): the
    /// default keeps each band's coefficient at every angle.
    pub wall_model: WallModel,
    /// The centres of every receiver of the whole bake, when this run traces a tile of them
    /// (receivers `first_receiver..` of these): the nee estimator then draws among all of them
    /// and deposits only into the tile's, so that tiles give the bits of the untiled bake.
    /// None: the run's receivers are the bake's.
    pub bake_receivers: Option<&'a [DVec3]>,
    /// The hybrid's early diffuse connections ([`nee::EarlyConnections`]): with the sphere
    /// estimator, diffuse reflections are connected to the receivers for the arrivals before
    /// the window's end (the rain and nee estimators connect every one already).
    pub early_connections: Option<nee::EarlyConnections>,
    /// The field's fixed-point quantum (J/m² a count), when the caller needs one quantum for
    /// several runs whose sources or receivers peak differently (level of detail's band groups,
    /// each with its own bands' gains): it must be at least this run's own
    /// ([`sound_quantum`] of its sources and receivers), so that no bin can overflow. None: the
    /// run's own.
    pub quantum: Option<f64>,
    /// The absorption α(θ) and scattering s(θ) of materials whose surface is described
    /// ([`scattering`]): at each bounce on them the rays take both at the angle of incidence
    /// instead of the coefficients (and the wall model).
    pub scattering_by_angle: Option<&'a ScatteringByAngle>,
    /// The grazing modes of parallel surface pairs ([`grazing`]): a ray nearly parallel to
    /// both planes of a pair loses that pair's grazing mode's energy along its path instead of
    /// its own absorption at their hits. None: off.
    pub grazing_modes: Option<&'a GrazingModes>,
    /// A progressive bake's heavy-tail diagnostic ([`tail`]): the largest per-ray late
    /// contributions of each receiver and band. None: off (the tracer tests one `Option`).
    pub tail: Option<&'a TailSettings>,
}

/// The fixed-point quantum (J/m² a count) of a bake of these sources into these receivers: set
/// by the sources' power × directivity peak and the receivers' peak gain and radius (no bin can
/// overflow). A bake of the same sources and receivers restricted to some of their bands has a
/// quantum no larger (a peak over fewer bands is no larger, and rounding is monotone).
pub fn sound_quantum(sources: &[SoundSource], receivers: &Receivers) -> f64 {
    emit::quantum(sources, receivers.radius_m, receivers.peak_gain())
}

/// [`trace_sound`] with [`Extras`].
#[allow(clippy::too_many_arguments)]
pub fn trace_sound_with(
    mesh: &Mesh,
    bvh: &Bvh,
    acoustics: &Acoustics,
    sources: &[SoundSource],
    receivers: &Receivers,
    settings: &SoundSettings,
    extras: Extras,
    progress: impl FnMut(&Progress) -> bool,
) -> Result<SoundResult, CoreError> {
    let covered = extras.covered;
    if let Some(lod) = extras.level_of_detail {
        if lod.band_centres_hz.len() != acoustics.n_bands || lod.band_centres_hz.iter().any(|f| !(*f > 0.0 && f.is_finite())) {
            return Err(CoreError::invalid("level of detail", format!("needs {} positive band centres, got {:?}", acoustics.n_bands, lod.band_centres_hz)));
        }
        if !(lod.speed_of_sound_m_s > 0.0 && lod.speed_of_sound_m_s.is_finite()) || lod.planes.plane_of_triangle.len() != mesh.triangles.len() {
            return Err(CoreError::invalid("level of detail", "built for another mesh, or a speed of sound that is not positive"));
        }
    }
    if let Some(c) = covered {
        if !(c.max_time_s >= 0.0) || c.max_order > 64 {
            return Err(CoreError::invalid("specular coverage", format!("order {} (≤ 64) and time {} s (≥ 0) expected", c.max_order, c.max_time_s)));
        }
    }
    if let Some(ec) = extras.early_connections {
        ec.check().map_err(|problem| CoreError::invalid("early_connections", problem))?;
    }
    let nb = acoustics.n_bands;
    settings.validate(acoustics, receivers.len())?;
    let n_mat = mesh.material.iter().map(|&m| m as usize + 1).max().unwrap_or(0);
    if acoustics.absorption.len() != n_mat * nb {
        return Err(CoreError::invalid("materials", format!("the mesh uses {n_mat} materials: {} values of absorption and scattering are needed ({nb} bands each), got {}", n_mat * nb, acoustics.absorption.len())));
    }
    if let Some(t) = extras.scattering_by_angle {
        if t.n_bands() != nb || t.n_materials() < n_mat {
            return Err(CoreError::invalid("scattering_by_angle", format!("a table of {} materials × {} bands given; the bake needs {n_mat} × {nb}", t.n_materials(), t.n_bands())));
        }
    }
    if let Some(g) = extras.grazing_modes {
        if g.n_bands() != nb {
            return Err(CoreError::invalid("grazing_modes", format!("a table of {} bands given; the bake has {nb}", g.n_bands())));
        }
    }
    if sources.is_empty() {
        return Err(CoreError::invalid("sources", "a sound bake needs at least one source"));
    }
    if let Some(k) = settings.only_source {
        if k >= sources.len() {
            return Err(CoreError::invalid("only_source", format!("source {k} asked for, but there are {} sources", sources.len())));
        }
    }
    for (i, s) in sources.iter().enumerate() {
        if !(s.position.is_finite() && s.power_w > 0.0 && s.power_w.is_finite()) {
            return Err(CoreError::invalid("sources", format!("source {i}: position must be finite and power positive")));
        }
        if let Err(problem) = s.directivity.check(nb) {
            return Err(CoreError::invalid("sources", format!("source {i}: {problem}")));
        }
    }
    if !(receivers.radius_m > 0.0 && receivers.radius_m.is_finite()) {
        return Err(CoreError::invalid("receivers", format!("radius_m = {} is not a positive length", receivers.radius_m)));
    }
    if receivers.centres.iter().any(|c| !c.is_finite()) {
        return Err(CoreError::invalid("receivers", "every position must be finite"));
    }
    receivers.check_patterns(nb).map_err(|problem| CoreError::invalid("receivers", problem))?;
    let layout = settings.layout(receivers.len(), nb);
    let convex = mesh.is_closed_convex();
    let scattering: Vec<&[f64]> = acoustics.scattering.chunks(nb).collect();
    let (tree_centres, tree_offset) = match extras.bake_receivers {
        Some(all) => {
            let first = settings.first_receiver as usize;
            if all.iter().any(|c| !c.is_finite()) || first.checked_add(receivers.len()).is_none_or(|end| end > all.len()) || all[first..first + receivers.len()] != receivers.centres[..] {
                return Err(CoreError::invalid("bake_receivers", format!("this run's {} receivers are not receivers {first}.. of the bake's {}", receivers.len(), all.len())));
            }
            (all, first)
        }
        None => (&receivers.centres[..], 0),
    };
    let early_connections = extras.early_connections.filter(|_| settings.estimator == Estimator::Paper);
    let receiver_tree = (matches!(settings.estimator, Estimator::Nee { .. }) || early_connections.is_some()).then(|| nee::ReceiverTree::new(tree_centres, receivers.radius_m));
    let scene = Scene {
        mesh,
        bvh,
        acoustics,
        sources,
        receivers,
        settings,
        layout: layout.clone(),
        convex,
        // The tracer reads a hit's material, not its triangle, unless level of detail asks for the panel.
        surfaces: Surfaces::new(mesh, bvh, convex, |r| sources.iter().all(|s| r.contains(s.position))).exact_triangles(extras.level_of_detail.is_some()),
        air: settings.air_attenuation_per_m.iter().any(|&a| a > 0.0),
        air_lanes: air::Air::new(&settings.air_attenuation_per_m[..nb]),
        p_diffuse: scattering.iter().map(|s| s.iter().sum::<f64>() / nb as f64).collect(),
        uniform_scattering: scattering.iter().all(|s| s.iter().all(|&x| x == s[0])) && extras.scattering_by_angle.is_none_or(|t| t.uniform()),
        covered,
        receiver_tree: receiver_tree.as_ref(),
        tree_centres,
        tree_offset,
        lod: extras.level_of_detail,
        walls: Walls::new(extras.wall_model, acoustics),
        early_connections,
        by_angle: extras.scattering_by_angle,
        grazing: extras.grazing_modes,
    };
    let own_quantum = sound_quantum(sources, receivers);
    let quantum = match extras.quantum {
        None => own_quantum,
        Some(q) if q.is_finite() && q >= own_quantum => q,
        Some(q) => {
            return Err(CoreError::invalid("quantum", format!("{q:e} J/m² a count is below this bake's own {own_quantum:e} (its sources' power × directivity peak and its receivers' peak gain): a bin could overflow; give the quantum of the whole bake's sources and receivers (sound_quantum)")));
        }
    };
    let n = settings.end_ray - settings.first_ray;
    let traced_sources = if settings.only_source.is_some() { 1 } else { sources.len() };
    if let Some(t) = extras.tail {
        if t.from_s.len() != receivers.len() * nb || t.keep == 0 || t.from_s.iter().any(|s| s.is_nan()) {
            return Err(CoreError::invalid("tail", format!("{} start times (one a receiver and band, not NaN) and at least one kept value expected; got {} and {}", receivers.len() * nb, t.from_s.len(), t.keep)));
        }
    }
    let huge = field::huge_pages_pay(n * traced_sources as u64, receivers.len(), layout.cells() * field::band_stride(nb));
    let field = Accumulator::for_bands(layout.cells(), nb, quantum, huge);
    let (workers, cancelled) = run_chunks(
        n,
        chunk_size(settings.estimator, receivers.len()),
        settings.threads,
        || trace::Worker::new(nb, receivers.len()).watching(extras.tail, nb),
        |worker, range| {
            // The chunk's rays, source by source, one after another (trace::trace_rays).
            let traced = (0..sources.len()).filter(|&s| settings.only_source.is_none_or(|k| k == s));
            let jobs = traced.flat_map(|s| range.clone().map(move |i| (s, settings.first_ray + i)));
            trace::trace_rays(&scene, jobs, &field, worker);
            field.flush(&mut worker.deposits);
        },
        progress,
    );
    let mut stats = SoundStats::new(nb);
    for w in &workers {
        stats.merge(&w.stats);
    }
    // (The rains' exact direct sound is deposited by the rays, a share a block: direct::direct_share.)
    stats.finish();
    let tail = extras.tail.map(|t| tail::merged(workers.into_iter().filter_map(|w| w.scratch.tail), t.from_s.len(), t.keep));
    Ok(SoundResult { layout, field, stats, cancelled, tail })
}
