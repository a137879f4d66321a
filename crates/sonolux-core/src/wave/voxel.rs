//! Voxelisation: which grid nodes are air, and the air–solid cell faces with the triangle each
//! one crosses.
//!
//! Every grid line along an axis is intersected with every triangle whose projection covers it
//! (a 2-D point-in-triangle test in the plane across the axis). Each crossing carries the sign of
//! the triangle's normal along the axis, so that summing the signs of the crossings before a node
//! gives its winding number: the count of closed surfaces around it, whatever their number or
//! nesting. A node is air when its winding number is the room's (+1 when normals face out of the
//! air, −1 when they face into it): nodes inside furniture (which cancels the room's winding)
//! and nodes outside the room are solid, and so are parts of an obstacle that stick out through
//! a wall.
//!
//! The 2-D test is watertight, after the rasterisation rule of graphics hardware: each edge
//! function is computed from the edge's end points in one canonical order, so the two triangles
//! of a shared edge get exactly opposite values, and a line through an edge or vertex is given
//! to exactly one triangle by the top-left rule. Line coordinates are rounded to f32 like the
//! vertices, so the differences and products of the edge functions are exact in f64 for any
//! scene of ordinary coordinates, and a line through a vertex is recognised as such. A line thus
//! crosses a closed surface an even number of times, never leaks through a seam, and grazing a
//! silhouette counts zero.

use rayon::prelude::*;

use super::grid::Grid;
use crate::error::CoreError;
use crate::mesh::Mesh;

/// Where a grid line crosses a triangle.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    line: u32,
    /// Coordinate along the line's axis.
    pos: f64,
    tri: u32,
    /// +1 entering, −1 leaving the volume that the normals point out of.
    sign: i8,
}

/// The crossings along one axis, sorted by (line, position), with where each line's start.
struct Lines {
    crossings: Vec<Crossing>,
    starts: Vec<u32>,
}

impl Lines {
    fn of(&self, line: usize) -> &[Crossing] {
        &self.crossings[self.starts[line] as usize..self.starts[line + 1] as usize]
    }
}

/// An air node's face whose neighbour is solid: `dir` is 2·axis + (0 towards −, 1 towards +).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Face {
    pub node: u32,
    pub dir: u8,
    /// The triangle the link from the node to its neighbour crosses.
    pub tri: u32,
}

/// What voxelisation found, for the run's statistics.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VoxelStats {
    /// Surface crossings of grid lines, all three axes.
    pub crossings: u64,
    /// Faces whose link crossed no triangle (rounding at grazing geometry): their triangle was
    /// taken from the nearest crossing of the node's lines.
    pub faces_without_crossing: u64,
    /// Air nodes without a single air neighbour, made solid.
    pub isolated_air_removed: u64,
}

/// The winding number of the air: +1 when the normals face out of the enclosed air (positive
/// signed volume), −1 when they face into it.
pub fn air_winding(mesh: &Mesh) -> i32 {
    if mesh.report().signed_volume >= 0.0 {
        1
    } else {
        -1
    }
}

/// Marks the grid's air nodes and returns the air–solid faces, sorted by node then direction.
pub fn voxelise(mesh: &Mesh, grid: &mut Grid) -> Result<(Vec<Face>, VoxelStats), CoreError> {
    let w_air = air_winding(mesh);
    let lines: Vec<Lines> = (0..3).map(|axis| crossings(mesh, grid, axis)).collect();
    let mut stats = VoxelStats { crossings: lines.iter().map(|l| l.crossings.len() as u64).sum(), ..Default::default() };
    classify(grid, &lines[2], w_air);
    // Isolated air nodes have no air neighbour, so making them solid changes no other node's faces.
    let isolated: Vec<usize> = (0..grid.cells()).into_par_iter().filter(|&n| grid.is_air(n) && air_neighbours(grid, n) == 0).collect();
    for &n in &isolated {
        grid.air[n] = 0;
    }
    stats.isolated_air_removed = isolated.len() as u64;
    if grid.air_cells() == 0 {
        return Err(CoreError::Geometry(
            "no grid node lies inside the room: the mesh is open, or thinner than one grid cell".into(),
        ));
    }
    let (faces, missing) = faces(grid, &lines);
    stats.faces_without_crossing = missing;
    Ok((faces, stats))
}

