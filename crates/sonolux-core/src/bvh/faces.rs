//! Tessellated faces at the root (`Shape::Faces`, a probe, not the default): a room whose walls,
//! floor and ceiling are cut into many small triangles gets each large flat face as one slot of
//! the root, resolved by a 2-D grid over the face's plane instead of a subtree
//! (docs/bvh-faces.md: the same hits, 62 % fewer node tests on l-room-100k, but no faster: the
//! cells' packets outgrow the cache).
//!
//! Why: in a room most rays end on its enclosure (a surface is struck at a rate proportional to
//! its area: Kuttruff, *Room Acoustics*, 5th ed., §5.1). When the enclosure is tessellated
//! (l-room-100k: ~0.2 m squares) its faces hold hundreds to thousands of triangles, too many
//! for a leaf of the hull (`hull.rs`, at most 32), and in the SAH tree a query to a wall
//! descends ~4 levels past the root beside the sculpture's boxes (5.98 node tests a query). But
//! a ray meets a plane at one point: the triangles it can hit there are the few around that
//! point. So a face's slot refers to a **grid** (reference [`FACE`] | index): the walk, on
//! meeting it, computes where the ray crosses the face's plane (f64), the grid cell there, and
//! goes on with that cell's leaf (its triangles in packets) as if the slot had been that leaf:
//! one node test (the root) and one packet test for a wall instead of about five node tests.
//! This is the uniform grid of ray tracing (Fujimoto, Tanaka and Iwata, "ARTS: Accelerated
//! ray-tracing system", IEEE CG&A 1986; Amanatides and Woo, "A fast voxel traversal algorithm",
//! Eurographics 1987) in two dimensions, where a ray visits one cell only.
//!
//! Exactness: the cell's leaf must hold every triangle of the face the watertight test could
//! report hit. A cell lists the triangles that meet its open rectangle (exactly, in f64); the
//! lookup is used only when the crossing point lies farther than a margin from the cell's
//! borders, the margin bounding how far the f32 watertight test's hit region and the face's
//! triangles (coplanar within `deviation_m`) can lie from the computed point (see
//! [`Grid::margin_m`]); otherwise, and for empty or overfull cells, the slot resolves to the
//! face's own SAH subtree (the fallback, also in the node array), or to an empty node. The walk
//! is otherwise unchanged, so the nearest hit is the same triangle at the same distance,
//! except at exact ties (two triangles hit at the same t), where the one visited first is
//! reported.

use std::collections::HashMap;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::build::{self, Built};
use super::{Node8, LEAF, PACKET_INDEX};
use crate::error::CoreError;
use crate::geometry::Aabb;
use crate::mesh::Mesh;

/// Marks a child reference as a face's grid (bit 30; interior nodes stay below it).
pub(crate) const FACE: u32 = 1 << 30;
/// Triangles in a packet.
const LANES: usize = 8;
/// A face resolved by a grid takes the place of a subtree of at least two levels: more than
/// eight leaves of eight triangles. A face of at most 32 triangles is a leaf of the hull
/// (`hull.rs`); one of 33–64 is one node over leaves, which the grid's lookup (about one node
/// test's work) would not beat.
const GRID_MIN_TRIANGLES: usize = 8 * LANES;
/// A cell's leaf holds at most four packets (two bits of a leaf reference).
const CELL_TRIANGLES: usize = 4 * LANES;
/// The faces take effect when they hold at least this share of the mesh's area, so that about
/// that share of a room's rays end on a face resolved by its grid (hits ∝ area; the hull's rule).
const FACE_AREA_SHARE: f64 = super::hull::HULL_AREA_SHARE;
/// Coplanar groups: unit normal and plane offset (of the mesh's size) rounded to 1/this. Coarser
/// than the hull's 10⁻⁶: a tessellated face off the axes is coplanar only to its f32 vertices,
/// and a small triangle's normal scatters by about ε · size / edge (~10⁻⁶ for 0.3 m triangles
/// 7 m from the origin: the turned room of `tests/bvh.rs`), which would split the face; whatever a group's triangles deviate from its plane
/// is measured and added to the lookup's margin, so the grouping never changes an answer.
const PLANE_KEY: f64 = 1e4;
/// The margin's multiple of ε₃₂ · reach (see [`Grid::margin_m`]).
const MARGIN_EPS: f64 = 32.0;

