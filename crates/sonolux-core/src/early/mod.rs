//! Exact early sound on any mesh: specular image sources, first-order edge diffraction and
//! level of detail, each arrival with its exact time, its direction and its energy per band.
//!
//! - [`planes`]: coplanar triangles merged into two-sided reflecting planes (one image source a
//!   plane, as ODEON and RAVEN do) and their connected pieces (panels), measured for [`lod`].
//! - [`image_sources`]: per source one tree of image sources up to an order and a time, pruned by
//!   geometry alone and shared by every receiver; per receiver each image's path is checked
//!   against the BVH (validity and visibility in one closest-hit query a reflection).
//! - [`edges`] and [`diffraction`]: the mesh's wedges that matter (open angle above π, free
//!   edges) and the Biot–Tolstoy–Medwin secondary-source model of first-order diffraction of the
//!   direct sound and of first-order image sources, per band, continuous across shadow and
//!   reflection boundaries.
//! - [`lod`]: Rindel's specular share of finite panels, per band, from the legs before and after
//!   each reflection (Christensen and Rindel's reflection-based scattering), shared with the
//!   particle tracer so that a hybrid with level of detail counts nothing twice.
//!
//! The particle tracer leaves out exactly the specular-only paths these arrivals count when it
//! runs with [`crate::sound::SpecularCoverage`] (see `docs/early-sound.md`).
//!
//! Energies are those of the sound tracer: a source of `power_w` gives at distance d the energy
//! `power_w / (4π d²)` per unit area (or its mean over the receiver's sphere when
//! `receiver_radius_m > 0`, so that early arrivals and particles measure the same thing).

pub mod btm;
pub mod diffraction;
pub mod edges;
pub mod image_sources;
pub mod lod;
pub mod planes;

use glam::DVec3;
use rayon::prelude::*;

use crate::bvh::Bvh;
use crate::error::CoreError;
use crate::mesh::Mesh;
use crate::sound::{Acoustics, Directivity, SoundSource, WallModel, Walls};
pub use image_sources::ImageTree;
pub use planes::Planes;

/// What to compute, and how.
#[derive(Clone, Debug)]
pub struct EarlySettings {
    /// Highest reflection order of the image sources (0 = direct sound only).
    pub max_order: u32,
    /// Arrivals later than this are left out (the transition to the particles).
    pub max_time_s: f64,
    pub speed_of_sound_m_s: f64,
    /// Energy attenuation of the air per metre, one value per band (1/m).
    pub air_attenuation_per_m: Vec<f64>,
    /// Band centres (Hz), one per band; used by diffraction and level of detail.
    pub band_centres_hz: Vec<f64>,
    /// 1 for octave bands, 3 for third-octave bands (band edges at centre · 2^(±1/2n)).
    pub bands_per_octave: f64,
    /// 0: point receivers; > 0: the mean over a sphere of this radius, as the particle tracer's.
    pub receiver_radius_m: f64,
    /// Rindel's finite-panel specular share on every reflection ([`lod`]).
    pub level_of_detail: bool,
    /// First-order edge diffraction of the direct sound and of first-order image sources.
    pub diffraction: bool,
    /// Longest piece of an edge whose visibility is tested as one (m).
    pub diffraction_piece_m: f64,
    /// How far apart two triangles' planes may lie and still merge into one reflector (m).
    pub plane_tolerance_m: f64,
    /// Worker threads, 0 = all cores. Does not change the result.
    pub threads: usize,
    /// How a reflection's absorption depends on its angle of incidence
    /// ([`crate::sound::reflectance`]): give the tracer of a hybrid the same.
    pub wall_model: WallModel,
    /// The absorption α(θ) and scattering s(θ) of materials with a surface profile
    /// ([`crate::sound::scattering`]): each reflection keeps (1 − α)(1 − s) at its angle of
    /// incidence, as the tracer of a hybrid does. None: every material's coefficients.
    pub by_angle: Option<crate::sound::ScatteringByAngle>,
}

impl EarlySettings {
    /// Defaults for `n_bands` octave bands from 125 Hz, no air, point receivers.
    pub fn octaves(n_bands: usize) -> EarlySettings {
        EarlySettings {
            max_order: 3,
            max_time_s: 0.1,
            speed_of_sound_m_s: 343.0,
            air_attenuation_per_m: vec![0.0; n_bands],
            band_centres_hz: (0..n_bands).map(|b| 125.0 * 2f64.powi(b as i32)).collect(),
            bands_per_octave: 1.0,
            receiver_radius_m: 0.0,
            level_of_detail: false,
            diffraction: false,
            diffraction_piece_m: 0.25,
            plane_tolerance_m: 1e-3,
            threads: 0,
            wall_model: WallModel::RandomIncidence,
            by_angle: None,
        }
    }

