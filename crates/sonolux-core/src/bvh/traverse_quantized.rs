//! Walking the compressed tree ([`QNode8`]) with one ray: [`super::traverse`]'s walk, with each
//! node's planes decoded before its box test. The same prepared ray, the same packet test and
//! the same order of visits (nearest entry first, the lower slot first on ties), so the same
//! nearest hit (docs/bvh.md, "Compressed nodes").
//!
//! Decoding a plane is two roundless operations on eight lanes (each byte OR-ed into the
//! mantissa of 2^(e+23), plus the node's base: exact f32 values by construction, see
//! [`super::quantized`]), then the slab test of `Aabb::hit` as the full-precision walk does it:
//! the same roundings and the same widened exit, so on a box that encloses the child's, a test
//! that lets through every ray that meets the child's box (Ize, "Robust BVH ray traversal",
//! JCGT 2013). Embree's compressed BVH8 decodes the same way, near and far planes picked by the
//! ray's direction signs (`kernels/bvh/node_intersector1.h`, `intersectNode` for
//! `QuantizedBaseNode`).

use super::lanes::{Lanes, Portable};
use super::quantized::QNode8;
use super::traverse::{packet_hit, TravRay};
use super::{Packet, LEAF, PACKET_INDEX};
use crate::geometry::{Hit, BOX_EXIT_WIDEN};

/// Stack entries kept in a fixed array; deeper stacks (pathological trees) spill to the heap.
const STACK: usize = 32;

/// The one lane operation the compressed walk needs beyond [`Lanes`].
pub(crate) trait ByteLanes: Lanes {
    /// Lane i = `f32::from_bits(high | b[i])`: eight bytes set into the low mantissa bits of one
    /// f32 (bit moves, no rounding).
    fn bytes(self, b: &[u8; 8], high: u32) -> Self::F;
}

impl ByteLanes for Portable {
    #[inline(always)]
    fn bytes(self, b: &[u8; 8], high: u32) -> [f32; 8] {
        b.map(|q| f32::from_bits(high | q as u32))
    }
}

#[cfg(target_arch = "x86_64")]
impl ByteLanes for super::lanes::Avx2 {
    #[inline(always)]
    fn bytes(self, b: &[u8; 8], high: u32) -> pulp::f32x8 {
        // One 8-byte load zero-extended to eight 32-bit lanes (vpmovzxbd), then one OR.
        let v = self.0;
        let wide = v.avx2._mm256_cvtepu8_epi32(v.sse2._mm_set1_epi64x(i64::from_le_bytes(*b)));
        pulp::bytemuck::cast(v.avx2._mm256_or_si256(wide, v.avx._mm256_set1_epi32(high as i32)))
    }
}

/// Distances along the ray to eight decoded planes normal to `axis`: the plane, (2^(e+23) +
/// q·2^e) + base = origin + q·2^e (exact), then `(plane − origin of the ray) · 1/dir` as in the
/// full-precision walk.
#[inline(always)]
fn slab<L: ByteLanes>(l: L, node: &QNode8, plane: usize, axis: usize, org: L::F, inv: L::F) -> L::F {
    let at = l.add(l.bytes(&node.planes[plane], node.high_bits(axis)), l.splat(node.base[axis]));
    l.mul(l.sub(at, org), inv)
}

/// Which of the node's children the ray meets within (t_min, t_max) (bit per slot), and the
/// entry distances: `traverse::hit_children` on the decoded boxes, empty slots masked out.
#[inline(always)]
fn hit_children<L: ByteLanes>(l: L, r: &TravRay<L>, node: &QNode8, t_max: f32) -> (u32, [f32; 8]) {
    let (org, inv, near, far, t_min) = r.box_values();
    let nx = slab(l, node, near[0], 0, org[0], inv[0]);
    let ny = slab(l, node, near[1], 1, org[1], inv[1]);
    let nz = slab(l, node, near[2], 2, org[2], inv[2]);
    let fx = slab(l, node, far[0], 0, org[0], inv[0]);
    let fy = slab(l, node, far[1], 1, org[1], inv[1]);
    let fz = slab(l, node, far[2], 2, org[2], inv[2]);
    let enter = l.max(l.max(nx, ny), l.max(nz, t_min));
    let exit = l.min(l.mul(l.min(l.min(fx, fy), fz), l.splat(BOX_EXIT_WIDEN)), l.splat(t_max));
    (l.bits(l.le(enter, exit)) & node.valid as u32, l.store(enter))
}

/// Starts loading a child that will be visited later (a node is two cache lines).
#[inline(always)]
fn prefetch<L: Lanes>(l: L, nodes: &[QNode8], packets: &[Packet], child: u32) {
    if child & LEAF == 0 {
        if let Some(n) = nodes.get(child as usize) {
            l.prefetch(n);
        }
    } else if let Some(p) = packets.get((child & PACKET_INDEX) as usize) {
        l.prefetch(p);
    }
}

/// A leaf reference's packets.
#[inline(always)]
fn leaf_packets(r: u32) -> std::ops::Range<usize> {
    let first = (r & PACKET_INDEX) as usize;
    first..first + ((r & !LEAF) >> 29) as usize + 1
}

