//! Binding of the sound tracer: settings objects in, the field (in the public order
//! [receiver, direction, band, time]) and its statistics out.
//!
//! Each class checks its own arrays' shapes when it is made; `SoundSettings::validate` in the
//! core checks everything else once, when `trace_sound` starts.

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use sonolux_core::glam_export::DVec3;
use sonolux_core::sound as core;

use crate::{check_threads, invalid, to_py, Geometry};

/// A (materials, bands) array, row-major, and its band count.
fn per_material(a: &PyReadonlyArray2<'_, f64>) -> (usize, Vec<f64>) {
    let a = a.as_array();
    (a.ncols(), a.iter().copied().collect())
}

/// What every material does to sound, per band: Acoustics(absorption, scattering,
/// wall_model="random-incidence"), both float64[material, band] in [0, 1]. Any number of bands,
/// the same in both. wall_model: "random-incidence" (each band's coefficient at every angle) or
/// "locally-reacting" (a locally reacting wall whose random-incidence absorption is the
/// coefficient, as the wave solver's; sonolux_core::sound::reflectance); `trace_sound` and
/// `early_arrivals` both use it, so a hybrid of the two agrees. by_angle: None, or
/// {material: float64[2, angle, band]}, the absorption then the scattering of materials whose
/// surface is described, at angles evenly spaced in cos θ from grazing (0) to normal incidence
/// (1), at least 2 (sonolux_core::sound::scattering); both calls use it too. grazing: None, or
/// (normals float64[pair, 3], offsets float64[pair, 2], cos_limit float64[pair, band],
/// rate_per_m float64[pair, band], profile float64[pair, band, node]: the grazing mode's energy
/// density over its mean, nodes evenly spaced from each pair's first plane to its second, at
/// least 2): the grazing modes of parallel surface pairs
/// (sonolux_core::sound::grazing; python/sonolux/sound/grazing.py); the tracer uses it.
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct Acoustics {
    inner: core::Acoustics,
    wall_model: core::WallModel,
    by_angle: Option<core::ScatteringByAngle>,
    grazing: Option<core::GrazingModes>,
}

/// The grazing table's five arrays (see [`Acoustics`]).
type GrazingArrays<'py> = (PyReadonlyArray2<'py, f64>, PyReadonlyArray2<'py, f64>, PyReadonlyArray2<'py, f64>, PyReadonlyArray2<'py, f64>, PyReadonlyArray3<'py, f64>);

fn grazing_modes(n_bands: usize, (normals, offsets, cos_limit, rate, profile): GrazingArrays<'_>) -> PyResult<core::GrazingModes> {
    let (normals, offsets) = (normals.as_array(), offsets.as_array());
    if normals.ncols() != 3 || offsets.ncols() != 2 || cos_limit.as_array().dim() != (normals.nrows(), n_bands) || rate.as_array().dim() != (normals.nrows(), n_bands) {
        return Err(invalid(format!("grazing: shapes {:?}, {:?}, {:?}, {:?}; (pairs, 3), (pairs, 2), (pairs, {n_bands}) and (pairs, {n_bands}) expected", normals.dim(), offsets.dim(), cos_limit.as_array().dim(), rate.as_array().dim())));
    }
    let n: Vec<[f64; 3]> = normals.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
    let o: Vec<[f64; 2]> = offsets.rows().into_iter().map(|r| [r[0], r[1]]).collect();
    let (pairs, bands, nodes) = profile.as_array().dim();
    if (pairs, bands) != (n.len(), n_bands) {
        return Err(invalid(format!("grazing: profile of shape {:?}; ({}, {n_bands}, nodes) expected", (pairs, bands, nodes), n.len())));
    }
    let table = core::GrazingModes::new(n_bands, &n, &o, cos_limit.as_array().iter().copied().collect(), rate.as_array().iter().copied().collect()).map_err(to_py)?;
    table.with_profiles(nodes, profile.as_array().iter().copied().collect()).map_err(to_py)
}