    pub fn validate(&self, n_bands: usize) -> Result<(), CoreError> {
        let bad = |what: &str, problem: String| Err(CoreError::invalid(what, problem));
        if self.max_order > 64 {
            return bad("max_order", format!("{} is more than the 64 allowed", self.max_order));
        }
        if !(self.max_time_s > 0.0 && self.max_time_s.is_finite()) {
            return bad("max_time_s", format!("{} is not a positive time", self.max_time_s));
        }
        if !(self.speed_of_sound_m_s > 0.0 && self.speed_of_sound_m_s.is_finite()) {
            return bad("speed_of_sound_m_s", format!("{} is not a positive speed", self.speed_of_sound_m_s));
        }
        if self.air_attenuation_per_m.len() != n_bands || self.air_attenuation_per_m.iter().any(|m| !(*m >= 0.0 && m.is_finite())) {
            return bad("air_attenuation_per_m", format!("needs {n_bands} finite values ≥ 0, got {:?}", self.air_attenuation_per_m));
        }
        if self.band_centres_hz.len() != n_bands || self.band_centres_hz.iter().any(|f| !(*f > 0.0 && f.is_finite())) {
            return bad("band_centres_hz", format!("needs {n_bands} positive frequencies, got {:?}", self.band_centres_hz));
        }
        if !(self.bands_per_octave >= 1.0 && self.bands_per_octave <= 24.0) {
            return bad("bands_per_octave", format!("{} is not in 1..24", self.bands_per_octave));
        }
        if !(self.receiver_radius_m >= 0.0 && self.receiver_radius_m.is_finite()) {
            return bad("receiver_radius_m", format!("{} is not a radius ≥ 0", self.receiver_radius_m));
        }
        if !(self.diffraction_piece_m > 0.0 && self.diffraction_piece_m.is_finite()) {
            return bad("diffraction_piece_m", format!("{} is not a positive length", self.diffraction_piece_m));
        }
        if !(self.plane_tolerance_m >= 0.0 && self.plane_tolerance_m < 1.0) {
            return bad("plane_tolerance_m", format!("{} is not in [0, 1) m", self.plane_tolerance_m));
        }
        Ok(())
    }

    /// Lower and upper edge of band `b` (Hz).
    pub fn band_edges_hz(&self, b: usize) -> (f64, f64) {
        let half = 2f64.powf(0.5 / self.bands_per_octave);
        (self.band_centres_hz[b] / half, self.band_centres_hz[b] * half)
    }
}

/// A suggested transition time from image sources to particles: the perceptual mixing time of
/// Lindau, Kosanke and Weinzierl ("Perceptual evaluation of model- and signal-based predictors
/// of the mixing time in binaural room impulse responses", JAES 60(11), 2012), t = 20 V/S + 12 ms.
pub fn suggested_transition_s(volume_m3: f64, area_m2: f64) -> f64 {
    (20.0 * volume_m3 / area_m2 + 12.0) * 1e-3
}

/// What an arrival is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum ArrivalKind {
    /// The direct sound (order 0) or a specular reflection path of `order` reflections.
    Specular { order: u32 },
    /// Diffracted at wedge `wedge`, from the source (`order` 0) or a first-order image (1).
    Diffracted { order: u32, wedge: u32 },
}

/// One early arrival at one receiver.
#[derive(Clone, Debug, PartialEq)]
pub struct Arrival {
    pub source: u32,
    pub receiver: u32,
    /// Exact arrival time (path length / c); for diffraction the onset (the shortest path).
    pub time_s: f64,
    /// Unit vector from the receiver towards where the sound comes from.
    pub from_direction: DVec3,
    pub kind: ArrivalKind,
    /// The image source (node of the source's [`ImageTree`]) the arrival comes from.
    pub image: u32,
}

/// Counts of what was done.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EarlyStats {
    pub planes: usize,
    pub wedges: usize,
    /// Image sources in the trees (all sources), and paths checked against the BVH.
    pub image_sources: usize,
    pub paths_checked: usize,
    pub specular_arrivals: usize,
    pub diffracted_arrivals: usize,
    /// Calls of the edge-diffraction integrand (bounded per edge part, see [`btm`]).
    pub integrand_calls: u64,
}

/// The early arrivals of every (source, receiver), sorted by source, receiver, then time.
#[derive(Clone, Debug)]
pub struct EarlyResult {
    pub n_bands: usize,
    pub arrivals: Vec<Arrival>,
    /// Energy of each arrival per band, `[arrival][band]` (J/m², as the sound field).
    pub energy: Vec<f64>,
    pub stats: EarlyStats,
}

