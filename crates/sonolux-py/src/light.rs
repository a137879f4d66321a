//! Binding of the light tracer: settings objects in, the flux on every surface patch out.

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use sonolux_core::glam_export::DVec3;
use sonolux_core::light::{self as core, Lighting as CoreLighting, Patches};

use crate::light_sources::Lighting;
use crate::{check_threads, invalid, to_py, Geometry};

/// Patches of at most this many a triangle's edge (so at most its square a triangle).
const MAX_PATCHES_PER_EDGE: u32 = 4096;

/// The patch layout of `geometry` for patches of `size_m`.
pub(crate) fn patches_of(geometry: &Geometry, size_m: f64) -> PyResult<Patches> {
    if !(size_m > 0.0 && size_m.is_finite()) {
        return Err(invalid(format!("patch_size_m: {size_m} is not a positive length")));
    }
    let m = &geometry.mesh;
    Ok(Patches::new((0..m.triangles.len()).map(|t| m.corners(t).map(|v| v.as_dvec3())), size_m, MAX_PATCHES_PER_EDGE))
}

/// How every material reflects light: Optics(rho: float64[material, 3] total reflectance per
/// RGB channel, specular: float64[material] the share reflected as a mirror or glossy lobe,
/// roughness: float64[material]), all in [0, 1].
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct Optics {
    inner: core::Optics,
}

#[pymethods]
impl Optics {
    #[new]
    fn new(rho: PyReadonlyArray2<'_, f64>, specular: PyReadonlyArray1<'_, f64>, roughness: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        let (rho, specular, roughness) = (rho.as_array(), specular.as_array(), roughness.as_array());
        if rho.ncols() != 3 || specular.len() != rho.nrows() || roughness.len() != rho.nrows() {
            return Err(invalid(format!("optics: rho {:?}, specular ({}) and roughness ({}) must be (material, 3), (material) and (material)", rho.shape(), specular.len(), roughness.len())));
        }
        let inner = core::Optics {
            rho: rho.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect(),
            specular: specular.to_vec(),
            roughness: roughness.to_vec(),
        };
        Ok(Optics { inner })
    }
}

/// The emitting triangles: Emitters(triangles_m: float64[emitter, 3, 3] (emitter, corner,
/// xyz), each emitting on the side of (b − a) × (c − a); flux_w: float64[emitter, 3], W per RGB
/// channel).
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct Emitters {
    inner: Vec<core::Emitter>,
}

#[pymethods]
impl Emitters {
    #[new]
    fn new(triangles_m: PyReadonlyArray3<'_, f64>, flux_w: PyReadonlyArray2<'_, f64>) -> PyResult<Self> {
        let e = triangles_m.as_array();
        let f = flux_w.as_array();
        if e.shape()[1..] != [3, 3] || f.shape() != [e.shape()[0], 3] {
            return Err(invalid(format!("emitters: expected triangles_m (E, 3, 3) and flux_w (E, 3), got {:?} and {:?}", e.shape(), f.shape())));
        }
        if e.iter().chain(f.iter()).any(|v| !v.is_finite()) || f.iter().any(|v| *v < 0.0) {
            return Err(invalid("emitters: corners must be finite and flux finite and ≥ 0"));
        }
        let inner = (0..e.shape()[0])
            .map(|i| core::Emitter {
                corners: std::array::from_fn(|k| DVec3::new(e[[i, k, 0]], e[[i, k, 1]], e[[i, k, 2]])),
                flux: [f[[i, 0]], f[[i, 1]], f[[i, 2]]],
            })
            .collect();
        Ok(Emitters { inner })
    }

    #[getter]
    fn count(&self) -> usize {
        self.inner.len()
    }
}

/// How to trace a light bake (keyword arguments only): particles in the whole bake, the range
/// first_ray..end_ray of them this run traces, seed, threads (0: all cores), patch_size_m and
/// max_bounces (a guard; Russian roulette ends particles long before).
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct LightSettings {
    inner: core::LightSettings,
    patch_size_m: f64,
}

