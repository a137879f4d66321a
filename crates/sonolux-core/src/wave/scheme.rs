//! The scheme: the standard rectilinear (7-point) leapfrog on a cubic grid, its update kernel,
//! its discrete energy and its dispersion.
//!
//! Why this scheme. The interpolated wideband scheme (IWB, Kowalczyk and van Walstijn, "Room
//! acoustics simulation using 3-D compact explicit FDTD schemes", IEEE TASL 19(1), 2011) reaches a
//! given phase error with fewer points per wavelength, but its 27-point stencil reads diagonal
//! neighbours, and energy-stable boundaries of any shape with frequency-dependent walls are known
//! in finite-volume form for the 7-point stencil (Bilbao 2013; Bilbao et al. 2016), whose links
//! are exactly the cell faces. We take the 7-point scheme at its Courant limit, where it has no
//! dispersion along the grid's diagonals and its worst (axial) phase-velocity error is 1.1% at
//! 10 points per wavelength, and pay with a finer grid: each update is one read of two arrays and
//! one write, the cheapest there is.
//!
//! Update (u = acoustic pressure, λ = cΔt/Δx, a₂ = λ²):
//!   u⁺ = (2 − 6a₂)·u + a₂·Σ₆ u_neighbour − u⁻,
//! in place (u⁺ overwrites u⁻), on every node of a row's air span, solid nodes held at 0 (those
//! next to air are reset after each sweep). Stability: von Neumann analysis gives
//! sin²(ωΔt/2) = λ² Σ_i sin²(k_iΔx/2), real ω for all k iff λ ≤ 1/√3. In f32, a₂ is rounded
//! down, so that the scheme the machine runs is itself inside the limit.
//!
//! Discrete energy (per Δx³/(2c²Δt²), conserved exactly in exact arithmetic with rigid walls):
//!   H^{n+½} = Σ_air (u_i^{n+1} − u_i^n)² + a₂ Σ_{air links ij} (u_i^{n+1} − u_j^{n+1})(u_i^n − u_j^n),
//! which is non-negative iff λ ≤ 1/√3. With walls, H plus the walls' stored energy never grows.
//!
//! Arithmetic order is fixed and the same in the SIMD lanes and the scalar tail (no fused
//! multiply-add), so a run gives the same bits for any thread count and any SIMD width.

use pulp::{Arch, Simd, WithSimd};
use rayon::prelude::*;

use super::boundary::{BoundarySlab, DiscreteWall};
use super::grid::Grid;
use crate::error::CoreError;

/// The phase velocity of the scheme over c for a plane wave of wavenumber direction `dir`
/// (unit) and `points_per_wavelength` = 2π/(kΔx), at Courant number `courant`.
pub fn phase_velocity_ratio(dir: [f64; 3], points_per_wavelength: f64, courant: f64) -> f64 {
    let kh = std::f64::consts::TAU / points_per_wavelength;
    let s: f64 = dir.iter().map(|d| (0.5 * kh * d).sin().powi(2)).sum();
    let omega_dt = 2.0 * (courant * s.sqrt()).min(1.0).asin();
    omega_dt / (courant * kh)
}

/// The angular frequency times Δt of the discrete mode whose graph-Laplacian eigenvalue is
/// `mu` (e.g. Σ_i 4 sin²(π m_i / (2N_i)) for mode (m_x, m_y, m_z) of a rigid box of N_i cells):
/// cos(ωΔt) = 1 − a₂·μ/2.
pub fn mode_omega_dt(mu: f64, a2: f64) -> f64 {
    (1.0 - 0.5 * a2 * mu).clamp(-1.0, 1.0).acos()
}

/// The f32 coefficients the machine runs: a₂ = λ² rounded down to f32, and a₁ = 2 − 6a₂.
pub fn coefficients(courant: f64) -> (f32, f32) {
    let exact = courant * courant;
    let mut a2 = exact as f32;
    if a2 as f64 > exact {
        a2 = f32::from_bits(a2.to_bits() - 1);
    }
    (a2, (2.0 - 6.0 * a2 as f64) as f32)
}

