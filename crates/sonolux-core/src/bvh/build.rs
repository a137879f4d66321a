//! Building the 8-wide BVH: a binary tree by the binned surface-area heuristic (SAH), then
//! collapsed into 8-wide nodes, then written out with the triangles packed eight to a packet.
//!
//! Binary step, per node: the triangles' centroids are sorted into [`BINS`] equal bins along
//! each axis; the plane between two bins that minimises A_L·N_L + A_R·N_R (areas of the two
//! sides' boxes, triangle counts) is the split (MacDonald and Booth, "Heuristics for ray
//! tracing using space subdivision", 1990; binning as in Wald, "On fast construction of
//! SAH-based bounding volume hierarchies", 2007). A node becomes a leaf when it holds at most
//! [`LEAF_TRIANGLES`] triangles and the split would not pay for itself, costs counted in packet
//! tests (see [`NODE_COST`]). Large nodes bin in parallel and subtrees build in parallel; both merge in a
//! fixed order, so the tree never depends on the thread count.
//!
//! Collapse ([`Collapse`]): by default the SAH-optimal choice of wide nodes and leaves
//! ([`collapse`]); or, as before session 13, a wide node starts with a binary node's two
//! children and opens the child of largest surface area until it has eight children or only
//! leaves.

use glam::Vec3;
use rayon::prelude::*;

use super::{Bvh, Node8, Nodes, Packet, Shape, LEAF};
use crate::error::CoreError;
use crate::geometry::Aabb;
use crate::mesh::Mesh;

mod collapse;
mod spatial;
mod walk_counts;

pub use collapse::{TestCosts, LEAF_PACKETS_LIMIT};
pub use walk_counts::WalkCounts;

/// How the binary tree becomes 8-wide nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Collapse {
    /// The wide nodes and leaves of least surface-area cost under these test costs (Ylitie,
    /// Karras and Laine 2017; [`collapse`]); the default with [`TestCosts::MEASURED`].
    SahOptimal(TestCosts),
    /// Open the child of largest area until eight (Wald, Benthin and Boulos 2008): the tree of
    /// sessions 1–12, kept to measure against.
    LargestFirst,
}

impl Collapse {
    /// What [`Bvh::build`] does.
    pub const DEFAULT: Collapse = Collapse::SahOptimal(TestCosts::MEASURED);
}

/// A probe's name for a collapse: `largest-first`, `sah` (the default) or
/// `sah:NODE:PACKET:LEAF_PACKETS` (the SAH-optimal collapse with these test costs, e.g.
/// `sah:1:1:4`).
impl std::str::FromStr for Collapse {
    type Err = String;

    fn from_str(s: &str) -> Result<Collapse, String> {
        let bad = || format!("a collapse is 'largest-first', 'sah' or 'sah:NODE:PACKET:LEAF_PACKETS', not {s:?}");
        match s {
            "largest-first" => Ok(Collapse::LargestFirst),
            "sah" => Ok(Collapse::DEFAULT),
            _ => {
                let v: Vec<f32> = s.strip_prefix("sah:").ok_or_else(bad)?.split(':').map(|x| x.parse().map_err(|_| bad())).collect::<Result<_, _>>()?;
                let [node_test, packet_test, leaf] = v[..] else { return Err(bad()) };
                let ok = node_test > 0.0 && packet_test > 0.0 && (1.0..=LEAF_PACKETS_LIMIT as f32).contains(&leaf) && leaf.fract() == 0.0;
                ok.then_some(Collapse::SahOptimal(TestCosts { node_test, packet_test, max_leaf_packets: leaf as usize })).ok_or_else(bad)
            }
        }
    }
}

