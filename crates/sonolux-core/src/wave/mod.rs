//! The wave solver: finite-difference time-domain acoustics on a regular grid, for the low bands
//! where rays are the wrong model.
//!
//! A run voxelises the scene's closed mesh once ([`voxel`]), fits each material's absorption per
//! band to a passive wall admittance ([`fit`], [`admittance`]), and advances the pressure with the 7-point
//! leapfrog scheme ([`scheme`]) whose boundary nodes carry those walls in finite-volume form
//! ([`boundary`]). Sources emit a band-limited pulse ([`source`]); receivers record pressure and
//! particle velocity ([`receiver`]); [`bands`] turns them into energy per band, time bin and
//! arrival direction, with the air's absorption, in the tracer's layout. What a run costs is
//! known before it starts ([`settings`]).
//!
//! Shapes of what comes back (all contiguous, row-major):
//! - pressure `[receiver][time]`, Pa; velocity `[receiver][axis x, y, z][time]`, m/s; sample n
//!   is at t = n·Δt from the start of the run, and the source pulse is centred at
//!   [`SourcePulse::delay_s`];
//! - the grid `[x][y][z]` (z fastest), see [`grid::Grid`].
//!
//! Results are the same bits for any thread count: every node's update is a fixed expression of
//! the previous fields, and every sum runs in a fixed order.

pub mod admittance;
pub mod bands;
pub mod boundary;
mod direct;
pub mod fit;
mod fit_targets;
pub mod grid;
mod lsq;
pub mod receiver;
pub mod scheme;
pub mod settings;
pub mod source;
pub mod voxel;
pub mod wells;

use std::time::Instant;

use glam::DVec3;

use crate::error::CoreError;
use crate::mesh::Mesh;
use crate::parallel::Progress;
pub use boundary::BoundaryStats;
pub use admittance::{Admittance, Branch, Discretisation};
pub use fit::MaterialFit;
pub use grid::Grid;
pub use scheme::WaveSolver;
pub use settings::{AbsorptionKind, MemoryEstimate, SceneSize, WaveSettings, COURANT_LIMIT, COURANT_MAX};
pub use source::{SourcePulse, SourceTerm, Sources};
pub use voxel::VoxelStats;
pub use wells::Wells;

/// Absorption of each material per band: `absorption` is `[material][band]`, flattened, at the
/// band centres `band_centres_hz` (any number of bands, increasing).
#[derive(Clone, Debug, PartialEq)]
pub struct WaveMaterials {
    pub band_centres_hz: Vec<f64>,
    pub absorption: Vec<f64>,
    /// Per material, its surface's wells ([`wells`]), or None (a flat wall); empty: none has.
    pub wells: Vec<Option<Wells>>,
}

impl WaveMaterials {
    pub fn n_bands(&self) -> usize {
        self.band_centres_hz.len()
    }

    /// Checks the table against the mesh's material ids.
    pub fn validate(&self, mesh: &Mesh) -> Result<(), CoreError> {
        let nb = self.n_bands();
        if nb == 0 {
            return Err(CoreError::invalid("band_centres_hz", "at least one band is needed"));
        }
        if self.band_centres_hz.iter().any(|f| !(f.is_finite() && *f > 0.0)) || self.band_centres_hz.windows(2).any(|w| !(w[1] > w[0])) {
            return Err(CoreError::invalid("band_centres_hz", format!("{:?} must be positive and increasing", self.band_centres_hz)));
        }
        let n_mat = mesh.material.iter().map(|&m| m as usize + 1).max().unwrap_or(0);
        if self.absorption.len() != n_mat * nb {
            return Err(CoreError::invalid(
                "absorption",
                format!("{} values given; the mesh names {n_mat} materials × {nb} bands = {}", self.absorption.len(), n_mat * nb),
            ));
        }
        if let Some(i) = self.absorption.iter().position(|a| !(0.0..=1.0).contains(a)) {
            return Err(CoreError::invalid(
                "absorption",
                format!("material {} band {} is {}, outside [0, 1]", i / nb, i % nb, self.absorption[i]),
            ));
        }
        Ok(())
    }
}

/// What a run did and what it cost.
#[derive(Clone, Debug)]
pub struct WaveStats {
    pub spacing_m: f64,
    pub time_step_s: f64,
    /// Nodes along x, y, z, and in all.
    pub dims: [usize; 3],
    pub cells: u64,
    pub air_cells: u64,
    pub voxels: VoxelStats,
    pub boundary: BoundaryStats,
    /// Each material's fit, by material id.
    pub fits: Vec<MaterialFit>,
    pub estimate: MemoryEstimate,
    /// Bytes the solver holds once built ([`WaveSolver::allocated_bytes`]): what the estimate's
    /// grid and boundary parts bound.
    pub allocated_bytes: u64,
    pub steps: u64,
    pub setup_s: f64,
    pub run_s: f64,
    /// Air-cell updates per second of the run (all threads).
    pub air_updates_per_s: f64,
}

