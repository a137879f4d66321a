//! The air's attenuation factors exp(−m_b · d) for every band at once.
//!
//! A segment of a sound ray loses exp(−m_b · length) of its energy in band b to the air (ISO
//! 9613-1's energy attenuation m_b, handed in per band), and a deposit carries the factor over
//! the leg to the receiver's centre. glibc's `exp` is a call per band (seven a segment for the
//! paper's octaves: 18 % of a paper-large grid bake with air, half of it the call's wrapper),
//! which the compiler cannot put in vector lanes. Here the bands' exponentials are computed
//! together, four lanes at a time:
//!
//! - Reduction (Cody & Waite, "Software Manual for the Elementary Functions", 1980, ch. 6;
//!   the two-part ln 2 of fdlibm's `e_exp.c`): y = k ln 2 + r with k the nearest integer to
//!   y / ln 2 and |r| ≤ ln 2 / 2 (a little more from the rounding of y log₂e), so that
//!   exp(y) = 2ᵏ exp(r). k is rounded by adding and subtracting 1.5 · 2⁵², whose sum also holds
//!   k in its low bits: 2ᵏ is built from those bits (an integer add and shift, which vector
//!   lanes have; a float-to-integer conversion of 64 bits has no AVX2 instruction).
//! - exp(r) by its Taylor series to r¹³ (Estrin's scheme, for a short dependency chain): the
//!   first term left out is |r|¹⁴/14! ≤ 0.347¹⁴/14! ≈ 4.3e-18, below a fortieth of an ulp
//!   of exp(r) ≥ 0.7. The evaluation's roundings leave the result within a few ulps of the
//!   exact value (the test measures it against glibc over the whole range).
//! - Below y = −708.39 (2ᵏ would be subnormal) the factor is 0; glibc gives subnormals down to
//!   −745, energies 10⁻³⁰⁸ of the ray's start that no deposit can hold (the field's quantum is
//!   far larger).
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
        for l in 0..out.len() {
            out[l] = f[l];
        }
    }
}

/// 1.5 · 2⁵²: adding it rounds a double of magnitude below 2⁵¹ to an integer, held in the low
/// bits of the sum's representation.
const SHIFT: f64 = 6_755_399_441_055_744.0;
/// ln 2 in two parts (fdlibm's `ln2HI`/`ln2LO`): k · LN2_HI is exact for |k| < 2²⁰.
const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-1;
const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
/// Below this the factor is 0 (2ᵏ would be subnormal).
const LOWEST: f64 = -708.39;
/// Above this exp overflows (never for an absorbing air; kept for a total function).
const HIGHEST: f64 = 709.78;

/// exp(y) in each lane (module doc): the same bits wherever it runs. Written one operation at a
/// time across the lanes (no branch: the ends are masks) so that the compiler puts each in one
/// vector instruction.
#[inline(always)]
pub(crate) fn exp_lanes(y: [f64; LANES]) -> [f64; LANES] {
    type V = [f64; LANES];
    #[inline(always)]
    fn each(f: impl Fn(usize) -> f64) -> V {
        std::array::from_fn(f)
    }
    // a + b · x, lane by lane (a multiply, then an add: two roundings).
    #[inline(always)]
    fn madd(a: V, b: V, x: V) -> V {
        each(|l| a[l] + b[l] * x[l])
    }
    #[inline(always)]
    fn splat(c: f64) -> V {
        [c; LANES]
    }
    // 1/i!, i = 0..=13.
    const C: [f64; 14] = [
        1.0,
        1.0,
        0.5,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
        1.0 / 6_227_020_800.0,
    ];
    // Reduction: k = round(y / ln 2), r = y − k ln 2.
    let t = each(|l| y[l] * std::f64::consts::LOG2_E + SHIFT);
    let k = each(|l| t[l] - SHIFT);
    let r = each(|l| (y[l] - k[l] * LN2_HI) - k[l] * LN2_LO);
    // exp(r) by Estrin's scheme.
    let r2 = each(|l| r[l] * r[l]);
    let r4 = each(|l| r2[l] * r2[l]);
    let r8 = each(|l| r4[l] * r4[l]);
    let q = |i: usize| madd(splat(C[i]), splat(C[i + 1]), r);
    let s0 = madd(q(0), q(2), r2);
    let s1 = madd(q(4), q(6), r2);
    let s2 = madd(q(8), q(10), r2);
    let u0 = madd(s0, s1, r4);
    let u1 = madd(s2, q(12), r4);
    let p = madd(u0, u1, r8);
    // 2ᵏ: the sum's bits are SHIFT's plus k; k + 1023 in the exponent field.
    let two_k = each(|l| f64::from_bits(t[l].to_bits().wrapping_sub(SHIFT.to_bits()).wrapping_add(1023) << 52));
    let v = each(|l| p[l] * two_k[l]);
    // The ends as masks: 0 below LOWEST, ∞ above HIGHEST (NaN passes through both).
    let low = each(|l| f64::from_bits(v[l].to_bits() & if y[l] < LOWEST { 0 } else { u64::MAX }));
    each(|l| f64::from_bits(low[l].to_bits() | if y[l] > HIGHEST { f64::INFINITY.to_bits() } else { 0 }))
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
                assert!(u <= 2, "exp({}) = {} against {}", y[l], f[l], y[l].exp());
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