/// One face's grid: its plane, the two axes it is gridded on, the cells' leaves.
#[derive(Clone, Debug)]
pub(crate) struct Grid {
    normal: DVec3,
    offset: f64,
    /// The largest distance of a face vertex from the plane (m).
    deviation_m: f64,
    lo: DVec3,
    hi: DVec3,
    axes: [usize; 2],
    origin: [f64; 2],
    inv_cell: [f64; 2],
    cells: [usize; 2],
    /// A cell's diagonal (m).
    cell_diagonal_m: f64,
    first: usize,
    /// The face's own subtree (a node index), for points near a border and overfull cells.
    fallback: u32,
}

/// The grids of the faces at the root and their cells' references.
#[derive(Clone, Debug, Default)]
pub(crate) struct Faces {
    grids: Vec<Grid>,
    cells: Vec<u32>,
}

impl Faces {
    pub(crate) fn len(&self) -> usize {
        self.grids.len()
    }

    /// Every bit of the grids, for [`super::Bvh::fingerprint`].
    pub(crate) fn words(&self) -> impl Iterator<Item = u32> + '_ {
        let grid = |g: &Grid| {
            let f = [g.normal.x, g.normal.y, g.normal.z, g.offset, g.deviation_m, g.origin[0], g.origin[1], g.inv_cell[0], g.inv_cell[1]];
            let ints = [g.axes[0], g.axes[1], g.cells[0], g.cells[1], g.first, g.fallback as usize];
            f.into_iter().map(f64::to_bits).chain(ints.into_iter().map(|i| i as u64)).flat_map(|w| [w as u32, (w >> 32) as u32])
        };
        self.grids.iter().flat_map(grid).chain(self.cells.iter().copied())
    }

    /// The reference the face slot `child` stands for on the ray from `o` along `d`: its cell's
    /// leaf, an empty node, or the face's subtree (near a border, or when unsure).
    #[inline(always)]
    pub(crate) fn resolve(&self, child: u32, o: Vec3, d: Vec3) -> u32 {
        let g = &self.grids[(child & !FACE) as usize];
        let (o, d) = (o.as_dvec3(), d.as_dvec3());
        let nd = g.normal.dot(d);
        let t = (g.offset - g.normal.dot(o)) / nd;
        let margin = g.margin_m(o) * d.length() / nd.abs();
        let mut cell = [0usize; 2];
        let mut ok = t > 0.0;
        for k in 0..2 {
            let a = g.axes[k];
            let f = (o[a] + t * d[a] - g.origin[k]) * g.inv_cell[k];
            let i = f.floor();
            let m = margin * g.inv_cell[k];
            // (NaN fails every comparison: a ray parallel to the plane takes the subtree.)
            ok &= f - i >= m && i + 1.0 - f >= m && i >= 0.0 && i < g.cells[k] as f64;
            cell[k] = i as usize;
        }
        if ok {
            self.cells[g.first + cell[1] * g.cells[0] + cell[0]]
        } else {
            g.fallback
        }
    }
}

impl Grid {
    /// How far, on the plane, a triangle the f32 test reports hit can lie from the crossing
    /// point computed here, for a ray from `o` (before the stretch by |d| / |n·d| from the
    /// ray's plane to the face's). The test moves each sheared corner coordinate by three
    /// roundings (translation, shear product, difference) of values at most 2R, R the reach
    /// (largest coordinate difference between the origin and the face's box, plus a cell's
    /// diagonal), so an edge by at most about 4√2 ε R (Woop, Benthin and Wald, JCGT 2013, §3;
    /// ε = 2⁻²⁴ the unit roundoff); [`MARGIN_EPS`] = 32 keeps a factor of about 5 to spare,
    /// and the f64 crossing point's own error (~10⁻¹⁵ R) is far inside it. The face's
    /// triangles off its plane by up to `deviation_m` add that.
    #[inline(always)]
    fn margin_m(&self, o: DVec3) -> f64 {
        let reach = (o - self.lo).abs().max((o - self.hi).abs()).max_element() + self.cell_diagonal_m;
        self.deviation_m + MARGIN_EPS * (f32::EPSILON as f64 * 0.5) * reach
    }
}

