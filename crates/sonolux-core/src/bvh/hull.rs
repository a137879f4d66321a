//! The hull: a mesh's few largest triangles (a room's walls, floor and ceiling) kept out of the
//! tree and tested first, all of them, with the packet test; the tree, built over the rest,
//! is then walked with its far end clipped to the hull's hit (docs/bvh.md, "The hull").
//!
//! Why: in a room most rays end on its enclosure (a surface is struck at a rate proportional to
//! its area in a diffuse field: Kuttruff, *Room Acoustics*, 5th ed., §5.1, the mean free path
//! 4V/S), and in a BVH those few large triangles have large boxes that every ray enters, so a
//! query pays a chain of node tests before the packet that holds its wall (the large-triangle
//! problem of SAH trees: Ernst and Greiner, "Early split clipping for bounding volume
//! hierarchies", RT 2007; Stich, Friedrich and Dietrich, "Spatial splits in bounding volume
//! hierarchies", HPG 2009). Tested first, with no tree above them, their packet tests do not
//! depend on one another, and the rest's tree, mostly furniture, is entered only by the rays
//! whose path up to the wall passes near it.
//!
//! The answers do not change: each triangle is tested by the same watertight packet test
//! (`traverse::hit_packet`, `geometry::intersect_triangle` to the bit), and the nearest of the
//! hull's and the tree's hits is the nearest of all. Where a hull triangle and a tree triangle
//! are hit at exactly the same t (a shared edge or vertex), the hull's is reported; the tree
//! alone reported whichever it visited first. The distance is the same either way.

use super::Packet;

/// Triangles in a packet.
const LANES: usize = 8;
use crate::mesh::Mesh;

/// At most this many packets of hull triangles (32 triangles). Every query tests them all.
pub(crate) const HULL_PACKETS: usize = 4;

/// The hull is kept only when its triangles hold at least this share of the mesh's area: then
/// at least about that share of a room's rays end on it (hits ∝ area), and the tree's walk is
/// clipped short for them. Below, the tree alone is used.
pub(crate) const HULL_AREA_SHARE: f64 = 0.5;

/// The mesh's hull: the indices of its largest non-degenerate triangles (by area, the lower
/// index first on ties), at most `HULL_PACKETS` packets of them, when they hold at least
/// `HULL_AREA_SHARE` of its area and leave some triangle to the tree; else none.
pub(crate) fn choose(mesh: &Mesh) -> Vec<u32> {
    let live: Vec<u32> = (0..mesh.triangles.len() as u32).filter(|&i| !mesh.degenerate[i as usize]).collect();
    let cap = HULL_PACKETS * LANES;
    if live.len() <= cap {
        return Vec::new();
    }
    let area: Vec<f64> = live.iter().map(|&i| mesh.area(i as usize)).collect();
    let total: f64 = area.iter().sum();
    let mut by_area: Vec<usize> = (0..live.len()).collect();
    by_area.sort_by(|&a, &b| area[b].total_cmp(&area[a]).then(a.cmp(&b)));
    by_area.truncate(cap);
    let held: f64 = by_area.iter().map(|&k| area[k]).sum();
    if !(held >= HULL_AREA_SHARE * total) {
        return Vec::new();
    }
    let mut hull: Vec<u32> = by_area.iter().map(|&k| live[k]).collect();
    hull.sort_unstable();
    hull
}

/// The hull's triangles packed eight to a packet (a short last packet repeats its last one).
pub(crate) fn pack(mesh: &Mesh, hull: &[u32]) -> Vec<Packet> {
    hull.chunks(LANES)
        .map(|chunk| {
            let mut p = Packet { corners: [[0.0; 8]; 9], ids: [0; 8] };
            for lane in 0..LANES {
                let id = chunk[lane.min(chunk.len() - 1)];
                for (k, v) in mesh.corners(id as usize).iter().enumerate() {
                    for axis in 0..3 {
                        p.corners[3 * k + axis][lane] = v[axis];
                    }
                }
                p.ids[lane] = id;
            }
            p
        })
        .collect()
}

/// The mesh without its hull's triangles (marked degenerate, so that the tree's build leaves
/// them out; indices unchanged, so the tree's packets name the mesh's own triangles).
pub(crate) fn rest(mesh: &Mesh, hull: &[u32]) -> Mesh {
    let mut rest = mesh.clone();
    for &i in hull {
        rest.degenerate[i as usize] = true;
    }
    rest
}