/// The result of [`simulate_waves`].
#[derive(Clone, Debug)]
pub struct WaveResult {
    pub sample_rate_hz: f64,
    pub n_receivers: usize,
    /// Samples per receiver (fewer than planned when cancelled).
    pub n_samples: usize,
    /// `[receiver][time]`, Pa.
    pub pressure_pa: Vec<f32>,
    /// `[receiver][axis][time]`, m/s.
    pub velocity_m_s: Vec<f32>,
    pub pulse: SourcePulse,
    /// The pulse's free-field pressure at 1 m without propagation delay, `[time]`: what the
    /// responses are normalised by to become impulse responses or energies per joule.
    pub source_pressure_1m_pa: Vec<f64>,
    pub stats: WaveStats,
    pub cancelled: bool,
}

impl WaveResult {
    /// Receiver `r`'s pressure (`channel` 0) or velocity along x, y, z (1, 2, 3), over time.
    pub fn pressure_or_velocity(&self, r: usize, channel: usize) -> &[f32] {
        let n = self.n_samples;
        match channel {
            0 => &self.pressure_pa[r * n..(r + 1) * n],
            c => &self.velocity_m_s[(3 * r + c - 1) * n..(3 * r + c) * n],
        }
    }
}

/// Slabs are about this many: enough to share among threads, independent of their number.
const TARGET_SLABS: usize = 64;

/// Voxelises the scene, fits its walls and allocates the fields (after checking the memory
/// estimate for `n_receivers`). Returns the solver, the fits and the voxelisation's counts.
pub fn build_solver(
    mesh: &Mesh,
    materials: &WaveMaterials,
    settings: &WaveSettings,
    n_receivers: usize,
) -> Result<(WaveSolver, WaveStats), CoreError> {
    let start = Instant::now();
    settings.validate()?;
    materials.validate(mesh)?;
    // The walls are fitted first (small and quick): the estimate counts their branches.
    let fits = fit_walls(materials, settings)?;
    let scene = SceneSize::of(mesh).with_wells(&materials.wells).with_fits(&fits);
    let fitted = settings::bands_fitted(&materials.band_centres_hz, settings.max_frequency_hz);
    let estimate = settings.memory_estimate(&scene, n_receivers, fitted);
    settings.check_memory(&estimate, &scene, n_receivers, &materials.band_centres_hz)?;

    let nb = materials.n_bands();
    let (walls, choice) = wells::expand(fits, &materials.wells, settings.speed_of_sound_m_s, settings.max_frequency_hz)?;
    let (solver, mut stats) = assemble(mesh, walls, &choice, settings, estimate, start)?;
    stats.fits.truncate(materials.absorption.len() / nb);
    Ok((solver, stats))
}

/// Each material's wall fitted to its absorption per band at `settings`' grid (by material id).
fn fit_walls(materials: &WaveMaterials, settings: &WaveSettings) -> Result<Vec<fit::MaterialFit>, CoreError> {
    let (a2, _) = scheme::coefficients(settings.courant);
    let scheme = admittance::Discretisation { time_step_s: settings.time_step_s(), courant: (a2 as f64).sqrt() };
    materials
        .absorption
        .chunks(materials.n_bands())
        .map(|a| fit::fit_material(&materials.band_centres_hz, a, settings.absorption_kind, settings.max_frequency_hz, Some(scheme)))
        .collect()
}

/// The branches of each material's fitted wall (by material id) as [`build_solver`] will fit
/// them: for the memory estimate before a run ([`SceneSize::with_fitted_branches`]).
pub fn wall_branches(materials: &WaveMaterials, settings: &WaveSettings) -> Result<Vec<usize>, CoreError> {
    Ok(wall_fits(materials, settings)?.iter().map(|f| f.admittance.branches.len()).collect())
}

/// Each material's fitted wall (by material id) as [`build_solver`] will fit it: for the memory
/// estimate before a run ([`SceneSize::with_fits`]: branches, and which walls are rigid).
pub fn wall_fits(materials: &WaveMaterials, settings: &WaveSettings) -> Result<Vec<fit::MaterialFit>, CoreError> {
    settings.validate()?;
    if materials.n_bands() == 0 {
        return Err(CoreError::invalid("band_centres_hz", "at least one band is needed"));
    }
    fit_walls(materials, settings)
}

