//! Bounding-volume hierarchy over a mesh's triangles, eight children a node, with closest-hit
//! and any-hit queries. Both tracers, the camera and the Python `Geometry` share one.
//!
//! - Layout ([`Node8`], [`Packet`]): a flat array of 8-wide nodes in depth-first order, each
//!   holding its eight children's boxes plane by plane (`[min x, max x, min y, …][child]`, so one
//!   SIMD register holds one plane of all eight) and their references; and a flat array of
//!   triangle packets, eight triangles each, corners laid out the same way, that the leaves
//!   point at. A leaf is one to four packets (at most [`build::LEAF_TRIANGLES`] triangles).
//! - Build ([`build`]): a binary tree by the binned surface-area heuristic, built in parallel,
//!   then collapsed into 8-wide nodes the SAH-optimal way (Ylitie, Karras and Laine, HPG 2017,
//!   §4.1; `build/collapse.rs`). Deterministic: the same mesh gives the same tree whatever the
//!   thread count.
//! - The hull at the root ([`hull`]): a room's large flat faces (coplanar groups of a few
//!   triangles holding most of its area) as leaves of the root itself, the SAH tree of the rest
//!   beside them, so that a query meets its wall after one node test.
//! - Traversal ([`traverse`]): one ray against the eight boxes of a node at once, the boxes it
//!   meets visited nearest first through a small stack whose entries remember their entry
//!   distance (so that those beyond the nearest hit found since are dropped unvisited); a leaf's
//!   triangles are tested eight at a time with the watertight test of
//!   [`crate::geometry::intersect_triangle`], operation for operation, so that the answers are
//!   the scalar test's to the bit.
//! - Compressed nodes ([`quantized`], [`traverse_quantized`]): a tree whose full-precision nodes
//!   outgrow the caches ([`COMPRESS_ABOVE_BYTES`]) is traversed on the same nodes with byte
//!   planes on a per-node grid (96 bytes a node instead of 224): the same hits.
//! - SIMD ([`lanes`]): AVX2 through `pulp` when the CPU has it (checked once, at build), else
//!   plain arrays that round every value the same way.

use glam::Vec3;
use rayon::prelude::*;

use crate::error::CoreError;

use crate::geometry::{Aabb, Hit, Ray};
use crate::mesh::Mesh;

pub(crate) mod build;
mod hull;
pub(crate) mod lanes;
mod quantized;
mod traverse;
mod traverse_quantized;

pub use build::{Collapse, TestCosts, WalkCounts, LEAF_PACKETS_LIMIT};
use quantized::QNode8;

use traverse::TravRay;

/// Eight children: their boxes plane by plane and their references.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct Node8 {
    /// `[min x, max x, min y, max y, min z, max z][slot]`; an empty slot has min = +∞ and
    /// max = −∞, which no ray meets.
    pub(crate) bounds: [[f32; 8]; 6],
    /// Per slot: an interior node's index, or [`LEAF`] | packets − 1 << 29 | first packet.
    pub(crate) child: [u32; 8],
}

/// Marks a child reference as a leaf.
pub(crate) const LEAF: u32 = 1 << 31;
/// Bits of a leaf reference that hold the index of its first packet.
pub(crate) const PACKET_INDEX: u32 = (1 << 29) - 1;

/// Eight triangles, their corners plane by plane: `corners[3·corner + axis][lane]`. A packet
/// with fewer triangles repeats its last one (a duplicate changes no answer).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct Packet {
    pub(crate) corners: [[f32; 8]; 9],
    /// Mesh index of each lane's triangle.
    pub(crate) ids: [u32; 8],
}

/// Which lanes traversal runs on, chosen when the BVH is built.
#[derive(Clone, Copy, Debug)]
enum Simd {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2(pulp::x86::V3),
}

