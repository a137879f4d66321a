//! Binding of the exact early sound (`sonolux_core::early`): an `EarlySettings` object in, the
//! arrivals out as numpy arrays, each already placed in the sound field's time and direction
//! bins so that the library adds them to a bake without knowing how the core bins.

use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use sonolux_core::early as core;
use sonolux_core::sound::SpecularCoverage;

use crate::sound::{Acoustics, Receivers, SoundSettings, SoundSource};
use crate::{check_threads, invalid, to_py, Geometry};

/// What the exact early part computes (keyword arguments only; see `sonolux_core::early::
/// EarlySettings`): image sources up to `max_order` reflections and `max_time_s` (the
/// transition to the particles), first-order edge diffraction (Biot–Tolstoy–Medwin) when
/// `diffraction`, Rindel's finite-panel specular share when `level_of_detail`. Bands are
/// described by their centres and `bands_per_octave` (1 octave, 3 third-octave, ...), any count.
/// `connect_diffuse`: a sphere-estimator bake that leaves these paths out also connects its
/// diffuse reflections to the receivers for the arrivals before `max_time_s` (ODEON's early
/// scattering: `sonolux_core::sound::nee::EarlyConnections`).
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct EarlySettings {
    pub(crate) inner: core::EarlySettings,
    pub(crate) connect_diffuse: bool,
}

#[pymethods]
impl EarlySettings {
    #[new]
    #[pyo3(signature = (
        *, max_order, max_time_s, speed_of_sound_m_s, air_attenuation_per_m, band_centres_hz,
        bands_per_octave, diffraction, level_of_detail, threads, diffraction_piece_m = 0.25,
        plane_tolerance_m = 1e-3, connect_diffuse = true
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        max_order: u32,
        max_time_s: f64,
        speed_of_sound_m_s: f64,
        air_attenuation_per_m: Vec<f64>,
        band_centres_hz: Vec<f64>,
        bands_per_octave: f64,
        diffraction: bool,
        level_of_detail: bool,
        threads: usize,
        diffraction_piece_m: f64,
        plane_tolerance_m: f64,
        connect_diffuse: bool,
    ) -> PyResult<Self> {
        let inner = core::EarlySettings {
            max_order,
            max_time_s,
            speed_of_sound_m_s,
            air_attenuation_per_m,
            band_centres_hz,
            bands_per_octave,
            receiver_radius_m: 0.0,
            level_of_detail,
            diffraction,
            diffraction_piece_m,
            plane_tolerance_m,
            threads: check_threads(threads)?,
            // Set from the `Acoustics` each call is given (its wall model), so that the image
            // sources and the tracer of one bake agree.
            wall_model: Default::default(),
            by_angle: None,
        };
        let n_bands = inner.band_centres_hz.len();
        inner.validate(n_bands).map_err(to_py)?;
        Ok(EarlySettings { inner, connect_diffuse })
    }

    #[getter]
    fn max_order(&self) -> u32 {
        self.inner.max_order
    }

    #[getter]
    fn max_time_s(&self) -> f64 {
        self.inner.max_time_s
    }

    #[getter]
    fn connect_diffuse(&self) -> bool {
        self.connect_diffuse
    }
}

impl EarlySettings {
    /// The specular-only paths these settings count, which the particle tracer leaves out.
    pub(crate) fn coverage(&self) -> SpecularCoverage {
        SpecularCoverage { max_order: self.inner.max_order, max_time_s: self.inner.max_time_s }
    }
}

