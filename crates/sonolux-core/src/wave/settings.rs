//! What a wave simulation is asked to do, checked once, and what it will cost before anything
//! large is allocated: cells, time steps and bytes, and the highest frequency that fits a
//! memory budget.

use glam::DVec3;

use crate::error::CoreError;
use crate::mesh::Mesh;

/// The stability limit of the standard rectilinear scheme in exact arithmetic,
/// λ = cΔt/Δx ≤ 1/√3 (see [`super::scheme`]).
pub const COURANT_LIMIT: f64 = 0.577_350_269_189_625_8;

/// The largest Courant number allowed, and the default: 0.999 of the limit. At the limit itself
/// the grid's Nyquist mode (k = (π, π, π)/Δx) has a double root, and the rounding of f32 updates,
/// which perturbs the coefficients by more than f32(1/3) lies below 1/3, makes it grow: a small
/// rigid box started from noise doubled its energy every ~2,500 steps. At 0.999 the mode sits
/// 0.09 rad below Nyquist, far beyond rounding, for a phase error that grows by less than 0.01%
/// (pffdtd backs off by the same factor, Hamilton 2021).
pub const COURANT_MAX: f64 = 0.999 * COURANT_LIMIT;

/// How the absorption coefficients handed in per band are meant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AbsorptionKind {
    /// Random-incidence (statistical, "Sabine") coefficients, as the tracer uses them: each band
    /// is converted to the real wall admittance whose random-incidence absorption it is (Paris'
    /// formula), and that admittance's normal-incidence absorption becomes the fit's target.
    RandomIncidence,
    /// Normal-incidence coefficients (impedance-tube data), fitted directly.
    NormalIncidence,
}

/// Everything a wave simulation needs besides the scene. Units are in the names.
#[derive(Clone, Debug, PartialEq)]
pub struct WaveSettings {
    /// Highest frequency the result is meant for; sets the grid spacing.
    pub max_frequency_hz: f64,
    /// Grid points per wavelength at `max_frequency_hz`. 10 keeps the scheme's phase-velocity
    /// error at that frequency below 1.2% in the worst (axial) direction, 0 along diagonals.
    pub points_per_wavelength: f64,
    /// Courant number λ = cΔt/Δx, at most [`COURANT_MAX`] (the default: the best dispersion).
    pub courant: f64,
    /// Length of the response.
    pub duration_s: f64,
    pub speed_of_sound_m_s: f64,
    pub air_density_kg_m3: f64,
    pub absorption_kind: AbsorptionKind,
    /// Worker threads, 0 = all cores. Does not change the result.
    pub threads: usize,
    /// The run is refused when its estimate exceeds this.
    pub memory_limit_bytes: u64,
}

impl Default for WaveSettings {
    fn default() -> Self {
        WaveSettings {
            max_frequency_hz: 500.0,
            points_per_wavelength: 10.0,
            courant: COURANT_MAX,
            duration_s: 1.0,
            speed_of_sound_m_s: 343.0,
            air_density_kg_m3: 1.2,
            absorption_kind: AbsorptionKind::RandomIncidence,
            threads: 0,
            memory_limit_bytes: 4 << 30,
        }
    }
}