/// A coplanar group of triangles.
struct Face {
    triangles: Vec<u32>,
    area: f64,
}

/// The tree with the mesh's large tessellated faces at the root when it has them (see the
/// module's note): the built tree, the grids; `None` when the mesh has no such faces.
pub(crate) fn build(mesh: &Mesh) -> Result<Option<(Built, Faces)>, CoreError> {
    let Some(mut faces) = large_faces(mesh) else { return Ok(None) };
    let live = mesh.degenerate.iter().filter(|&&d| !d).count();
    // Eight slots for faces when they are the whole mesh, else seven and the rest's tree; the
    // smaller faces beyond go to the rest's tree.
    let all: usize = faces.iter().map(|f| f.triangles.len()).sum();
    faces.truncate(if faces.len() <= 8 && all == live { 8 } else { 7 });
    let mut rest = mesh.clone();
    faces.iter().flat_map(|f| &f.triangles).for_each(|&i| rest.degenerate[i as usize] = true);
    let rest_tree = if rest.degenerate.iter().all(|&d| d) { None } else { Some(build::build(&rest)?) };
    Ok(Some(assemble(mesh, &faces, rest_tree)?))
}

/// The mesh's coplanar groups of more than [`GRID_MIN_TRIANGLES`] triangles, largest area first,
/// when they hold at least [`FACE_AREA_SHARE`] of its area; grouped by unit normal and plane
/// offset rounded to 1/[`PLANE_KEY`]. The grouping only shapes the tree; no answer depends on it.
fn large_faces(mesh: &Mesh) -> Option<Vec<Face>> {
    let live: Vec<u32> = (0..mesh.triangles.len() as u32).filter(|&i| !mesh.degenerate[i as usize]).collect();
    if live.len() <= GRID_MIN_TRIANGLES {
        return None;
    }
    let size = mesh.bounds().extent().max_element().max(f32::MIN_POSITIVE) as f64;
    let keyed: Vec<([i64; 4], f64)> = live
        .par_iter()
        .with_min_len(4096)
        .map(|&i| {
            let n = mesh.normal(i as usize).as_dvec3();
            let d = n.dot(mesh.corners(i as usize)[0].as_dvec3()) / size;
            ([n.x, n.y, n.z, d].map(|x| (x * PLANE_KEY).round() as i64), mesh.area(i as usize))
        })
        .collect();
    let total: f64 = keyed.iter().map(|k| k.1).sum();
    let mut groups: HashMap<[i64; 4], Face> = HashMap::new();
    for (&i, (key, area)) in live.iter().zip(&keyed) {
        let f = groups.entry(*key).or_insert(Face { triangles: Vec::new(), area: 0.0 });
        f.triangles.push(i);
        f.area += area;
    }
    let mut faces: Vec<Face> = groups.into_values().filter(|f| f.triangles.len() > GRID_MIN_TRIANGLES).collect();
    // Largest first; equal areas by their first triangle (never the hash map's order).
    faces.sort_by(|a, b| b.area.total_cmp(&a.area).then(a.triangles[0].cmp(&b.triangles[0])));
    let held: f64 = faces.iter().take(8).map(|f| f.area).sum();
    (held >= FACE_AREA_SHARE * total).then_some(faces)
}

