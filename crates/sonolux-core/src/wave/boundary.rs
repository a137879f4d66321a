//! Boundary nodes: air nodes with solid neighbours, and the update of their walls.
//!
//! The finite-volume view (Bilbao, "Modeling of complex geometries and boundary conditions in
//! finite difference/finite volume time domain room acoustics simulation", IEEE TASLP 21(7),
//! 2013): each air node owns its cell of volume Δx³. A face towards an air neighbour carries the
//! flux Δx·(u_j − u_i); a face towards a solid neighbour is wall. With K air neighbours, and the
//! Courant number λ, the rigid update is
//!
//!   u⁺ = (2 − Kλ²)u + λ² Σ_air u_j − u⁻,
//!
//! which conserves a discrete energy (see [`super::scheme`]). The sweep computes every node as if
//! all six neighbours were air, with solid nodes held at 0; this module adds back (6 − K)λ²u.
//!
//! A wall of specific admittance Y adds the flux −S·ρ·∂v/∂t through its area S. The staircase
//! puts h² of wall on each solid face, while a plane of unit normal n cuts its cells with
//! (|n_x| + |n_y| + |n_z|) times more staircase faces than its true area: each face is given the
//! area h²/‖n‖₁ of the triangle it crosses, so that a slanted wall absorbs as much as a straight
//! one (the surface-area correction of Hamilton's pffdtd).
//!
//! The branches of Y are discretised as in Bilbao, Hamilton, Botts and Savioja 2016 (IEEE/ACM
//! TASLP 24(1)): with branch "velocity" w at half steps and its integral g,
//!   d(w⁺ − w⁻) + e(w⁺ + w⁻)/2 + f(g⁺ + g⁻)/2 = (u⁺ − u⁻)/2,   g⁺ = g⁻ + (w⁺ + w⁻)/2,
//! where d = D/Δt, e = E, f = F·Δt, and the node feels −λβ·Σ(w⁺ + w⁻)/2 with β = S/h². The node
//! and its branches are solved together, in closed form (semi-implicit: one division per node).
//! Multiplying the branch equation by (w⁺ + w⁻)/2 shows the wall stores d·w² + f·g², never
//! negative, and dissipates 2e((w⁺ + w⁻)/2)² ≥ 0: the scheme with walls keeps a non-increasing
//! energy for any D, E, F ≥ 0 ([`BoundarySlab::stored_energy`]), so it is stable by construction.

use glam::DVec3;

use super::admittance::Admittance;
use super::grid::Grid;
use super::voxel::Face;
use crate::mesh::Mesh;

/// One admittance branch in the scheme's dimensionless form.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DiscreteBranch {
    /// 1/(d + e/2 + f/4).
    b: f64,
    d: f64,
    f: f64,
}

/// A material's admittance in the scheme's form.
#[derive(Clone, Debug)]
pub(crate) struct DiscreteWall {
    branches: Vec<DiscreteBranch>,
    /// Σ b over the branches, plus 2·conductance (a stateless branch of b = 2/e).
    sum_b: f64,
    rigid: bool,
}

impl DiscreteWall {
    pub fn new(y: &Admittance, dt: f64) -> DiscreteWall {
        let branches: Vec<DiscreteBranch> = y
            .branches
            .iter()
            .map(|br| {
                let (d, e, f) = (br.mass_s / dt, br.resistance, br.stiffness_per_s * dt);
                DiscreteBranch { b: 1.0 / (d + 0.5 * e + 0.25 * f), d, f }
            })
            .collect();
        let sum_b = branches.iter().map(|b| b.b).sum::<f64>() + 2.0 * y.conductance;
        DiscreteWall { branches, sum_b, rigid: y.is_rigid() }
    }
}

impl DiscreteWall {
    /// Bytes this wall holds besides itself.
    pub fn allocated_bytes(&self) -> u64 {
        (std::mem::size_of::<DiscreteWall>() + self.branches.capacity() * std::mem::size_of::<DiscreteBranch>()) as u64
    }
}

/// The walls of one node for one material: the node's faces of that material summed.
#[derive(Clone, Copy, Debug)]
struct Entry {
    material: u32,
    /// λ·β: λ times the wall area in units of h².
    coefficient: f64,
    /// Where this entry's branch states start in `state` (w then g per branch).
    state: u32,
}

