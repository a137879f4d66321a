//! Binding of the light tracer and of the patch lookup that pictures need.

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use sonolux_core::glam_export::DVec3;
use sonolux_core::light::patches::barycentric;
use sonolux_core::light::{trace_light_sources as trace, LightSettings, LightSource, Lighting, Optics, Patches};

use crate::{light_sources, to_py, Geometry, InvalidInputError};

fn patches_of(geometry: &Geometry, size: f64) -> Patches {
    let m = &geometry.mesh;
    Patches::new((0..m.triangles.len()).map(|t| m.corners(t).map(|v| v.as_dvec3())), size, 4096)
}

/// Traces light particles. rho float64[materials, 3] (total reflectance per channel), specular
/// and roughness float64[materials]; emitters float64[E, 3, 3] (triangles, emitting on the side
/// of (b − a) × (c − a)) with emitter_flux float64[E, 3] in W; patch_size_m sets the patches.
///
/// Returns a dict: patch_resolution uint32[T] (k: triangle t has k² patches), patch_offset
/// uint64[T + 1], patch_area_m2 float64[P], flux_w float64[P, 3] (incident flux per patch),
/// hits uint64[P] (particles that landed there), stats, cancelled.
///
/// Optional: `sources` (luminaires, sky, sun: see `light_sources::extra_sources`),
/// `transmittance` float64[materials, 3], `work_plane` (a dict: height_m, origin_m, spacing_m,
/// lo, count); then also plane_flux_w float64[cells, 3] and plane_hits uint64[cells].
#[pyfunction]
#[pyo3(signature = (geometry, rho, specular, roughness, emitters, emitter_flux, patch_size_m, *,
                    particles, first, end, seed, threads, max_bounces = 10_000, progress = None,
                    sources = None, transmittance = None, work_plane = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn trace_light<'py>(
    py: Python<'py>,
    geometry: &Geometry,
    rho: PyReadonlyArray2<'py, f64>,
    specular: PyReadonlyArray1<'py, f64>,
    roughness: PyReadonlyArray1<'py, f64>,
    emitters: PyReadonlyArray3<'py, f64>,
    emitter_flux: PyReadonlyArray2<'py, f64>,
    patch_size_m: f64,
    particles: u64,
    first: u64,
    end: u64,
    seed: u64,
    threads: usize,
    max_bounces: u32,
    progress: Option<Bound<'py, PyAny>>,
    sources: Option<Bound<'py, PyDict>>,
    transmittance: Option<PyReadonlyArray2<'py, f64>>,
    work_plane: Option<Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let rho = rho.as_array();
    if rho.ncols() != 3 {
        return Err(InvalidInputError::new_err("rho: expected shape (materials, 3)"));
    }
    let optics = Optics {
        rho: rho.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect(),
        specular: specular.as_array().to_vec(),
        roughness: roughness.as_array().to_vec(),
    };
    let e = emitters.as_array();
    let f = emitter_flux.as_array();
    if e.shape()[1..] != [3, 3] || f.shape() != [e.shape()[0], 3] {
        return Err(InvalidInputError::new_err("emitters: expected (E, 3, 3) corners and (E, 3) flux"));
    }
    let mut ems: Vec<LightSource> = (0..e.shape()[0])
        .map(|i| LightSource::Lambert {
            corners: std::array::from_fn(|k| DVec3::new(e[[i, k, 0]], e[[i, k, 1]], e[[i, k, 2]])),
            flux: [f[[i, 0]], f[[i, 1]], f[[i, 2]]],
        })
        .collect();
    if let Some(d) = &sources {
        ems.extend(light_sources::extra_sources(d)?);
    }
    let tau = transmittance.as_ref().map(light_sources::transmittance).transpose()?.unwrap_or_default();
    let plane = work_plane.as_ref().map(light_sources::work_plane).transpose()?;
    if patch_size_m.is_nan() || patch_size_m <= 0.0 {
        return Err(InvalidInputError::new_err(format!("patch_size_m: {patch_size_m} is not a positive size")));
    }
    let patches = patches_of(geometry, patch_size_m);
    let settings = LightSettings { particles, first, end, seed, threads, max_bounces };
    let mut interrupted: Option<PyErr> = None;
    let progress: Option<Py<PyAny>> = progress.map(|p| p.unbind());
    let result = py.detach(|| {
        let lighting = Lighting { sources: &ems, transmittance: &tau, work_plane: plane.as_ref() };
        trace(&geometry.mesh, &geometry.bvh, &optics, lighting, patches, &settings, |p| {
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

/// The patch (index into the arrays of `trace_light`) of each point on its triangle, for a
/// layout of `patch_size_m`: int64[k]; −1 where the triangle is −1 (a miss).
#[pyfunction]
pub(crate) fn patch_index<'py>(
    py: Python<'py>,
    geometry: &Geometry,
    patch_size_m: f64,
    triangles: PyReadonlyArray1<'py, i64>,
    points: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, numpy::PyArray1<i64>>> {
    let patches = patches_of(geometry, patch_size_m);
    let t = triangles.as_array();
    let p = points.as_array();
    if p.ncols() != 3 || p.nrows() != t.len() {
        return Err(InvalidInputError::new_err("points: expected (k, 3) with one triangle each"));
    }
    let n_tri = geometry.mesh.triangles.len() as i64;
    let out: Vec<i64> = (0..t.len())
        .map(|i| {
            let tri = t[i];
            if tri < 0 || tri >= n_tri {
                return -1;
            }
            let [a, b, c] = geometry.mesh.corners(tri as usize).map(|v| v.as_dvec3());
            let (s, u) = barycentric(DVec3::new(p[[i, 0]], p[[i, 1]], p[[i, 2]]), a, b, c);
            patches.index(tri as usize, s, u) as i64
        })
        .collect();
    Ok(out.into_pyarray(py))
}