#[pymethods]
impl Acoustics {
    #[new]
    #[pyo3(signature = (absorption, scattering, wall_model = "random-incidence", by_angle = None, grazing = None))]
    fn new(
        absorption: PyReadonlyArray2<'_, f64>,
        scattering: PyReadonlyArray2<'_, f64>,
        wall_model: &str,
        by_angle: Option<std::collections::BTreeMap<usize, PyReadonlyArray3<'_, f64>>>,
        grazing: Option<GrazingArrays<'_>>,
    ) -> PyResult<Self> {
        let (a, s) = (absorption.as_array().dim(), scattering.as_array().dim());
        if a != s {
            return Err(invalid(format!("scattering: shape {s:?} differs from the absorption's {a:?} (material, band)")));
        }
        let Some(wall) = core::WallModel::from_name(wall_model) else {
            return Err(invalid(format!("wall_model: '{wall_model}' is not one of {}", core::WallModel::NAMES.map(|n| format!("'{n}'")).join(", "))));
        };
        let (n_bands, absorption) = per_material(&absorption);
        let (_, scattering) = per_material(&scattering);
        let n_materials = a.0;
        let by_angle = match by_angle {
            None => None,
            Some(tables) => {
                let mut rows: Vec<Option<Vec<f64>>> = vec![None; n_materials];
                let mut n_cos = 0;
                for (m, t) in &tables {
                    let (two, angles, bands) = t.as_array().dim();
                    if *m >= n_materials || two != 2 || bands != n_bands || (n_cos != 0 && angles != n_cos) {
                        return Err(invalid(format!("by_angle: material {m} has shape ({two}, {angles}, {bands}); a material below {n_materials}, shape (2, angles, {n_bands}) and the same angle count for all expected")));
                    }
                    n_cos = angles;
                    rows[*m] = Some(t.as_array().iter().copied().collect());
                }
                if tables.is_empty() {
                    None
                } else {
                    Some(core::ScatteringByAngle::new(n_bands, n_cos, &rows).map_err(to_py)?)
                }
            }
        };
        let grazing = grazing.map(|g| grazing_modes(n_bands, g)).transpose()?;
        Ok(Acoustics { inner: core::Acoustics { n_bands, absorption, scattering }, wall_model: wall, by_angle, grazing })
    }

    #[getter]
    fn n_bands(&self) -> usize {
        self.inner.n_bands
    }

    #[getter]
    fn wall_model(&self) -> &'static str {
        self.wall_model.name()
    }

    /// (material, band) of the bands that keep their coefficient at every angle under the
    /// locally reacting model (their coefficient is above the 0.951 such a wall can absorb);
    /// empty for the random-incidence model.
    fn kept_constant(&self) -> Vec<(usize, usize)> {
        core::Walls::new(self.wall_model, &self.inner).kept_constant(self.inner.n_bands)
    }
}

impl Acoustics {
    pub(crate) fn inner(&self) -> &core::Acoustics {
        &self.inner
    }

    pub(crate) fn model(&self) -> core::WallModel {
        self.wall_model
    }

    pub(crate) fn by_angle(&self) -> Option<&core::ScatteringByAngle> {
        self.by_angle.as_ref()
    }

    pub(crate) fn grazing(&self) -> Option<&core::GrazingModes> {
        self.grazing.as_ref()
    }
}

/// How a source sends its rays out: `Directivity.omni()`; `Directivity.cone(axis,
/// half_angle_deg)`: uniformly within half_angle_deg (0 to 180°] of the axis, as the paper's
/// directional source; or `Directivity.pattern(gains, forward, up)`: per-band energy gains,
/// float64[theta, phi, band] on the grid of `sonolux_core::sound::pattern` (θ from forward, 0
/// to π inclusive; φ around it from up towards up × forward, 0 to 2π exclusive), emitted by
/// importance; each band is normalised to a mean gain of 1.
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct Directivity {
    inner: core::Directivity,
    half_angle_deg: f64,
}

#[pymethods]
impl Directivity {
    #[staticmethod]
    fn omni() -> Self {
        Directivity { inner: core::Directivity::Omni, half_angle_deg: 180.0 }
    }

