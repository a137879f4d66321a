//! The PyO3 layer: numpy arrays in, numpy arrays out, the GIL released while the core works,
//! and one Python exception class per kind of core error. No physics lives here.

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use sonolux_core::glam_export::Vec3;
use sonolux_core::{Bvh, CoreError, Mesh, Ray};

mod convolve;
mod light;
mod light_sources;
mod sound;

create_exception!(_core, InvalidInputError, PyValueError, "An array or value handed to the core is malformed.");
create_exception!(_core, GeometryError, PyValueError, "The geometry cannot be used as it is.");

pub(crate) fn to_py(e: CoreError) -> PyErr {
    match e {
        CoreError::InvalidInput { .. } => InvalidInputError::new_err(e.to_string()),
        CoreError::Geometry(_) => GeometryError::new_err(e.to_string()),
    }
}

/// Reads an (n, 3) float64 array into points, naming the argument in errors.
pub(crate) fn points(name: &str, a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<Vec3>> {
    let a = a.as_array();
    if a.ncols() != 3 {
        return Err(InvalidInputError::new_err(format!("{name}: expected shape (n, 3), got {:?}", a.shape())));
    }
    Ok(a.rows().into_iter().map(|r| Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32)).collect())
}

/// The progress closure both tracers get: it takes the GIL back briefly (the tracers run
/// without it) to notice Ctrl-C and to call the user's `progress(done, total, elapsed_s)`,
/// whose False stops the run. An interrupt or an error in the callback is kept to be raised
/// once the workers have stopped.
pub(crate) fn report_progress(
    progress: &Option<Py<PyAny>>,
    p: &sonolux_core::parallel::Progress,
    interrupted: &mut Option<PyErr>,
) -> bool {
    Python::attach(|py| {
        if let Err(e) = py.check_signals() {
            *interrupted = Some(e);
            return false;
        }
        let Some(cb) = progress else { return true };
        match cb.bind(py).call1((p.done, p.total, p.elapsed.as_secs_f64())) {
            Ok(v) => v.extract::<bool>().unwrap_or(true),
            Err(e) => {
                *interrupted = Some(e);
                false
            }
        }
    })
}

/// Runs `f` on a rayon pool of `threads` workers (0: all cores) with the GIL released.
fn on_pool<T: Send>(py: Python<'_>, threads: usize, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| InvalidInputError::new_err(format!("threads: {e}")))?;
    Ok(py.detach(|| pool.install(f)))
}

/// (distance, triangle) per ray.
type HitArrays<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>);

/// A triangle mesh with its acceleration structure.
///
/// Geometry(vertices: float64[n, 3] metres, triangles: uint32[m, 3], material_ids: uint32[m])
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct Geometry {
    pub(crate) mesh: Mesh,
    pub(crate) bvh: Bvh,
    build_time_s: f64,
}

#[pymethods]
impl Geometry {
    #[new]
    fn new(
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f64>,
        triangles: PyReadonlyArray2<'_, u32>,
        material_ids: PyReadonlyArray1<'_, u32>,
    ) -> PyResult<Geometry> {
        let v = points("vertices", &vertices)?;
        let t = triangles.as_array();
        if t.ncols() != 3 {
            return Err(InvalidInputError::new_err(format!("triangles: expected shape (m, 3), got {:?}", t.shape())));
        }
        let t: Vec<[u32; 3]> = t.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
        let m = material_ids.as_array().to_vec();
        py.detach(|| {
            let mesh = Mesh::new(v, t, m)?;
            let start = std::time::Instant::now();
            let bvh = Bvh::build(&mesh)?;
            Ok(Geometry { mesh, bvh, build_time_s: start.elapsed().as_secs_f64() })
        })
        .map_err(to_py)
    }

    #[getter]
    fn n_triangles(&self) -> usize {
        self.mesh.triangles.len()
    }

    /// Seconds spent building the BVH.
    #[getter]
    fn build_time_s(&self) -> f64 {
        self.build_time_s
    }

    #[getter]
    fn bvh_nodes(&self) -> usize {
        self.bvh.node_count()
    }