/// The boundary nodes of one slab of the grid, in index order, with their walls' state.
#[derive(Clone, Debug, Default)]
pub(crate) struct BoundarySlab {
    /// Nodes whose walls are all rigid, and their (6 − K)·λ²: the sweep's missing-neighbour
    /// correction, all they need.
    rigid: Vec<(u32, f32)>,
    /// Nodes with lossy walls, and their (6 − K)·λ².
    lossy: Vec<u32>,
    lossy_gain: Vec<f64>,
    /// γ of the node's walls, and 1/(1 + γ).
    gamma: Vec<f64>,
    inverse: Vec<f64>,
    /// The node's entries are `entries[entry_start[i]..entry_start[i + 1]]`.
    entry_start: Vec<u32>,
    entries: Vec<Entry>,
    state: Vec<f64>,
    /// u⁻ of each lossy node, kept before the sweep overwrites it.
    saved: Vec<f32>,
}

/// The most a boundary face can hold, in bytes, besides its branches' state: a lossy node of its
/// own (index, gain, γ, 1/(1 + γ), entry start, saved pressure), one entry, and the solid node
/// behind it in the slab's shell. The memory estimate's per-face bytes (settings.rs).
pub(crate) const BYTES_PER_FACE: u64 =
    (3 * std::mem::size_of::<u32>() + 3 * std::mem::size_of::<f64>() + std::mem::size_of::<f32>() + std::mem::size_of::<Entry>()) as u64;
/// The most a face of a rigid wall can hold: a rigid node of its own (index, (6 − K)·λ²) and the
/// solid node behind it in the slab's shell.
pub(crate) const BYTES_PER_RIGID_FACE: u64 = (std::mem::size_of::<(u32, f32)>() + std::mem::size_of::<u32>()) as u64;
/// Per admittance branch of an entry: its two f64 states, w and g.
pub(crate) const BYTES_PER_BRANCH: u64 = 2 * std::mem::size_of::<f64>() as u64;

/// Counts of the boundary, for the run's statistics.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BoundaryStats {
    pub nodes: u64,
    pub faces: u64,
    /// (node, material) pairs of lossy walls, each with its branches' state.
    pub lossy_entries: u64,
    /// Total wall area as the solver sees it (after the slant correction), m².
    pub area_m2: f64,
}

/// Builds the slabs' boundary nodes from the voxelised faces. `slab_of(index)` names the slab of
/// a grid index; slabs come back in order.
#[allow(clippy::too_many_arguments)]
pub(crate) fn build(
    grid: &Grid,
    mesh: &Mesh,
    faces: &[Face],
    walls: &[DiscreteWall],
    a2: f64,
    slab_of: impl Fn(usize) -> usize,
    n_slabs: usize,
    wall_of: impl Fn(&Face) -> u32,
) -> (Vec<BoundarySlab>, BoundaryStats) {
    let lambda = a2.sqrt();
    let mut slabs = vec![BoundarySlab::default(); n_slabs];
    let mut stats = BoundaryStats { faces: faces.len() as u64, ..Default::default() };
    let h2 = grid.spacing_m * grid.spacing_m;
    let mut i = 0;
    while i < faces.len() {
        let node = faces[i].node;
        let mut end = i;
        while end < faces.len() && faces[end].node == node {
            end += 1;
        }
        // Wall area per material, in units of h².
        let mut areas: Vec<(u32, f64)> = Vec::new();
        for f in &faces[i..end] {
            let tri = f.tri as usize;
            let n: DVec3 = mesh.normal(tri).as_dvec3();
            let l1 = n.x.abs() + n.y.abs() + n.z.abs();
            let beta = if l1 > 0.0 { 1.0 / l1 } else { 1.0 };
            // The face's wall: its material's, or the well of its patch (wells.rs).
            let m = wall_of(f);
            match areas.iter_mut().find(|a| a.0 == m) {
                Some(a) => a.1 += beta,
                None => areas.push((m, beta)),
            }
        }
        areas.sort_by_key(|a| a.0);
        let s = &mut slabs[slab_of(node as usize)];
        let gain = (end - i) as f64 * a2;
        let first_entry = s.entries.len();
        let mut gamma = 0.0;
        for (m, beta) in areas {
            stats.area_m2 += beta * h2;
            let wall = &walls[m as usize];
            if wall.rigid {
                continue;
            }
            let coefficient = lambda * beta;
            gamma += 0.25 * coefficient * wall.sum_b;
            s.entries.push(Entry { material: m, coefficient, state: s.state.len() as u32 });
            s.state.extend(std::iter::repeat_n(0.0, 2 * wall.branches.len()));
            stats.lossy_entries += 1;
        }
        if s.entries.len() == first_entry {
            s.rigid.push((node, gain as f32));
        } else {
            s.lossy.push(node);
            s.lossy_gain.push(gain);
            s.entry_start.push(first_entry as u32);
            s.gamma.push(gamma);
            s.inverse.push(1.0 / (1.0 + gamma));
        }
        stats.nodes += 1;
        i = end;
    }
    for s in &mut slabs {
        s.entry_start.push(s.entries.len() as u32);
        s.saved = vec![0.0; s.lossy.len()];
        s.shrink();
    }
    (slabs, stats)
}