/// The traversal stack: child references with the entry distance they were pushed with.
struct Stack {
    items: [(u32, f32); STACK],
    len: usize,
    spill: Vec<(u32, f32)>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Stack {
        Stack { items: [(0, 0.0); STACK], len: 0, spill: Vec::new() }
    }

    #[inline(always)]
    fn push(&mut self, child: u32, t: f32) {
        if self.len < STACK {
            self.items[self.len] = (child, t);
        } else {
            self.spill.push((child, t));
        }
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        if self.len < STACK {
            Some(self.items[self.len])
        } else {
            self.spill.pop()
        }
    }
}

/// Closest hit: children visited nearest entry first; stack entries whose entry distance is
/// beyond the nearest hit found since they were pushed are dropped.
#[inline(always)]
pub(super) fn closest<L: ByteLanes>(l: L, nodes: &[QNode8], packets: &[Packet], r: &TravRay<L>, t_max: f32) -> Option<Hit> {
    let mut t_best = t_max;
    let mut triangle = u32::MAX;
    let mut stack = Stack::new();
    let mut current = 0u32; // the root
    loop {
        if current & LEAF == 0 {
            let node = &nodes[current as usize];
            let (mask, enter) = hit_children(l, r, node, t_best);
            match mask.count_ones() {
                0 => {}
                1 => {
                    current = node.child[mask.trailing_zeros() as usize];
                    continue;
                }
                2 => {
                    let a = mask.trailing_zeros() as usize;
                    let b = (mask & (mask - 1)).trailing_zeros() as usize;
                    let (near, far) = if enter[b] < enter[a] { (b, a) } else { (a, b) };
                    prefetch(l, nodes, packets, node.child[far]);
                    stack.push(node.child[far], enter[far]);
                    current = node.child[near];
                    continue;
                }
                _ => {
                    // Each hit slot's place in the nearest-first order counted with one 8-lane
                    // comparison (the hit slots entered before it; the lower slot first on
                    // ties), as in the full-precision walk; slots not hit go to scratch place 8.
                    let lanes = l.load(&enter);
                    let mut order = [(0.0f32, 0u32); 9];
                    for slot in 0..8 {
                        let t = l.splat(enter[slot]);
                        let before = l.bits(l.lt(lanes, t)) | (l.bits(l.eq(lanes, t)) & ((1 << slot) - 1));
                        let place = if mask >> slot & 1 != 0 { (before & mask).count_ones() as usize } else { 8 };
                        order[place] = (enter[slot], node.child[slot]);
                    }
                    let n = mask.count_ones() as usize;
                    for &(t, child) in order[1..n].iter().rev() {
                        prefetch(l, nodes, packets, child);
                        stack.push(child, t);
                    }
                    current = order[0].1;
                    continue;
                }
            }
        } else {
            for p in leaf_packets(current) {
                let (t, lane) = packet_hit(l, r, &packets[p], t_best);
                let nearer = t < t_best;
                triangle = if nearer { packets[p].ids[lane] } else { triangle };
                t_best = if nearer { t } else { t_best };
            }
        }
        // Next: the nearest pending child that may still hold a nearer hit.
        loop {
            match stack.pop() {
                None => return (triangle != u32::MAX).then_some(Hit { t: t_best, triangle }),
                Some((child, t)) if t <= t_best => {
                    current = child;
                    break;
                }
                Some(_) => {}
            }
        }
    }
}

/// Any hit: children in slot order, done at the first triangle hit.
#[inline(always)]
pub(super) fn any<L: ByteLanes>(l: L, nodes: &[QNode8], packets: &[Packet], r: &TravRay<L>, t_max: f32) -> bool {
    let mut stack = Stack::new();
    let mut current = 0u32;
    loop {
        if current & LEAF == 0 {
            let node = &nodes[current as usize];
            let (mut mask, _) = hit_children(l, r, node, t_max);
            if mask != 0 {
                let first = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                while mask != 0 {
                    let slot = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    stack.push(node.child[slot], 0.0);
                }
                current = node.child[first];
                continue;
            }
        } else if leaf_packets(current).any(|p| packet_hit(l, r, &packets[p], t_max).0 < t_max) {
            return true;
        }
        match stack.pop() {
            None => return false,
            Some((child, _)) => current = child,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AVX2 byte widening gives the portable lanes' values, for every byte in every lane,
    /// and a byte q under the exponent of 2^23 is 2^23 + q.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_and_portable_bytes_agree() {
        let Some(v3) = pulp::x86::V3::try_new() else { return };
        let a = super::super::lanes::Avx2(v3);
        for k in 0..=255u8 {
            let b: [u8; 8] = std::array::from_fn(|i| k.wrapping_mul(7).wrapping_add(31 * i as u8));
            for high in [150u32 << 23, 50 << 23, 254 << 23] {
                let (x, y) = (a.store(a.bytes(&b, high)), Portable.bytes(&b, high));
                assert_eq!(x.map(f32::to_bits), y.map(f32::to_bits));
            }
            assert_eq!(Portable.bytes(&b, 150 << 23), b.map(|q| 8388608.0 + q as f32));
        }
    }
}