    #[staticmethod]
    fn cone(axis: [f64; 3], half_angle_deg: f64) -> PyResult<Self> {
        let a = DVec3::from_array(axis);
        if !(a.is_finite() && a.length() > 0.0) {
            return Err(invalid(format!("directivity axis: {axis:?} is not a direction")));
        }
        if !(half_angle_deg > 0.0 && half_angle_deg <= 180.0) {
            return Err(invalid(format!("directivity half_angle_deg: {half_angle_deg} is not in (0, 180]")));
        }
        Ok(Directivity { inner: core::Directivity::Cone { axis: a.normalize(), cos_half_angle: half_angle_deg.to_radians().cos() }, half_angle_deg })
    }

    #[staticmethod]
    fn pattern(gains: PyReadonlyArray3<'_, f64>, forward: [f64; 3], up: [f64; 3]) -> PyResult<Self> {
        let g = gains.as_array();
        let (nt, np, nb) = g.dim();
        let values: Vec<f64> = g.iter().copied().collect();
        let p = core::Pattern::new(nt, np, nb, &values, DVec3::from_array(forward), DVec3::from_array(up)).map_err(|e| invalid(e.to_string()))?;
        Ok(Directivity { inner: core::Directivity::Pattern(std::sync::Arc::new(p)), half_angle_deg: 180.0 })
    }

    /// The pattern's gain per band towards each unit direction: float64[direction, band]
    /// (1 in every band for omni; the mean over the sphere is 1). `directions`: float64[n, 3].
    fn gains<'py>(&self, py: Python<'py>, directions: PyReadonlyArray2<'_, f64>, n_bands: usize) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        let d = directions.as_array();
        if d.ncols() != 3 || n_bands == 0 {
            return Err(invalid(format!("directions: shape {:?}, (n, 3) expected, and n_bands ≥ 1", d.dim())));
        }
        if let Err(problem) = self.inner.check(n_bands) {
            return Err(invalid(format!("directivity: {problem}")));
        }
        let mut out = numpy::ndarray::Array2::<f64>::zeros((d.nrows(), n_bands));
        for (row, mut o) in d.rows().into_iter().zip(out.rows_mut()) {
            let v = DVec3::new(row[0], row[1], row[2]).normalize_or_zero();
            self.inner.gains(v, o.as_slice_mut().expect("a row of a new array is contiguous"));
        }
        Ok(out.into_pyarray(py))
    }

    /// "omni" or "cone".
    #[getter]
    fn kind(&self) -> &'static str {
        match self.inner {
            core::Directivity::Omni => "omni",
            core::Directivity::Cone { .. } => "cone",
            core::Directivity::Pattern(_) => "pattern",
        }
    }

    fn __repr__(&self) -> String {
        match self.inner {
            core::Directivity::Omni => "Directivity.omni()".into(),
            core::Directivity::Cone { axis, .. } => format!("Directivity.cone({:?}, {})", axis.to_array(), self.half_angle_deg),
            core::Directivity::Pattern(ref p) => format!("Directivity.pattern(<{} bands>)", p.n_bands()),
        }
    }
}

/// A sound source: SoundSource(position_m, power_w, directivity=Directivity.omni()). Its
/// impulse carries power_w joules (a source of that power for one second).
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct SoundSource {
    pub(crate) inner: core::SoundSource,
}

#[pymethods]
impl SoundSource {
    #[new]
    #[pyo3(signature = (position_m, power_w, directivity = None))]
    fn new(position_m: [f64; 3], power_w: f64, directivity: Option<PyRef<'_, Directivity>>) -> PyResult<Self> {
        let position = DVec3::from_array(position_m);
        if !position.is_finite() {
            return Err(invalid(format!("source position_m: {position_m:?} is not finite")));
        }
        if !(power_w > 0.0 && power_w.is_finite()) {
            return Err(invalid(format!("source power_w: {power_w} is not a positive power")));
        }
        let directivity = directivity.map_or(core::Directivity::Omni, |d| d.inner.clone());
        Ok(SoundSource { inner: core::SoundSource { position, power_w, directivity } })
    }
}

