//! Binding of the partitioned convolver. Samples are float32; spectra are planar float32
//! (real parts, then imaginary parts, of every bin: the last two axes are [2, bins]). Shapes are
//! checked here so that errors name the argument and the shape expected.

use numpy::ndarray::{Dim, Dimension, IntoDimension};
use numpy::{Element, IntoPyArray, PyArray, PyArray2, PyArray3, PyArray4, PyArrayMethods, PyReadonlyArray, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3, PyReadonlyArray4, PyUntypedArrayMethods};
use pyo3::prelude::*;

use sonolux_core::convolver as core;

use crate::{invalid, to_py};

fn contiguous<'a, T: Element, D: Dimension>(name: &str, a: &'a PyReadonlyArray<'_, T, D>) -> PyResult<&'a [T]> {
    a.as_slice().map_err(|_| invalid(format!("{name}: must be one C-contiguous array")))
}

fn shaped<const N: usize>(py: Python<'_>, v: Vec<f32>, shape: [usize; N]) -> PyResult<Bound<'_, PyArray<f32, Dim<[usize; N]>>>>
where
    [usize; N]: IntoDimension<Dim = Dim<[usize; N]>>,
{
    v.into_pyarray(py).reshape(shape)
}

/// Convolver(block, partitions, fft_size): uniformly partitioned overlap-save convolution of
/// one input with filters of up to partitions × block taps (see `sonolux_core::convolver`).
#[pyclass(module = "sonolux._core")]
pub(crate) struct Convolver {
    inner: core::Convolver,
}

impl Convolver {
    fn bad_shape(name: &str, got: &[usize], want: &str) -> PyErr {
        invalid(format!("{name}: shape {got:?} does not fit the convolver: expected {want}"))
    }
}

#[pymethods]
impl Convolver {
    #[new]
    fn new(block: usize, partitions: usize, fft_size: usize) -> PyResult<Self> {
        Ok(Convolver { inner: core::Convolver::new(block, partitions, fft_size).map_err(to_py)? })
    }

    #[getter]
    fn block(&self) -> usize {
        self.inner.block()
    }
    #[getter]
    fn fft_size(&self) -> usize {
        self.inner.fft_size()
    }
    #[getter]
    fn partitions(&self) -> usize {
        self.inner.partitions()
    }
    #[getter]
    fn bins(&self) -> usize {
        self.inner.bins()
    }

    /// Takes the next block of input samples, float32[block].
    fn push(&mut self, x: PyReadonlyArray1<'_, f32>) -> PyResult<()> {
        self.inner.push(contiguous("x", &x)?).map_err(to_py)
    }

    /// float32[channel, 2, bins]: the block's output spectra through the filters
    /// float32[channel, partitions, 2, bins] (from `partition` or `fold`).
    fn apply<'py>(&self, py: Python<'py>, filters: PyReadonlyArray4<'py, f32>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let s = filters.shape();
        let (p, f) = (self.inner.partitions(), self.inner.bins());
        if s[1..] != [p, 2, f] {
            return Err(Self::bad_shape("filters", s, &format!("(channel, {p}, 2, {f})")));
        }
        let mut out = vec![0.0f32; s[0] * 2 * f];
        self.inner.apply(contiguous("filters", &filters)?, &mut out).map_err(to_py)?;
        shaped(py, out, [s[0], 2, f])
    }

    /// float32[channel, block]: the last block samples of the inverse FFT of each spectrum
    /// float32[channel, 2, bins].
    fn inverse<'py>(&mut self, py: Python<'py>, spectra: PyReadonlyArray3<'py, f32>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let s = spectra.shape();
        let (b, f) = (self.inner.block(), self.inner.bins());
        if s[1..] != [2, f] {
            return Err(Self::bad_shape("spectra", s, &format!("(channel, 2, {f})")));
        }
        let mut out = vec![0.0f32; s[0] * b];
        self.inner.inverse(contiguous("spectra", &spectra)?, &mut out).map_err(to_py)?;
        shaped(py, out, [s[0], b])
    }

    /// float32[channel, block]: the block's output through the filters (apply, then inverse).
    fn output<'py>(&mut self, py: Python<'py>, filters: PyReadonlyArray4<'py, f32>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let spectra = self.apply(py, filters)?;
        self.inverse(py, spectra.readonly())
    }
}

/// float32[channel, partitions, 2, fft_size/2 + 1]: filters float32[channel, n] cut into
/// partitions of `block` taps, each zero-padded to `fft_size` and transformed (planar).
#[pyfunction]
pub(crate) fn partition<'py>(py: Python<'py>, filters: PyReadonlyArray2<'py, f32>, block: usize, fft_size: usize, partitions: usize) -> PyResult<Bound<'py, PyArray4<f32>>> {
    let c = filters.shape()[0];
    let h = contiguous("filters", &filters)?;
    let out = py.detach(|| core::partition(h, c, block, fft_size, partitions)).map_err(to_py)?;
    shaped(py, out, [c, partitions, 2, fft_size / 2 + 1])
}

/// float32[channel, partitions, 2, bins]: out[e, p] = Σ_d mix[e, d] · filters[d, p], complex,
/// bin by bin, for filters float32[direction, partitions, 2, bins] and mix
/// float32[channel, direction, 2, bins] (all planar spectra).
#[pyfunction]
pub(crate) fn fold<'py>(py: Python<'py>, filters: PyReadonlyArray4<'py, f32>, mix: PyReadonlyArray4<'py, f32>) -> PyResult<Bound<'py, PyArray4<f32>>> {
    let (hs, gs) = (filters.shape().to_vec(), mix.shape().to_vec());
    if hs[2] != 2 || gs[1] != hs[0] || gs[2..] != hs[2..] {
        return Err(invalid(format!(
            "fold: mix of shape {gs:?} does not fit filters of shape {hs:?}: expected (channel, {}, 2, {})",
            hs[0], hs[3]
        )));
    }
    let (h, g) = (contiguous("filters", &filters)?, contiguous("mix", &mix)?);
    let out = py.detach(|| core::fold(h, hs[0], g, gs[0])).map_err(to_py)?;
    shaped(py, out, [gs[0], hs[1], 2, hs[3]])
}