/// [`build_solver`] with each material's wall admittance given (one per material id of the
/// mesh) instead of fitted to absorption per band: for boundary models that are not a fit to
/// band values, such as the phase-grating wells of Kowalczyk, van Walstijn and Murphy (IEEE
/// TASLP 19(3), 2011) written as Foster branches (tests/wave_scattering.rs). Every branch must
/// be passive (D, E, F ≥ 0): the walls are then stable by construction ([`boundary`]).
pub fn build_solver_with_walls(mesh: &Mesh, walls: &[Admittance], settings: &WaveSettings, n_receivers: usize) -> Result<(WaveSolver, WaveStats), CoreError> {
    let start = Instant::now();
    settings.validate()?;
    let n_mat = mesh.material.iter().map(|&m| m as usize + 1).max().unwrap_or(0);
    if walls.len() != n_mat {
        return Err(CoreError::invalid("walls", format!("{} admittances given; the mesh names {n_mat} materials", walls.len())));
    }
    let passive = |b: &Branch| b.mass_s >= 0.0 && b.resistance >= 0.0 && b.stiffness_per_s >= 0.0 && b.mass_s + b.resistance > 0.0;
    if let Some(i) = walls.iter().position(|w| !(w.conductance >= 0.0) || !w.branches.iter().all(passive)) {
        return Err(CoreError::invalid("walls", format!("material {i}'s admittance is not passive (every conductance, mass, resistance and stiffness must be ≥ 0, and each branch needs a mass or a resistance)")));
    }
    let scene = SceneSize { rigid: walls.iter().map(|w| w.is_rigid()).collect(), ..SceneSize::of(mesh).with_fitted_branches(walls.iter().map(|w| w.branches.len()).collect()) };
    let estimate = settings.memory_estimate(&scene, n_receivers, 0);
    if estimate.total_bytes > settings.memory_limit_bytes {
        return Err(CoreError::invalid("max_frequency_hz", format!("the run needs {} bytes, more than the limit of {}", estimate.total_bytes, settings.memory_limit_bytes)));
    }
    let fits = walls
        .iter()
        .map(|y| fit::MaterialFit { admittance: y.clone(), n_bands_fitted: 0, target_normal: Vec::new(), fitted_normal: Vec::new(), error_db: Vec::new(), clamped: false, ripple_tolerance: 0.0 })
        .collect();
    assemble(mesh, fits, &wells::WallChoice::none(), settings, estimate, start)
}

/// The solver for `mesh` with the walls of `fits` (one per material id, then the wells' walls
/// that `choice` picks among).
fn assemble(mesh: &Mesh, fits: Vec<fit::MaterialFit>, choice: &wells::WallChoice, settings: &WaveSettings, estimate: MemoryEstimate, start: Instant) -> Result<(WaveSolver, WaveStats), CoreError> {
    let h = settings.spacing_m();
    let dt = settings.time_step_s();
    let mut grid = Grid::over(&mesh.bounds(), h)?;
    let (faces, voxels) = voxel::voxelise(mesh, &mut grid)?;
    let (a2, _) = scheme::coefficients(settings.courant);
    let walls: Vec<boundary::DiscreteWall> = fits.iter().map(|f| boundary::DiscreteWall::new(&f.admittance, dt)).collect();

    let nx = grid.dims[0];
    let thickness = nx.div_ceil(TARGET_SLABS).max(1);
    let plane = grid.strides()[0];
    let n_slabs = nx.div_ceil(thickness);
    let slab_of = |index: usize| index / plane / thickness;
    let wall_of = |f: &voxel::Face| choice.wall(&grid, f, mesh.material[f.tri as usize]);
    let (boundaries, boundary_stats) = boundary::build(&grid, mesh, &faces, &walls, a2 as f64, slab_of, n_slabs, wall_of);
    let strides = grid.strides();
    let mut shells: Vec<Vec<u32>> = vec![Vec::new(); n_slabs];
    for f in &faces {
        let s = strides[f.dir as usize / 2];
        let m = if f.dir % 2 == 1 { f.node as usize + s } else { f.node as usize - s };
        shells[slab_of(m)].push(m as u32);
    }
    let slabs = boundaries
        .into_iter()
        .zip(shells)
        .enumerate()
        .map(|(i, (boundary, mut shell))| {
            shell.sort_unstable();
            shell.dedup();
            shell.shrink_to_fit();
            let first = i * thickness;
            scheme::Slab { first, planes: thickness.min(nx - first), boundary, shell }
        })
        .collect();
    drop(faces);
    let stats = WaveStats {
        spacing_m: h,
        time_step_s: dt,
        dims: grid.dims,
        cells: grid.cells() as u64,
        air_cells: grid.air_cells() as u64,
        voxels,
        boundary: boundary_stats,
        fits,
        estimate,
        allocated_bytes: 0,
        steps: 0,
        setup_s: 0.0,
        run_s: 0.0,
        air_updates_per_s: 0.0,
    };
    let solver = WaveSolver::assemble(grid, slabs, walls, settings.courant, settings.threads)?;
    let allocated_bytes = solver.allocated_bytes();
    Ok((solver, WaveStats { setup_s: start.elapsed().as_secs_f64(), allocated_bytes, ..stats }))
}