/// How a receiver weighs sound by the direction it arrives from (see
/// `sonolux_core::sound::ReceiverPattern`): omni(), first_order(a, axis, power=2.0) (energy
/// |a + (1 − a) cos θ|^power, θ from the axis), or measured(gains float64[theta, phi, band],
/// forward, up) (a measured gain per band on the source patterns' grid, kept at its level).
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct ReceiverPattern {
    inner: core::ReceiverPattern,
}

#[pymethods]
impl ReceiverPattern {
    #[staticmethod]
    fn omni() -> Self {
        ReceiverPattern { inner: core::ReceiverPattern::Omni }
    }

    #[staticmethod]
    #[pyo3(signature = (a, axis, power = 2.0))]
    fn first_order(a: f64, axis: [f64; 3], power: f64) -> PyResult<Self> {
        let v = DVec3::from_array(axis);
        if !(v.is_finite() && v.length() > 0.0) {
            return Err(invalid(format!("receiver pattern axis: {axis:?} is not a direction")));
        }
        let inner = core::ReceiverPattern::FirstOrder { axis: v.normalize(), a, power };
        inner.check(1).map_err(|p| invalid(format!("receiver pattern: {p}")))?;
        Ok(ReceiverPattern { inner })
    }

    #[staticmethod]
    fn measured(gains: PyReadonlyArray3<'_, f64>, forward: [f64; 3], up: [f64; 3]) -> PyResult<Self> {
        let g = gains.as_array();
        let (nt, np, nb) = g.dim();
        let values: Vec<f64> = g.iter().copied().collect();
        let p = core::Pattern::measured(nt, np, nb, &values, DVec3::from_array(forward), DVec3::from_array(up)).map_err(|e| invalid(e.to_string()))?;
        Ok(ReceiverPattern { inner: core::ReceiverPattern::Table(std::sync::Arc::new(p)) })
    }

    /// The energy gain per band from each unit direction of arrival: float64[direction, band].
    fn gains<'py>(&self, py: Python<'py>, directions: PyReadonlyArray2<'_, f64>, n_bands: usize) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        let d = directions.as_array();
        if d.ncols() != 3 || n_bands == 0 {
            return Err(invalid(format!("directions: shape {:?}, (n, 3) expected, and n_bands ≥ 1", d.dim())));
        }
        self.inner.check(n_bands).map_err(|p| invalid(format!("receiver pattern: {p}")))?;
        let mut out = numpy::ndarray::Array2::<f64>::ones((d.nrows(), n_bands));
        let mut scratch = vec![0.0; n_bands];
        for (row, mut o) in d.rows().into_iter().zip(out.rows_mut()) {
            let v = DVec3::new(row[0], row[1], row[2]).normalize_or_zero();
            self.inner.weigh(v, o.as_slice_mut().expect("a row of a new array is contiguous"), &mut scratch);
        }
        Ok(out.into_pyarray(py))
    }
}

/// The receiver spheres: Receivers(positions_m: float64[receiver, 3], radius_m, patterns=None),
/// `patterns` one ReceiverPattern a receiver (None: all omnidirectional).
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct Receivers {
    inner: core::Receivers,
}

#[pymethods]
impl Receivers {
    #[new]
    #[pyo3(signature = (positions_m, radius_m, patterns = None))]
    fn new(positions_m: PyReadonlyArray2<'_, f64>, radius_m: f64, patterns: Option<Vec<PyRef<'_, ReceiverPattern>>>) -> PyResult<Self> {
        let p = positions_m.as_array();
        if p.ncols() != 3 {
            return Err(invalid(format!("receivers positions_m: expected shape (n, 3), got {:?}", p.shape())));
        }
        if p.iter().any(|v| !v.is_finite()) {
            return Err(invalid("receivers positions_m: every coordinate must be finite"));
        }
        // A sphere's energy density divides by its volume: below 0.1 mm that underflows.
        if !((1e-4..=1e4).contains(&radius_m)) {
            return Err(invalid(format!("receivers radius_m: {radius_m} is not a length from 0.0001 to 10000 m")));
        }
        let centres = p.rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect();
        let mut inner = core::Receivers::new(centres, radius_m);
        if let Some(list) = patterns {
            inner = inner.with_patterns(list.iter().map(|x| x.inner.clone()).collect()).map_err(|p| invalid(format!("receivers patterns: {p}")))?;
        }
        Ok(Receivers { inner })
    }