/// The number of air neighbours of node `n` (which must not lie on the grid's outer layer).
pub fn air_neighbours(grid: &Grid, n: usize) -> usize {
    let [sx, sy, sz] = grid.strides();
    [n - sx, n + sx, n - sy, n + sy, n - sz, n + sz].iter().filter(|&&m| grid.is_air(m)).count()
}

/// The two axes across `axis`, in right-handed order (u, v, axis).
fn across(axis: usize) -> (usize, usize) {
    ((axis + 1) % 3, (axis + 2) % 3)
}

/// The index of the line along `axis` through node coordinates (ju, jv) on the axes across it.
fn line_index(grid: &Grid, axis: usize, ju: usize, jv: usize) -> usize {
    let (_, v) = across(axis);
    ju * grid.dims[v] + jv
}

fn crossings(mesh: &Mesh, grid: &Grid, axis: usize) -> Lines {
    let (u, v) = across(axis);
    let h = grid.spacing_m;
    // Line coordinates rounded to f32, like the vertices (see the module's notes).
    let line_u = |j: usize| (grid.coordinate(u, j) as f32) as f64;
    let line_v = |j: usize| (grid.coordinate(v, j) as f32) as f64;
    let mut all: Vec<Crossing> = (0..mesh.triangles.len())
        .into_par_iter()
        .filter(|&t| !mesh.degenerate[t])
        .fold(Vec::new, |mut out, t| {
            let c = mesh.corners(t).map(|p| p.as_dvec3());
            let q = c.map(|p| [p[u], p[v]]);
            let area2 = edge(q[0], q[1], q[2]);
            if area2 == 0.0 {
                return out; // parallel to the axis: no line crosses it
            }
            let o = area2.signum();
            let range = |axis_c: usize, lo: f64, hi: f64| {
                let a = ((lo - grid.origin_m[axis_c]) / h).ceil().max(0.0) as usize;
                let b = (((hi - grid.origin_m[axis_c]) / h).floor().max(-1.0) + 1.0) as usize;
                a..b.min(grid.dims[axis_c])
            };
            let (umin, umax) = (q[0][0].min(q[1][0]).min(q[2][0]), q[0][0].max(q[1][0]).max(q[2][0]));
            let (vmin, vmax) = (q[0][1].min(q[1][1]).min(q[2][1]), q[0][1].max(q[1][1]).max(q[2][1]));
            // The f32 rounding of a line coordinate may move it by a hair past the box.
            let pad = 1e-6 * h;
            for ju in range(u, umin - pad, umax + pad) {
                for jv in range(v, vmin - pad, vmax + pad) {
                    let p = [line_u(ju), line_v(jv)];
                    if let Some(pos) = crossing(&q, &c, axis, o, p) {
                        out.push(Crossing { line: line_index(grid, axis, ju, jv) as u32, pos, tri: t as u32, sign: -o as i8 });
                    }
                }
            }
            out
        })
        .reduce(Vec::new, |mut a, mut b| {
            a.append(&mut b);
            a
        });
    all.par_sort_unstable_by(|a, b| a.line.cmp(&b.line).then(a.pos.total_cmp(&b.pos)).then(a.tri.cmp(&b.tri)));
    let n_lines = grid.dims[u] * grid.dims[v];
    let mut starts = vec![0u32; n_lines + 1];
    for c in &all {
        starts[c.line as usize + 1] += 1;
    }
    for i in 0..n_lines {
        starts[i + 1] += starts[i];
    }
    Lines { crossings: all, starts }
}

