//! Binding of the sound tracer: arrays and settings in, the field and its statistics out.

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use rayon::prelude::*;
use pyo3::types::PyDict;

use sonolux_core::glam_export::DVec3;
use sonolux_core::sound::{trace_sound as trace, Acoustics, Directivity, Estimator, Receivers, SoundSettings, SoundSource};

use crate::{points, to_py, Geometry, InvalidInputError};

/// Reads a (materials, bands) array row-major.
fn per_material(name: &str, a: &PyReadonlyArray2<'_, f64>, n_bands: usize) -> PyResult<Vec<f64>> {
    let a = a.as_array();
    if a.ncols() != n_bands {
        return Err(InvalidInputError::new_err(format!("{name}: expected {n_bands} bands per material, got shape {:?}", a.shape())));
    }
    Ok(a.iter().copied().collect())
}

/// Traces a sound bake. Arrays: absorption and scattering float64[materials, bands];
/// source_positions float64[S, 3], source_powers float64[S] (J), source_axes float64[S, 3] and
/// source_cos_half_angle float64[S] (≤ −1 for an omnidirectional source); receivers float64[R, 3].
/// `progress(done, total, elapsed_s)` is called about every 100 ms and may return False to stop.
///
/// Returns a dict: energy float32[R, D, B, T] in J/m², bin_start_s and bin_width_s float64[T],
/// counts uint64[T, R, D, B] and quantum (only with keep_counts, for exact merging), the layout
/// numbers, stats (a dict) and cancelled.
#[pyfunction]
#[pyo3(signature = (
    geometry, absorption, scattering, source_positions, source_powers, source_axes, source_cos_half_angle,
    receivers, radius, *, rays, first_ray, end_ray, seed, threads, estimator, speed_of_sound,
    air_attenuation, energy_drop_db, max_time_s, sample_rate, early_s, late_bin_s, n_azimuth, n_elevation,
    progress = None, keep_counts = false
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn trace_sound<'py>(
    py: Python<'py>,
    geometry: &Geometry,
    absorption: PyReadonlyArray2<'py, f64>,
    scattering: PyReadonlyArray2<'py, f64>,
    source_positions: PyReadonlyArray2<'py, f64>,
    source_powers: PyReadonlyArray1<'py, f64>,
    source_axes: PyReadonlyArray2<'py, f64>,
    source_cos_half_angle: PyReadonlyArray1<'py, f64>,
    receivers: PyReadonlyArray2<'py, f64>,
    radius: f64,
    rays: u64,
    first_ray: u64,
    end_ray: u64,
    seed: u64,
    threads: usize,
    estimator: &str,
    speed_of_sound: f64,
    air_attenuation: PyReadonlyArray1<'py, f64>,
    energy_drop_db: f64,
    max_time_s: f64,
    sample_rate: f64,
    early_s: f64,
    late_bin_s: f64,
    n_azimuth: usize,
    n_elevation: usize,
    progress: Option<Bound<'py, PyAny>>,
    keep_counts: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let air = air_attenuation.as_array().to_vec();
    let nb = air.len();
    let acoustics = Acoustics { n_bands: nb, absorption: per_material("absorption", &absorption, nb)?, scattering: per_material("scattering", &scattering, nb)? };
    let pos = points("source_positions", &source_positions)?;
    let axes = points("source_axes", &source_axes)?;
    let powers = source_powers.as_array().to_vec();
    let cos = source_cos_half_angle.as_array().to_vec();
    if axes.len() != pos.len() || powers.len() != pos.len() || cos.len() != pos.len() {
        return Err(InvalidInputError::new_err("sources: positions, powers, axes and cone angles differ in number"));
    }
    // Positions in double precision (points() rounds to the geometry's f32).
    let positions = source_positions.as_array();
    let sources: Vec<SoundSource> = (0..pos.len())
        .map(|i| SoundSource {
            position: DVec3::new(positions[[i, 0]], positions[[i, 1]], positions[[i, 2]]),
            power_w: powers[i],
            directivity: if cos[i] <= -1.0 { Directivity::Omni } else { Directivity::Cone { axis: axes[i].as_dvec3().normalize(), cos_half_angle: cos[i] } },
        })
        .collect();
    let rc = receivers.as_array();
    if rc.ncols() != 3 {
        return Err(InvalidInputError::new_err(format!("receivers: expected shape (n, 3), got {:?}", rc.shape())));
    }
    let centres: Vec<DVec3> = rc.rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect();
    let estimator = match estimator {
        "paper" => Estimator::Paper,
        "rain" => Estimator::Rain,
        other => return Err(InvalidInputError::new_err(format!("estimator: '{other}' is not one of 'rain', 'paper'"))),
    };
    let settings = SoundSettings {
        rays, first_ray, end_ray, seed, threads, estimator, speed_of_sound, air_attenuation: air, energy_drop_db,
        max_time_s, sample_rate, early_s, late_bin_s, n_azimuth, n_elevation,
    };
    let receivers = Receivers::new(centres, radius);

    // Trace with the GIL released; the progress closure takes it back briefly to report and to
    // notice Ctrl-C.
    let mut interrupted: Option<PyErr> = None;
    let progress: Option<Py<PyAny>> = progress.map(|p| p.unbind());
    let result = py.detach(|| {
        trace(&geometry.mesh, &geometry.bvh, &acoustics, &sources, &receivers, &settings, |p| {
            crate::report_progress(&progress, p, &mut interrupted)
        })
    });
    // Ctrl-C or an error in the progress callback: the workers have stopped; re-raise it.
    if let Some(e) = interrupted {
        return Err(e);
    }
    let res = result.map_err(to_py)?;

    // Energies in J/m², reordered to [receiver][direction][band][time] for analysis.
    let l = &res.layout;
    let (nr, nt, nd) = (l.n_receivers, l.n_time(), l.n_directions());
    let q = res.field.quantum;
    let mut energy = vec![0f32; res.field.len()];
    if !energy.is_empty() {
        // One receiver's block [direction][band][time] per task, on the bake's thread count.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| InvalidInputError::new_err(format!("threads: {e}")))?;
        let field = &res.field;
        py.detach(|| {
            pool.install(|| {
                energy.par_chunks_mut(nd * nb * nt).enumerate().for_each(|(r, block)| {
                    for t in 0..nt {
                        for d in 0..nd {
                            let base = l.index(r, t, d);
                            for b in 0..nb {
                                block[(d * nb + b) * nt + t] = (field.get(base + b) as f64 * q) as f32;
                            }
                        }
                    }
                })
            })
        });
    }
    let out = PyDict::new(py);
    out.set_item("energy", energy.into_pyarray(py).reshape([nr, nd, nb, nt])?)?;
    let (starts, widths) = l.bin_starts_and_widths();
    out.set_item("bin_start_s", starts.into_pyarray(py))?;
    out.set_item("bin_width_s", widths.into_pyarray(py))?;
    out.set_item("early_bins", l.early_bins)?;
    out.set_item("late_bin_s", l.late_bin_s)?;
    out.set_item("quantum", q)?;
    out.set_item("saturated", res.field.saturated())?;
    out.set_item("cancelled", res.cancelled)?;
    if keep_counts {
        out.set_item("counts", res.field.to_vec().into_pyarray(py).reshape([nt, nr, nd, nb])?)?;
    }
    let st = &res.stats;
    let s = PyDict::new(py);
    s.set_item("rays", st.rays)?;
    s.set_item("segments", st.segments)?;
    s.set_item("surface_hits", st.surface_hits)?;
    s.set_item("escaped_rays", st.escaped_rays)?;
    s.set_item("deposits", st.deposits)?;
    s.set_item("max_reflections", st.max_reflections)?;
    s.set_item("mean_free_path_m", st.mean_free_path())?;
    s.set_item("free_path_relative_variance", st.free_path_relative_variance())?;
    for w in ["emitted", "absorbed_surfaces", "absorbed_air", "escaped", "remaining", "reweighted"] {
        s.set_item(format!("energy_{w}_j"), st.energy(w).unwrap_or_default().into_pyarray(py))?;
    }
    let escapes: Vec<(u32, u64, [f64; 3], [f64; 3])> = st.escapes.iter().map(|e| (e.source, e.ray, e.from, e.dir)).collect();
    s.set_item("escapes", escapes)?;
    out.set_item("stats", s)?;
    Ok(out)
}