    #[getter]
    fn count(&self) -> usize {
        self.inner.len()
    }
}

impl Receivers {
    pub(crate) fn inner(&self) -> &core::Receivers {
        &self.inner
    }
}

/// How to trace and bin a sound bake (keyword arguments only; see `sonolux_core::sound::
/// SoundSettings`). `keep_counts` also returns the exact fixed-point counts, for merging ray
/// ranges; `max_field_bytes` is the largest field the caller accepts; `first_receiver` is the
/// index of the first receiver in the whole bake when it is traced in tiles of receivers;
/// `only_source` traces that source alone (a field per source); `tail_from_s` (one a receiver
/// and band, receiver-major; inf: not watched) and `tail_keep` ask for the largest per-ray late
/// contributions (sonolux_core::sound::tail), returned as `tail`.
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct SoundSettings {
    inner: core::SoundSettings,
    keep_counts: bool,
    /// M of the hybrid's early connections (and of the nee estimator).
    nee_receivers: u32,
    /// The field's fixed-point quantum, when several runs must share one (None: the run's own).
    quantum: Option<f64>,
    tail: Option<core::TailSettings>,
}

#[pymethods]
impl SoundSettings {
    #[new]
    #[pyo3(signature = (
        *, rays, first_ray, end_ray, seed, threads, estimator, speed_of_sound_m_s, air_attenuation_per_m,
        energy_drop_db, max_time_s, sample_rate_hz, early_s, late_bin_s, azimuth_bands, elevation_bands,
        max_field_bytes, keep_counts = false, first_receiver = 0, only_source = None, nee_receivers = 8,
        quantum = None, tail_from_s = None, tail_keep = 0
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        rays: u64,
        first_ray: u64,
        end_ray: u64,
        seed: u64,
        threads: usize,
        estimator: &str,
        speed_of_sound_m_s: f64,
        air_attenuation_per_m: Vec<f64>,
        energy_drop_db: f64,
        max_time_s: f64,
        sample_rate_hz: f64,
        early_s: f64,
        late_bin_s: f64,
        azimuth_bands: usize,
        elevation_bands: usize,
        max_field_bytes: u64,
        keep_counts: bool,
        first_receiver: u64,
        only_source: Option<usize>,
        nee_receivers: u32,
        quantum: Option<f64>,
        tail_from_s: Option<Vec<f64>>,
        tail_keep: usize,
    ) -> PyResult<Self> {
        if let Some(q) = quantum {
            if !(q > 0.0 && q.is_finite()) {
                return Err(invalid(format!("quantum: {q} is not a positive finite energy (J/m² a count)")));
            }
        }
        if !(1..=sonolux_core::sound::nee::MAX_CONNECTIONS).contains(&nee_receivers) {
            return Err(invalid(format!("nee_receivers: {nee_receivers} receivers a reflection; from 1 to {}", sonolux_core::sound::nee::MAX_CONNECTIONS)));
        }
        let estimator = match estimator {
            "paper" => core::Estimator::Paper,
            "rain" => core::Estimator::Rain,
            "nee" => core::Estimator::Nee { connections: nee_receivers },
            other => return Err(invalid(format!("estimator: '{other}' is not one of 'paper', 'rain', 'nee'"))),
        };
        let inner = core::SoundSettings {
            rays,
            first_ray,
            end_ray,
            first_receiver,
            only_source,
            seed,
            threads,
            estimator,
            speed_of_sound_m_s,
            air_attenuation_per_m,
            energy_drop_db,
            max_time_s,
            sample_rate_hz,
            early_s,
            late_bin_s,
            n_azimuth: azimuth_bands,
            n_elevation: elevation_bands,
            // Never more than this machine has: the core allocates what this allows.
            max_field_bytes: max_field_bytes.min(crate::available_memory_bytes()),
        };
        let tail = tail_from_s.map(|from_s| core::TailSettings { from_s, keep: tail_keep });
        Ok(SoundSettings { inner, keep_counts, nee_receivers, quantum, tail })
    }
}

