//! The hull at the top of the tree: a room's large flat faces (walls, floor, ceiling: coplanar
//! groups of a few triangles) as leaves of the root itself, beside the tree built by the SAH
//! over the rest (docs/bvh.md, "The hull at the root").
//!
//! Why: in a room most rays end on its enclosure (in a diffuse field a surface is struck at a
//! rate proportional to its area: Kuttruff, *Room Acoustics*, 5th ed., §5.1, the mean free path
//! 4V/S), and a binned SAH tree splits space by the triangles' centroids, so a wall's few large
//! triangles end up in leaves whose boxes span the room beside furniture, and a query tests
//! about two nodes and two packets before its wall's (the large-triangle problem of SAH trees:
//! Ernst and Greiner, "Early split clipping for bounding volume hierarchies", RT 2007; Stich,
//! Friedrich and Dietrich, "Spatial splits in bounding volume hierarchies", HPG 2009). Here the
//! root's slots are the faces (a face's box is flat, so its entry distance is the distance to
//! the face's plane within its rectangle) and one slot is the rest's tree: the walk, unchanged,
//! visits the nearest face first, and once its wall is hit the rest's tree (mostly furniture)
//! is dropped unvisited unless the ray passed through its box before the wall.
//!
//! Only the tree's shape changes: the walk, the box test (conservative: Ize 2013) and the packet
//! test are the same, so the nearest hit is the same triangle at the same distance, except
//! where two triangles are hit at exactly the same t (a shared edge or vertex), where the one
//! visited first is reported, in either tree.

use std::collections::HashMap;

use rayon::prelude::*;

use super::build::{self, Built};
use super::{Node8, Packet, LEAF};
use crate::error::CoreError;
use crate::geometry::Aabb;
use crate::mesh::Mesh;

/// Triangles in a packet.
const LANES: usize = 8;
/// A leaf holds at most four packets (two bits of its reference), so a face of the hull at most
/// 32 triangles; larger faces (finely tessellated walls) stay in the rest's tree.
const FACE_PACKETS: usize = 4;
/// Slots of the root: the hull's faces take at most seven, the rest's tree one.
const HULL_SLOTS: usize = 7;
/// The hull is put at the root only when its faces hold at least this share of the mesh's area,
/// so that at least about that share of a room's rays end on a face tested first (hits ∝ area).
pub(crate) const HULL_AREA_SHARE: f64 = 0.5;

/// One slot of the hull: its triangles (mesh indices) and their box.
struct Face {
    triangles: Vec<u32>,
    bounds: Aabb,
    area: f64,
}

/// The tree over `mesh` with its hull at the root when it has one (see the module's note), else
/// the SAH tree of [`build::build`]; and the number of the root's slots the hull takes (0: none).
pub(crate) fn build(mesh: &Mesh) -> Result<(Built, usize), CoreError> {
    let faces = hull_faces(mesh);
    if faces.is_empty() {
        return Ok((build::build(mesh)?, 0));
    }
    let mut rest = mesh.clone();
    for f in &faces {
        for &i in &f.triangles {
            // Marked degenerate, the tree's build leaves it out; indices are unchanged, so the
            // rest's packets name the mesh's own triangles.
            rest.degenerate[i as usize] = true;
        }
    }
    let tree = build::build(&rest)?;
    Ok((with_hull_at_root(mesh, &faces, tree), faces.len()))
}

/// The hull's faces: coplanar groups of at most 32 triangles among the mesh's 256 largest, the
/// largest groups (by area) first, at most eight, merged down to [`HULL_SLOTS`] by the pair whose merged box is smallest
/// (half-area × packets, the SAH's cost); none when they hold less than [`HULL_AREA_SHARE`] of the
/// area or leave no triangle to the rest.
fn hull_faces(mesh: &Mesh) -> Vec<Face> {
    let live: Vec<u32> = (0..mesh.triangles.len() as u32).filter(|&i| !mesh.degenerate[i as usize]).collect();
    let area: Vec<f64> = live.par_iter().with_min_len(4096).map(|&i| mesh.area(i as usize)).collect();
    let total: f64 = area.iter().sum();
    // Only the largest (HULL_SLOTS + 1) · 32 triangles can be in the hull; when even they hold
    // less than the share, there is none (a large mesh is decided here, without grouping it).
    let cap = (HULL_SLOTS + 1) * FACE_PACKETS * LANES;
    let mut largest: Vec<usize> = (0..live.len()).collect();
    let by_area = |a: &usize, b: &usize| area[*b].total_cmp(&area[*a]).then(a.cmp(b));
    if largest.len() > cap {
        largest.select_nth_unstable_by(cap, by_area);
        largest.truncate(cap);
    }
    if !(largest.iter().map(|&k| area[k]).sum::<f64>() >= HULL_AREA_SHARE * total) {
        return Vec::new();
    }
    // Coplanar groups among them: the unit normal and the plane's offset, rounded to 1e-6 (of
    // the normal, and of the mesh's size for the offset). The grouping only shapes the tree; no
    // answer depends on it.
    let size = mesh.bounds().extent().max_element().max(f32::MIN_POSITIVE) as f64;
    let mut groups: HashMap<[i64; 4], Vec<u32>> = HashMap::new();
    for &k in &largest {
        let i = live[k];
        let n = mesh.normal(i as usize).as_dvec3();
        let d = n.dot(mesh.corners(i as usize)[0].as_dvec3()) / size;
        let key = [n.x, n.y, n.z, d].map(|x| (x * 1e6).round() as i64);
        groups.entry(key).or_default().push(i);
    }
    let mut faces: Vec<Face> = groups
        .into_values()
        .filter(|t| t.len() <= FACE_PACKETS * LANES)
        .map(|triangles| face(mesh, triangles))
        .collect();
    // Largest first; equal areas by their first triangle, so the order never depends on the
    // hash map's.
    faces.sort_by(|a, b| b.area.total_cmp(&a.area).then(a.triangles[0].cmp(&b.triangles[0])));
    faces.truncate(HULL_SLOTS + 1);
    while faces.len() > HULL_SLOTS {
        merge_cheapest_pair(mesh, &mut faces);
    }
    let held: f64 = faces.iter().map(|f| f.area).sum();
    let in_hull: usize = faces.iter().map(|f| f.triangles.len()).sum();
    if !(held >= HULL_AREA_SHARE * total) || in_hull == live.len() {
        return Vec::new();
    }
    faces
}