impl Bvh {
    /// [`Bvh::build_with`] on full-precision nodes, collapsed the way asked: the same hits
    /// either way (a probe of the tree's quality; `examples/query_chain.rs`).
    pub fn build_collapsed(mesh: &Mesh, how: Collapse) -> Result<Bvh, CoreError> {
        let mut bvh = Bvh::build_shaped(mesh, Nodes::Full, Shape::Sah)?;
        if how != Collapse::DEFAULT {
            let built = build_as(mesh, how, false)?;
            (bvh.nodes, bvh.packets) = (built.nodes, built.packets);
        }
        Ok(bvh)
    }

    /// [`Bvh::build_collapsed`] over a binary tree with spatial splits ([`spatial`]): a probe of
    /// what they give (serial build), the same hits.
    pub fn build_with_spatial_splits(mesh: &Mesh, how: Collapse) -> Result<Bvh, CoreError> {
        let mut bvh = Bvh::build_shaped(mesh, Nodes::Full, Shape::Sah)?;
        let built = build_as(mesh, how, true)?;
        (bvh.nodes, bvh.packets) = (built.nodes, built.packets);
        Ok(bvh)
    }
}

/// Bins per axis.
const BINS: usize = 32;
/// Triangles in a packet.
const LANES: usize = 8;
/// At most this many triangles in a leaf (one packet).
pub(crate) const LEAF_TRIANGLES: usize = LANES;
/// Cost of a binary split against one packet test, for the SAH: an 8-wide node test costs
/// about one packet test and stands for three binary levels (2³ = 8 children), so a binary
/// split costs about a third of one.
const NODE_COST: f32 = 1.0 / 3.0;
/// Nodes larger than this bin in parallel, and their children build in parallel.
const PARALLEL_MIN: usize = 4096;
/// Past this depth the binary tree splits in the middle of the list (balanced, whatever the
/// geometry), which bounds the depth by this plus log2 of the triangle count.
const SAH_DEPTH: usize = 48;

pub(crate) struct Built {
    pub(crate) nodes: Vec<Node8>,
    pub(crate) packets: Vec<Packet>,
    pub(crate) bounds: Aabb,
}

/// A node of the binary tree: its box, and either a run of the triangle order or two children.
enum Binary {
    Leaf { bounds: Aabb, start: usize, end: usize },
    Inner { bounds: Aabb, children: Box<[Binary; 2]> },
}

impl Binary {
    fn bounds(&self) -> &Aabb {
        match self {
            Binary::Leaf { bounds, .. } | Binary::Inner { bounds, .. } => bounds,
        }
    }
}

/// What the binary builder reads: each triangle's box and centroid, by mesh index.
struct Prims {
    boxes: Vec<Aabb>,
    centroids: Vec<Vec3>,
}

/// Box and centroid box of a run of triangles.
#[derive(Clone, Copy)]
struct Extent {
    bounds: Aabb,
    centroids: Aabb,
}

impl Extent {
    const EMPTY: Extent = Extent { bounds: Aabb::EMPTY, centroids: Aabb::EMPTY };

    fn union(&self, o: &Extent) -> Extent {
        Extent { bounds: self.bounds.union(&o.bounds), centroids: self.centroids.union(&o.centroids) }
    }

    fn of(prims: &Prims, order: &[u32]) -> Extent {
        let one = |e: Extent, &i: &u32| {
            let mut c = e.centroids;
            c.grow(prims.centroids[i as usize]);
            Extent { bounds: e.bounds.union(&prims.boxes[i as usize]), centroids: c }
        };
        if order.len() < PARALLEL_MIN {
            order.iter().fold(Extent::EMPTY, one)
        } else {
            // min and max are exact, so the merge order cannot change the result.
            order.par_chunks(PARALLEL_MIN).map(|c| c.iter().fold(Extent::EMPTY, one)).reduce(|| Extent::EMPTY, |a, b| a.union(&b))
        }
    }
}

/// Per axis and bin: the triangles' box, their centroids' box and their count.
#[derive(Clone, Copy)]
struct Bins {
    extent: [[Extent; BINS]; 3],
    count: [[u32; BINS]; 3],
}

impl Bins {
    fn empty() -> Bins {
        Bins { extent: [[Extent::EMPTY; BINS]; 3], count: [[0; BINS]; 3] }
    }

