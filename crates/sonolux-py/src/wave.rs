//! Binding of the wave solver: a settings object in, the pressure and velocity responses (and,
//! given the bake's binning, the energy per band, direction and time bin) out as numpy arrays.
//!
//! `WaveSettings` checks itself when it is made (`sonolux_core::wave::WaveSettings::validate`),
//! so a bad value is an `InvalidInputError` naming the setting before anything runs; the rest
//! (materials against the mesh, receivers in the air, the memory estimate) is checked by the
//! core when `simulate_waves` starts, before anything large is allocated.

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use sonolux_core::glam_export::DVec3;
use sonolux_core::wave as core;

use crate::sound::SoundSettings;
use crate::{check_threads, invalid, to_py, Geometry};

/// How to run the wave solver (keyword arguments; see `sonolux_core::wave::WaveSettings`):
/// max_frequency_hz sets the grid (Δx = c / (f · points_per_wavelength)), duration_s the
/// response's length; absorption_kind "random" (the tracer's coefficients, default) or
/// "normal" (impedance-tube data); threads 0 = all cores; memory_limit_bytes refuses larger runs.
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct WaveSettings {
    inner: core::WaveSettings,
}

#[pymethods]
impl WaveSettings {
    #[new]
    #[pyo3(signature = (
        *, max_frequency_hz, duration_s, points_per_wavelength = 10.0, courant = core::COURANT_MAX,
        speed_of_sound_m_s = 343.0, air_density_kg_m3 = 1.2, absorption_kind = "random", threads = 0,
        memory_limit_bytes = 4u64 << 30
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        max_frequency_hz: f64,
        duration_s: f64,
        points_per_wavelength: f64,
        courant: f64,
        speed_of_sound_m_s: f64,
        air_density_kg_m3: f64,
        absorption_kind: &str,
        threads: usize,
        memory_limit_bytes: u64,
    ) -> PyResult<Self> {
        let absorption_kind = match absorption_kind {
            "random" => core::AbsorptionKind::RandomIncidence,
            "normal" => core::AbsorptionKind::NormalIncidence,
            other => return Err(invalid(format!("absorption_kind: '{other}' is not one of 'random', 'normal'"))),
        };
        let inner = core::WaveSettings {
            max_frequency_hz,
            points_per_wavelength,
            courant,
            duration_s,
            speed_of_sound_m_s,
            air_density_kg_m3,
            absorption_kind,
            threads: check_threads(threads)?,
            // Never more than this machine has.
            memory_limit_bytes: memory_limit_bytes.min(crate::available_memory_bytes()),
        };
        inner.validate().map_err(to_py)?;
        Ok(WaveSettings { inner })
    }

    #[getter]
    fn spacing_m(&self) -> f64 {
        self.inner.spacing_m()
    }

    #[getter]
    fn sample_rate_hz(&self) -> f64 {
        self.inner.sample_rate_hz()
    }

    #[getter]
    fn steps(&self) -> u64 {
        self.inner.n_steps()
    }

    #[getter]
    fn memory_limit_bytes(&self) -> u64 {
        self.inner.memory_limit_bytes
    }

    /// What a run on `geometry` with `n_receivers` would take, before anything is allocated:
    /// a dict of cells, steps, boundary_faces, grid/boundary/receiver/setup/total bytes.
    /// `absorption` float64[material, band]: the walls are fitted as the run will fit them and
    /// their branches counted (else one per fitted band is assumed); `wells`: {material: (depths
    /// m, patch m)} as for simulate_waves (their branches' state).
    #[pyo3(signature = (geometry, n_receivers, band_centres_hz, absorption = None, wells = None))]
    fn memory_estimate<'py>(&self, py: Python<'py>, geometry: &Geometry, n_receivers: usize, band_centres_hz: Vec<f64>, absorption: Option<PyReadonlyArray2<'py, f64>>, wells: Option<std::collections::BTreeMap<usize, (Vec<f64>, f64)>>) -> PyResult<Bound<'py, PyDict>> {
        let n_mat = geometry.mesh.material.iter().map(|&m| m as usize + 1).max().unwrap_or(0);
        let mut scene = core::SceneSize::of(&geometry.mesh).with_wells(&wells_per_material(wells, n_mat, "the geometry")?);
        if let Some(a) = absorption {
            let a = a.as_array();
            let materials = core::WaveMaterials { band_centres_hz: band_centres_hz.clone(), absorption: a.iter().copied().collect(), wells: Vec::new() };
            if a.ncols() != band_centres_hz.len() || a.nrows() < n_mat {
                return Err(invalid(format!("absorption: shape {:?}, expected (at least {n_mat} materials, {} bands)", a.shape(), band_centres_hz.len())));
            }
            scene = scene.with_fits(&py.detach(|| core::wall_fits(&materials, &self.inner)).map_err(to_py)?);
        }
        let fitted = core::settings::bands_fitted(&band_centres_hz, self.inner.max_frequency_hz);
        let e = self.inner.memory_estimate(&scene, n_receivers, fitted);
        let d = PyDict::new(py);
        d.set_item("cells", e.cells)?;
        d.set_item("steps", e.steps)?;
        d.set_item("boundary_faces", e.boundary_faces)?;
        d.set_item("grid_bytes", e.grid_bytes)?;
        d.set_item("boundary_bytes", e.boundary_bytes)?;
        d.set_item("receiver_bytes", e.receiver_bytes)?;
        d.set_item("setup_bytes", e.setup_bytes)?;
        d.set_item("total_bytes", e.total_bytes)?;
        Ok(d)
    }

    /// The highest max_frequency_hz (other settings kept) whose estimate fits budget_bytes, or
    /// None when not even 1 Hz fits.
    fn max_frequency_within(&self, geometry: &Geometry, n_receivers: usize, band_centres_hz: Vec<f64>, budget_bytes: u64) -> Option<f64> {
        let scene = core::SceneSize::of(&geometry.mesh);
        self.inner.max_frequency_within(&scene, n_receivers, &band_centres_hz, budget_bytes)
    }
}

