//! Eight f32 lanes, the width of one BVH node's children and of one triangle packet, with the
//! few operations traversal needs. Two implementations that give the same bits:
//! - [`Avx2`]: AVX2 registers through `pulp` (no `unsafe` here), used when the CPU has AVX2 and
//!   FMA (checked once at run time, when the BVH is built);
//! - [`Portable`]: plain arrays, for every other CPU.
//!
//! Every operation is exactly rounded IEEE arithmetic (no fused multiply-add), and `min`/`max`
//! follow the x86 rule (`min(a, b) = if a < b { a } else { b }`, likewise `max`), so both
//! implementations, and the scalar triangle test in `geometry`, round every value alike.

/// Eight f32 lanes and their comparison masks.
pub(crate) trait Lanes: Copy {
    type F: Copy;
    type M: Copy;
    fn load(self, a: &[f32; 8]) -> Self::F;
    fn splat(self, x: f32) -> Self::F;
    fn store(self, a: Self::F) -> [f32; 8];
    fn add(self, a: Self::F, b: Self::F) -> Self::F;
    fn sub(self, a: Self::F, b: Self::F) -> Self::F;
    fn mul(self, a: Self::F, b: Self::F) -> Self::F;
    fn div(self, a: Self::F, b: Self::F) -> Self::F;
    fn min(self, a: Self::F, b: Self::F) -> Self::F;
    fn max(self, a: Self::F, b: Self::F) -> Self::F;
    fn lt(self, a: Self::F, b: Self::F) -> Self::M;
    fn le(self, a: Self::F, b: Self::F) -> Self::M;
    fn eq(self, a: Self::F, b: Self::F) -> Self::M;
    fn or(self, a: Self::M, b: Self::M) -> Self::M;
    fn and(self, a: Self::M, b: Self::M) -> Self::M;
    /// Bit i set where lane i of the mask is true.
    fn bits(self, m: Self::M) -> u32;
    /// `a` where the mask is true, else `b`.
    fn select(self, m: Self::M, a: Self::F, b: Self::F) -> Self::F;
    /// The least of the eight values in every lane (by the x86 `min` rule; exact for numbers).
    fn hmin(self, a: Self::F) -> Self::F;
    /// Lane i of the result is lane `idx[i]` (< 8) of `a`: values moved, never rounded.
    fn permute(self, a: Self::F, idx: &[u32; 8]) -> Self::F;
    /// Asks the CPU to bring `x` into the cache: a hint, which changes no result.
    fn prefetch<T>(self, x: &T);
}

/// Plain arrays: any CPU.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Portable;

#[inline(always)]
fn map2(a: [f32; 8], b: [f32; 8], f: impl Fn(f32, f32) -> f32) -> [f32; 8] {
    std::array::from_fn(|i| f(a[i], b[i]))
}

#[inline(always)]
fn mask(a: [f32; 8], b: [f32; 8], f: impl Fn(f32, f32) -> bool) -> u32 {
    (0..8).fold(0, |m, i| m | ((f(a[i], b[i]) as u32) << i))
}

