//! Receivers: pressure and particle velocity at any points, recorded every step.
//!
//! Pressure is interpolated trilinearly from the 8 nodes around the point (solid ones left out,
//! the rest renormalised). For a plane wave of wavenumber k this is a spatial low-pass whose
//! worst loss, at a cell's centre, is cos³(kΔx/2)-like: 1 − cos(kΔx/2) ≈ (kΔx)²/8 per axis, 0.8%
//! per axis at the pulse's peak frequency (20 points per wavelength), 4.8% at 10. Arrival times
//! are those of linear interpolation: no error for a plane wave along an axis, and none from
//! rounding the position to a node (which would shift them by up to 1.5 steps at λ = 1/√3).
//!
//! Velocity comes from Euler's equation ρ ∂v/∂t = −∇p, staggered in time as the leapfrog is:
//! v^{n+½} = v^{n−½} − (Δt/ρ)∇p^n, with ∇p^n the central difference at each of the 8 nodes
//! (a solid neighbour mirrors the node: zero normal gradient at a rigid wall), interpolated like
//! the pressure. The recorded v^n = (v^{n+½} + v^{n−½})/2 sits at the same instant as p^n, so
//! p^n·v^n is the instantaneous intensity, whose direction is the direction energy flows.

use rayon::prelude::*;

use super::grid::Grid;

/// One receiver's nodes: (index, weight).
type Stencil = Vec<(usize, f64)>;

/// Pressure and velocity at the receivers, `[receiver][time]` and `[receiver][axis][time]`.
#[derive(Clone, Debug)]
pub(crate) struct Recorder {
    stencils: Vec<Stencil>,
    pub n_samples: usize,
    pub pressure: Vec<f32>,
    pub velocity: Vec<f32>,
    /// v^{n−½} per receiver.
    half: Vec<[f64; 3]>,
    dt_over_rho: f64,
}

/// Receivers beyond this many are recorded on all threads.
const PARALLEL_RECEIVERS: usize = 64;

impl Recorder {
    pub fn new(stencils: Vec<Stencil>, n_samples: usize, dt: f64, rho: f64) -> Recorder {
        let n = stencils.len();
        Recorder {
            stencils,
            n_samples,
            pressure: vec![0.0; n * n_samples],
            velocity: vec![0.0; 3 * n * n_samples],
            half: vec![[0.0; 3]; n],
            dt_over_rho: dt / rho,
        }
    }

    /// Records p^n and v^n from the field u^n, and advances v to n + ½.
    pub fn record(&mut self, n: usize, field: &[f32], grid: &Grid) {
        let ns = self.n_samples;
        let k = self.dt_over_rho;
        let one = |st: &Stencil, p: &mut [f32], v: &mut [f32], half: &mut [f64; 3]| {
            let (pressure, gradient) = probe(st, field, grid);
            p[n] = pressure as f32;
            for a in 0..3 {
                v[a * ns + n] = (half[a] - 0.5 * k * gradient[a]) as f32;
                half[a] -= k * gradient[a];
            }
        };
        if self.stencils.len() > PARALLEL_RECEIVERS {
            let jobs = self.stencils.par_iter().zip(self.pressure.par_chunks_mut(ns)).zip(self.velocity.par_chunks_mut(3 * ns));
            jobs.zip(self.half.par_iter_mut()).for_each(|(((st, p), v), h)| one(st, p, v, h));
        } else {
            let jobs = self.stencils.iter().zip(self.pressure.chunks_mut(ns)).zip(self.velocity.chunks_mut(3 * ns));
            jobs.zip(self.half.iter_mut()).for_each(|(((st, p), v), h)| one(st, p, v, h));
        }
    }

    /// Drops the samples after the first `n` (a cancelled run).
    pub fn truncate(&mut self, n: usize) {
        let ns = self.n_samples;
        if n >= ns {
            return;
        }
        self.pressure = self.pressure.chunks(ns).flat_map(|r| r[..n].to_vec()).collect();
        self.velocity = self.velocity.chunks(ns).flat_map(|r| r[..n].to_vec()).collect();
        self.n_samples = n;
    }
}

/// Pressure and its gradient at a receiver.
fn probe(stencil: &Stencil, u: &[f32], grid: &Grid) -> (f64, [f64; 3]) {
    let strides = grid.strides();
    let inv_2h = 0.5 / grid.spacing_m;
    let (mut p, mut g) = (0.0, [0.0; 3]);
    for &(i, w) in stencil {
        let ui = u[i] as f64;
        p += w * ui;
        for a in 0..3 {
            let s = strides[a];
            let side = |m: usize| if grid.is_air(m) { u[m] as f64 } else { ui };
            g[a] += w * (side(i + s) - side(i - s)) * inv_2h;
        }
    }
    (p, g)
}