/// {material: (depths m, patch m)} as one entry per material (None: a flat wall).
fn wells_per_material(given: Option<std::collections::BTreeMap<usize, (Vec<f64>, f64)>>, n_materials: usize, what: &str) -> PyResult<Vec<Option<core::Wells>>> {
    let Some(given) = given else { return Ok(Vec::new()) };
    let mut per_material = vec![None; n_materials];
    for (m, (depths_m, patch_m)) in given {
        if m >= n_materials {
            return Err(invalid(format!("wells: material {m} given; {what} names {n_materials} materials")));
        }
        let w = core::Wells { depths_m, patch_m };
        w.validate(m).map_err(|e| invalid(e.to_string()))?;
        per_material[m] = Some(w);
    }
    Ok(per_material)
}

fn dvec3s(name: &str, a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<DVec3>> {
    let a = a.as_array();
    if a.ncols() != 3 {
        return Err(invalid(format!("{name}: expected shape (n, 3), got {:?}", a.shape())));
    }
    let p: Vec<DVec3> = a.rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect();
    if p.iter().any(|v| !v.is_finite()) {
        return Err(invalid(format!("{name}: every coordinate must be finite")));
    }
    Ok(p)
}

/// Runs the wave solver: every source in `sources_m` float64[s, 3] emits the same pulse at once
/// (coherently; run each alone for incoherent sources), walls from `absorption`
/// float64[material, band] at `band_centres_hz`; responses at `receivers_m` float64[r, 3].
/// `progress(done, total, elapsed_s)` counts time steps, about every 100 ms; False stops.
///
/// Returns a dict: pressure_pa float32[receiver, time], velocity_m_s float32[receiver, axis,
/// time], source_pressure_1m_pa float64[time] (the pulse's free-field pressure at 1 m, to
/// normalise by), sample_rate_hz, pulse_delay_s, cancelled, stats (a dict: spacing_m,
/// time_step_s, dims, cells, air_cells, steps, setup_s, run_s, air_updates_per_s, total_bytes,
/// fit_rms_db and fit_branches per material, clamped_bands per material). With `binning` (the
/// bake's SoundSettings: its bins, directions, speed of sound and air attenuation per band),
/// also energy float32[receiver, direction, band, time]: J/m² per joule of source energy in
/// each band, the tracer's convention, air included. With `without_direct`, that energy is the
/// room's part alone: every source's free-field direct sound is taken out of the responses first
/// (`bands::reflected_energies`; the pressure returned keeps it).
///
/// A directional source: `term_positions_m` float64[term, 3] and `term_signals_m3_s2`
/// float64[term, step], a cluster of monopoles each fed its own volume acceleration (sample n
/// at n·Δt), with the pulse that normalises the responses centred at `pulse_delay_s`; then
/// `sources_m` is not emitted (docs/waves-sources.md).
///
/// `wells`: {material: (depths m, patch m)}, the materials whose surface is a profile of wells
/// (a well of one of the depths behind every patch of their walls; sonolux_core::wave::wells).
///
/// `energy_bands` k: the energy holds the first k bands only (a hybrid's wave bands; default:
/// all), each band's numbers the same as with all. The energy's size (8 bytes a cell while it is
/// binned, 4 more for the array returned) is checked against the binning's `max_field_bytes`
/// before the run.
#[pyfunction]
#[pyo3(signature = (geometry, absorption, band_centres_hz, sources_m, receivers_m, settings, binning = None, progress = None, without_direct = false, term_positions_m = None, term_signals_m3_s2 = None, pulse_delay_s = 0.0, energy_bands = None, wells = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn simulate_waves<'py>(
    py: Python<'py>,
    geometry: &Geometry,
    absorption: PyReadonlyArray2<'py, f64>,
    band_centres_hz: Vec<f64>,
    sources_m: PyReadonlyArray2<'py, f64>,
    receivers_m: PyReadonlyArray2<'py, f64>,
    settings: &WaveSettings,
    binning: Option<PyRef<'py, SoundSettings>>,
    progress: Option<Bound<'py, PyAny>>,
    without_direct: bool,
    term_positions_m: Option<PyReadonlyArray2<'py, f64>>,
    term_signals_m3_s2: Option<PyReadonlyArray2<'py, f64>>,
    pulse_delay_s: f64,
    energy_bands: Option<usize>,
    wells: Option<std::collections::BTreeMap<usize, (Vec<f64>, f64)>>,
) -> PyResult<Bound<'py, PyDict>> {
    let terms: Vec<core::SourceTerm> = match (&term_positions_m, &term_signals_m3_s2) {
        (None, None) => Vec::new(),
        (Some(p), Some(s)) => {
            let positions = dvec3s("term_positions_m", p)?;
            let s = s.as_array();
            if s.nrows() != positions.len() || positions.is_empty() {
                return Err(invalid(format!("term_signals_m3_s2: {} signals for {} term positions (at least one)", s.nrows(), positions.len())));
            }
            positions.into_iter().zip(s.rows()).map(|(position_m, row)| core::SourceTerm { position_m, volume_acceleration_m3_s2: row.to_vec() }).collect()
        }
        _ => return Err(invalid("term_positions_m and term_signals_m3_s2 go together")),
    };
    if !(pulse_delay_s.is_finite() && (0.0..=settings.inner.duration_s).contains(&pulse_delay_s)) {
        return Err(invalid(format!("pulse_delay_s = {pulse_delay_s}: must be within [0, duration_s = {}]", settings.inner.duration_s)));
    }
    let a = absorption.as_array();
    if a.ncols() != band_centres_hz.len() {
        return Err(invalid(format!("absorption: {} bands per material but {} band centres", a.ncols(), band_centres_hz.len())));
    }
    let wells = wells_per_material(wells, a.nrows(), "the absorption")?;
    let materials = core::WaveMaterials { band_centres_hz: band_centres_hz.clone(), absorption: a.iter().copied().collect(), wells };
    let sources = dvec3s("sources_m", &sources_m)?;
    let receivers = dvec3s("receivers_m", &receivers_m)?;
    if sources.is_empty() {
        return Err(invalid("sources_m: at least one source is needed"));
    }
    let binning = binning.map(|b| b.inner().clone());
    let kept = energy_bands.unwrap_or(band_centres_hz.len());
    if !(1..=band_centres_hz.len()).contains(&kept) {
        return Err(invalid(format!("energy_bands = {kept}: must be from 1 to the {} band centres", band_centres_hz.len())));
    }
    if let Some(b) = &binning {
        let bands = sonolux_core::sound::Acoustics { n_bands: band_centres_hz.len(), absorption: a.iter().copied().collect(), scattering: vec![0.0; a.len()] };
        // The settings checked as the tracer's, but the size is the energy's own (kept bands, the
        // bytes it takes here), not a tracer field's of every band.
        let mut unbounded = b.clone();
        unbounded.max_field_bytes = u64::MAX;
        unbounded.validate(&bands, receivers.len()).map_err(to_py)?;
        let layout = b.layout(receivers.len(), kept);
        let bytes = layout.len() as f64 * ENERGY_BYTES_PER_CELL as f64;
        if bytes > b.max_field_bytes as f64 {
            return Err(invalid(format!(
                "binning: the waves' energy would take {:.3} GB ({} receiver points × {} directions × {kept} bands × {} time bins × {ENERGY_BYTES_PER_CELL} bytes), more than max_field_bytes = {:.3} GB: use fewer receivers or directions, fewer energy_bands (a lower crossover), or a shorter max_time_s",
                bytes / 1e9,
                receivers.len(),
                layout.n_directions(),
                layout.n_time(),
                b.max_field_bytes as f64 / 1e9
            )));
        }
        if b.air_attenuation_per_m.len() != band_centres_hz.len() {
            return Err(invalid(format!(
                "binning: air_attenuation_per_m has {} bands but there are {} band centres",
                b.air_attenuation_per_m.len(),
                band_centres_hz.len()
            )));
        }
    }
    let set = settings.inner.clone();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(set.threads).build().map_err(|e| invalid(format!("threads: {e}")))?;
    let mut interrupted: Option<PyErr> = None;
    let progress: Option<Py<PyAny>> = progress.map(|p| p.unbind());
    let result = py.detach(|| {
        pool.install(|| {
            let emitted = if terms.is_empty() { core::Sources::Monopoles(&sources) } else { core::Sources::Terms { terms: &terms, pulse_delay_s } };
            let res = core::simulate_sources(&geometry.mesh, &materials, &emitted, &receivers, &set, |p| {
                crate::report_progress(&progress, p, &mut interrupted)
            })?;
            let energy = match &binning {
                Some(b) => {
                    let layout = b.layout(receivers.len(), kept);
                    let direct = without_direct.then_some(core::bands::DirectPaths { sources_m: &sources, receivers_m: &receivers, terms: &terms });
                    let e = core::bands::reflected_energies(&res, &band_centres_hz, &b.air_attenuation_per_m, b.speed_of_sound_m_s, &layout, direct)?;
                    Some((public_order(&e, &layout), layout))
                }
                None => None,
            };
            Ok::<_, sonolux_core::CoreError>((res, energy))
        })
    });
    if let Some(e) = interrupted {
        return Err(e);
    }
    let (res, energy) = result.map_err(to_py)?;
    let out = PyDict::new(py);
    let (nr, ns) = (res.n_receivers, res.n_samples);
    out.set_item("pressure_pa", res.pressure_pa.into_pyarray(py).reshape([nr, ns])?)?;
    out.set_item("velocity_m_s", res.velocity_m_s.into_pyarray(py).reshape([nr, 3, ns])?)?;
    out.set_item("source_pressure_1m_pa", res.source_pressure_1m_pa.into_pyarray(py))?;
    out.set_item("sample_rate_hz", res.sample_rate_hz)?;
    out.set_item("pulse_delay_s", res.pulse.delay_s)?;
    out.set_item("cancelled", res.cancelled)?;
    if let Some((e, l)) = energy {
        out.set_item("energy", e.into_pyarray(py).reshape([l.n_receivers, l.n_directions(), l.n_bands, l.n_time()])?)?;
    }
    let st = &res.stats;
    let s = PyDict::new(py);
    s.set_item("spacing_m", st.spacing_m)?;
    s.set_item("time_step_s", st.time_step_s)?;
    s.set_item("dims", st.dims.to_vec())?;
    s.set_item("cells", st.cells)?;
    s.set_item("air_cells", st.air_cells)?;
    s.set_item("steps", st.steps)?;
    s.set_item("setup_s", st.setup_s)?;
    s.set_item("run_s", st.run_s)?;
    s.set_item("air_updates_per_s", st.air_updates_per_s)?;
    s.set_item("total_bytes", st.estimate.total_bytes)?;
    s.set_item("allocated_bytes", st.allocated_bytes)?;
    s.set_item("fit_error_db", st.fits.iter().map(|f| f.error_db.clone()).collect::<Vec<_>>())?;
    s.set_item("fit_branches", st.fits.iter().map(|f| f.admittance.branches.len()).collect::<Vec<_>>())?;
    s.set_item("fit_clamped", st.fits.iter().map(|f| f.clamped).collect::<Vec<_>>())?;
    out.set_item("stats", s)?;
    Ok(out)
}

/// What one cell of the waves' energy takes while it is made: the f64 sum being binned and the
/// f32 array returned.
const ENERGY_BYTES_PER_CELL: u64 = 8 + 4;

/// [time][receiver][direction][band] f64 to the public [receiver][direction][band][time] f32.
fn public_order(e: &[f64], l: &sonolux_core::sound::Layout) -> Vec<f32> {
    let (nr, nd, nb, nt) = (l.n_receivers, l.n_directions(), l.n_bands, l.n_time());
    let mut out = vec![0f32; e.len()];
    for t in 0..nt {
        for r in 0..nr {
            for d in 0..nd {
                for b in 0..nb {
                    out[((r * nd + d) * nb + b) * nt + t] = e[l.index(r, t, d) + b] as f32;
                }
            }
        }
    }
    out
}
