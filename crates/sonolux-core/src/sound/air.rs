//! The air's attenuation factors exp(−m_b · d) for every band at once.
//!
//! A segment of a sound ray loses exp(−m_b · length) of its energy in band b to the air (ISO
//! 9613-1's energy attenuation m_b, handed in per band), and a deposit carries the factor over
//! the leg to the receiver's centre. glibc's `exp` is a call per band (seven a segment for the
//! paper's octaves: 18 % of a paper-large grid bake with air, half of it the call's wrapper),
//! which the compiler cannot put in vector lanes. Here the bands' exponentials are computed
//! together, four lanes at a time, by Tang's table-driven method (P. T. P. Tang, "Table-driven
//! implementation of the exponential function in IEEE floating-point arithmetic", ACM TOMS
//! 15(2), 1989):
//!
//! - Reduction: y = (32 m + j) ln 2 / 32 + r with k = 32 m + j the nearest integer to
//!   32 y / ln 2, j in 0..32 and |r| ≤ ln 2 / 64 (a little more from the rounding of
//!   32 y log₂e); ln 2 / 32 in two parts (fdlibm's `e_exp.c` `ln2HI`/`ln2LO` over 32, as in
//!   Cody & Waite, "Software Manual for the Elementary Functions", 1980, ch. 6) so that r is
//!   nearly exact. k is rounded by adding and subtracting 1.5 · 2⁵², whose sum also holds k
//!   in its low bits: j and 2ᵐ come from those bits (an and, a subtraction and a shift, which
//!   vector lanes have; a float-to-integer conversion of 64 bits has no AVX2 instruction).
//! - exp(y) = 2ᵐ · 2^(j/32) · exp(r), with 2^(j/32) from a table of 32 doubles in two parts
//!   (hi + lo, computed to 200 bits) and exp(r) − 1 by its Taylor series to r⁶ (the first
//!   term left out, r⁷/7!, is below 3.5e-18 of the result), combined as
//!   hi + (lo + hi · (exp(r) − 1)) (Tang's eq. 5): within one ulp of glibc's `exp`
//!   everywhere the test looks (400 k values over the whole range, and the reduction's ends).
//! - Below y = −708.39 (2ᵐ would be subnormal) the factor is 0; glibc gives subnormals down to
//!   −745, energies 10⁻³⁰⁸ of the ray's start that no deposit can hold (the field's quantum is
//!   far larger).
//! - Measured (paper-large grid with air, 1 thread, CPU a segment, alternated with main's
//!   build): 105.8–110.8 ns with glibc's `exp`, 95.8–96.7 with these lanes (a Taylor series
//!   to r¹³ without the table ran as fast, 96.1–96.4; the table is kept for its accuracy). At
//!   1 M rays: medians 101.6 → 93.1 ns (−8 %); the SSE2 path alone ≈ glibc's speed, with the
//!   same bake hash as the AVX2 path.
//!
//! **The same bits on every machine**: only IEEE 754's correctly rounded +, −, × and exact bit
//! operations, in a fixed order, no fused multiply-add (Rust never contracts a · b + c). The
//! AVX2 path (pulp's `V3` token, chosen at run time) compiles this same code for wider lanes;
//! the baseline SSE2 path and any other architecture give the same results. The factors differ
//! from glibc's `exp` by a few ulps, so bakes with air moved their bits when this replaced it
//! (session 11, docs/convex.md); the energy budget still closes exactly (the air's tally is
//! before − after).

/// Lanes computed together: AVX2's four doubles (SSE2 runs them as two pairs).
const LANES: usize = 4;

/// The bake's air: each band's m_b (1/m), padded with zeros to whole groups of lanes
/// (exp(0) = 1, never read), and the AVX2 token where the processor has it.
#[derive(Clone, Debug)]
pub(crate) struct Air {
    per_m: Vec<[f64; LANES]>,
    #[cfg(target_arch = "x86_64")]
    v3: Option<pulp::x86::V3>,
}