impl Lanes for Portable {
    type F = [f32; 8];
    type M = u32;
    #[inline(always)]
    fn load(self, a: &[f32; 8]) -> [f32; 8] {
        *a
    }
    #[inline(always)]
    fn splat(self, x: f32) -> [f32; 8] {
        [x; 8]
    }
    #[inline(always)]
    fn store(self, a: [f32; 8]) -> [f32; 8] {
        a
    }
    #[inline(always)]
    fn add(self, a: [f32; 8], b: [f32; 8]) -> [f32; 8] {
        map2(a, b, |x, y| x + y)
    }
    #[inline(always)]
    fn sub(self, a: [f32; 8], b: [f32; 8]) -> [f32; 8] {
        map2(a, b, |x, y| x - y)
    }
    #[inline(always)]
    fn mul(self, a: [f32; 8], b: [f32; 8]) -> [f32; 8] {
        map2(a, b, |x, y| x * y)
    }
    #[inline(always)]
    fn div(self, a: [f32; 8], b: [f32; 8]) -> [f32; 8] {
        map2(a, b, |x, y| x / y)
    }
    #[inline(always)]
    fn min(self, a: [f32; 8], b: [f32; 8]) -> [f32; 8] {
        map2(a, b, |x, y| if x < y { x } else { y })
    }
    #[inline(always)]
    fn max(self, a: [f32; 8], b: [f32; 8]) -> [f32; 8] {
        map2(a, b, |x, y| if x > y { x } else { y })
    }
    #[inline(always)]
    fn lt(self, a: [f32; 8], b: [f32; 8]) -> u32 {
        mask(a, b, |x, y| x < y)
    }
    #[inline(always)]
    fn le(self, a: [f32; 8], b: [f32; 8]) -> u32 {
        mask(a, b, |x, y| x <= y)
    }
    #[inline(always)]
    fn eq(self, a: [f32; 8], b: [f32; 8]) -> u32 {
        mask(a, b, |x, y| x == y)
    }
    #[inline(always)]
    fn or(self, a: u32, b: u32) -> u32 {
        a | b
    }
    #[inline(always)]
    fn and(self, a: u32, b: u32) -> u32 {
        a & b
    }
    #[inline(always)]
    fn bits(self, m: u32) -> u32 {
        m
    }
    #[inline(always)]
    fn select(self, m: u32, a: [f32; 8], b: [f32; 8]) -> [f32; 8] {
        std::array::from_fn(|i| if m & (1 << i) != 0 { a[i] } else { b[i] })
    }
    #[inline(always)]
    fn hmin(self, a: [f32; 8]) -> [f32; 8] {
        // The same pairing as the AVX2 lanes: halves, then pairs, then neighbours.
        let m = self.min(a, std::array::from_fn(|i| a[i ^ 4]));
        let m = self.min(m, std::array::from_fn(|i| m[i ^ 2]));
        self.min(m, std::array::from_fn(|i| m[i ^ 1]))
    }
    #[inline(always)]
    fn permute(self, a: [f32; 8], idx: &[u32; 8]) -> [f32; 8] {
        std::array::from_fn(|i| a[idx[i] as usize & 7])
    }
    #[inline(always)]
    fn prefetch<T>(self, _: &T) {}
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::Avx2;

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use pulp::bytemuck::cast;
    use pulp::x86::V3;
    use pulp::{f32x8, m32x8};

    use super::Lanes;

    /// AVX2 registers; only made from a `V3` token, which proves the CPU has them.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Avx2(pub V3);