impl EarlyResult {
    pub fn energy_of(&self, i: usize) -> &[f64] {
        &self.energy[i * self.n_bands..(i + 1) * self.n_bands]
    }
}

/// A per-band gain of a source towards a unit direction, written into `out` (one per band): the
/// hook through which measured directivities (e.g. from a SOFA file) enter. It multiplies the
/// source's own [`Directivity`].
pub type SourceGains = dyn Fn(usize, DVec3, &mut [f64]) + Sync;

/// Gain of the tracer's directivity towards the unit direction `dir` (energy per solid angle
/// relative to an omnidirectional source of the same power).
/// A tabulated pattern's gain differs by band: it enters through the per-band hook that
/// [`early_arrivals`] wraps around the caller's, so it counts 1 here.
pub fn directivity_gain(d: &Directivity, dir: DVec3) -> f64 {
    match *d {
        Directivity::Omni | Directivity::Pattern(_) => 1.0,
        Directivity::Cone { axis, cos_half_angle } => {
            if axis.dot(dir) < cos_half_angle {
                0.0
            } else {
                2.0 / (1.0 - cos_half_angle)
            }
        }
    }
}

/// [`SourceGains`] that may borrow (the sources' patterns wrapped around the caller's hook).
pub(crate) type ScopedGains<'a> = dyn Fn(usize, DVec3, &mut [f64]) + Sync + 'a;

/// Everything the per-receiver work reads.
pub(crate) struct Context<'a> {
    pub mesh: &'a Mesh,
    pub bvh: &'a Bvh,
    pub planes: &'a Planes,
    pub acoustics: &'a Acoustics,
    pub sources: &'a [SoundSource],
    pub gains: Option<&'a ScopedGains<'a>>,
    pub settings: &'a EarlySettings,
    /// Level of detail (with `settings.level_of_detail`): Rindel's K on every reflection.
    pub lod: Option<&'a lod::LevelOfDetail>,
    /// Each reflection's absorption at its angle of incidence, as the tracer's.
    pub walls: Walls,
    /// Offset (m) that keeps a visibility ray from finding the surface it starts on.
    pub epsilon_m: f64,
}