impl Air {
    pub(crate) fn new(per_m: &[f64]) -> Air {
        let per_m = per_m.chunks(LANES).map(|c| std::array::from_fn(|l| c.get(l).copied().unwrap_or(0.0))).collect();
        Air {
            per_m,
            #[cfg(target_arch = "x86_64")]
            v3: pulp::x86::V3::try_new(),
        }
    }

    /// The same as [`Air::new`], computed without the AVX2 path (for the test that both agree).
    #[cfg(test)]
    fn portable(per_m: &[f64]) -> Air {
        Air {
            #[cfg(target_arch = "x86_64")]
            v3: None,
            ..Air::new(per_m)
        }
    }

    /// Absorbs over `length_m`: each band's energy `e[b]` times exp(−m_b · length), what it
    /// loses added to `absorbed[b]`.
    #[inline]
    pub(crate) fn absorb(&self, length_m: f64, e: &mut [f64], absorbed: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.v3 {
            return v3.vectorize(
                #[inline(always)]
                || absorb_lanes(&self.per_m, length_m, e, absorbed),
            );
        }
        absorb_lanes(&self.per_m, length_m, e, absorbed)
    }

    /// Multiplies each `values[b]` by exp(−m_b · distance_m) (a connection's or the direct
    /// sound's leg: the same bits as the free [`attenuate`]).
    #[inline]
    pub(crate) fn attenuate(&self, distance_m: f64, values: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.v3 {
            return v3.vectorize(
                #[inline(always)]
                || attenuate_lanes(self.per_m.iter().copied(), distance_m, values),
            );
        }
        attenuate_lanes(self.per_m.iter().copied(), distance_m, values)
    }

    /// Writes exp(−m_b · distance_m) into `out[b]` for every band b of `out`.
    #[inline]
    pub(crate) fn factors(&self, distance_m: f64, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.v3 {
            return v3.vectorize(
                #[inline(always)]
                || factor_lanes(&self.per_m, distance_m, out),
            );
        }
        factor_lanes(&self.per_m, distance_m, out)
    }
}

#[inline(always)]
fn absorb_lanes(per_m: &[[f64; LANES]], length_m: f64, e: &mut [f64], absorbed: &mut [f64]) {
    for ((m, e), absorbed) in per_m.iter().zip(e.chunks_mut(LANES)).zip(absorbed.chunks_mut(LANES)) {
        let f = exp_lanes(std::array::from_fn(|l| -m[l] * length_m));
        // Whole groups as arrays (one vector operation each), the last partial one by band.
        if let (Ok(e), Ok(absorbed)) = (<&mut [f64; LANES]>::try_from(&mut *e), <&mut [f64; LANES]>::try_from(&mut *absorbed)) {
            let kept: [f64; LANES] = std::array::from_fn(|l| e[l] * f[l]);
            *absorbed = std::array::from_fn(|l| absorbed[l] + (e[l] - kept[l]));
            *e = kept;
            continue;
        }
        for l in 0..e.len() {
            let kept = e[l] * f[l];
            absorbed[l] += e[l] - kept;
            e[l] = kept;
        }
    }
}

#[inline(always)]
fn factor_lanes(per_m: &[[f64; LANES]], distance_m: f64, out: &mut [f64]) {
    for (m, out) in per_m.iter().zip(out.chunks_mut(LANES)) {
        let f = exp_lanes(std::array::from_fn(|l| -m[l] * distance_m));
        if let Ok(out) = <&mut [f64; LANES]>::try_from(&mut *out) {
            *out = f;
            continue;
        }
        // By element: `copy_from_slice` of a length unknown here is a `memcpy` call.
        #[allow(clippy::manual_memcpy)]
        for l in 0..out.len() {
            out[l] = f[l];
        }
    }
}