/// Trees whose full-precision nodes take more than this many bytes are traversed on compressed
/// nodes ([`Nodes::Compressed`]). Set from measurements on the 2-core EPYC development machine
/// (1 MB L2 a core, 32 MB L3; docs/bvh.md, "Compressed nodes"): at 0.5–3.7 MB of nodes (45k to
/// 352k triangles) the compressed query was 10–25 % slower on independent rays (decoding
/// lengthens every node test), at 14 MB (1.3 M triangles) as fast within the noise, with 57 %
/// fewer node bytes. So: compressed from 8 MB, between the two.
pub const COMPRESS_ABOVE_BYTES: usize = 8 * 1024 * 1024;

/// Which nodes a tree is traversed on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Nodes {
    /// Compressed when the full-precision nodes would take more than [`COMPRESS_ABOVE_BYTES`].
    Auto,
    /// f32 planes, 224 bytes a node ([`Node8`]).
    Full,
    /// Byte planes on a per-node grid, 96 bytes a node ([`quantized`]).
    Compressed,
}

/// Whether a tree whose full-precision nodes take `node_bytes` is traversed on compressed nodes.
fn compresses(nodes: Nodes, node_bytes: usize) -> bool {
    match nodes {
        Nodes::Auto => node_bytes > COMPRESS_ABOVE_BYTES,
        Nodes::Full => false,
        Nodes::Compressed => true,
    }
}

/// The tree's shape at the top.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// The mesh's hull, its large flat faces (a room's walls, floor, ceiling), as leaves of the
    /// root beside the SAH tree of the rest, when the mesh has one (`hull.rs`); else the SAH tree.
    Auto,
    /// The SAH tree over every triangle.
    Sah,
}

/// The acceleration structure. Queries take `&self` and are safe to share between threads.
#[derive(Clone, Debug)]
pub struct Bvh {
    /// The full-precision nodes, or none when the tree is compressed.
    nodes: Vec<Node8>,
    /// The compressed nodes (the same tree, node for node), or none.
    qnodes: Vec<QNode8>,
    packets: Vec<Packet>,
    /// Slots of the root that hold the mesh's hull, its large flat faces (`hull.rs`); 0: none.
    hull_slots: usize,
    bounds: Aabb,
    simd: Simd,
}

impl Bvh {
    /// Builds the hierarchy over the mesh's non-degenerate triangles, on the current rayon pool.
    /// Its nodes compressed when they outgrow the caches ([`Nodes::Auto`]).
    pub fn build(mesh: &Mesh) -> Result<Bvh, CoreError> {
        Bvh::build_with(mesh, Nodes::Auto)
    }

    /// [`Bvh::build`] on the nodes asked for: the same tree, so the same hits, either way.
    pub fn build_with(mesh: &Mesh, nodes: Nodes) -> Result<Bvh, CoreError> {
        Bvh::build_shaped(mesh, nodes, Shape::Auto)
    }

    /// [`Bvh::build_with`] in the shape asked for: the same hits either way (for benchmarks
    /// and tests).
    pub fn build_shaped(mesh: &Mesh, nodes: Nodes, shape: Shape) -> Result<Bvh, CoreError> {
        let (built, hull_slots) = match shape {
            Shape::Auto => hull::build(mesh)?,
            Shape::Sah => (build::build(mesh)?, 0),
        };
        #[cfg(target_arch = "x86_64")]
        let simd = pulp::x86::V3::try_new().map_or(Simd::Portable, Simd::Avx2);
        #[cfg(not(target_arch = "x86_64"))]
        let simd = Simd::Portable;
        let compress = compresses(nodes, built.nodes.len() * size_of::<Node8>());
        // (A tree with a node beyond the compressed grid's range, coordinates near f32's
        // limit, keeps its full-precision nodes.)
        let qnodes: Option<Vec<QNode8>> =
            if compress { built.nodes.par_iter().with_min_len(1024).map(QNode8::from_node).collect() } else { None };
        let (nodes, qnodes) = match qnodes {
            Some(q) => (Vec::new(), q),
            None => (built.nodes, Vec::new()),
        };
        Ok(Bvh { nodes, qnodes, packets: built.packets, hull_slots, bounds: built.bounds, simd })
    }