    fn merge(mut self: Box<Bins>, o: &Bins) -> Bins {
        for a in 0..3 {
            for b in 0..BINS {
                self.extent[a][b] = self.extent[a][b].union(&o.extent[a][b]);
                self.count[a][b] += o.count[a][b];
            }
        }
        *self
    }
}

/// Maps a centroid coordinate to its bin along one axis.
#[derive(Clone, Copy)]
struct Binner {
    min: Vec3,
    scale: Vec3,
}

impl Binner {
    fn new(centroids: &Aabb) -> Binner {
        let e = centroids.extent();
        let scale = e.map(|x| if x > 0.0 { BINS as f32 / x } else { 0.0 });
        Binner { min: centroids.min, scale }
    }

    #[inline]
    fn bin(&self, c: Vec3, axis: usize) -> usize {
        (((c[axis] - self.min[axis]) * self.scale[axis]) as usize).min(BINS - 1)
    }
}

/// The best binned split of a node: axis, first bin of the right side, the SAH cost of the
/// split (in packet tests, relative to a ray that meets the node), and both sides' extents.
struct Split {
    axis: usize,
    boundary: usize,
    cost: f32,
    left: (Extent, usize),
    right: (Extent, usize),
}

pub(super) fn packets(n: usize) -> f32 {
    n.div_ceil(LANES) as f32
}

/// Builds the wide BVH over the mesh's non-degenerate triangles.
pub(crate) fn build(mesh: &Mesh) -> Result<Built, CoreError> {
    build_as(mesh, Collapse::DEFAULT, false)
}

/// [`build`], collapsed the way asked.
fn build_as(mesh: &Mesh, how: Collapse, spatial_splits: bool) -> Result<Built, CoreError> {
    let mut order: Vec<u32> = (0..mesh.triangles.len() as u32).filter(|&i| !mesh.degenerate[i as usize]).collect();
    if order.is_empty() {
        return Err(CoreError::Geometry("no triangles with a non-zero area".into()));
    }
    let (boxes, centroids) = (0..mesh.triangles.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|i| {
            let [a, b, c] = mesh.corners(i);
            let mut bb = Aabb::EMPTY;
            bb.grow(a);
            bb.grow(b);
            bb.grow(c);
            (bb, bb.center())
        })
        .unzip();
    let prims = Prims { boxes, centroids };
    let extent = Extent::of(&prims, &order);
    let root = if spatial_splits {
        let refs = order.iter().map(|&id| spatial::Ref { id, bounds: prims.boxes[id as usize] }).collect();
        order.clear();
        spatial::build(mesh, refs, &mut order)
    } else {
        split(&prims, &mut order, 0, extent, 0)
    };

    // Collapse and write out, depth first.
    let mut out = Built { nodes: Vec::new(), packets: Vec::new(), bounds: extent.bounds };
    match &root {
        Binary::Inner { .. } => match how {
            Collapse::SahOptimal(costs) => {
                let costs = TestCosts { max_leaf_packets: costs.max_leaf_packets.clamp(1, LEAF_PACKETS_LIMIT), ..costs };
                emit_planned(&root, &collapse::plan(&root, &costs), &order, mesh, &mut out);
            }
            Collapse::LargestFirst => {
                emit_node(&root, &order, mesh, &mut out);
            }
        },
        // A single leaf still gets a root node, so that traversal always starts at node 0.
        Binary::Leaf { .. } => {
            out.nodes.push(empty_node());
            let r = emit(&root, &order, mesh, &mut out);
            set_slot(&mut out.nodes[0], 0, root.bounds(), r);
        }
    }
    Ok(out)
}