/// Multiplies each `values[b]` by exp(−m_b · distance_m), for the air's m_b per band `per_m`: the
/// air of the paths found outside the ray kernel (image sources, edge diffraction), with the
/// same factors, bit for bit, as the kernel's [`Air`] (each lane is computed alone), without
/// an [`Air`] to build or the AVX2 dispatch (a few calls a path).
pub(crate) fn attenuate(per_m: &[f64], distance_m: f64, values: &mut [f64]) {
    attenuate_lanes(per_m.chunks(LANES).map(|m| std::array::from_fn(|l| m.get(l).copied().unwrap_or(0.0))), distance_m, values)
}

#[inline(always)]
fn attenuate_lanes(per_m: impl Iterator<Item = [f64; LANES]>, distance_m: f64, values: &mut [f64]) {
    for (m, v) in per_m.zip(values.chunks_mut(LANES)) {
        let f = exp_lanes(std::array::from_fn(|l| -m[l] * distance_m));
        if let Ok(v) = <&mut [f64; LANES]>::try_from(&mut *v) {
            *v = std::array::from_fn(|l| v[l] * f[l]);
            continue;
        }
        for l in 0..v.len() {
            v[l] *= f[l];
        }
    }
}

/// exp(y) of one value with [`exp_lanes`]' arithmetic: the same bits on every machine (glibc's
/// `exp` may differ between libm versions), for the few scalar losses outside the air (the
/// grazing modes' damping, `sound/grazing.rs`).
#[inline]
pub(crate) fn exp(y: f64) -> f64 {
    exp_lanes([y; LANES])[0]
}

/// 1.5 · 2⁵²: adding it rounds a double of magnitude below 2⁵¹ to an integer, held in the low
/// bits of the sum's representation.
const SHIFT: f64 = 6_755_399_441_055_744.0;
/// ln 2 / 32 in two parts (fdlibm's `ln2HI`/`ln2LO` over 32, exact): k · LN2_32_HI is exact
/// for |k| < 2²⁰.
/// (0x3fe62e42fee00000 = 6.93147180369123816490e-1, 0x3dea39ef35793c76 = 1.90821492927058770002e-10.)
const LN2_32_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000) / 32.0;
const LN2_32_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76) / 32.0;
/// Below this the factor is 0 (2ᵐ would be subnormal).
const LOWEST: f64 = -708.39;
/// Above this exp overflows (never for an absorbing air; kept for a total function).
const HIGHEST: f64 = 709.78;
/// 2^(j/32), j = 0..32, as the nearest double (HI) and the rest (LO), computed to 200 bits
/// with mpmath; printed as the shortest decimals that read back to the same doubles.
#[rustfmt::skip]
const TABLE_HI: [f64; 32] = [1.0, 1.0218971486541166, 1.0442737824274138, 1.0671404006768237, 1.0905077326652577, 1.1143867425958924, 1.1387886347566916, 1.1637248587775775, 1.189207115002721, 1.215247359980469, 1.241857812073484, 1.2690509571917332, 1.2968395546510096, 1.3252366431597413, 1.3542555469368927, 1.383909881963832, std::f64::consts::SQRT_2, 1.4451808069770467, 1.4768261459394993, 1.5091644275934228, 1.5422108254079407, 1.5759808451078865, 1.6104903319492543, 1.645755478153965, 1.681792830507429, 1.718619298122478, 1.7562521603732995, 1.7947090750031072, 1.8340080864093424, 1.8741676341103, 1.9152065613971474, 1.9571441241754002];
#[rustfmt::skip]
const TABLE_LO: [f64; 32] = [0.0, 5.109225028973444e-17, 8.551889705537965e-17, -7.899853966841582e-17, -3.046782079812471e-17, 1.0410278456845571e-16, 8.912812676025408e-17, 3.8292048369240935e-17, 3.982015231465646e-17, -7.712630692681488e-17, 4.658027591836937e-17, 2.667932131342186e-18, 2.5382502794888315e-17, -2.8587312100388614e-17, 7.70094837980299e-17, -6.770511658794786e-17, -9.667293313452913e-17, -3.0237581349939873e-17, -3.483994556892796e-17, -1.016455327754295e-16, 7.949834809697621e-17, -1.0136916471278304e-17, 2.4707192569797888e-17, -1.0125679913674773e-16, 8.199010020581497e-17, -1.851380418263111e-17, 2.960140695448873e-17, 1.8227458427912087e-17, 3.283107224245627e-17, -6.122763413004143e-17, -1.0619946056195963e-16, 8.960767791036668e-17];