/// Simulates the response at `receivers` to every source in `sources` emitting the same pulse at
/// once (coherently: for incoherent sources, run each alone). `progress` is called about every
/// 100 ms with steps done; returning false stops the run after the current step.
pub fn simulate_waves(
    mesh: &Mesh,
    materials: &WaveMaterials,
    sources: &[DVec3],
    receivers: &[DVec3],
    settings: &WaveSettings,
    progress: impl FnMut(&Progress) -> bool,
) -> Result<WaveResult, CoreError> {
    simulate_waves_observed(mesh, materials, sources, receivers, settings, progress, |_| {})
}

/// [`simulate_waves`] of any [`Sources`]: omnidirectional monopoles, or the terms of a
/// directional source (a cluster of monopoles, each with its own signal).
pub fn simulate_sources(
    mesh: &Mesh,
    materials: &WaveMaterials,
    sources: &Sources,
    receivers: &[DVec3],
    settings: &WaveSettings,
    progress: impl FnMut(&Progress) -> bool,
) -> Result<WaveResult, CoreError> {
    run(mesh, materials, sources, receivers, settings, progress, |_| {})
}

/// [`simulate_waves`], with `observe` shown the solver after every step: the whole pressure field
/// ([`WaveSolver::pressure`], every cell a receiver for free) for snapshots, pictures or
/// checkpoints, at no cost when it returns at once.
pub fn simulate_waves_observed(
    mesh: &Mesh,
    materials: &WaveMaterials,
    sources: &[DVec3],
    receivers: &[DVec3],
    settings: &WaveSettings,
    progress: impl FnMut(&Progress) -> bool,
    observe: impl FnMut(&WaveSolver),
) -> Result<WaveResult, CoreError> {
    run(mesh, materials, &Sources::Monopoles(sources), receivers, settings, progress, observe)
}

fn run(
    mesh: &Mesh,
    materials: &WaveMaterials,
    sources: &Sources,
    receivers: &[DVec3],
    settings: &WaveSettings,
    mut progress: impl FnMut(&Progress) -> bool,
    mut observe: impl FnMut(&WaveSolver),
) -> Result<WaveResult, CoreError> {
    let (mut solver, mut stats) = build_solver(mesh, materials, settings, receivers.len())?;
    let dt = settings.time_step_s();
    let pulse = sources.pulse(settings.max_frequency_hz, settings.air_density_kg_m3);
    let injector = source::Injector::of(solver.grid(), sources, pulse, settings.speed_of_sound_m_s, dt)?;
    let stencils = receivers
        .iter()
        .enumerate()
        .map(|(i, p)| source::weights_in_air(solver.grid(), *p, "receiver", i))
        .collect::<Result<Vec<_>, _>>()?;
    let steps = settings.n_steps();
    let mut recorder = receiver::Recorder::new(stencils, steps as usize, dt, settings.air_density_kg_m3);

    let start = Instant::now();
    let mut last_report = start;
    let mut inject = Vec::new();
    let mut cancelled = false;
    let mut done = 0u64;
    while done < steps {
        let n = done;
        solver.install(|s| recorder.record(n as usize, s.pressure(), s.grid()));
        injector.at_step(n, &mut inject);
        solver.step(&inject);
        observe(&solver);
        done += 1;
        if last_report.elapsed().as_millis() >= 100 || done == steps {
            last_report = Instant::now();
            if !progress(&Progress { done, total: steps, elapsed: start.elapsed() }) && done < steps {
                cancelled = true;
                break;
            }
        }
    }
    recorder.truncate(done as usize);
    stats.steps = done;
    stats.run_s = start.elapsed().as_secs_f64();
    stats.air_updates_per_s = stats.air_cells as f64 * done as f64 / stats.run_s.max(1e-9);
    let source_pressure_1m_pa = (0..recorder.n_samples).map(|n| pulse.pressure_at_1m(n as f64 * dt)).collect();
    Ok(WaveResult {
        sample_rate_hz: 1.0 / dt,
        n_receivers: receivers.len(),
        n_samples: recorder.n_samples,
        pressure_pa: recorder.pressure,
        velocity_m_s: recorder.velocity,
        pulse,
        source_pressure_1m_pa,
        stats,
        cancelled,
    })
}