/// Twice the signed area of (a, b, p), with the edge's end points always taken in the same
/// (lexicographic) order so that (a, b) and (b, a) give exactly opposite values.
#[inline]
fn edge(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    let raw = |a: [f64; 2], b: [f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    if (a[0], a[1]) <= (b[0], b[1]) {
        raw(a, b)
    } else {
        -raw(b, a)
    }
}

/// The top-left rule: a point exactly on an edge belongs to the triangle that runs the edge
/// (counter-clockwise) downwards, or leftwards when it is level. Of two triangles on either side
/// of an edge, exactly one does.
#[inline]
fn owns(d: [f64; 2]) -> bool {
    d[1] < 0.0 || (d[1] == 0.0 && d[0] < 0.0)
}

/// Where the line through `p` along `axis` crosses the triangle with corners `c` (projections
/// `q`, orientation `o` = ±1), if it does.
#[inline]
fn crossing(q: &[[f64; 2]; 3], c: &[glam::DVec3; 3], axis: usize, o: f64, p: [f64; 2]) -> Option<f64> {
    let mut w = [0.0f64; 3];
    for e in 0..3 {
        let (a, b) = (q[e], q[(e + 1) % 3]);
        let value = o * edge(a, b, p);
        let inside = value > 0.0 || (value == 0.0 && owns([o * (b[0] - a[0]), o * (b[1] - a[1])]));
        if !inside {
            return None;
        }
        // The edge from corner e to e + 1 weighs the opposite corner.
        w[(e + 2) % 3] = value;
    }
    let sum = w[0] + w[1] + w[2];
    if !(sum > 0.0) {
        return None;
    }
    Some((w[0] * c[0][axis] + w[1] * c[1][axis] + w[2] * c[2][axis]) / sum)
}

/// Air where the winding number along z is the room's.
fn classify(grid: &mut Grid, lines_z: &Lines, w_air: i32) {
    let [nx, ny, nz] = grid.dims;
    let z: Vec<f64> = (0..nz).map(|k| grid.coordinate(2, k)).collect();
    grid.air.par_chunks_mut(nz).enumerate().for_each(|(row, air)| {
        let (i, j) = (row / ny, row % ny);
        if i == 0 || j == 0 || i == nx - 1 || j == ny - 1 {
            return;
        }
        let cs = lines_z.of(row);
        let (mut w, mut next) = (0i32, 0usize);
        for k in 1..nz - 1 {
            while next < cs.len() && cs[next].pos < z[k] {
                w += cs[next].sign as i32;
                next += 1;
            }
            air[k] = (w == w_air) as u8;
        }
    });
}

/// Every air node's faces towards solid neighbours, with the triangle crossed; and how many
/// needed the fallback.
fn faces(grid: &Grid, lines: &[Lines]) -> (Vec<Face>, u64) {
    let [_, ny, nz] = grid.dims;
    let strides = grid.strides();
    let rows: Vec<(Vec<Face>, u64)> = (0..grid.dims[0] * ny)
        .into_par_iter()
        .map(|row| {
            let (mut out, mut missing) = (Vec::new(), 0u64);
            let (i, j) = (row / ny, row % ny);
            for k in 0..nz {
                let n = row * nz + k;
                if !grid.is_air(n) {
                    continue;
                }
                let ijk = [i, j, k];
                for dir in 0..6u8 {
                    let axis = dir as usize / 2;
                    let up = dir % 2 == 1;
                    let m = if up { n + strides[axis] } else { n - strides[axis] };
                    if grid.is_air(m) {
                        continue;
                    }
                    let (tri, found) = crossed(grid, lines, ijk, axis, up);
                    missing += !found as u64;
                    out.push(Face { node: n as u32, dir, tri });
                }
            }
            (out, missing)
        })
        .collect();
    let missing = rows.iter().map(|r| r.1).sum();
    (rows.into_iter().flat_map(|r| r.0).collect(), missing)
}

/// The triangle between node `ijk` and its neighbour along `axis` (upwards or not): the crossing
/// of that link nearest the node; failing that, the nearest crossing on any of the node's lines.
fn crossed(grid: &Grid, lines: &[Lines], ijk: [usize; 3], axis: usize, up: bool) -> (u32, bool) {
    let x0 = grid.coordinate(axis, ijk[axis]);
    let h = grid.spacing_m;
    let on_line = |a: usize| {
        let (u, v) = across(a);
        lines[a].of(line_index(grid, a, ijk[u], ijk[v]))
    };
    let cs = on_line(axis);
    let first_at_or_after = cs.partition_point(|c| c.pos < x0);
    let link = if up {
        cs.get(first_at_or_after).filter(|c| c.pos <= x0 + h)
    } else {
        first_at_or_after.checked_sub(1).map(|i| &cs[i]).filter(|c| c.pos >= x0 - h)
    };
    if let Some(c) = link {
        return (c.tri, true);
    }
    let nearest = (0..3)
        .flat_map(|a| {
            let x = grid.coordinate(a, ijk[a]);
            on_line(a).iter().map(move |c| ((c.pos - x).abs(), c.tri))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    (nearest.map_or(0, |n| n.1), false)
}