/// Builds the binary subtree over `order` (which it reorders), whose first element is at
/// `offset` in the whole order.
fn split(prims: &Prims, order: &mut [u32], offset: usize, extent: Extent, depth: usize) -> Binary {
    let n = order.len();
    let leaf = Binary::Leaf { bounds: extent.bounds, start: offset, end: offset + n };
    if n == 1 {
        return leaf;
    }
    let best = if depth < SAH_DEPTH { best_split(prims, order, &extent) } else { None };
    let (mid, left, right) = match best {
        Some(s) => {
            let area = extent.bounds.half_area().max(f32::MIN_POSITIVE);
            let split_cost = NODE_COST + s.cost / area;
            if n <= LEAF_TRIANGLES && packets(n) <= split_cost {
                return leaf;
            }
            let binner = Binner::new(&extent.centroids);
            let (axis, boundary) = (s.axis, s.boundary);
            let mid = partition(order, |i| binner.bin(prims.centroids[i as usize], axis) < boundary);
            (mid, s.left.0, s.right.0)
        }
        None if n <= LEAF_TRIANGLES => return leaf,
        // All centroids coincide, or the tree is deep already: halve the list.
        None => {
            let mid = n / 2;
            (mid, Extent::of(prims, &order[..mid]), Extent::of(prims, &order[mid..]))
        }
    };
    let (lo, hi) = order.split_at_mut(mid);
    let (l, r) = if n >= PARALLEL_MIN {
        rayon::join(|| split(prims, lo, offset, left, depth + 1), || split(prims, hi, offset + mid, right, depth + 1))
    } else {
        (split(prims, lo, offset, left, depth + 1), split(prims, hi, offset + mid, right, depth + 1))
    };
    Binary::Inner { bounds: extent.bounds, children: Box::new([l, r]) }
}

/// The cheapest binned split over the three axes, or None when every centroid coincides.
fn best_split(prims: &Prims, order: &[u32], extent: &Extent) -> Option<Split> {
    let binner = Binner::new(&extent.centroids);
    let fill = |order: &[u32]| {
        let mut bins = Bins::empty();
        for &i in order {
            let c = prims.centroids[i as usize];
            let bb = &prims.boxes[i as usize];
            for axis in 0..3 {
                let b = binner.bin(c, axis);
                let e = &mut bins.extent[axis][b];
                e.bounds = e.bounds.union(bb);
                e.centroids.grow(c);
                bins.count[axis][b] += 1;
            }
        }
        Box::new(bins)
    };
    // Counts add and boxes take min and max, both exact: the merge order cannot matter.
    let bins = if order.len() < PARALLEL_MIN {
        fill(order)
    } else {
        order.par_chunks(PARALLEL_MIN).map(fill).reduce(|| Box::new(Bins::empty()), |a, b| Box::new(a.merge(&b)))
    };

    let mut best: Option<Split> = None;
    for axis in 0..3 {
        if binner.scale[axis] == 0.0 {
            continue;
        }
        // Sweep from the right for the extent and count right of each boundary.
        let mut right = [(Extent::EMPTY, 0usize); BINS];
        let mut acc = (Extent::EMPTY, 0usize);
        for b in (1..BINS).rev() {
            acc = (acc.0.union(&bins.extent[axis][b]), acc.1 + bins.count[axis][b] as usize);
            right[b] = acc;
        }
        let mut left = (Extent::EMPTY, 0usize);
        for b in 1..BINS {
            left = (left.0.union(&bins.extent[axis][b - 1]), left.1 + bins.count[axis][b - 1] as usize);
            if left.1 == 0 || right[b].1 == 0 {
                continue;
            }
            let cost = left.0.bounds.half_area() * packets(left.1) + right[b].0.bounds.half_area() * packets(right[b].1);
            if best.as_ref().is_none_or(|s| cost < s.cost) {
                best = Some(Split { axis, boundary: b, cost, left, right: right[b] });
            }
        }
    }
    best
}

