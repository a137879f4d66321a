//! The regular grid of the wave solver: node positions, the flat index and its axis order, and
//! which nodes are air.
//!
//! Axis order: x slowest, z fastest: node (i, j, k) is `(i·ny + j)·nz + k`. Node (i, j, k) sits
//! at `origin + (i, j, k)·Δx`. The grid is cell-centred on the scene: node 1 lies half a cell
//! inside the minimum corner of the scene's box, so a box-shaped room whose sides are whole
//! multiples of Δx has its walls exactly on cell faces. One layer of nodes outside the box on
//! every side is always solid, so that the update never reads beyond the arrays.

use glam::DVec3;

use crate::error::CoreError;
use crate::geometry::Aabb;

#[derive(Clone, Debug)]
pub struct Grid {
    pub spacing_m: f64,
    /// Position of node (0, 0, 0).
    pub origin_m: DVec3,
    /// Nodes along x, y, z.
    pub dims: [usize; 3],
    /// 1 where the node is air, 0 where it is solid (inside walls or obstacles, or outside).
    pub air: Vec<u8>,
}

impl Grid {
    /// An all-solid grid over `bounds` with spacing `h`; fails beyond 2³² nodes.
    pub fn over(bounds: &Aabb, h: f64) -> Result<Grid, CoreError> {
        if !(bounds.min.x <= bounds.max.x) {
            return Err(CoreError::Geometry("the scene has no vertices to voxelise".into()));
        }
        let lo = bounds.min.as_dvec3();
        let extent = bounds.max.as_dvec3() - lo;
        // A hair under a whole number of cells counts as whole: vertices are f32.
        let n = |e: f64| (e / h - 1e-6).ceil().max(1.0) as usize + 2;
        let dims = [n(extent.x), n(extent.y), n(extent.z)];
        let cells = dims.iter().map(|&d| d as u128).product::<u128>();
        if cells > u32::MAX as u128 {
            return Err(CoreError::invalid(
                "max_frequency_hz",
                format!("the grid would have {cells} nodes ({dims:?}), more than the 2³² the solver indexes"),
            ));
        }
        Ok(Grid { spacing_m: h, origin_m: lo - DVec3::splat(0.5 * h), dims, air: vec![0; cells as usize] })
    }

    pub fn cells(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    pub fn air_cells(&self) -> usize {
        self.air.iter().map(|&a| a as usize).sum()
    }

    /// Distance in the flat index between neighbours along x, y and z.
    #[inline]
    pub fn strides(&self) -> [usize; 3] {
        [self.dims[1] * self.dims[2], self.dims[2], 1]
    }

    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (i * self.dims[1] + j) * self.dims[2] + k
    }

    /// (i, j, k) of a flat index.
    #[inline]
    pub fn ijk(&self, index: usize) -> [usize; 3] {
        let k = index % self.dims[2];
        let r = index / self.dims[2];
        [r / self.dims[1], r % self.dims[1], k]
    }

    #[inline]
    pub fn position(&self, index: usize) -> DVec3 {
        let [i, j, k] = self.ijk(index);
        self.origin_m + DVec3::new(i as f64, j as f64, k as f64) * self.spacing_m
    }

    /// Coordinate of node `i` along `axis`.
    #[inline]
    pub fn coordinate(&self, axis: usize, i: usize) -> f64 {
        self.origin_m[axis] + i as f64 * self.spacing_m
    }

    #[inline]
    pub fn is_air(&self, index: usize) -> bool {
        self.air[index] != 0
    }

    /// The node whose cell holds `p`, if inside the grid.
    pub fn nearest_node(&self, p: DVec3) -> Option<usize> {
        let f = (p - self.origin_m) / self.spacing_m;
        let mut ijk = [0usize; 3];
        for a in 0..3 {
            let r = f[a].round();
            if !(r >= 0.0 && r < self.dims[a] as f64) {
                return None;
            }
            ijk[a] = r as usize;
        }
        Some(self.index(ijk[0], ijk[1], ijk[2]))
    }

    /// The index of the lower corner of the cell of nodes around `p` and the fractional position
    /// inside it (each in [0, 1)), for trilinear weights; None unless all 8 nodes are inside the grid.
    pub fn cell_of(&self, p: DVec3) -> Option<(usize, DVec3)> {
        let f = (p - self.origin_m) / self.spacing_m;
        let mut ijk = [0usize; 3];
        let mut frac = DVec3::ZERO;
        for a in 0..3 {
            let fl = f[a].floor();
            if !(fl >= 0.0 && fl + 1.0 < self.dims[a] as f64) {
                return None;
            }
            ijk[a] = fl as usize;
            frac[a] = f[a] - fl;
        }
        Some((self.index(ijk[0], ijk[1], ijk[2]), frac))
    }

    /// The 8 nodes around `p` and their trilinear weights, with solid nodes left out and the rest
    /// renormalised; None when `p` is outside the grid or all 8 are solid.
    pub fn air_weights(&self, p: DVec3) -> Option<Vec<(usize, f64)>> {
        let (base, f) = self.cell_of(p)?;
        let [sx, sy, _] = self.strides();
        let mut out = Vec::with_capacity(8);
        let mut total = 0.0;
        for corner in 0..8 {
            let (di, dj, dk) = (corner >> 2 & 1, corner >> 1 & 1, corner & 1);
            let w = (if di == 1 { f.x } else { 1.0 - f.x })
                * (if dj == 1 { f.y } else { 1.0 - f.y })
                * (if dk == 1 { f.z } else { 1.0 - f.z });
            let idx = base + di * sx + dj * sy + dk;
            if self.is_air(idx) && w > 0.0 {
                out.push((idx, w));
                total += w;
            }
        }
        if out.is_empty() {
            // p sits exactly on a node face whose weighted corners are all solid.
            return None;
        }
        for (_, w) in &mut out {
            *w /= total;
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_box_of_whole_cells_has_its_walls_on_cell_faces() {
        let b = Aabb { min: Vec3::ZERO, max: Vec3::new(1.0, 0.5, 0.25) };
        let g = Grid::over(&b, 0.05).unwrap();
        assert_eq!(g.dims[0], 22);
        // Node 1 is half a cell inside the wall at 0.
        assert!((g.coordinate(0, 1) - 0.025).abs() < 1e-12);
        let idx = g.index(3, 4, 5);
        assert_eq!(g.ijk(idx), [3, 4, 5]);
        assert_eq!(g.nearest_node(g.position(idx)), Some(idx));
    }
}
