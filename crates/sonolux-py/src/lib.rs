//! The PyO3 layer: settings objects and numpy arrays in, numpy arrays out, the GIL released
//! while the core works, and the core's errors raised as the Python package's own exception
//! classes. No physics lives here.
//!
//! Errors: the exception classes are defined once, in `sonolux.errors` (so that every error a
//! user can cause is a `SonoluxError`), and fetched from there when this module is first
//! imported; the core itself knows nothing of Python.

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyType};

use sonolux_core::bvh::Nodes;
use sonolux_core::glam_export::{DVec3, Vec3};
use sonolux_core::light::patches::barycentric;
use sonolux_core::sound::MAX_THREADS;
use sonolux_core::{Bvh, CoreError, Mesh, Ray};

mod convolve;
mod early;
mod light;
mod light_sources;
mod sound;
mod wave;

/// `sonolux.errors.InvalidInputError` and `sonolux.errors.GeometryError`, fetched at import.
static INVALID_INPUT: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static GEOMETRY: PyOnceLock<Py<PyType>> = PyOnceLock::new();

fn raise(cell: &'static PyOnceLock<Py<PyType>>, class: &str, message: String) -> PyErr {
    Python::attach(|py| match cell.import(py, "sonolux.errors", class) {
        Ok(t) => PyErr::from_type(t.clone(), message),
        Err(e) => e,
    })
}

/// An input handed to the core is malformed or out of range: `sonolux.errors.InvalidInputError`.
pub(crate) fn invalid(message: impl Into<String>) -> PyErr {
    raise(&INVALID_INPUT, "InvalidInputError", message.into())
}

pub(crate) fn to_py(e: CoreError) -> PyErr {
    match e {
        CoreError::InvalidInput { .. } => invalid(e.to_string()),
        CoreError::Geometry(_) => raise(&GEOMETRY, "GeometryError", e.to_string()),
    }
}

/// Reads an (n, 3) float64 array into points, naming the argument in errors.
pub(crate) fn points(name: &str, a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<Vec3>> {
    let a = a.as_array();
    if a.ncols() != 3 {
        return Err(invalid(format!("{name}: expected shape (n, 3), got {:?}", a.shape())));
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

/// Memory this process may still take (MemAvailable of /proc/meminfo), or no limit where the
/// system does not say. Large allocations are checked against it before they are made.
pub(crate) fn available_memory_bytes() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
            let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(kib.saturating_mul(1024))
        })
        .unwrap_or(u64::MAX)
}

/// Checks a thread count (0: all cores).
pub(crate) fn check_threads(threads: usize) -> PyResult<usize> {
    if threads > MAX_THREADS {
        return Err(invalid(format!("threads: {threads} is more than {MAX_THREADS} (0 uses every core)")));
    }
    Ok(threads)
}

/// Runs `f` on a rayon pool of `threads` workers (0: all cores) with the GIL released.
fn on_pool<T: Send>(py: Python<'_>, threads: usize, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(check_threads(threads)?)
        .build()
        .map_err(|e| invalid(format!("threads: {e}")))?;
    Ok(py.detach(|| pool.install(f)))
}

/// (distance, triangle) per ray.
type HitArrays<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>);

/// A triangle mesh with its acceleration structure (BVH), shared by both tracers.
///
/// Geometry(vertices_m: float64[n, 3], triangles: uint32[m, 3], material_ids: uint32[m],
///          bvh_encoding: "auto" | "full" | "compressed" = "auto")
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct Geometry {
    pub(crate) mesh: Mesh,
    pub(crate) bvh: Bvh,
    build_time_s: f64,
}