fn face(mesh: &Mesh, mut triangles: Vec<u32>) -> Face {
    triangles.sort_unstable();
    let mut bounds = Aabb::EMPTY;
    for &i in &triangles {
        mesh.corners(i as usize).iter().for_each(|&v| bounds.grow(v));
    }
    let area = triangles.iter().map(|&i| mesh.area(i as usize)).sum();
    Face { triangles, bounds, area }
}

/// Merges the two faces whose union has the least SAH cost (box half-area × packets) among the
/// pairs that fit one leaf (the first such pair on ties).
fn merge_cheapest_pair(mesh: &Mesh, faces: &mut Vec<Face>) {
    let mut best: Option<(usize, usize, f32)> = None;
    for a in 0..faces.len() {
        for b in a + 1..faces.len() {
            let n = faces[a].triangles.len() + faces[b].triangles.len();
            if n > FACE_PACKETS * LANES {
                continue;
            }
            let cost = faces[a].bounds.union(&faces[b].bounds).half_area() * n.div_ceil(LANES) as f32;
            if best.is_none_or(|(_, _, c)| cost < c) {
                best = Some((a, b, cost));
            }
        }
    }
    match best {
        Some((a, b, _)) => {
            let fb = faces.remove(b);
            let mut triangles = std::mem::take(&mut faces[a].triangles);
            triangles.extend(fb.triangles);
            faces[a] = face(mesh, triangles);
        }
        // No pair fits a leaf: the smallest face goes back to the tree.
        None => {
            faces.pop();
        }
    }
}

/// A new root over the hull's faces (leaves) and the rest's tree: the rest's root's children
/// spliced in when they fit the free slots, else its root as one slot.
fn with_hull_at_root(mesh: &Mesh, faces: &[Face], tree: Built) -> Built {
    let Built { nodes: rest_nodes, mut packets, bounds } = tree;
    let mut root = Node8 { bounds: [[f32::INFINITY; 8]; 6], child: [0; 8] };
    for plane in [1, 3, 5] {
        root.bounds[plane] = [f32::NEG_INFINITY; 8];
    }
    let mut all = bounds;
    for (slot, f) in faces.iter().enumerate() {
        let first = packets.len();
        packets.extend(f.triangles.chunks(LANES).map(|c| packet(mesh, c)));
        let r = LEAF | (((packets.len() - first) as u32 - 1) << 29) | first as u32;
        set_slot(&mut root, slot, &f.bounds, r);
        all = all.union(&f.bounds);
    }
    let rest_root = &rest_nodes[0];
    let used: Vec<usize> = (0..8).filter(|&s| rest_root.bounds[0][s] <= rest_root.bounds[1][s]).collect();
    let mut nodes = vec![root];
    if faces.len() + used.len() <= 8 {
        // The rest's root's children take the free slots; the new root takes its place (node 0),
        // so every other node keeps its index.
        for (k, &s) in used.iter().enumerate() {
            let slot = faces.len() + k;
            for plane in 0..6 {
                nodes[0].bounds[plane][slot] = rest_root.bounds[plane][s];
            }
            nodes[0].child[slot] = rest_root.child[s];
        }
        nodes.extend_from_slice(&rest_nodes[1..]);
    } else {
        // The rest's root as one slot; its nodes move one place down (interior references + 1).
        set_slot(&mut nodes[0], faces.len(), &bounds, 1);
        let shift = |c: u32| if c & LEAF == 0 { c + 1 } else { c };
        nodes.extend(rest_nodes.iter().map(|n| Node8 { bounds: n.bounds, child: n.child.map(shift) }));
    }
    Built { nodes, packets, bounds: all }
}

fn set_slot(node: &mut Node8, slot: usize, b: &Aabb, child: u32) {
    for axis in 0..3 {
        node.bounds[2 * axis][slot] = b.min[axis];
        node.bounds[2 * axis + 1][slot] = b.max[axis];
    }
    node.child[slot] = child;
}

/// Up to eight triangles as a packet (a short one repeats its last triangle, as the tree's do).
fn packet(mesh: &Mesh, tris: &[u32]) -> Packet {
    let mut p = Packet { corners: [[0.0; 8]; 9], ids: [0; 8] };
    for lane in 0..LANES {
        let id = tris[lane.min(tris.len() - 1)];
        for (k, v) in mesh.corners(id as usize).iter().enumerate() {
            for axis in 0..3 {
                p.corners[3 * k + axis][lane] = v[axis];
            }
        }
        p.ids[lane] = id;
    }
    p
}