    /// Topology and measures: see `sonolux_core::MeshReport`.
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = py.detach(|| self.mesh.report());
        let d = PyDict::new(py);
        d.set_item("n_triangles", r.n_triangles)?;
        d.set_item("n_degenerate", r.degenerate.len())?;
        d.set_item("degenerate", r.degenerate.iter().map(|&i| i as i64).collect::<Vec<_>>().into_pyarray(py))?;
        d.set_item("n_open_edges", r.n_open_edges)?;
        d.set_item("open_edge_midpoints", vec3s_to_array(py, &r.open_edge_midpoints))?;
        d.set_item("n_nonmanifold_edges", r.n_nonmanifold_edges)?;
        d.set_item("n_inconsistent_edges", r.n_inconsistent_edges)?;
        d.set_item("signed_volume_m3", r.signed_volume)?;
        d.set_item("area_m2", r.area_by_material.into_pyarray(py))?;
        d.set_item("bbox_min", r.bounds.min.as_dvec3().to_array().to_vec().into_pyarray(py))?;
        d.set_item("bbox_max", r.bounds.max.as_dvec3().to_array().to_vec().into_pyarray(py))?;
        Ok(d)
    }

    /// Generalised winding number of each point: float64[k].
    #[pyo3(signature = (points, threads = 0))]
    fn winding_numbers<'py>(&self, py: Python<'py>, points: PyReadonlyArray2<'py, f64>, threads: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let p = self::points("points", &points)?;
        Ok(on_pool(py, threads, || self.mesh.winding_numbers(&p))?.into_pyarray(py))
    }

    /// Distance from each point to the nearest surface: float64[k].
    #[pyo3(signature = (points, threads = 0))]
    fn distance_to_surface<'py>(&self, py: Python<'py>, points: PyReadonlyArray2<'py, f64>, threads: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let p = self::points("points", &points)?;
        Ok(on_pool(py, threads, || self.mesh.distance_to_surface(&p))?.into_pyarray(py))
    }

    /// Closest hit of each ray: (t float64[k], inf on a miss; triangle int64[k], −1 on a miss).
    /// Directions need not be unit length; t is in units of the direction.
    #[pyo3(signature = (origins, directions, t_max = f64::INFINITY, threads = 0))]
    fn closest_hit<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f64>,
        directions: PyReadonlyArray2<'py, f64>,
        t_max: f64,
        threads: usize,
    ) -> PyResult<HitArrays<'py>> {
        let (o, d) = (xyz_rows("origins", &origins)?, xyz_rows("directions", &directions)?);
        if o.len() != d.len() {
            return Err(InvalidInputError::new_err(format!("{} origins but {} directions", o.len() / 3, d.len() / 3)));
        }
        // Rays are made, traced and written out in place by the pool's workers, in chunks:
        // no per-ray list is built or converted on one thread.
        let n = o.len() / 3;
        let (mut t, mut tri) = (vec![f64::INFINITY; n], vec![-1i64; n]);
        let t_max = t_max as f32;
        on_pool(py, threads, || {
            use rayon::prelude::*;
            const CHUNK: usize = 1024;
            t.par_chunks_mut(CHUNK).zip(tri.par_chunks_mut(CHUNK)).enumerate().for_each(|(c, (t, tri))| {
                for (k, (t, tri)) in t.iter_mut().zip(tri).enumerate() {
                    let i = 3 * (c * CHUNK + k);
                    let (o, d) = (&o[i..i + 3], &d[i..i + 3]);
                    let ray = Ray::new(Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32), Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32));
                    if let Some(h) = self.bvh.closest_hit(&ray, 0.0, t_max) {
                        (*t, *tri) = (h.t as f64, h.triangle as i64);
                    }
                }
            })
        })?;
        Ok((t.into_pyarray(py), tri.into_pyarray(py)))
    }
}

/// An (n, 3) float64 array as x, y, z in a row, borrowed when it is C-contiguous, copied
/// otherwise; the error names the argument.
fn xyz_rows<'a>(name: &str, a: &'a PyReadonlyArray2<'_, f64>) -> PyResult<std::borrow::Cow<'a, [f64]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(InvalidInputError::new_err(format!("{name}: expected shape (n, 3), got {:?}", v.shape())));
    }
    // ndarray's as_slice, not numpy's: the latter also accepts Fortran order, whose memory
    // order is not x, y, z in a row.
    Ok(match v.to_slice() {
        Some(flat) => std::borrow::Cow::Borrowed(flat),
        None => std::borrow::Cow::Owned(v.iter().copied().collect()),
    })
}

fn vec3s_to_array<'py>(py: Python<'py>, v: &[Vec3]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = v.iter().flat_map(|p| [p.x as f64, p.y as f64, p.z as f64]).collect();
    flat.into_pyarray(py).reshape([v.len(), 3]).expect("3 values per point")
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", sonolux_core::VERSION)?;
    m.add_class::<Geometry>()?;
    m.add_class::<convolve::Convolver>()?;
    m.add_function(wrap_pyfunction!(convolve::partition, m)?)?;
    m.add_function(wrap_pyfunction!(convolve::fold, m)?)?;
    m.add_function(wrap_pyfunction!(sound::trace_sound, m)?)?;
    m.add_function(wrap_pyfunction!(light::trace_light, m)?)?;
    m.add_function(wrap_pyfunction!(light::patch_index, m)?)?;
    m.add("InvalidInputError", m.py().get_type::<InvalidInputError>())?;
    m.add("GeometryError", m.py().get_type::<GeometryError>())?;
    Ok(())
}