/// Computes the early arrivals of every source at every receiver.
pub fn early_arrivals(
    mesh: &Mesh,
    bvh: &Bvh,
    acoustics: &Acoustics,
    sources: &[SoundSource],
    receivers: &[DVec3],
    settings: &EarlySettings,
    gains: Option<&SourceGains>,
) -> Result<EarlyResult, CoreError> {
    let nb = acoustics.n_bands;
    settings.validate(nb)?;
    let n_mat = mesh.material.iter().map(|&m| m as usize + 1).max().unwrap_or(0);
    if acoustics.absorption.len() != n_mat * nb || acoustics.scattering.len() != n_mat * nb {
        return Err(CoreError::invalid("materials", format!("need {n_mat} materials × {nb} bands of absorption and scattering")));
    }
    if acoustics.absorption.iter().chain(&acoustics.scattering).any(|a| !(0.0..=1.0).contains(a)) {
        return Err(CoreError::invalid("materials", "absorption and scattering must lie in [0, 1]"));
    }
    for (i, s) in sources.iter().enumerate() {
        if !s.position.is_finite() || !(s.power_w > 0.0) {
            return Err(CoreError::invalid("sources", format!("source {i}: position must be finite and power positive")));
        }
        if let Err(problem) = s.directivity.check(nb) {
            return Err(CoreError::invalid("sources", format!("source {i}: {problem}")));
        }
    }
    // The sources' tabulated patterns (per band), times the caller's own gains if any.
    let with_patterns = |s: usize, dir: DVec3, out: &mut [f64]| {
        match gains {
            Some(hook) => hook(s, dir, out),
            None => out.fill(1.0),
        }
        if let Directivity::Pattern(p) = &sources[s].directivity {
            let mut g = vec![0.0; out.len()];
            p.gains(dir, &mut g);
            out.iter_mut().zip(&g).for_each(|(o, g)| *o *= g);
        }
    };
    let patterned = sources.iter().any(|s| matches!(s.directivity, Directivity::Pattern(_)));
    let gains: Option<&ScopedGains<'_>> = if patterned { Some(&with_patterns) } else { gains };
    if let Some(i) = receivers.iter().position(|r| !r.is_finite()) {
        return Err(CoreError::invalid("receivers", format!("receiver {i} has a non-finite position {:?}", receivers[i])));
    }
    let planes = Planes::build(mesh, settings.plane_tolerance_m);
    let detail = settings.level_of_detail.then(|| lod::LevelOfDetail::with_planes(mesh, planes.clone(), settings.band_centres_hz.clone(), settings.speed_of_sound_m_s));
    let wedges = if settings.diffraction { edges::wedges(mesh, &planes) } else { Vec::new() };
    let ctx = Context {
        mesh,
        bvh,
        planes: &planes,
        acoustics,
        sources,
        gains,
        settings,
        lod: detail.as_ref(),
        walls: Walls::new(settings.wall_model, acoustics),
        epsilon_m: 1e-5 * (bvh.bounds().extent().length() as f64).max(1.0),
    };
    let max_path_m = settings.max_time_s * settings.speed_of_sound_m_s;
    let apertures = image_sources::Apertures::new(&ctx);
    let beams = apertures.spheres();
    let trees: Vec<ImageTree> = sources.iter().map(|s| ImageTree::build_in_beams(&planes, s.position, receivers, settings.max_order, max_path_m, Some(&beams))).collect();
    let twins: Vec<image_sources::Twins> = trees.iter().map(image_sources::Twins::of).collect();

    let threads = if settings.threads == 0 { std::thread::available_parallelism().map_or(1, |n| n.get()) } else { settings.threads };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| CoreError::invalid("threads", format!("cannot start {threads} threads: {e}")))?;
    let pairs: Vec<(usize, usize)> = (0..sources.len()).flat_map(|s| (0..receivers.len()).map(move |r| (s, r))).collect();
    // Each (source, receiver) is computed alone and the results are concatenated in order: the
    // same bits for any thread count.
    let per_pair: Vec<(Vec<Arrival>, Vec<f64>, usize, u64)> = pool.install(|| {
        pairs
            .par_iter()
            .with_min_len(1)
            .map(|&(s, r)| {
                let mut out = image_sources::arrivals(&ctx, &trees[s], &twins[s], &apertures, s, r, receivers[r]);
                if settings.diffraction {
                    diffraction::add_arrivals(&ctx, &trees[s], &wedges, s, r, receivers[r], &mut out);
                }
                out.sort();
                let (checked, calls) = (out.checked, out.integrand_calls);
                let (arrivals, energy) = out.into_parts();
                (arrivals, energy, checked, calls)
            })
            .collect()
    });
    let mut result = EarlyResult { n_bands: nb, arrivals: Vec::new(), energy: Vec::new(), stats: EarlyStats::default() };
    result.stats.planes = planes.planes.len();
    result.stats.wedges = wedges.len();
    result.stats.image_sources = trees.iter().map(|t| t.nodes.len()).sum();
    for (a, e, checked, calls) in per_pair {
        result.stats.paths_checked += checked;
        result.stats.integrand_calls += calls;
        for x in &a {
            match x.kind {
                ArrivalKind::Specular { .. } => result.stats.specular_arrivals += 1,
                ArrivalKind::Diffracted { .. } => result.stats.diffracted_arrivals += 1,
            }
        }
        result.arrivals.extend(a);
        result.energy.extend(e);
    }
    Ok(result)
}

/// The arrivals of one (source, receiver) while they are computed.
pub(crate) struct PairArrivals {
    pub n_bands: usize,
    pub arrivals: Vec<Arrival>,
    pub energy: Vec<f64>,
    /// Paths checked against the BVH.
    pub checked: usize,
    pub integrand_calls: u64,
}

impl PairArrivals {
    pub fn new(n_bands: usize) -> PairArrivals {
        PairArrivals { n_bands, arrivals: Vec::new(), energy: Vec::new(), checked: 0, integrand_calls: 0 }
    }

    pub fn push(&mut self, a: Arrival, energy: &[f64]) {
        self.arrivals.push(a);
        self.energy.extend_from_slice(energy);
    }

    pub fn energy_mut(&mut self, i: usize) -> &mut [f64] {
        &mut self.energy[i * self.n_bands..(i + 1) * self.n_bands]
    }

    /// Sorts by time, then kind, then image: a total order, so the result never depends on
    /// the order of discovery.
    pub fn sort(&mut self) {
        let mut idx: Vec<usize> = (0..self.arrivals.len()).collect();
        idx.sort_by(|&a, &b| {
            let (x, y) = (&self.arrivals[a], &self.arrivals[b]);
            x.time_s.total_cmp(&y.time_s).then(x.kind.cmp(&y.kind)).then(x.image.cmp(&y.image))
        });
        let nb = self.n_bands;
        let arrivals = idx.iter().map(|&i| self.arrivals[i].clone()).collect();
        let energy = idx.iter().flat_map(|&i| self.energy[i * nb..(i + 1) * nb].iter().copied()).collect();
        self.arrivals = arrivals;
        self.energy = energy;
    }

    pub fn into_parts(self) -> (Vec<Arrival>, Vec<f64>) {
        (self.arrivals, self.energy)
    }
}