/// A slab of whole x-planes, processed by one task.
#[derive(Clone, Debug, Default)]
pub(crate) struct Slab {
    /// First plane and number of planes.
    pub first: usize,
    pub planes: usize,
    pub boundary: BoundarySlab,
    /// Solid nodes next to air in these planes, reset to 0 after each sweep.
    pub shell: Vec<u32>,
}

/// The state of a simulation and the machinery to advance it.
pub struct WaveSolver {
    pub(crate) grid: Grid,
    /// Runs of the sweep per x-plane: `runs[plane_runs[i]..plane_runs[i + 1]]` are (start, length)
    /// within plane i, in order.
    runs: Vec<[u32; 2]>,
    plane_runs: Vec<u32>,
    cur: Vec<f32>,
    prev: Vec<f32>,
    pub(crate) slabs: Vec<Slab>,
    pub(crate) walls: Vec<DiscreteWall>,
    a1: f32,
    a2: f32,
    pool: rayon::ThreadPool,
    arch: Arch,
    steps: u64,
}

impl std::fmt::Debug for WaveSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WaveSolver").field("dims", &self.grid.dims).field("steps", &self.steps).finish_non_exhaustive()
    }
}

impl WaveSolver {
    /// Assembles a solver from a voxelised grid, its boundary slabs and walls (see
    /// [`super::build_solver`]).
    pub(crate) fn assemble(grid: Grid, slabs: Vec<Slab>, walls: Vec<DiscreteWall>, courant: f64, threads: usize) -> Result<WaveSolver, CoreError> {
        let (runs, plane_runs) = sweep_runs(&grid);
        let (a2, a1) = coefficients(courant);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| CoreError::invalid("threads", format!("cannot start {threads} threads: {e}")))?;
        let cells = grid.cells();
        Ok(WaveSolver { grid, runs, plane_runs, cur: vec![0.0; cells], prev: vec![0.0; cells], slabs, walls, a1, a2, pool, arch: Arch::new(), steps: 0 })
    }

    /// Bytes the solver holds: the grid's air mask, the two pressure fields, the sweep's runs,
    /// the slabs' boundary nodes and shells, the walls (vector capacities; what the memory
    /// estimate's grid and boundary parts bound, tests/wave_memory.rs).
    pub fn allocated_bytes(&self) -> u64 {
        fn bytes<T>(v: &Vec<T>) -> u64 {
            (v.capacity() * std::mem::size_of::<T>()) as u64
        }
        let slabs: u64 = self.slabs.iter().map(|s| s.boundary.allocated_bytes() + bytes(&s.shell)).sum();
        let walls: u64 = self.walls.iter().map(|w| w.allocated_bytes()).sum();
        bytes(&self.grid.air) + bytes(&self.cur) + bytes(&self.prev) + bytes(&self.runs) + bytes(&self.plane_runs) + slabs + walls
    }

    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The pressure field u^n (solid nodes 0), in the grid's axis order.
    pub fn pressure(&self) -> &[f32] {
        &self.cur
    }

    /// The previous field u^{n−1}.
    pub fn previous_pressure(&self) -> &[f32] {
        &self.prev
    }

    /// Steps taken so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// λ² as run (f32).
    pub fn a2(&self) -> f32 {
        self.a2
    }

    /// Runs `f` on the solver's own threads.
    pub(crate) fn install<R: Send>(&self, f: impl FnOnce(&Self) -> R + Send) -> R {
        self.pool.install(|| f(self))
    }

    /// Sets u^n and u^{n−1} (e.g. to start from a mode shape, or to resume), zeroes solid nodes
    /// and the walls' state.
    pub fn set_state(&mut self, current: &[f32], previous: &[f32]) -> Result<(), CoreError> {
        let n = self.grid.cells();
        if current.len() != n || previous.len() != n {
            return Err(CoreError::invalid("state", format!("needs {n} values per field, got {} and {}", current.len(), previous.len())));
        }
        for i in 0..n {
            let air = self.grid.air[i] as f32;
            self.cur[i] = current[i] * air;
            self.prev[i] = previous[i] * air;
        }
        for s in &mut self.slabs {
            s.boundary.reset();
        }
        Ok(())
    }

    /// Advances one step. `inject` lists (grid index, value) added to u^{n+1} before the walls
    /// are solved (sources), sorted by index.
    pub fn step(&mut self, inject: &[(usize, f32)]) {
        let plane = self.grid.strides()[0];
        let [nx, ny, nz] = self.grid.dims;
        let (cur, runs, plane_runs, walls, arch) = (&self.cur, &self.runs, &self.plane_runs, &self.walls, self.arch);
        let (a1, a2) = (self.a1, self.a2);
        let slabs = &mut self.slabs;
        let prev = &mut self.prev;
        self.pool.install(|| {
            let mut parts: Vec<(&mut Slab, &mut [f32])> = Vec::with_capacity(slabs.len());
            let mut rest: &mut [f32] = prev;
            for s in slabs.iter_mut() {
                let (mine, tail) = rest.split_at_mut(s.planes * plane);
                parts.push((s, mine));
                rest = tail;
            }
            parts.into_par_iter().for_each(|(slab, next)| {
                let base = slab.first * plane;
                slab.boundary.save(next, base);
                let sweep = Sweep { next, cur, runs, plane_runs, base, first: slab.first, planes: slab.planes, dims: [nx, ny, nz], a1, a2 };
                arch.dispatch(sweep);
                let end = base + slab.planes * plane;
                let lo = inject.partition_point(|&(i, _)| i < base);
                for &(i, v) in inject[lo..].iter().take_while(|&&(i, _)| i < end) {
                    next[i - base] += v;
                }
                slab.boundary.update(next, cur, base, walls);
                for &s in &slab.shell {
                    next[s as usize - base] = 0.0;
                }
            });
        });
        std::mem::swap(&mut self.cur, &mut self.prev);
        self.steps += 1;
    }

    /// The discrete energy H^{n+½} between the current field and the previous one, plus what the
    /// walls hold (in units of Δx³/(2c²Δt²)): constant with rigid walls, never growing with
    /// passive ones. Summed in a fixed order.
    pub fn energy(&self) -> f64 {
        let [sx, sy, sz] = self.grid.strides();
        let (u1, u0) = (&self.cur, &self.prev);
        let air = &self.grid.air;
        let a2 = self.a2 as f64;
        let per_plane: Vec<f64> = (0..self.grid.dims[0])
            .into_par_iter()
            .map(|i| {
                let mut e = 0.0;
                for n in i * sx..(i + 1) * sx {
                    if air[n] == 0 {
                        continue;
                    }
                    let d = u1[n] as f64 - u0[n] as f64;
                    e += d * d;
                    for s in [sx, sy, sz] {
                        let m = n + s;
                        if m < air.len() && air[m] != 0 {
                            e += a2 * (u1[n] as f64 - u1[m] as f64) * (u0[n] as f64 - u0[m] as f64);
                        }
                    }
                }
                e
            })
            .collect();
        let walls: f64 = self.slabs.iter().map(|s| s.boundary.stored_energy(&self.walls)).sum();
        per_plane.iter().sum::<f64>() + walls
    }
}