impl BoundarySlab {
    /// Gives back what the vectors' growth over-allocated while they were built: the run holds
    /// what it uses (the memory estimate bounds that).
    fn shrink(&mut self) {
        self.rigid.shrink_to_fit();
        self.lossy.shrink_to_fit();
        self.lossy_gain.shrink_to_fit();
        self.gamma.shrink_to_fit();
        self.inverse.shrink_to_fit();
        self.entry_start.shrink_to_fit();
        self.entries.shrink_to_fit();
        self.state.shrink_to_fit();
    }

    /// Bytes this slab holds (its vectors' capacities).
    pub fn allocated_bytes(&self) -> u64 {
        fn bytes<T>(v: &Vec<T>) -> u64 {
            (v.capacity() * std::mem::size_of::<T>()) as u64
        }
        bytes(&self.rigid) + bytes(&self.lossy) + bytes(&self.lossy_gain) + bytes(&self.gamma) + bytes(&self.inverse)
            + bytes(&self.entry_start) + bytes(&self.entries) + bytes(&self.state) + bytes(&self.saved)
    }

    /// Keeps u⁻ of every lossy node; `prev` is the slab's part of the previous field, starting at
    /// grid index `base`.
    pub fn save(&mut self, prev: &[f32], base: usize) {
        for (s, &n) in self.saved.iter_mut().zip(&self.lossy) {
            *s = prev[n as usize - base];
        }
    }

    /// Finishes the boundary nodes after the sweep: `next` (the slab's part, from `base`) holds
    /// the sweep's values, `cur` the whole current field.
    pub fn update(&mut self, next: &mut [f32], cur: &[f32], base: usize, walls: &[DiscreteWall]) {
        for &(n, gain) in &self.rigid {
            let n = n as usize;
            next[n - base] += gain * cur[n];
        }
        for i in 0..self.lossy.len() {
            let n = self.lossy[i] as usize;
            let rigid = next[n - base] as f64 + self.lossy_gain[i] * cur[n] as f64;
            let entries = &self.entries[self.entry_start[i] as usize..self.entry_start[i + 1] as usize];
            let prev = self.saved[i] as f64;
            // The walls' history term: Σ λβ Σ_m b (d·w − f·g/2).
            let mut history = 0.0;
            for e in entries {
                let st = &self.state[e.state as usize..];
                let mut sum = 0.0;
                for (m, br) in walls[e.material as usize].branches.iter().enumerate() {
                    sum += br.b * (br.d * st[2 * m] - 0.5 * br.f * st[2 * m + 1]);
                }
                history += e.coefficient * sum;
            }
            let u = (rigid + self.gamma[i] * prev - history) * self.inverse[i];
            let u = u as f32;
            next[n - base] = u;
            // Advance each branch with the node's change over two steps.
            let du = u as f64 - prev;
            for e in entries {
                let st = &mut self.state[e.state as usize..];
                for (m, br) in walls[e.material as usize].branches.iter().enumerate() {
                    let (w, g) = (st[2 * m], st[2 * m + 1]);
                    let w_new = 0.5 * br.b * du + (2.0 * br.b * br.d - 1.0) * w - br.b * br.f * g;
                    st[2 * m] = w_new;
                    st[2 * m + 1] = g + 0.5 * (w_new + w);
                }
            }
        }
    }

    /// Energy held by the walls, in the units of [`super::scheme::WaveSolver::energy`]:
    /// Σ λβ Σ_m (d·w² + f·g²).
    pub fn stored_energy(&self, walls: &[DiscreteWall]) -> f64 {
        self.entries
            .iter()
            .map(|e| {
                let st = &self.state[e.state as usize..];
                let s: f64 =
                    walls[e.material as usize].branches.iter().enumerate().map(|(m, br)| br.d * st[2 * m].powi(2) + br.f * st[2 * m + 1].powi(2)).sum();
                e.coefficient * s
            })
            .sum()
    }

    /// Clears the walls' state.
    pub fn reset(&mut self) {
        self.state.iter_mut().for_each(|s| *s = 0.0);
    }
}