#[pymethods]
impl LightSettings {
    #[new]
    #[pyo3(signature = (*, particles, first_ray, end_ray, seed, threads, patch_size_m, max_bounces = 10_000))]
    fn new(particles: u64, first_ray: u64, end_ray: u64, seed: u64, threads: usize, patch_size_m: f64, max_bounces: u32) -> Self {
        LightSettings { inner: core::LightSettings { particles, first_ray, end_ray, seed, threads, max_bounces }, patch_size_m }
    }
}

/// Traces light particles. `progress(done, total, elapsed_s)` is called about every 100 ms and
/// may return False to stop.
///
/// Returns a dict: patch_resolution uint32[triangle] (k: triangle t has k² patches),
/// patch_offset uint64[triangle + 1], patch_area_m2 float64[patch], flux_w float64[patch, 3]
/// (incident flux per RGB channel), hits uint64[patch] (particles that landed there), stats
/// (a dict) and cancelled. With `lighting` (luminaires, sky, sun, glazing, a work plane: see
/// [`Lighting`]) and a work plane, also plane_flux_w float64[cell, 3] and plane_hits uint64[cell].
#[pyfunction]
#[pyo3(signature = (geometry, optics, emitters, settings, progress = None, lighting = None))]
pub(crate) fn trace_light<'py>(
    py: Python<'py>,
    geometry: &Geometry,
    optics: &Optics,
    emitters: &Emitters,
    settings: &LightSettings,
    progress: Option<Bound<'py, PyAny>>,
    lighting: Option<&Lighting>,
) -> PyResult<Bound<'py, PyDict>> {
    check_threads(settings.inner.threads)?;
    let patches = patches_of(geometry, settings.patch_size_m)?;
    let mut sources: Vec<core::LightSource> = emitters.inner.iter().map(|e| core::LightSource::Lambert { corners: e.corners, flux: e.flux }).collect();
    let (transmittance, plane) = match lighting {
        Some(l) => {
            sources.extend(l.sources.iter().cloned());
            (l.transmittance.clone(), l.work_plane.clone())
        }
        None => (Vec::new(), None),
    };
    let mut interrupted: Option<PyErr> = None;
    let progress: Option<Py<PyAny>> = progress.map(|p| p.unbind());
    let result = py.detach(|| {
        let lighting = CoreLighting { sources: &sources, transmittance: &transmittance, work_plane: plane.as_ref() };
        core::trace_light_sources(&geometry.mesh, &geometry.bvh, &optics.inner, lighting, patches, &settings.inner, |p| {
            crate::report_progress(&progress, p, &mut interrupted)
        })
    });
    if let Some(e) = interrupted {
        return Err(e);
    }
    let res = result.map_err(to_py)?;
    let out = PyDict::new(py);
    let n = res.flux.len();
    out.set_item("patch_resolution", res.patches.resolution.clone().into_pyarray(py))?;
    out.set_item("patch_offset", res.patches.offsets.clone().into_pyarray(py))?;
    out.set_item("patch_area_m2", res.patches.area.clone().into_pyarray(py))?;
    out.set_item("flux_w", res.flux.iter().flatten().copied().collect::<Vec<f64>>().into_pyarray(py).reshape([n, 3])?)?;
    out.set_item("hits", res.hits.into_pyarray(py))?;
    if plane.is_some() {
        let cells = res.plane_flux.len();
        out.set_item("plane_flux_w", res.plane_flux.into_iter().flatten().collect::<Vec<f64>>().into_pyarray(py).reshape([cells, 3])?)?;
        out.set_item("plane_hits", res.plane_hits.into_pyarray(py))?;
    }
    out.set_item("cancelled", res.cancelled)?;
    let st = &res.stats;
    let s = PyDict::new(py);
    s.set_item("particles", st.particles)?;
    s.set_item("bounces", st.bounces)?;
    s.set_item("escaped_particles", st.escaped_particles)?;
    s.set_item("flux_emitted_w", st.emitted.to_vec())?;
    s.set_item("flux_absorbed_w", st.absorbed.to_vec())?;
    s.set_item("flux_escaped_w", st.escaped.to_vec())?;
    s.set_item("flux_roulette_w", st.roulette.to_vec())?;
    out.set_item("stats", s)?;
    Ok(out)
}