    /// Whether the tree is traversed on compressed nodes.
    pub fn is_compressed(&self) -> bool {
        !self.qnodes.is_empty()
    }

    /// The same hierarchy traversed without SIMD registers: the fallback for CPUs without
    /// AVX2, kept reachable so that tests can check both give the same bits.
    pub fn portable(mut self) -> Bvh {
        self.simd = Simd::Portable;
        self
    }

    /// The AVX2 token the queries run on, when they do: a caller that runs its own loop under
    /// it (`V3::vectorize`) gets the queries compiled into that loop, with no call between
    /// (the sound tracer's kernel on a mesh, `sound/trace.rs`).
    #[cfg(target_arch = "x86_64")]
    pub fn avx2(&self) -> Option<pulp::x86::V3> {
        match self.simd {
            Simd::Avx2(v3) => Some(v3),
            Simd::Portable => None,
        }
    }

    /// "avx2" or "portable": the lanes the queries run on.
    pub fn simd_name(&self) -> &'static str {
        match self.simd {
            Simd::Portable => "portable",
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2(_) => "avx2",
        }
    }

    /// How many of the root's slots hold the mesh's hull (its large flat faces as leaves,
    /// `hull.rs`); 0 when the tree is the SAH tree alone.
    pub fn hull_slots(&self) -> usize {
        self.hull_slots
    }

    /// Number of 8-wide nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len() + self.qnodes.len()
    }

    /// Number of 8-triangle packets in the leaves.
    pub fn packet_count(&self) -> usize {
        self.packets.len()
    }

    /// Bytes held by the nodes and the packets.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * size_of::<Node8>() + self.qnodes.len() * size_of::<QNode8>() + self.packets.len() * size_of::<Packet>()
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// A 64-bit FNV-1a hash of every bit of the tree (nodes, packets, bounds): equal trees
    /// hash equal, so tests can check that a build is deterministic.
    pub fn fingerprint(&self) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |w: u32| {
            for b in w.to_le_bytes() {
                h = (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for n in &self.nodes {
            n.bounds.iter().flatten().for_each(|x| eat(x.to_bits()));
            n.child.iter().for_each(|&c| eat(c));
        }
        for n in &self.qnodes {
            n.planes.iter().flatten().for_each(|&q| eat(q as u32));
            n.base.iter().for_each(|x| eat(x.to_bits()));
            n.exponent.iter().for_each(|&e| eat(e as u32));
            eat(n.valid as u32);
            n.child.iter().for_each(|&c| eat(c));
        }
        for p in &self.packets {
            p.corners.iter().flatten().for_each(|x| eat(x.to_bits()));
            p.ids.iter().for_each(|&i| eat(i));
        }
        [self.bounds.min, self.bounds.max].iter().flat_map(|v| v.to_array()).for_each(|x| eat(x.to_bits()));
        h
    }

    /// The nearest triangle hit with t in (t_min, t_max).
    #[inline]
    pub fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2(v3) => {
                let l = lanes::Avx2(v3);
                // One walk in each closure: a closure holding both grows past what the compiler
                // inlines into `vectorize`'s AVX2 function, and its SIMD calls stay calls.
                if self.qnodes.is_empty() {
                    v3.vectorize(|| traverse::closest(l, &self.nodes, &self.packets, &TravRay::new(l, ray, t_min), t_max))
                } else {
                    v3.vectorize(|| traverse::closest(l, &self.qnodes, &self.packets, &TravRay::new(l, ray, t_min), t_max))
                }
            }
            Simd::Portable => {
                let l = lanes::Portable;
                self.closest_on(l, &TravRay::new(l, ray, t_min), t_max)
            }
        }
    }

    /// [`Bvh::closest_hit`] of the ray from `origin` along `dir`, t in (0, ∞), with the ray's
    /// set-up ([`Ray::new`]) done inside the kernel: compiled with the kernel's CPU features and
    /// handed to it in registers rather than through memory (the sound tracer's query, on the
    /// chain of a ray's segments), its axis picks done as lane permutes. The same arithmetic,
    /// so the same hits.
    #[inline]
    pub fn closest_hit_from(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2(v3) => {
                let l = lanes::Avx2(v3);
                let (o, d, inf) = (origin, dir, f32::INFINITY);
                if self.qnodes.is_empty() {
                    v3.vectorize(|| traverse::closest(l, &self.nodes, &self.packets, &TravRay::from_origin_dir(l, o, d, 0.0), inf))
                } else {
                    v3.vectorize(|| traverse::closest(l, &self.qnodes, &self.packets, &TravRay::from_origin_dir(l, o, d, 0.0), inf))
                }
            }
            Simd::Portable => {
                let l = lanes::Portable;
                self.closest_on(l, &TravRay::from_origin_dir(l, origin, dir, 0.0), f32::INFINITY)
            }
        }
    }

    /// [`Bvh::closest_hit_from`] on the AVX2 lanes of `v3` (this BVH's [`Bvh::avx2`]), inlined
    /// into a caller that runs under `v3.vectorize` (the sound kernel on a mesh): the same
    /// arithmetic, so the same hits. Called elsewhere it is right but slow (each SIMD operation
    /// a call).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn closest_hit_avx2(&self, v3: pulp::x86::V3, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let l = lanes::Avx2(v3);
        self.closest_on(l, &TravRay::from_origin_dir(l, origin, dir, 0.0), f32::INFINITY)
    }

    /// The closest-hit walk on whichever nodes the tree has (a branch every query takes the
    /// same way).
    #[inline(always)]
    fn closest_on<L: traverse_quantized::ByteLanes>(&self, l: L, r: &TravRay<L>, t_max: f32) -> Option<Hit> {
        if self.qnodes.is_empty() {
            traverse::closest(l, &self.nodes, &self.packets, r, t_max)
        } else {
            traverse::closest(l, &self.qnodes, &self.packets, r, t_max)
        }
    }

    /// Whether any triangle is hit with t in (t_min, t_max): the visibility test.
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2(v3) => {
                let l = lanes::Avx2(v3);
                if self.qnodes.is_empty() {
                    v3.vectorize(|| traverse::any(l, &self.nodes, &self.packets, &TravRay::new(l, ray, t_min), t_max))
                } else {
                    v3.vectorize(|| traverse::any(l, &self.qnodes, &self.packets, &TravRay::new(l, ray, t_min), t_max))
                }
            }
            Simd::Portable => self.any_on(lanes::Portable, ray, t_min, t_max),
        }
    }

    #[inline(always)]
    fn any_on<L: traverse_quantized::ByteLanes>(&self, l: L, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        if self.qnodes.is_empty() {
            traverse::any(l, &self.nodes, &self.packets, &TravRay::new(l, ray, t_min), t_max)
        } else {
            traverse::any(l, &self.qnodes, &self.packets, &TravRay::new(l, ray, t_min), t_max)
        }
    }

    /// Closest hits of many rays on the current rayon pool; one result per ray, in order.
    pub fn closest_hits(&self, rays: &[Ray], t_max: f32) -> Vec<Option<Hit>> {
        rays.par_iter().with_min_len(256).map(|r| self.closest_hit(r, 0.0, t_max)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Nodes::Auto` compresses exactly above the threshold; the explicit choices always hold.
    #[test]
    fn auto_compresses_exactly_above_the_threshold() {
        for bytes in [0, COMPRESS_ABOVE_BYTES - 224, COMPRESS_ABOVE_BYTES, COMPRESS_ABOVE_BYTES + 224, 1 << 40] {
            assert_eq!(compresses(Nodes::Auto, bytes), bytes > COMPRESS_ABOVE_BYTES);
            assert!(!compresses(Nodes::Full, bytes) && compresses(Nodes::Compressed, bytes));
        }
    }
}
