//! The compressed 8-wide node: each child's box as eight-bit planes on a per-node, per-axis grid,
//! 96 bytes a node instead of [`Node8`]'s 224, for trees too large for the caches.
//!
//! The scheme is Ylitie, Karras and Laine's ("Efficient incoherent ray traversal on GPUs through
//! compressed wide BVHs", HPG 2017, §3.1: an origin and a power-of-two scale per axis, child
//! planes as unsigned bytes rounded outward) and Embree's quantized BVH8 node
//! (`kernels/bvh/bvh_node_qaabb.h`: `QuantizedBaseNode_t`, start + scale·q per axis, lower
//! planes rounded down and upper planes up, then corrected until they enclose the box). Unlike
//! Embree's (a float scale, decoded by a fused multiply-add whose result is rounded), the scale
//! here is a power of two 2^e and the origin a multiple of it, both chosen so that every
//! decoded plane `origin + q·2^e` (q = 0…255) is an f32 exactly: decoding rounds nothing, so
//! the decoded box encloses the child's box exactly as built, and the box test of
//! [`super::traverse`] (the slab test with Ize's widened exit, which is conservative for any
//! box) stays conservative unchanged on the larger box. A larger box only lets more children
//! through, never fewer, so the nearest hit is the same triangle at the same distance as on
//! the full-precision tree (docs/bvh.md, "Compressed nodes").
//!
//! Decoding takes no multiplication and no conversion: the f32 whose exponent field is that of
//! 2^(e+23) and whose low mantissa bits are q *is* 2^(e+23) + q·2^e, so a byte becomes its plane
//! by one OR and one addition of the stored `base` = origin − 2^(e+23) (both sums exact, see
//! [`quantize_axis`]): on the critical path of a node test, one integer OR and one add where a
//! conversion, a multiplication and an add would take three times as long.
//!
//! The tree is the full-precision one, node for node: the same child references, the same
//! indices, the same packets; only each node's boxes are re-encoded ([`QNode8::from_node`]).

use super::Node8;

/// Smallest exponent of a grid step: 2^-100 is a normal f32, so q·2^e (q ≤ 255) is exact and
/// never subnormal. A child box thinner than 2^-100 m simply gets a coarser grid.
const EXPONENT_MIN: i32 = -100;
/// Largest: 2^(e+23) must be a finite f32 (biased exponent e + 150 ≤ 254). Only a node spanning
/// ~10^31 m or lying ~10^38 m out would need more; such a tree keeps its full-precision nodes.
const EXPONENT_MAX: i32 = 104;
/// Largest grid index: planes are bytes.
const Q_MAX: f64 = 255.0;

/// Eight children: their boxes as byte planes on the node's grid, and their references.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct QNode8 {
    /// `[min x, max x, min y, max y, min z, max z][slot]`: grid indices q, plane = origin + q·2^e
    /// on the axis' grid, min planes rounded down and max planes up. Zero in empty slots.
    pub(crate) planes: [[u8; 8]; 6],
    /// Per axis, origin − 2^(e+23), an f32 exactly (the grid's origin is a multiple of 2^e).
    pub(crate) base: [f32; 3],
    /// Per axis, e + 150: the biased f32 exponent of 2^(e+23), so that
    /// `f32::from_bits(exponent << 23 | q)` = 2^(e+23) + q·2^e.
    pub(crate) exponent: [u8; 3],
    /// Bit per slot: which slots hold a child (the others are never visited).
    pub(crate) valid: u8,
    /// Per slot, as [`Node8::child`]: an interior node's index, or a leaf reference.
    pub(crate) child: [u32; 8],
}

/// One axis of a node encoded: the grid's base and biased exponent, and the children's min and
/// max planes on it.
struct Axis {
    base: f32,
    exponent: u8,
    min: [u8; 8],
    max: [u8; 8],
}

impl QNode8 {
    /// The node's boxes re-encoded on its grid, each enclosing the original box exactly; None
    /// for a node beyond the grid's range ([`EXPONENT_MAX`]).
    pub(crate) fn from_node(node: &Node8) -> Option<QNode8> {
        let b = &node.bounds;
        // A slot holds a child when its box is not the empty one (min = +∞, max = −∞).
        let valid = (0..8).filter(|&s| b[0][s] <= b[1][s]).fold(0u8, |m, s| m | 1 << s);
        let mut q = QNode8 { planes: [[0; 8]; 6], base: [0.0; 3], exponent: [150; 3], valid, child: node.child };
        if valid == 0 {
            return Some(q);
        }
        for axis in 0..3 {
            let a = quantize_axis(&b[2 * axis], &b[2 * axis + 1], valid)?;
            q.base[axis] = a.base;
            q.exponent[axis] = a.exponent;
            q.planes[2 * axis] = a.min;
            q.planes[2 * axis + 1] = a.max;
        }
        Some(q)
    }

