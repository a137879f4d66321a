//! Walking the compressed tree ([`QNode8`]) with one ray: [`super::traverse`]'s walk (one
//! definition, generic over [`WideNode`]), with each node's planes decoded before its box test.
//! The same prepared ray, the same packet test and the same order of visits (nearest entry first, the lower slot first on ties), so the same
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
use super::traverse::{TravRay, WideNode};
use crate::geometry::BOX_EXIT_WIDEN;

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
    // (Widened after the clip, as the full-precision test: `traverse::hit_children`.)
    let exit = l.mul(l.min(l.min(l.min(fx, fy), fz), l.splat(t_max)), l.splat(BOX_EXIT_WIDEN));
    (l.bits(l.le(enter, exit)) & node.valid as u32, l.store(enter))
}

impl<L: ByteLanes> WideNode<L> for QNode8 {
    #[inline(always)]
    fn child(&self, slot: usize) -> u32 {
        self.child[slot]
    }

    #[inline(always)]
    fn hit_children(&self, l: L, r: &TravRay<L>, t_max: f32) -> (u32, [f32; 8]) {
        hit_children(l, r, self, t_max)
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
