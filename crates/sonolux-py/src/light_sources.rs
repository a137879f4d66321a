//! Reading the light sources beyond Lambertian triangles (luminaires, sky, sun), the glazing
//! transmittance and the work plane from the plain dicts of numpy arrays that the Python
//! package hands over. Shapes and axis orders are documented on [`extra_sources`].

use std::sync::Arc;

use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyAnyMethods, PyDict, PyDictMethods, PyList};

use sonolux_core::glam_export::DVec3;
use sonolux_core::light::{DirectionTable, LightSource, WorkPlane};
use sonolux_core::sampling::Frame;

use crate::{invalid, to_py};

fn bad(msg: String) -> PyErr {
    invalid(msg)
}

/// Reads d[key] as T, None where the key is absent; the error names the key.
macro_rules! get {
    ($d:expr, $key:expr, $t:ty) => {
        match $d.get_item($key)? {
            None => None,
            Some(v) => Some(v.extract::<$t>().map_err(|e| bad(format!("sources.{}: {}", $key, PyErr::from(e))))?),
        }
    };
}

fn rows3(name: &str, a: &PyReadonlyArray2<'_, f64>, n: usize) -> PyResult<Vec<DVec3>> {
    let a = a.as_array();
    if a.shape() != [n, 3] {
        return Err(bad(format!("{name}: expected shape ({n}, 3), got {:?}", a.shape())));
    }
    Ok(a.rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect())
}

fn triangles(name: &str, a: &PyReadonlyArray3<'_, f64>) -> PyResult<Vec<[DVec3; 3]>> {
    let a = a.as_array();
    if a.shape()[1..] != [3, 3] {
        return Err(bad(format!("{name}: expected shape (n, 3, 3), got {:?}", a.shape())));
    }
    Ok((0..a.shape()[0]).map(|i| std::array::from_fn(|k| DVec3::new(a[[i, k, 0]], a[[i, k, 1]], a[[i, k, 2]]))).collect())
}

fn table_of<'py>(tables: &[Arc<DirectionTable>], index: &PyReadonlyArray1<'py, i64>, n: usize, name: &str) -> PyResult<Vec<Arc<DirectionTable>>> {
    let index = index.as_array();
    if index.len() != n {
        return Err(bad(format!("{name}: expected {n} table indices, got {}", index.len())));
    }
    index.iter().map(|&i| usize::try_from(i).ok().and_then(|i| tables.get(i).cloned()).ok_or_else(|| bad(format!("{name}: no table {i}")))).collect()
}