/// The early arrivals of every source at every receiver (the mean over each receiver's sphere,
/// as the particles measure), binned as `trace_sound` with the same `settings` bins.
///
/// Returns a dict of arrays, one row an arrival, sorted by source, receiver, time: source and
/// receiver int64[k], time_s float64[k], from_direction float64[k, 3] (unit, towards where the
/// sound comes from), kind int8[k] (0 specular, 1 diffracted), order int64[k] (reflections; for
/// a diffracted arrival the order of its emitter), energy float64[k, band] (J/m²),
/// direction_bin int64[k] and time_bin int64[k] (−1 past the field's end); and stats (a dict).
#[pyfunction]
#[pyo3(signature = (geometry, acoustics, sources, receivers, early, settings))]
pub(crate) fn early_arrivals<'py>(
    py: Python<'py>,
    geometry: &Geometry,
    acoustics: &Acoustics,
    sources: Vec<PyRef<'py, SoundSource>>,
    receivers: &Receivers,
    early: &EarlySettings,
    settings: &SoundSettings,
) -> PyResult<Bound<'py, PyDict>> {
    let sources: Vec<_> = sources.iter().map(|s| s.inner.clone()).collect();
    let rec = receivers.inner();
    let mut set = early.inner.clone();
    set.receiver_radius_m = rec.radius_m;
    set.wall_model = acoustics.model();
    set.by_angle = acoustics.by_angle().cloned();
    let nb = acoustics.inner().n_bands;
    let mut res = py
        .detach(|| core::early_arrivals(&geometry.mesh, &geometry.bvh, acoustics.inner(), &sources, &rec.centres, &set, None))
        .map_err(to_py)?;
    // Each arrival weighed by its receiver's pattern towards where it comes from, as the
    // tracer weighs its deposits.
    rec.check_patterns(nb).map_err(|p| invalid(format!("receivers patterns: {p}")))?;
    let mut scratch = vec![0.0; nb];
    for (i, a) in res.arrivals.iter().enumerate() {
        rec.weigh(a.receiver as usize, a.from_direction, &mut res.energy[i * nb..(i + 1) * nb], &mut scratch);
    }
    let layout = settings.inner().layout(rec.len(), nb);
    let k = res.arrivals.len();
    let (mut source, mut receiver, mut time_s, mut from, mut kind, mut order, mut dir_bin, mut time_bin) =
        (Vec::with_capacity(k), Vec::with_capacity(k), Vec::with_capacity(k), Vec::with_capacity(3 * k), Vec::with_capacity(k), Vec::with_capacity(k), Vec::with_capacity(k), Vec::with_capacity(k));
    for a in &res.arrivals {
        source.push(a.source as i64);
        receiver.push(a.receiver as i64);
        time_s.push(a.time_s);
        from.extend_from_slice(&a.from_direction.to_array());
        let (kd, o) = match a.kind {
            core::ArrivalKind::Specular { order } => (0i8, order),
            core::ArrivalKind::Diffracted { order, .. } => (1i8, order),
        };
        kind.push(kd);
        order.push(o as i64);
        dir_bin.push(layout.direction_bin(a.from_direction) as i64);
        time_bin.push(layout.time_bin(a.time_s).map_or(-1, |t| t as i64));
    }
    let out = PyDict::new(py);
    out.set_item("source", source.into_pyarray(py))?;
    out.set_item("receiver", receiver.into_pyarray(py))?;
    out.set_item("time_s", time_s.into_pyarray(py))?;
    out.set_item("from_direction", from.into_pyarray(py).reshape([k, 3])?)?;
    out.set_item("kind", kind.into_pyarray(py))?;
    out.set_item("order", order.into_pyarray(py))?;
    out.set_item("energy", res.energy.into_pyarray(py).reshape([k, nb])?)?;
    out.set_item("direction_bin", dir_bin.into_pyarray(py))?;
    out.set_item("time_bin", time_bin.into_pyarray(py))?;
    let st = &res.stats;
    let s = PyDict::new(py);
    s.set_item("planes", st.planes)?;
    s.set_item("wedges", st.wedges)?;
    s.set_item("image_sources", st.image_sources)?;
    s.set_item("paths_checked", st.paths_checked)?;
    s.set_item("specular_arrivals", st.specular_arrivals)?;
    s.set_item("diffracted_arrivals", st.diffracted_arrivals)?;
    s.set_item("integrand_calls", st.integrand_calls)?;
    out.set_item("stats", s)?;
    Ok(out)
}