    /// The exponent field of `axis`' planes: decoded plane = f32::from_bits(high | q) + base.
    #[inline(always)]
    pub(crate) fn high_bits(&self, axis: usize) -> u32 {
        (self.exponent[axis] as u32) << 23
    }

    /// The decoded plane `plane` (of [`QNode8::planes`]) of `slot`, as traversal computes it.
    #[cfg(test)]
    pub(crate) fn decoded(&self, plane: usize, slot: usize) -> f32 {
        let axis = plane / 2;
        f32::from_bits(self.high_bits(axis) | self.planes[plane][slot] as u32) + self.base[axis]
    }

    /// The grid step of `axis`, 2^e.
    #[cfg(test)]
    pub(crate) fn step(&self, axis: usize) -> f32 {
        f32::from_bits((self.exponent[axis] as u32 - 23) << 23)
    }
}

/// The grid of one axis and the children's planes on it. In f64, where a node's values are exact:
/// the origin is the children's least min rounded down to a multiple of the step 2^e, and e is
/// the least exponent (≥ [`EXPONENT_MIN`]) for which 255 steps reach the greatest max and every
/// multiple of 2^e between origin and origin + 255·2^e is an f32 (their magnitude below
/// 2^(e+24)), and so is base = origin − 2^(e+23): then 2^(e+23) + q·2^e (an f32: 24 significant
/// bits) plus base is the exact sum origin + q·2^e, which f32 addition returns unrounded. Each plane is then rounded outward and checked against its f32 value, and moved
/// one step further out while the check fails (the f64 quotient may round across an integer
/// when the plane lies far below the step's scale): the decoded box always encloses the box.
fn quantize_axis(min: &[f32; 8], max: &[f32; 8], valid: u8) -> Option<Axis> {
    let slots = || (0..8).filter(move |&s| valid >> s & 1 != 0);
    let lo = slots().map(|s| min[s] as f64).fold(f64::INFINITY, f64::min);
    let hi = slots().map(|s| max[s] as f64).fold(f64::NEG_INFINITY, f64::max);
    // The least e with (hi − lo)/2^e ≤ 254 (one step of slack for the origin's rounding).
    let span = hi - lo;
    let mut e = if span > 0.0 { (span / (Q_MAX - 1.0)).log2().ceil() as i32 - 1 } else { EXPONENT_MIN };
    e = e.max(EXPONENT_MIN);
    let (origin, step, base) = loop {
        if e > EXPONENT_MAX {
            return None;
        }
        let step = (e as f64).exp2();
        let origin = (lo / step).floor() * step;
        let top = origin + Q_MAX * step;
        let base = origin - (e as f64 + 23.0).exp2();
        let exact = (e as f64 + 24.0).exp2();
        if top >= hi && origin.abs().max(top.abs()).max(base.abs()) < exact {
            break (origin, step, base);
        }
        e += 1;
    };
    let high = ((e + 150) as u32) << 23;
    let decode = |q: u8| f32::from_bits(high | q as u32) + base as f32;
    debug_assert!(base as f32 as f64 == base && decode(0) as f64 == origin && decode(255) as f64 == origin + Q_MAX * step);
    let mut a = Axis { base: base as f32, exponent: (e + 150) as u8, min: [0; 8], max: [0; 8] };
    for s in slots() {
        let mut q_min = ((min[s] as f64 - origin) / step).floor().clamp(0.0, Q_MAX) as u8;
        while decode(q_min) > min[s] {
            q_min -= 1; // q = 0 decodes to the origin, ≤ every min: the loop ends there at last
        }
        let mut q_max = ((max[s] as f64 - origin) / step).ceil().clamp(0.0, Q_MAX) as u8;
        while decode(q_max) < max[s] {
            q_max += 1; // q = 255 decodes to top ≥ every max
        }
        (a.min[s], a.max[s]) = (q_min, q_max);
    }
    Some(a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;

    /// A node with `n` children at random places and sizes around `centre`, of scale `size`.
    fn random_node(s: &mut Stream, n: usize, centre: f32, size: f32) -> Node8 {
        let mut node = Node8 { bounds: [[f32::INFINITY; 8]; 6], child: [0; 8] };
        for plane in [1, 3, 5] {
            node.bounds[plane] = [f32::NEG_INFINITY; 8];
        }
        for slot in 0..n {
            node.child[slot] = slot as u32 + 1;
            for axis in 0..3 {
                let a = centre + (s.uniform_f32() - 0.5) * size;
                // Boxes from flat (a wall's leaf) to as large as the node.
                let w = if slot % 3 == 0 { 0.0 } else { s.uniform_f32().powi(4) * size };
                node.bounds[2 * axis][slot] = a;
                node.bounds[2 * axis + 1][slot] = a + w;
            }
        }
        node
    }

    /// Every decoded box encloses its child's box, every decoded plane is exact (the f64 sum
    /// equals the f32 one), the grid is no coarser than it must be, and empty slots stay empty:
    /// over nodes near the origin, far from it (where f32 spacing exceeds the boxes' scale), tiny
    /// and huge, with one to eight children.
    #[test]
    fn decoded_boxes_enclose_the_children_exactly_on_an_exact_grid() {
        let mut s = Stream::new(5, 0, 0);
        for (centre, size) in [(0.0, 10.0), (3.7, 1e-3), (-6000.0, 0.5), (1.0e6, 7.0), (2.5e7, 1.0), (0.0, 1e-35), (-1e30, 1e29)] {
            for trial in 0..400 {
                let n = 1 + trial % 8;
                let node = random_node(&mut s, n, centre, size);
                let q = QNode8::from_node(&node).unwrap();
                assert_eq!(q.valid, ((1u32 << n) - 1) as u8);
                assert_eq!(q.child, node.child);
                for axis in 0..3 {
                    let step = q.step(axis) as f64;
                    // The grid's origin, from base = origin − 2^(e+23), in f64 (exact).
                    let origin = q.base[axis] as f64 + step * 8388608.0;
                    for qi in [0u8, 1, 128, 254, 255] {
                        let exact = origin + qi as f64 * step;
                        let decoded = f32::from_bits(q.high_bits(axis) | qi as u32) + q.base[axis];
                        assert_eq!(decoded as f64, exact, "plane {qi} of axis {axis} not exact at centre {centre}");
                    }
                    for slot in 0..n {
                        let (lo, hi) = (q.decoded(2 * axis, slot), q.decoded(2 * axis + 1, slot));
                        assert!(lo <= node.bounds[2 * axis][slot] && hi >= node.bounds[2 * axis + 1][slot]);
                        // Outward by less than two steps, except where f32 spacing forces more.
                        let ulp = (centre.abs() * f32::EPSILON) as f64;
                        let slack = 2.0 * step.max(ulp);
                        let moved = node.bounds[2 * axis][slot] as f64 - lo as f64;
                        assert!(moved <= slack, "min moved {moved} > {slack}");
                        assert!(hi as f64 - node.bounds[2 * axis + 1][slot] as f64 <= slack);
                    }
                }
            }
        }
    }

    /// The grid step is as fine as 8 bits allow: the node's extent takes more than a quarter of
    /// the 255 steps wherever f32 spacing does not force a coarser grid.
    #[test]
    fn the_grid_uses_most_of_its_range() {
        let mut s = Stream::new(6, 0, 0);
        for _ in 0..500 {
            let node = random_node(&mut s, 8, 2.0, 5.0);
            let q = QNode8::from_node(&node).unwrap();
            for axis in 0..3 {
                let lo = (0..8).map(|k| node.bounds[2 * axis][k]).fold(f32::INFINITY, f32::min);
                let hi = (0..8).map(|k| node.bounds[2 * axis + 1][k]).fold(f32::NEG_INFINITY, f32::max);
                assert!((hi - lo) / q.step(axis) > 255.0 / 4.0, "extent {} step {}", hi - lo, q.step(axis));
            }
        }
    }

    /// A node whose grid would need a step beyond 2^104 (coordinates near f32's limit) is not
    /// encoded: its tree keeps the full-precision nodes.
    #[test]
    fn a_node_beyond_the_grids_range_is_refused() {
        let mut s = Stream::new(7, 0, 0);
        let node = random_node(&mut s, 4, -3.0e38, 1.0e36);
        assert!(QNode8::from_node(&node).is_none());
        assert!(QNode8::from_node(&random_node(&mut s, 4, 1.0e30, 1.0e29)).is_some());
    }

    #[test]
    fn a_node_is_96_bytes() {
        assert_eq!(size_of::<QNode8>(), 96);
    }
}