/// Moves the items for which `left` holds to the front, keeping no order; returns their count.
fn partition(items: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let (mut i, mut j) = (0, items.len());
    loop {
        while i < j && left(items[i]) {
            i += 1;
        }
        while i < j && !left(items[j - 1]) {
            j -= 1;
        }
        if i >= j {
            return i;
        }
        items.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

fn empty_node() -> Node8 {
    let mut bounds = [[f32::INFINITY; 8]; 6];
    for plane in [1, 3, 5] {
        bounds[plane] = [f32::NEG_INFINITY; 8];
    }
    Node8 { bounds, child: [0; 8] }
}

fn set_slot(node: &mut Node8, slot: usize, b: &Aabb, child: u32) {
    for axis in 0..3 {
        node.bounds[2 * axis][slot] = b.min[axis];
        node.bounds[2 * axis + 1][slot] = b.max[axis];
    }
    node.child[slot] = child;
}

/// Writes a subtree and returns its reference.
fn emit(node: &Binary, order: &[u32], mesh: &Mesh, out: &mut Built) -> u32 {
    match node {
        Binary::Leaf { start, end, .. } => emit_leaf(&order[*start..*end], mesh, out),
        Binary::Inner { .. } => emit_node(node, order, mesh, out) as u32,
    }
}

/// Writes the wide node that collapses `node` and what is below it; returns its index.
fn emit_node(node: &Binary, order: &[u32], mesh: &Mesh, out: &mut Built) -> usize {
    let index = out.nodes.len();
    out.nodes.push(empty_node());
    let mut kids: Vec<&Binary> = vec![node];
    // Open the interior child of largest area until there are eight (the first on ties).
    while kids.len() < 8 {
        let widest = kids
            .iter()
            .enumerate()
            .filter(|(_, k)| matches!(k, Binary::Inner { .. }))
            .fold(None, |best: Option<(usize, f32)>, (i, k)| {
                let a = k.bounds().half_area();
                if best.is_none_or(|(_, b)| a > b) {
                    Some((i, a))
                } else {
                    best
                }
            });
        let Some((i, _)) = widest else { break };
        let Binary::Inner { children, .. } = kids[i] else { unreachable!("filtered to interior nodes") };
        kids.splice(i..=i, [&children[0], &children[1]]);
    }
    for (slot, kid) in kids.iter().enumerate() {
        let r = emit(kid, order, mesh, out);
        set_slot(&mut out.nodes[index], slot, kid.bounds(), r);
    }
    index
}

/// Writes the wide node that stands for `node` as `plan` chose; returns its index.
fn emit_planned(node: &Binary, plan: &collapse::Plan, order: &[u32], mesh: &Mesh, out: &mut Built) -> usize {
    let index = out.nodes.len();
    out.nodes.push(empty_node());
    for (slot, s) in collapse::slots(node, plan).into_iter().enumerate() {
        let (bounds, r) = match s {
            collapse::Slot::Leaf(n) => {
                let (start, end) = collapse::run(n);
                (n.bounds(), emit_leaf(&order[start..end], mesh, out))
            }
            collapse::Slot::Node(n, p) => (n.bounds(), emit_planned(n, p, order, mesh, out) as u32),
        };
        set_slot(&mut out.nodes[index], slot, bounds, r);
    }
    index
}

/// Packs a leaf's triangles eight to a packet and returns the leaf's reference.
fn emit_leaf(tris: &[u32], mesh: &Mesh, out: &mut Built) -> u32 {
    let first = out.packets.len();
    for chunk in tris.chunks(LANES) {
        let mut p = Packet { corners: [[0.0; 8]; 9], ids: [0; 8] };
        for lane in 0..LANES {
            // Short packets repeat their last triangle.
            let id = chunk[lane.min(chunk.len() - 1)];
            let corners = mesh.corners(id as usize);
            for (k, v) in corners.iter().enumerate() {
                for axis in 0..3 {
                    p.corners[3 * k + axis][lane] = v[axis];
                }
            }
            p.ids[lane] = id;
        }
        out.packets.push(p);
    }
    let count = out.packets.len() - first;
    LEAF | ((count as u32 - 1) << 29) | first as u32
}