impl WaveSettings {
    pub fn validate(&self) -> Result<(), CoreError> {
        let positive = |what: &str, v: f64| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(CoreError::invalid(what, format!("{v} is not a positive finite number")))
            }
        };
        positive("max_frequency_hz", self.max_frequency_hz)?;
        positive("duration_s", self.duration_s)?;
        positive("speed_of_sound_m_s", self.speed_of_sound_m_s)?;
        positive("air_density_kg_m3", self.air_density_kg_m3)?;
        if !(4.0..=100.0).contains(&self.points_per_wavelength) {
            return Err(CoreError::invalid(
                "points_per_wavelength",
                format!("{} is outside 4..100 (below 4 the phase error passes 10%)", self.points_per_wavelength),
            ));
        }
        if !(self.courant > 0.0 && self.courant <= COURANT_MAX) {
            return Err(CoreError::invalid(
                "courant",
                format!(
                    "{} is outside (0, {COURANT_MAX:.6}]: the scheme is unstable above 1/√3 = {COURANT_LIMIT:.6}, and in f32 above 0.999 of it",
                    self.courant
                ),
            ));
        }
        if self.memory_limit_bytes == 0 {
            return Err(CoreError::invalid("memory_limit_bytes", "must be positive"));
        }
        if self.n_steps() > u32::MAX as u64 {
            return Err(CoreError::invalid("duration_s", format!("{} s needs more than 2³² steps", self.duration_s)));
        }
        Ok(())
    }

    /// Grid spacing Δx = c / (f_max · points per wavelength).
    pub fn spacing_m(&self) -> f64 {
        self.speed_of_sound_m_s / (self.max_frequency_hz * self.points_per_wavelength)
    }

    /// Time step Δt = λ Δx / c.
    pub fn time_step_s(&self) -> f64 {
        self.courant * self.spacing_m() / self.speed_of_sound_m_s
    }

    pub fn sample_rate_hz(&self) -> f64 {
        1.0 / self.time_step_s()
    }

    pub fn n_steps(&self) -> u64 {
        (self.duration_s / self.time_step_s()).ceil() as u64
    }

    /// What a run on `scene` with `n_receivers` receivers would hold at its peak, before anything
    /// is voxelised or allocated. `n_bands_fitted` is the number of bands whose centre lies
    /// below the fit's limit (each is at most one boundary branch; see [`super::fit`]).
    ///
    /// Each material's faces carry its wall's branches: its fit's count where the scene knows it
    /// ([`SceneSize::with_fitted_branches`], [`super::wall_branches`]: what the run will build),
    /// else one per fitted band (the fit usually needs no more, but can: 4 for 2 bands was
    /// measured, tests/wave_memory.rs); and where the material has wells (a described surface,
    /// [`super::wells`]), [`super::wells::well_branch_count`] of its deepest well at this
    /// `max_frequency_hz` ([`SceneSize::with_wells`]).
    pub fn memory_estimate(&self, scene: &SceneSize, n_receivers: usize, n_bands_fitted: usize) -> MemoryEstimate {
        let h = self.spacing_m();
        // Per material, the branches of each face, or None for a rigid wall without wells.
        let branches: Vec<Option<u64>> = (0..scene.staircase_by_material_m2.len())
            .map(|m| {
                let fit = scene.fitted_branches.get(m).copied().unwrap_or(n_bands_fitted);
                let well = scene.deepest_well_m.get(m).map_or(0, |&d| super::wells::well_branch_count(d, self.speed_of_sound_m_s, self.max_frequency_hz));
                let rigid = scene.rigid.get(m).copied().unwrap_or(false) && scene.deepest_well_m.get(m).is_none_or(|&d| d == 0.0);
                (!rigid).then_some((fit + well) as u64)
            })
            .collect();
        estimate(h, self.n_steps(), scene, n_receivers, &branches)
    }

    /// The highest `max_frequency_hz` (other settings kept) whose estimate fits `budget_bytes`,
    /// or None when not even 1 Hz fits.
    pub fn max_frequency_within(
        &self,
        scene: &SceneSize,
        n_receivers: usize,
        band_centres_hz: &[f64],
        budget_bytes: u64,
    ) -> Option<f64> {
        // The fits' own counts hold at this frequency only: the bisection counts a branch per
        // fitted band (the largest frequency named is a suggestion, checked when it is run).
        let scene = &SceneSize { fitted_branches: Vec::new(), rigid: Vec::new(), ..scene.clone() };
        let bytes = |f: f64| {
            let s = WaveSettings { max_frequency_hz: f, ..self.clone() };
            let fitted = bands_fitted(band_centres_hz, f);
            s.memory_estimate(scene, n_receivers, fitted).total_bytes
        };
        let (mut lo, mut hi) = (1.0, 1.0);
        if bytes(lo) > budget_bytes {
            return None;
        }
        while bytes(hi) <= budget_bytes {
            lo = hi;
            hi *= 2.0;
            if hi > 1e6 {
                return Some(lo);
            }
        }
        // Memory grows with frequency (cells ∝ f³, steps ∝ f): bisect to 0.1%.
        while hi / lo > 1.001 {
            let mid = (lo * hi).sqrt();
            if bytes(mid) <= budget_bytes {
                lo = mid
            } else {
                hi = mid
            }
        }
        Some(lo)
    }

    /// Fails with the largest frequency that would fit when the estimate exceeds the limit.
    pub fn check_memory(&self, estimate: &MemoryEstimate, scene: &SceneSize, n_receivers: usize, band_centres_hz: &[f64]) -> Result<(), CoreError> {
        if estimate.total_bytes <= self.memory_limit_bytes {
            return Ok(());
        }
        let fits = match self.max_frequency_within(scene, n_receivers, band_centres_hz, self.memory_limit_bytes) {
            Some(f) => format!("the largest max_frequency_hz that fits is {f:.0} Hz"),
            None => "nothing fits: lower the duration or the receivers".to_string(),
        };
        Err(CoreError::invalid(
            "memory_limit_bytes",
            format!(
                "the wave simulation needs about {:.2} GB ({} cells × {} steps at {:.0} Hz, {} receivers) but the limit is {:.2} GB; {fits}",
                estimate.total_bytes as f64 / 1e9,
                estimate.cells,
                estimate.steps,
                self.max_frequency_hz,
                n_receivers,
                self.memory_limit_bytes as f64 / 1e9
            ),
        ))
    }
}