/// exp(y) in each lane (module doc): the same bits wherever it runs. Written one operation at a
/// time across the lanes (no branch: the ends are masks) so that the compiler puts each in one
/// vector instruction.
#[inline(always)]
pub(crate) fn exp_lanes(y: [f64; LANES]) -> [f64; LANES] {
    type V = [f64; LANES];
    #[inline(always)]
    fn each<T>(f: impl Fn(usize) -> T) -> [T; LANES] {
        std::array::from_fn(f)
    }
    // a + b · x, lane by lane (a multiply, then an add: two roundings).
    #[inline(always)]
    fn madd(a: f64, b: f64, x: V) -> V {
        each(|l| a + b * x[l])
    }
    // Reduction: k = round(32 y / ln 2) = 32 m + j, r = y − k ln 2 / 32, |r| ≤ ln 2 / 64.
    let t = each(|l| y[l] * (32.0 * std::f64::consts::LOG2_E) + SHIFT);
    let k = each(|l| t[l] - SHIFT);
    let r = each(|l| (y[l] - k[l] * LN2_32_HI) - k[l] * LN2_32_LO);
    // exp(r) − 1 = r (1 + r/2 + r²/6 + r³/24 + r⁴/120 + r⁵/720) (Taylor; the first term left
    // out, r⁷/7!, is below 3.5e-18 of the result), by Estrin's scheme.
    let r2 = each(|l| r[l] * r[l]);
    let (a0, a1, a2) = (madd(1.0, 0.5, r), madd(1.0 / 6.0, 1.0 / 24.0, r), madd(1.0 / 120.0, 1.0 / 720.0, r));
    let s = each(|l| (a0[l] + a1[l] * r2[l]) + a2[l] * (r2[l] * r2[l]));
    let q = each(|l| r[l] * s[l]);
    // 2^(j/32) exp(r) = hi + (lo + hi (exp(r) − 1)) (Tang 1989, ACM TOMS 15(2), eq. 5), then
    // times 2ᵐ, whose exponent field is (k − j) · 2⁴⁷ + 1023 · 2⁵² (k − j = 32 m).
    let bits = each(|l| t[l].to_bits().wrapping_sub(SHIFT.to_bits()));
    let j = each(|l| (bits[l] & 31) as usize);
    let hi = each(|l| TABLE_HI[j[l]]);
    let lo = each(|l| TABLE_LO[j[l]]);
    let two_m = each(|l| f64::from_bits(bits[l].wrapping_sub(j[l] as u64).wrapping_shl(47).wrapping_add(1023 << 52)));
    let v = each(|l| (hi[l] + (lo[l] + hi[l] * q[l])) * two_m[l]);
    // The ends as masks: 0 below LOWEST, ∞ above HIGHEST (NaN passes through both).
    let low = each(|l| f64::from_bits(v[l].to_bits() & if y[l] < LOWEST { 0 } else { u64::MAX }));
    each(|l| {
        let over = if y[l] > HIGHEST { u64::MAX } else { 0 };
        f64::from_bits((low[l].to_bits() & !over) | (f64::INFINITY.to_bits() & over))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;

    /// Distance in ulps between two positive doubles.
    fn ulps(a: f64, b: f64) -> u64 {
        a.to_bits().abs_diff(b.to_bits())
    }

    #[test]
    fn the_lanes_exp_is_within_two_ulps_of_glibc() {
        // Over the whole range an air gives (y from −708 to 0, most of it small |y|: m · d is
        // 1e-6 to 10 in a bake), and at the ends of the reduction's intervals, where r is
        // largest. glibc's exp is within 1 ulp of exact, so 2 ulps from it bounds ours to 3.
        let mut rng = Stream::new(3, 1, 4);
        let mut worst = 0;
        let mut ys: Vec<f64> = (0..400_000).map(|i| if i % 2 == 0 { -708.0 * rng.uniform() } else { -(10f64).powf(8.0 * rng.uniform() - 7.0) }).collect();
        ys.extend((0..1022).flat_map(|k| [-(k as f64 + 0.5) * std::f64::consts::LN_2, -(k as f64) * std::f64::consts::LN_2]));
        ys.extend([0.0, -0.0, -1e-300, -5e-324, -708.0, 1.0, 700.0]);
        for y in ys.chunks(LANES) {
            let y: [f64; LANES] = std::array::from_fn(|l| y.get(l).copied().unwrap_or(0.0));
            let f = exp_lanes(y);
            for l in 0..LANES {
                let u = ulps(f[l], y[l].exp());
                worst = worst.max(u);
                assert!(u <= 1, "exp({}) = {} against {}", y[l], f[l], y[l].exp());
            }
        }
        // Not exact everywhere (else this would be glibc's code): the test can fail.
        assert!(worst >= 1, "{worst}");
        // The ends: 0 below the normal range, ∞ above, NaN through.
        let f = exp_lanes([-709.0, -1e300, f64::NEG_INFINITY, f64::NAN]);
        assert_eq!(&f[..3], &[0.0, 0.0, 0.0]);
        assert!(f[3].is_nan());
        assert_eq!(exp_lanes([710.0, f64::INFINITY, 0.0, -0.0]), [f64::INFINITY, f64::INFINITY, 1.0, 1.0]);
    }

    #[test]
    fn the_air_is_the_same_bits_on_every_path_and_band_count() {
        // The AVX2 path (where this machine has it) and the portable one; 1 to 19 bands (whole
        // groups of lanes and partial ones): the same factors, band by band, as the lanes alone.
        let mut rng = Stream::new(5, 9, 2);
        for nb in 1..=19 {
            let m: Vec<f64> = (0..nb).map(|_| 0.03 * rng.uniform()).collect();
            let (fast, portable) = (Air::new(&m), Air::portable(&m));
            for _ in 0..200 {
                let d = 300.0 * rng.uniform();
                let (mut a, mut b) = (vec![0.0; nb], vec![0.0; nb]);
                fast.factors(d, &mut a);
                portable.factors(d, &mut b);
                let lone: Vec<f64> = m.iter().map(|&m| exp_lanes([-m * d; LANES])[0]).collect();
                assert_eq!(a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), lone.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
                assert_eq!(a, b);
                // Attenuation of given values (kernel's and free): values × the same factors.
                let v0: Vec<f64> = (0..nb).map(|_| rng.uniform()).collect();
                let (mut v, mut w, mut x) = (v0.clone(), v0.clone(), v0.clone());
                fast.attenuate(d, &mut v);
                portable.attenuate(d, &mut w);
                attenuate(&m, d, &mut x);
                assert_eq!((&v, &v), (&w, &x));
                assert!(v.iter().zip(&v0).zip(&lone).all(|((v, v0), f)| *v == v0 * f));
                // Absorption: energy kept times the factor, the loss tallied, the budget exact.
                let e0: Vec<f64> = (0..nb).map(|_| rng.uniform()).collect();
                let (mut e, mut absorbed) = (e0.clone(), vec![0.0; nb]);
                fast.absorb(d, &mut e, &mut absorbed);
                let (mut e2, mut absorbed2) = (e0.clone(), vec![0.0; nb]);
                portable.absorb(d, &mut e2, &mut absorbed2);
                assert_eq!((&e, &absorbed), (&e2, &absorbed2));
                for b in 0..nb {
                    assert_eq!(e[b], e0[b] * lone[b]);
                    assert_eq!(absorbed[b], e0[b] - e[b]);
                }
            }
        }
    }
}