    impl Lanes for Avx2 {
        type F = f32x8;
        type M = m32x8;
        #[inline(always)]
        fn load(self, a: &[f32; 8]) -> f32x8 {
            cast(*a)
        }
        #[inline(always)]
        fn splat(self, x: f32) -> f32x8 {
            self.0.splat_f32x8(x)
        }
        #[inline(always)]
        fn store(self, a: f32x8) -> [f32; 8] {
            cast(a)
        }
        #[inline(always)]
        fn add(self, a: f32x8, b: f32x8) -> f32x8 {
            self.0.add_f32x8(a, b)
        }
        #[inline(always)]
        fn sub(self, a: f32x8, b: f32x8) -> f32x8 {
            self.0.sub_f32x8(a, b)
        }
        #[inline(always)]
        fn mul(self, a: f32x8, b: f32x8) -> f32x8 {
            self.0.mul_f32x8(a, b)
        }
        #[inline(always)]
        fn div(self, a: f32x8, b: f32x8) -> f32x8 {
            self.0.div_f32x8(a, b)
        }
        #[inline(always)]
        fn min(self, a: f32x8, b: f32x8) -> f32x8 {
            self.0.min_f32x8(a, b)
        }
        #[inline(always)]
        fn max(self, a: f32x8, b: f32x8) -> f32x8 {
            self.0.max_f32x8(a, b)
        }
        #[inline(always)]
        fn lt(self, a: f32x8, b: f32x8) -> m32x8 {
            self.0.cmp_lt_f32x8(a, b)
        }
        #[inline(always)]
        fn le(self, a: f32x8, b: f32x8) -> m32x8 {
            self.0.cmp_le_f32x8(a, b)
        }
        #[inline(always)]
        fn eq(self, a: f32x8, b: f32x8) -> m32x8 {
            self.0.cmp_eq_f32x8(a, b)
        }
        #[inline(always)]
        fn or(self, a: m32x8, b: m32x8) -> m32x8 {
            self.0.or_m32x8(a, b)
        }
        #[inline(always)]
        fn and(self, a: m32x8, b: m32x8) -> m32x8 {
            self.0.and_m32x8(a, b)
        }
        #[inline(always)]
        fn bits(self, m: m32x8) -> u32 {
            self.0.avx._mm256_movemask_ps(cast(m)) as u32
        }
        #[inline(always)]
        fn select(self, m: m32x8, a: f32x8, b: f32x8) -> f32x8 {
            cast(self.0.avx._mm256_blendv_ps(cast(b), cast(a), cast(m)))
        }
        #[inline(always)]
        fn hmin(self, a: f32x8) -> f32x8 {
            let avx = self.0.avx;
            let m = self.min(a, cast(avx._mm256_permute2f128_ps::<1>(cast(a), cast(a))));
            let m = self.min(m, cast(avx._mm256_permute_ps::<0b01_00_11_10>(cast(m))));
            self.min(m, cast(avx._mm256_permute_ps::<0b10_11_00_01>(cast(m))))
        }
        #[inline(always)]
        fn permute(self, a: f32x8, idx: &[u32; 8]) -> f32x8 {
            cast(self.0.avx2._mm256_permutevar8x32_ps(cast(a), cast(*idx)))
        }
        #[inline(always)]
        fn prefetch<T>(self, x: &T) {
            // One hint per 64-byte line; a prefetch never faults, whatever the address. (A
            // counted loop over a constant, which the compiler unrolls: `step_by` kept a
            // loop and its branch, 4-5 a pushed child.)
            let p = (x as *const T).cast::<i8>();
            for line in 0..size_of::<T>().div_ceil(64) {
                self.0.sse._mm_prefetch::<{ core::arch::x86_64::_MM_HINT_T0 }>(p.wrapping_add(64 * line));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values that stress rounding and the special cases: signed zeros, infinities, NaN.
    fn samples() -> Vec<[f32; 8]> {
        let special = [0.0, -0.0, 1.0, -1.5, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 1e-30];
        let mut v = vec![special];
        let mut x = 0.1234f32;
        for _ in 0..64 {
            v.push(std::array::from_fn(|i| {
                x = (x * 3.77 + 0.31 * i as f32).fract() * if i % 2 == 0 { 1e3 } else { -7e-3 };
                x
            }));
        }
        v.push([f32::NAN, 0.0, -0.0, f32::INFINITY, 2.0, 2.0, -3.0, 1e30]);
        v
    }

    /// The AVX2 lanes round exactly as the portable ones (bit for bit, NaN payloads aside).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_and_portable_lanes_agree_bit_for_bit() {
        let Some(v3) = pulp::x86::V3::try_new() else { return };
        let (a, p) = (Avx2(v3), Portable);
        let same = |x: [f32; 8], y: [f32; 8]| {
            x.iter().zip(&y).all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
        };
        let s = samples();
        for x in &s {
            for y in &s {
                let (ax, ay, px, py) = (a.load(x), a.load(y), p.load(x), p.load(y));
                assert!(same(a.store(a.add(ax, ay)), p.add(px, py)));
                assert!(same(a.store(a.sub(ax, ay)), p.sub(px, py)));
                assert!(same(a.store(a.mul(ax, ay)), p.mul(px, py)));
                assert!(same(a.store(a.div(ax, ay)), p.div(px, py)));
                assert!(same(a.store(a.min(ax, ay)), p.min(px, py)));
                assert!(same(a.store(a.max(ax, ay)), p.max(px, py)));
                assert_eq!(a.bits(a.lt(ax, ay)), p.lt(px, py));
                assert_eq!(a.bits(a.le(ax, ay)), p.le(px, py));
                assert_eq!(a.bits(a.eq(ax, ay)), p.eq(px, py));
                let (m, n) = (a.lt(ax, ay), a.eq(ax, ay));
                assert_eq!(a.bits(a.or(m, n)), p.lt(px, py) | p.eq(px, py));
                assert_eq!(a.bits(a.and(m, a.le(ax, ay))), p.lt(px, py) & p.le(px, py));
                assert!(same(a.store(a.select(m, ax, ay)), p.select(p.lt(px, py), px, py)));
                assert!(same(a.store(a.hmin(ax)), p.hmin(px)));
                let idx: [u32; 8] = std::array::from_fn(|i| (x[i].to_bits() ^ y[7 - i].to_bits()) % 8);
                assert!(same(a.store(a.permute(ax, &idx)), p.permute(px, &idx)));
            }
        }
    }
}