/// The root over the faces' grids and the rest's tree, then the rest's nodes, each face's
/// subtree, an empty node; packets likewise, then the cells' packets.
fn assemble(mesh: &Mesh, faces: &[Face], rest: Option<Built>) -> Result<(Built, Faces), CoreError> {
    let mut out = Built { nodes: vec![build::empty_node()], packets: Vec::new(), bounds: Aabb::EMPTY };
    let mut slot = faces.len();
    if let Some(rest) = rest {
        // The rest's tree first: spliced (its root's children in the free slots, its other
        // nodes keeping their indices), or its root as node 1 (interior references + 1).
        let used: Vec<usize> = (0..8).filter(|&s| rest.nodes[0].bounds[0][s] <= rest.nodes[0].bounds[1][s]).collect();
        out.bounds = rest.bounds;
        if faces.len() + used.len() <= 8 {
            for &s in &used {
                for plane in 0..6 {
                    out.nodes[0].bounds[plane][slot] = rest.nodes[0].bounds[plane][s];
                }
                out.nodes[0].child[slot] = rest.nodes[0].child[s];
                slot += 1;
            }
            append(&mut out, &rest, 1);
        } else {
            build::set_slot(&mut out.nodes[0], slot, &rest.bounds, 1);
            append(&mut out, &rest, 0);
        }
    }
    let mut grids = Faces::default();
    let mut bounds = Vec::new();
    let mut cell_sets = Vec::new();
    for f in faces {
        let mut sub = mesh.clone();
        sub.degenerate.iter_mut().for_each(|d| *d = true);
        f.triangles.iter().for_each(|&i| sub.degenerate[i as usize] = false);
        let tree = build::build(&sub)?;
        let fallback = out.nodes.len() as u32;
        append(&mut out, &tree, 0);
        bounds.push(tree.bounds);
        // Cells of ½, 1 or 2 mean triangle boxes a side: the scale with the fewest packet tests
        // a lookup (cells weighted alike), then the fewest packets.
        let best = [0.5, 1.0, 2.0]
            .into_iter()
            .map(|scale| {
                let g = grid(mesh, f, &tree.bounds, fallback, scale);
                let packed = pack(&cell_lists(mesh, f, &g));
                (packed.tests_per_lookup(), packed.packets(), g, packed)
            })
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .expect("three scales");
        grids.grids.push(best.2);
        cell_sets.push(best.3);
    }
    let empty = out.nodes.len() as u32;
    out.nodes.push(build::empty_node());
    for (k, packed) in cell_sets.into_iter().enumerate() {
        grids.grids[k].first = grids.cells.len();
        let fallback = grids.grids[k].fallback;
        let leaves: Vec<u32> = packed.leaves.iter().map(|t| build::emit_leaf(t, mesh, &mut out)).collect();
        grids.cells.extend(packed.cells.iter().map(|c| match *c {
            Cell::Empty => empty,
            Cell::Subtree => fallback,
            Cell::Leaf(i) => leaves[i],
        }));
        build::set_slot(&mut out.nodes[0], k, &bounds[k], FACE | k as u32);
        out.bounds = out.bounds.union(&bounds[k]);
    }
    Ok((out, grids))
}

/// What a cell refers to.
#[derive(Clone, Copy)]
enum Cell {
    Empty,
    /// More than a leaf holds: the face's subtree.
    Subtree,
    Leaf(usize),
}

/// A face's cells packed into leaves.
struct Packed {
    leaves: Vec<Vec<u32>>,
    cells: Vec<Cell>,
}

impl Packed {
    /// Packet tests of a lookup, the mean over the cells that hold triangles (a cell sent to
    /// the subtree counted as its triangles' packets).
    fn tests_per_lookup(&self) -> f64 {
        let (mut tests, mut n) = (0, 0);
        for c in &self.cells {
            match *c {
                Cell::Empty => continue,
                Cell::Subtree => tests += CELL_TRIANGLES.div_ceil(LANES) + 1,
                Cell::Leaf(i) => tests += self.leaves[i].len().div_ceil(LANES),
            }
            n += 1;
        }
        tests as f64 / n.max(1) as f64
    }