/// The sources of `sources`, a dict with any of these keys (n_* rows each):
/// - tables: list of (theta_rad float64[nt], phi_rad float64[np], values float64[np, nt]);
/// - point_position float64[P, 3], point_frame float64[P, 3, 3] (rows: the frame's t, b and n,
///   n being the axis that θ = 0 of the table points along), point_scale float64[P, 3] (W/sr
///   per table unit, per channel), point_table int64[P];
/// - sky_corners float64[S, 3, 3] (emitting on the side of (b − a) × (c − a)), sky_scale
///   float64[S, 3], sky_table int64[S] (radiance per world travel direction);
/// - sun_corners float64[U, 3, 3], sun_direction float64[U, 3] (unit, the way the light
///   travels), sun_irradiance float64[U, 3] (W/m² normal to the beam, per channel).
pub(crate) fn extra_sources(d: &Bound<'_, PyDict>) -> PyResult<Vec<LightSource>> {
    let mut tables = Vec::new();
    if let Some(list) = get!(d, "tables", Bound<'_, PyList>) {
        for (i, item) in list.iter().enumerate() {
            let (theta, phi, values): (PyReadonlyArray1<f64>, PyReadonlyArray1<f64>, PyReadonlyArray2<f64>) =
                item.extract().map_err(|e| bad(format!("sources.tables[{i}]: {e}")))?;
            let values = values.as_array();
            let flat: Vec<f64> = values.iter().copied().collect();
            if values.shape() != [phi.len()?, theta.len()?] {
                return Err(bad(format!("sources.tables[{i}]: values must have shape (len(phi), len(theta))")));
            }
            tables.push(Arc::new(DirectionTable::new(theta.as_array().to_vec(), phi.as_array().to_vec(), flat).map_err(to_py)?));
        }
    }
    let mut out = Vec::new();
    if let Some(pos) = get!(d, "point_position", PyReadonlyArray2<f64>) {
        let n = pos.as_array().nrows();
        let pos = rows3("point_position", &pos, n)?;
        let frame = get!(d, "point_frame", PyReadonlyArray3<f64>).ok_or_else(|| bad("sources.point_frame is missing".into()))?;
        let frame = triangles("point_frame", &frame)?;
        let scale = get!(d, "point_scale", PyReadonlyArray2<f64>).ok_or_else(|| bad("sources.point_scale is missing".into()))?;
        let scale = rows3("point_scale", &scale, n)?;
        let index = get!(d, "point_table", PyReadonlyArray1<i64>).ok_or_else(|| bad("sources.point_table is missing".into()))?;
        let table = table_of(&tables, &index, n, "point_table")?;
        if frame.len() != n {
            return Err(bad(format!("point_frame: expected {n} frames")));
        }
        for i in 0..n {
            let [t, b, nn] = frame[i];
            out.push(LightSource::Point { position: pos[i], frame: Frame { t, b, n: nn }, intensity: table[i].clone(), scale: scale[i].to_array() });
        }
    }
    if let Some(corners) = get!(d, "sky_corners", PyReadonlyArray3<f64>) {
        let corners = triangles("sky_corners", &corners)?;
        let n = corners.len();
        let scale = get!(d, "sky_scale", PyReadonlyArray2<f64>).ok_or_else(|| bad("sources.sky_scale is missing".into()))?;
        let scale = rows3("sky_scale", &scale, n)?;
        let index = get!(d, "sky_table", PyReadonlyArray1<i64>).ok_or_else(|| bad("sources.sky_table is missing".into()))?;
        let table = table_of(&tables, &index, n, "sky_table")?;
        for i in 0..n {
            out.push(LightSource::Sky { corners: corners[i], radiance: table[i].clone(), scale: scale[i].to_array() });
        }
    }
    if let Some(corners) = get!(d, "sun_corners", PyReadonlyArray3<f64>) {
        let corners = triangles("sun_corners", &corners)?;
        let n = corners.len();
        let dir = get!(d, "sun_direction", PyReadonlyArray2<f64>).ok_or_else(|| bad("sources.sun_direction is missing".into()))?;
        let dir = rows3("sun_direction", &dir, n)?;
        let e = get!(d, "sun_irradiance", PyReadonlyArray2<f64>).ok_or_else(|| bad("sources.sun_irradiance is missing".into()))?;
        let e = rows3("sun_irradiance", &e, n)?;
        for i in 0..n {
            out.push(LightSource::Sun { corners: corners[i], direction: dir[i], irradiance: e[i].to_array() });
        }
    }
    Ok(out)
}

/// The work plane of a dict with height_m, origin_m (x, y), spacing_m, lo (i, j), count (nx, ny).
pub(crate) fn work_plane(d: &Bound<'_, PyDict>) -> PyResult<WorkPlane> {
    let need = |k: &str| d.get_item(k)?.ok_or_else(|| bad(format!("work_plane.{k} is missing")));
    let plane = WorkPlane {
        height_m: need("height_m")?.extract()?,
        origin_m: need("origin_m")?.extract()?,
        spacing_m: need("spacing_m")?.extract()?,
        lo: need("lo")?.extract()?,
        count: need("count")?.extract()?,
    };
    plane.validate().map_err(to_py)?;
    Ok(plane)
}

/// Transmittance per material and channel from float64[M, 3].
pub(crate) fn transmittance(a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<[f64; 3]>> {
    let a = a.as_array();
    if a.ncols() != 3 {
        return Err(bad(format!("transmittance: expected shape (materials, 3), got {:?}", a.shape())));
    }
    Ok(a.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

/// What a light bake has besides Lambertian triangles (keyword arguments only): sources (a dict,
/// see [`extra_sources`]), transmittance float64[material, 3] (glazing; 0 = opaque) and
/// work_plane (a dict, see [`work_plane`]). Validated here, once.
#[pyclass(module = "sonolux._core", frozen)]
pub(crate) struct Lighting {
    pub(crate) sources: Vec<LightSource>,
    pub(crate) transmittance: Vec<[f64; 3]>,
    pub(crate) work_plane: Option<WorkPlane>,
}

#[pymethods]
impl Lighting {
    #[new]
    #[pyo3(signature = (*, sources = None, transmittance = None, work_plane = None))]
    fn new(sources: Option<Bound<'_, PyDict>>, transmittance: Option<PyReadonlyArray2<'_, f64>>, work_plane: Option<Bound<'_, PyDict>>) -> PyResult<Self> {
        Ok(Lighting {
            sources: sources.as_ref().map(extra_sources).transpose()?.unwrap_or_default(),
            transmittance: transmittance.as_ref().map(self::transmittance).transpose()?.unwrap_or_default(),
            work_plane: work_plane.as_ref().map(self::work_plane).transpose()?,
        })
    }
}