/// The number of bands the boundary fit uses: those centred at most
/// [`super::fit::FIT_LIMIT_RATIO`] × the maximum frequency.
pub fn bands_fitted(band_centres_hz: &[f64], max_frequency_hz: f64) -> usize {
    band_centres_hz.iter().filter(|&&f| f <= super::fit::FIT_LIMIT_RATIO * max_frequency_hz).count()
}

/// What the memory estimate needs to know of a scene: its box, and the staircase area of its
/// surfaces, Σ area · (|n_x| + |n_y| + |n_z|), which is the number of air–solid cell faces
/// times Δx² once voxelised; per material too, with the depth of its deepest well where the
/// material has wells (their branches add state to each of its faces).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSize {
    pub extent_m: DVec3,
    pub staircase_area_m2: f64,
    /// Per material id, its part of `staircase_area_m2`.
    pub staircase_by_material_m2: Vec<f64>,
    /// Per material id, its deepest well (m), 0 for a flat wall; empty: no wells.
    pub deepest_well_m: Vec<f64>,
    /// Per material id, the branches of its fitted wall; empty: one per fitted band is assumed.
    pub fitted_branches: Vec<usize>,
    /// Per material id, whether its fitted wall is rigid (no conductance, no branches: its
    /// faces' nodes hold only the rigid node's 8 bytes and the shell's 4, when it has no wells);
    /// empty: every material is counted as lossy.
    pub rigid: Vec<bool>,
}

impl SceneSize {
    pub fn of(mesh: &Mesh) -> SceneSize {
        let b = mesh.bounds();
        let n_mat = mesh.material.iter().map(|&m| m as usize + 1).max().unwrap_or(0);
        let mut staircase_by_material_m2 = vec![0.0; n_mat];
        for i in (0..mesh.triangles.len()).filter(|&i| !mesh.degenerate[i]) {
            let n = mesh.normal(i).as_dvec3();
            staircase_by_material_m2[mesh.material[i] as usize] += mesh.area(i) * (n.x.abs() + n.y.abs() + n.z.abs());
        }
        let staircase_area_m2 = staircase_by_material_m2.iter().sum();
        let extent_m = if b.min.x <= b.max.x { (b.max - b.min).as_dvec3() } else { DVec3::ZERO };
        SceneSize { extent_m, staircase_area_m2, staircase_by_material_m2, deepest_well_m: Vec::new(), fitted_branches: Vec::new(), rigid: Vec::new() }
    }