    fn packets(&self) -> usize {
        self.leaves.iter().map(|t| t.len().div_ceil(LANES)).sum()
    }
}

/// The cells' lists as leaves, neighbours sharing one: along each row, a cell joins the
/// current packet while the union of their triangles fits one (eight), since testing a
/// superset of a cell's triangles gives the same nearest hit (every one tested is a real
/// triangle). Neighbouring cells share most triangles, so a packet serves several cells and the
/// packets stay about as many as the face's triangles / 8 instead of one a cell. A list longer
/// than a packet is a leaf of its own (up to four packets), longer than that the subtree.
fn pack(lists: &[Vec<u32>]) -> Packed {
    let mut p = Packed { leaves: Vec::new(), cells: Vec::with_capacity(lists.len()) };
    // The packet being filled: its leaf's index.
    let mut open: Option<usize> = None;
    for list in lists {
        let cell = match list.len() {
            0 => Cell::Empty,
            n if n > CELL_TRIANGLES => Cell::Subtree,
            n if n > LANES => {
                p.leaves.push(list.clone());
                Cell::Leaf(p.leaves.len() - 1)
            }
            _ => {
                let mut union: Vec<u32> = open.map_or(Vec::new(), |i| p.leaves[i].clone());
                union.extend(list);
                union.sort_unstable();
                union.dedup();
                match open {
                    Some(i) if union.len() <= LANES => p.leaves[i] = union,
                    _ => {
                        p.leaves.push(list.clone());
                        open = Some(p.leaves.len() - 1);
                    }
                }
                Cell::Leaf(open.expect("a packet being filled"))
            }
        };
        p.cells.push(cell);
    }
    p
}

/// Appends `tree`'s nodes (all of them, or from node `skip`) and packets to `out`, its
/// references moved to their new places.
fn append(out: &mut Built, tree: &Built, skip: usize) {
    let (node_base, packet_base) = (out.nodes.len() as u32 - skip as u32, out.packets.len() as u32);
    out.nodes.extend(tree.nodes[skip..].iter().map(|n| Node8 { bounds: n.bounds, child: n.child.map(|c| shift(c, node_base, packet_base)) }));
    out.packets.extend_from_slice(&tree.packets);
}

/// A reference moved: an interior node by `nodes`, a leaf's first packet by `packets`.
fn shift(c: u32, nodes: u32, packets: u32) -> u32 {
    if c & LEAF == 0 {
        c + nodes
    } else {
        (c & !PACKET_INDEX) | ((c & PACKET_INDEX) + packets)
    }
}

/// The face's plane (area-weighted mean normal, mean offset of its corners), its deviation,
/// and a grid on the two axes other than the normal's largest: a cell `scale` times the size of
/// the mean triangle's box on those axes (at scale 1 a cell meets two triangles when it falls on
/// a pair of a tessellation's squares, up to about eight when it straddles four: one packet).
fn grid(mesh: &Mesh, f: &Face, bounds: &Aabb, fallback: u32, scale: f64) -> Grid {
    let mut normal = DVec3::ZERO;
    let mut mean_box = [0.0f64; 3];
    for &i in &f.triangles {
        normal += mesh.normal(i as usize).as_dvec3() * mesh.area(i as usize);
        let c = mesh.corners(i as usize).map(Vec3::as_dvec3);
        for (a, m) in mean_box.iter_mut().enumerate() {
            *m += c[0][a].max(c[1][a]).max(c[2][a]) - c[0][a].min(c[1][a]).min(c[2][a]);
        }
    }
    let normal = normal.normalize();
    let corners = || f.triangles.iter().flat_map(|&i| mesh.corners(i as usize)).map(Vec3::as_dvec3);
    let offset = corners().map(|v| normal.dot(v)).sum::<f64>() / (3 * f.triangles.len()) as f64;
    let deviation_m = corners().map(|v| (normal.dot(v) - offset).abs()).fold(0.0, f64::max);
    let drop = normal.abs().max_position();
    let axes = [(drop + 1) % 3, (drop + 2) % 3];
    let (lo, hi) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
    let mut cells = [1usize; 2];
    let mut inv_cell = [0.0; 2];
    let mut diagonal = 0.0;
    for k in 0..2 {
        let a = axes[k];
        let span = hi[a] - lo[a];
        let mean = scale * mean_box[a] / f.triangles.len() as f64;
        // At most as many cells a side as triangles (a sliver face stays small).
        cells[k] = if mean > 0.0 { ((span / mean).round() as usize).clamp(1, f.triangles.len()) } else { 1 };
        let cell = span / cells[k] as f64;
        inv_cell[k] = if cell > 0.0 { 1.0 / cell } else { 0.0 };
        diagonal += cell * cell;
    }
    Grid {
        normal,
        offset,
        deviation_m,
        lo,
        hi,
        axes,
        origin: [lo[axes[0]], lo[axes[1]]],
        inv_cell,
        cells,
        cell_diagonal_m: diagonal.sqrt(),
        first: 0,
        fallback,
    }
}