#[pymethods]
impl Geometry {
    #[new]
    #[pyo3(signature = (vertices_m, triangles, material_ids, bvh_encoding = "auto"))]
    fn new(
        py: Python<'_>,
        vertices_m: PyReadonlyArray2<'_, f64>,
        triangles: PyReadonlyArray2<'_, u32>,
        material_ids: PyReadonlyArray1<'_, u32>,
        bvh_encoding: &str,
    ) -> PyResult<Geometry> {
        let nodes = match bvh_encoding {
            "auto" => Nodes::Auto,
            "full" => Nodes::Full,
            "compressed" => Nodes::Compressed,
            other => {
                return Err(invalid(format!("bvh_encoding: got {other:?}, expected \"auto\", \"full\" or \"compressed\"")));
            }
        };
        let v = points("vertices_m", &vertices_m)?;
        let t = triangles.as_array();
        if t.ncols() != 3 {
            return Err(invalid(format!("triangles: expected shape (m, 3), got {:?}", t.shape())));
        }
        let t: Vec<[u32; 3]> = t.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
        let m = material_ids.as_array().to_vec();
        py.detach(|| {
            let mesh = Mesh::new(v, t, m)?;
            let start = std::time::Instant::now();
            let bvh = Bvh::build_with(&mesh, nodes)?;
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

    /// Whether the BVH is traversed on compressed nodes (docs/bvh.md, "Compressed nodes").
    #[getter]
    fn bvh_compressed(&self) -> bool {
        self.bvh.is_compressed()
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
    #[pyo3(signature = (points_m, threads = 0))]
    fn winding_numbers<'py>(&self, py: Python<'py>, points_m: PyReadonlyArray2<'py, f64>, threads: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let p = points("points_m", &points_m)?;
        Ok(on_pool(py, threads, || self.mesh.winding_numbers(&p))?.into_pyarray(py))
    }

    /// Distance from each point to the nearest surface: float64[k].
    #[pyo3(signature = (points_m, threads = 0))]
    fn distance_to_surface<'py>(&self, py: Python<'py>, points_m: PyReadonlyArray2<'py, f64>, threads: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let p = points("points_m", &points_m)?;
        Ok(on_pool(py, threads, || self.mesh.distance_to_surface(&p))?.into_pyarray(py))
    }

    /// Closest hit of each ray: (t float64[k], inf on a miss; triangle int64[k], −1 on a miss).
    /// Directions need not be unit length; t is in units of the direction.
    #[pyo3(signature = (origins_m, directions, t_max = f64::INFINITY, threads = 0))]
    fn closest_hit<'py>(
        &self,
        py: Python<'py>,
        origins_m: PyReadonlyArray2<'py, f64>,
        directions: PyReadonlyArray2<'py, f64>,
        t_max: f64,
        threads: usize,
    ) -> PyResult<HitArrays<'py>> {
        let (o, d) = (xyz_rows("origins_m", &origins_m)?, xyz_rows("directions", &directions)?);
        if o.len() != d.len() {
            return Err(invalid(format!("{} origins but {} directions", o.len() / 3, d.len() / 3)));
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

    /// The light patch (index into the arrays of `trace_light`) of each point on its triangle,
    /// for patches of `patch_size_m`: int64[k]; −1 where the triangle is −1 (a miss).
    fn patch_index<'py>(
        &self,
        py: Python<'py>,
        patch_size_m: f64,
        triangles: PyReadonlyArray1<'py, i64>,
        points_m: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let patches = light::patches_of(self, patch_size_m)?;
        let t = triangles.as_array();
        let p = points_m.as_array();
        if p.ncols() != 3 || p.nrows() != t.len() {
            return Err(invalid(format!("points_m: expected shape ({}, 3), one point a triangle, got {:?}", t.len(), p.shape())));
        }
        let n_tri = self.mesh.triangles.len() as i64;
        let out: Vec<i64> = (0..t.len())
            .map(|i| {
                let tri = t[i];
                if tri < 0 || tri >= n_tri {
                    return -1;
                }
                let [a, b, c] = self.mesh.corners(tri as usize).map(|v| v.as_dvec3());
                let (s, u) = barycentric(DVec3::new(p[[i, 0]], p[[i, 1]], p[[i, 2]]), a, b, c);
                patches.index(tri as usize, s, u) as i64
            })
            .collect();
        Ok(out.into_pyarray(py))
    }
}

/// An (n, 3) float64 array as x, y, z in a row, borrowed when it is C-contiguous, copied
/// otherwise; the error names the argument.
fn xyz_rows<'a>(name: &str, a: &'a PyReadonlyArray2<'_, f64>) -> PyResult<std::borrow::Cow<'a, [f64]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(invalid(format!("{name}: expected shape (n, 3), got {:?}", v.shape())));
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
    // The exception classes come from the Python package; fail at import if they are missing.
    INVALID_INPUT.import(m.py(), "sonolux.errors", "InvalidInputError")?;
    GEOMETRY.import(m.py(), "sonolux.errors", "GeometryError")?;
    m.add("__version__", sonolux_core::VERSION)?;
    m.add("MAX_THREADS", MAX_THREADS)?;
    m.add_class::<Geometry>()?;
    m.add_class::<sound::Acoustics>()?;
    m.add_class::<sound::Directivity>()?;
    m.add_class::<sound::SoundSource>()?;
    m.add_class::<sound::Receivers>()?;
    m.add_class::<sound::ReceiverPattern>()?;
    m.add_class::<sound::SoundSettings>()?;
    m.add_function(wrap_pyfunction!(sound::trace_sound, m)?)?;
    m.add_function(wrap_pyfunction!(sound::sound_quantum, m)?)?;
    m.add_class::<wave::WaveSettings>()?;
    m.add_function(wrap_pyfunction!(wave::simulate_waves, m)?)?;
    m.add_class::<early::EarlySettings>()?;
    m.add_function(wrap_pyfunction!(early::early_arrivals, m)?)?;
    m.add_class::<light::Optics>()?;
    m.add_class::<light::Emitters>()?;
    m.add_class::<light::LightSettings>()?;
    m.add_class::<light_sources::Lighting>()?;
    m.add_function(wrap_pyfunction!(light::trace_light, m)?)?;
    m.add_class::<convolve::Convolver>()?;
    m.add_function(wrap_pyfunction!(convolve::partition, m)?)?;
    m.add_function(wrap_pyfunction!(convolve::fold, m)?)?;
    Ok(())
}