    /// The same scene whose materials' fitted walls have `counts` branches (per material id, at
    /// the settings' `max_frequency_hz`; [`super::wall_branches`]).
    pub fn with_fitted_branches(mut self, counts: Vec<usize>) -> SceneSize {
        self.fitted_branches = counts;
        self
    }

    /// The same scene whose materials' walls are `fits` (per material id, at the settings'
    /// `max_frequency_hz`; [`super::wall_fits`]): their branches, and which are rigid.
    pub fn with_fits(self, fits: &[super::MaterialFit]) -> SceneSize {
        let rigid = fits.iter().map(|f| f.admittance.is_rigid()).collect();
        SceneSize { rigid, ..self.with_fitted_branches(fits.iter().map(|f| f.admittance.branches.len()).collect()) }
    }

    /// The same scene whose materials have `wells` (per material id, as
    /// [`super::WaveMaterials::wells`]; empty: none).
    pub fn with_wells(mut self, wells: &[Option<super::Wells>]) -> SceneSize {
        self.deepest_well_m = (0..self.staircase_by_material_m2.len())
            .map(|m| wells.get(m).and_then(|w| w.as_ref()).map_or(0.0, |w| w.depths_m.iter().fold(0.0, |a: f64, &d| a.max(d))))
            .collect();
        self
    }
}

/// Bytes and counts of a run, as estimated before it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryEstimate {
    /// Grid nodes, air and solid, padding included.
    pub cells: u64,
    pub steps: u64,
    /// Air–solid cell faces (an upper bound on boundary entries).
    pub boundary_faces: u64,
    /// Two pressure grids, the air mask and the sweep's runs.
    pub grid_bytes: u64,
    /// Boundary nodes and the state of their admittance branches.
    pub boundary_bytes: u64,
    /// Recorded pressure and velocity at the receivers.
    pub receiver_bytes: u64,
    /// Voxelisation's temporary crossings (freed before the grids are allocated).
    pub setup_bytes: u64,
    /// The peak: the larger of setup and run.
    pub total_bytes: u64,
}

/// Bytes per grid node: two f32 pressure grids and one byte of air mask.
const BYTES_PER_CELL: u64 = 4 + 4 + 1;
use super::boundary::{BYTES_PER_BRANCH, BYTES_PER_FACE, BYTES_PER_RIGID_FACE};
/// A surface crossing of a grid line during voxelisation (position, triangle, line, sign).
const BYTES_PER_CROSSING: u64 = 24;

/// `branches`: per material id, the branches each of its faces carries (None: a rigid wall).
fn estimate(h: f64, steps: u64, scene: &SceneSize, n_receivers: usize, branches: &[Option<u64>]) -> MemoryEstimate {
    let n = |e: f64| (e / h - 1e-6).ceil().max(1.0) as u64 + 2;
    let (nx, ny) = (n(scene.extent_m.x), n(scene.extent_m.y));
    let cells = nx * ny * n(scene.extent_m.z);
    let boundary_faces = (scene.staircase_area_m2 / (h * h)).ceil() as u64;
    // The sweep's runs: at most one (start, length) of u32 per row of a plane, and an offset per
    // plane (scheme.rs `sweep_runs`).
    let grid_bytes = cells * BYTES_PER_CELL + nx * ny * 8 + (nx + 1) * 4;
    let boundary_bytes = scene
        .staircase_by_material_m2
        .iter()
        .zip(branches)
        .map(|(&area, &b)| (area / (h * h)).ceil() as u64 * b.map_or(BYTES_PER_RIGID_FACE, |b| BYTES_PER_FACE + b * BYTES_PER_BRANCH))
        .sum();
    // Pressure and three velocity components per receiver and step, in f32, and the source's
    // pulse in f64.
    let receiver_bytes = n_receivers as u64 * steps * 16 + steps * 8;
    let setup_bytes = cells + boundary_faces * BYTES_PER_CROSSING * 2;
    let run = grid_bytes + boundary_bytes + receiver_bytes;
    MemoryEstimate {
        cells,
        steps,
        boundary_faces,
        grid_bytes,
        boundary_bytes,
        receiver_bytes,
        setup_bytes,
        total_bytes: run.max(setup_bytes),
    }
}