/// Gaps of solid nodes up to this long between two rows' air spans are swept through rather
/// than skipped: one long run vectorises better than many short ones.
const MAX_SWEPT_GAP: usize = 64;

/// The runs of nodes each plane's sweep covers: every row's span from its first to its last air
/// node, with spans closer than [`MAX_SWEPT_GAP`] merged. Solid nodes swept through are either next
/// to air (then reset after each sweep, see [`Slab::shell`]) or surrounded by solid nodes that
/// are all 0, and so stay 0.
fn sweep_runs(grid: &Grid) -> (Vec<[u32; 2]>, Vec<u32>) {
    let [nx, ny, nz] = grid.dims;
    let plane = ny * nz;
    let (mut runs, mut plane_runs) = (Vec::new(), vec![0u32]);
    for i in 0..nx {
        let mut current: Option<[usize; 2]> = None;
        for j in 0..ny {
            let row = &grid.air[i * plane + j * nz..i * plane + (j + 1) * nz];
            let (Some(a), Some(b)) = (row.iter().position(|&x| x != 0), row.iter().rposition(|&x| x != 0)) else { continue };
            let (start, end) = (j * nz + a, j * nz + b + 1);
            current = match current {
                Some([s, e]) if start - e <= MAX_SWEPT_GAP => Some([s, end]),
                Some([s, e]) => {
                    runs.push([s as u32, (e - s) as u32]);
                    Some([start, end])
                }
                None => Some([start, end]),
            };
        }
        if let Some([s, e]) = current {
            runs.push([s as u32, (e - s) as u32]);
        }
        plane_runs.push(runs.len() as u32);
    }
    runs.shrink_to_fit();
    (runs, plane_runs)
}