impl SoundSettings {
    pub(crate) fn inner(&self) -> &core::SoundSettings {
        &self.inner
    }
}

/// Traces a sound bake (or the range of rays its settings name). `progress(done, total,
/// elapsed_s)` is called about every 100 ms and may return False to stop. With `early` (an
/// `EarlySettings`), the tracer leaves out the specular-only paths that `early_arrivals` counts
/// with those settings (up to its order and time), so that the two add without double counting;
/// with `cover_early = False` it leaves nothing out (a particles-only bake that takes only the
/// level of detail from `early`). When `early.level_of_detail`, every reflection's scattering
/// becomes Rindel's s' = 1 − (1 − s) K (sonolux_core::early::lod), as the image sources apply it.
/// `bake_receivers` (the whole bake's `Receivers`, when `receivers` is the tile of them from
/// `settings.first_receiver`): the nee estimator draws among all of them (tiles = untiled bits).
///
/// Returns a dict: energy float32[receiver, direction, band, time] in J/m², bin_start_s and
/// bin_width_s float64[time], early_bins, late_bin_s, quantum, counts uint64[receiver,
/// direction, band, time] (only with keep_counts: energy = counts × quantum, exactly), saturated,
/// cancelled and stats (a dict).
#[pyfunction]
#[pyo3(signature = (geometry, acoustics, sources, receivers, settings, progress = None, early = None, cover_early = true, bake_receivers = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn trace_sound<'py>(
    py: Python<'py>,
    geometry: &Geometry,
    acoustics: &Acoustics,
    sources: Vec<PyRef<'py, SoundSource>>,
    receivers: &Receivers,
    settings: &SoundSettings,
    progress: Option<Bound<'py, PyAny>>,
    early: Option<PyRef<'py, crate::early::EarlySettings>>,
    cover_early: bool,
    bake_receivers: Option<PyRef<'py, Receivers>>,
) -> PyResult<Bound<'py, PyDict>> {
    let set = &settings.inner;
    let covered = early.as_ref().filter(|_| cover_early).map(|e| e.coverage());
    // The hybrid's early diffuse connections: with the paths the image sources count left out.
    let early_connections = early
        .as_ref()
        .filter(|e| cover_early && e.connect_diffuse)
        .map(|e| core::nee::EarlyConnections { until_s: e.inner.max_time_s, connections: settings.nee_receivers });
    let detail = early.as_ref().filter(|e| e.inner.level_of_detail).map(|e| {
        let e = &e.inner;
        sonolux_core::early::lod::LevelOfDetail::new(&geometry.mesh, e.band_centres_hz.clone(), e.speed_of_sound_m_s, e.plane_tolerance_m)
    });
    let threads = check_threads(set.threads)?;
    let sources: Vec<core::SoundSource> = sources.iter().map(|s| s.inner.clone()).collect();
    let all_receivers = bake_receivers.as_ref().map(|r| &r.inner().centres[..]);
    // Trace with the GIL released; the progress closure takes it back briefly to report and to
    // notice Ctrl-C. The field is copied out in the public order on the bake's own threads.
    let mut interrupted: Option<PyErr> = None;
    let progress: Option<Py<PyAny>> = progress.map(|p| p.unbind());
    let result = py.detach(|| {
        let extras = core::Extras {
            covered,
            level_of_detail: detail.as_ref(),
            wall_model: acoustics.model(),
            bake_receivers: all_receivers,
            early_connections,
            quantum: settings.quantum,
            scattering_by_angle: acoustics.by_angle(),
            grazing_modes: acoustics.grazing(),
            tail: settings.tail.as_ref(),
        };
        let res = core::trace_sound_with(&geometry.mesh, &geometry.bvh, &acoustics.inner, &sources, &receivers.inner, set, extras, |p| {
            crate::report_progress(&progress, p, &mut interrupted)
        })?;
        let energy = res.energy(threads);
        let counts = settings.keep_counts.then(|| res.counts(threads));
        Ok::<_, sonolux_core::CoreError>((res, energy, counts))
    });
    // Ctrl-C or an error in the progress callback: the workers have stopped; re-raise it.
    if let Some(e) = interrupted {
        return Err(e);
    }
    let (res, energy, counts) = result.map_err(to_py)?;
    let l = &res.layout;
    let shape = [l.n_receivers, l.n_directions(), l.n_bands, l.n_time()];
    let out = PyDict::new(py);
    out.set_item("energy", energy.into_pyarray(py).reshape(shape)?)?;
    if let Some(counts) = counts {
        out.set_item("counts", counts.into_pyarray(py).reshape(shape)?)?;
    }
    let (starts, widths) = l.bin_starts_and_widths();
    out.set_item("bin_start_s", starts.into_pyarray(py))?;
    out.set_item("bin_width_s", widths.into_pyarray(py))?;
    out.set_item("early_bins", l.early_bins)?;
    out.set_item("late_bin_s", l.late_bin_s)?;
    out.set_item("quantum", res.field.quantum)?;
    out.set_item("saturated", res.field.saturated())?;
    out.set_item("cancelled", res.cancelled)?;
    let st = &res.stats;
    let s = PyDict::new(py);
    s.set_item("rays", st.rays)?;
    s.set_item("segments", st.segments)?;
    s.set_item("surface_hits", st.surface_hits)?;
    s.set_item("escaped_rays", st.escaped_rays)?;
    s.set_item("deposits", st.deposits)?;
    s.set_item("shadow_rays", st.shadow_rays)?;
    s.set_item("draws", st.draws)?;
    s.set_item("max_reflections", st.max_reflections)?;
    s.set_item("mean_free_path_m", st.mean_free_path())?;
    s.set_item("free_path_relative_variance", st.free_path_relative_variance())?;
    for w in ["emitted", "absorbed_surfaces", "absorbed_air", "escaped", "remaining", "reweighted"] {
        s.set_item(format!("energy_{w}_j"), st.energy(w).unwrap_or_default().into_pyarray(py))?;
    }
    let escapes: Vec<(u32, u64, [f64; 3], [f64; 3])> = st.escapes.iter().map(|e| (e.source, e.ray, e.from, e.dir)).collect();
    s.set_item("escapes", escapes)?;
    out.set_item("stats", s)?;
    if let Some(t) = &res.tail {
        let keep = t.kept.iter().map(Vec::len).max().unwrap_or(0);
        let mut values = vec![0.0; t.kept.len() * keep];
        for (i, list) in t.kept.iter().enumerate() {
            values[i * keep..i * keep + list.len()].iter_mut().zip(list).for_each(|(v, c)| *v = c.value);
        }
        let d = PyDict::new(py);
        d.set_item("values", values.into_pyarray(py).reshape([t.kept.len(), keep])?)?;
        d.set_item("contributing", t.contributing.clone().into_pyarray(py))?;
        out.set_item("tail", d)?;
    }
    Ok(out)
}

/// The fixed-point quantum (J/m² a count) of a bake of `sources` into `receivers`: what
/// `trace_sound` uses unless its settings give one (`SoundSettings(quantum=...)`, which must be
/// at least this). A bake traced in parts whose sources or receivers peak differently (level of
/// detail's band groups, each with its own bands' gains) gives every part the quantum of the
/// whole bake's sources and receivers, so that their counts add exactly.
#[pyfunction]
pub(crate) fn sound_quantum(sources: Vec<PyRef<'_, SoundSource>>, receivers: &Receivers) -> PyResult<f64> {
    let sources: Vec<core::SoundSource> = sources.iter().map(|s| s.inner.clone()).collect();
    if sources.is_empty() {
        return Err(invalid("sources: a sound bake needs at least one source"));
    }
    Ok(core::sound_quantum(&sources, &receivers.inner))
}