/// Per cell (row by row), the face's triangles that meet its open rectangle, in mesh order.
fn cell_lists(mesh: &Mesh, f: &Face, g: &Grid) -> Vec<Vec<u32>> {
    let [nu, nv] = g.cells;
    let mut lists = vec![Vec::new(); nu * nv];
    let size = [1.0 / g.inv_cell[0], 1.0 / g.inv_cell[1]];
    let mut tris = f.triangles.clone();
    tris.sort_unstable();
    for &i in &tris {
        let p = mesh.corners(i as usize).map(|c| {
            let c = c.as_dvec3();
            [c[g.axes[0]], c[g.axes[1]]]
        });
        let mut range = [[0usize; 2]; 2];
        for k in 0..2 {
            let lo = p.iter().map(|q| q[k]).fold(f64::INFINITY, f64::min);
            let hi = p.iter().map(|q| q[k]).fold(f64::NEG_INFINITY, f64::max);
            let cell = |x: f64| (((x - g.origin[k]) * g.inv_cell[k]).floor().max(0.0) as usize).min(g.cells[k] - 1);
            range[k] = [cell(lo), cell(hi)];
        }
        for v in range[1][0]..=range[1][1] {
            for u in range[0][0]..=range[0][1] {
                let lo = [g.origin[0] + u as f64 * size[0], g.origin[1] + v as f64 * size[1]];
                let hi = [lo[0] + size[0], lo[1] + size[1]];
                if meets_open_rect(&p, lo, hi) {
                    lists[v * nu + u].push(i);
                }
            }
        }
    }
    lists
}

/// Whether the triangle meets the open rectangle (lo, hi): no separating axis among the
/// rectangle's two and the triangle's three edge normals, touching counting as separate (a
/// triangle that only touches a cell's border cannot be hit farther than the margin inside it).
/// Rounding can only make a touching triangle meet, which adds it to a list.
fn meets_open_rect(p: &[[f64; 2]; 3], lo: [f64; 2], hi: [f64; 2]) -> bool {
    for k in 0..2 {
        let (a, b) = (p.iter().map(|q| q[k]).fold(f64::INFINITY, f64::min), p.iter().map(|q| q[k]).fold(f64::NEG_INFINITY, f64::max));
        if b <= lo[k] || a >= hi[k] {
            return false;
        }
    }
    let rect = [[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]];
    for e in 0..3 {
        let (a, b, c) = (p[e], p[(e + 1) % 3], p[(e + 2) % 3]);
        let n = [b[1] - a[1], a[0] - b[0]];
        let side = |q: [f64; 2]| n[0] * (q[0] - a[0]) + n[1] * (q[1] - a[1]);
        let inner = side(c).signum();
        // Separated when the whole rectangle is on the far side of the edge's line (or on it).
        if rect.iter().all(|&q| side(q) * inner <= 0.0) {
            return false;
        }
    }
    true
}