/// The interior update of one slab's runs.
struct Sweep<'a> {
    next: &'a mut [f32],
    cur: &'a [f32],
    runs: &'a [[u32; 2]],
    plane_runs: &'a [u32],
    base: usize,
    first: usize,
    planes: usize,
    dims: [usize; 3],
    a1: f32,
    a2: f32,
}

impl WithSimd for Sweep<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let Sweep { next, cur, runs, plane_runs, base, first, planes, dims: [nx, ny, nz], a1, a2 } = self;
        let (sx, sy) = (ny * nz, nz);
        let (va1, va2) = (simd.splat_f32s(a1), simd.splat_f32s(a2));
        for i in first.max(1)..(first + planes).min(nx - 1) {
            for &[start, len] in &runs[plane_runs[i] as usize..plane_runs[i + 1] as usize] {
                let g = i * sx + start as usize;
                let len = len as usize;
                let c = &cur[g..g + len];
                let (zm, zp) = (&cur[g - 1..g - 1 + len], &cur[g + 1..g + 1 + len]);
                let (ym, yp) = (&cur[g - sy..g - sy + len], &cur[g + sy..g + sy + len]);
                let (xm, xp) = (&cur[g - sx..g - sx + len], &cur[g + sx..g + sx + len]);
                let out = &mut next[g - base..g - base + len];
                let (o, o_t) = S::as_mut_simd_f32s(out);
                let (c_v, c_t) = S::as_simd_f32s(c);
                let (zm_v, zm_t) = S::as_simd_f32s(zm);
                let (zp_v, zp_t) = S::as_simd_f32s(zp);
                let (ym_v, ym_t) = S::as_simd_f32s(ym);
                let (yp_v, yp_t) = S::as_simd_f32s(yp);
                let (xm_v, xm_t) = S::as_simd_f32s(xm);
                let (xp_v, xp_t) = S::as_simd_f32s(xp);
                let lanes = o.iter_mut().zip(c_v).zip(zm_v.iter().zip(zp_v)).zip(ym_v.iter().zip(yp_v)).zip(xm_v.iter().zip(xp_v));
                for ((((o, &c), (&zm, &zp)), (&ym, &yp)), (&xm, &xp)) in lanes {
                    let s = simd.add_f32s(simd.add_f32s(simd.add_f32s(zm, zp), simd.add_f32s(ym, yp)), simd.add_f32s(xm, xp));
                    *o = simd.sub_f32s(simd.add_f32s(simd.mul_f32s(va2, s), simd.mul_f32s(va1, c)), *o);
                }
                let tail = o_t.iter_mut().zip(c_t).zip(zm_t.iter().zip(zp_t)).zip(ym_t.iter().zip(yp_t)).zip(xm_t.iter().zip(xp_t));
                for ((((o, &c), (&zm, &zp)), (&ym, &yp)), (&xm, &xp)) in tail {
                    let s = ((zm + zp) + (ym + yp)) + (xm + xp);
                    *o = (a2 * s + a1 * c) - *o;
                }
            }
        }
    }
}
