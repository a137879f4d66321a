//! The convolution engine of the auralization: uniformly partitioned overlap-save convolution
//! (a frequency-domain delay line) of one input signal with many long filters, and the fold
//! of short per-bin filters (HRIRs) into partitioned filters.
//!
//! The input is cut into blocks of B samples. Each block, the spectrum of the last K input
//! samples (K ≥ 2B, the FFT size) enters a ring of P spectra. A filter of up to P·B taps is cut
//! into P partitions of B taps, each zero-padded to K and transformed ([`partition`]). The
//! block's output spectrum is Σ_p X[i − p] · H[p] ([`Convolver::apply`]); after the inverse FFT
//! its last B samples are exact linear convolution ([`Convolver::inverse`]). K > 2B leaves room
//! for a short filter of L ≤ K − 2B + 1 taps to be multiplied into the spectra first, still
//! exactly: that is how HRIRs are applied ([`fold`]).
//!
//! Spectra are planar: a spectrum of F = K/2 + 1 bins is 2F `f32`, its real parts then its
//! imaginary parts. Layouts (all contiguous):
//! - filters `[channel][partition][2][F]`, partition 0 = the first B taps (it meets the newest
//!   input spectrum);
//! - one block's spectra `[channel][2][F]`; its samples `[channel][B]`.
//!
//! The complex multiply-adds run through `pulp`, which picks the widest SIMD the CPU has at run
//! time (AVX2 + FMA on current x86-64) with no `unsafe` here; the FFTs are `realfft`'s, which
//! does the same. Everything runs on the caller's thread in a fixed order: the same input gives
//! the same bits on one machine.

use std::sync::Arc;

use num_complex::Complex32 as C32;
use pulp::{Arch, Simd, WithSimd};
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};

use crate::error::CoreError;

/// Partitioned overlap-save convolution of one input with any number of filters.
pub struct Convolver {
    block: usize,
    fft_size: usize,
    partitions: usize,
    bins: usize,
    /// The last K input samples.
    input: Vec<f32>,
    /// P planar input spectra; `slot` holds the newest.
    ring: Vec<f32>,
    slot: usize,
    r2c: Arc<dyn RealToComplex<f32>>,
    c2r: Arc<dyn ComplexToReal<f32>>,
    scratch: Vec<C32>,
    frame: Vec<f32>,
    spectrum: Vec<C32>,
    arch: Arch,
}

impl Convolver {
    /// A convolver of `partitions` partitions of `block` samples, FFT size `fft_size` ≥ 2·block.
    pub fn new(block: usize, partitions: usize, fft_size: usize) -> Result<Self, CoreError> {
        check_sizes(block, fft_size)?;
        if partitions == 0 {
            return Err(CoreError::invalid("partitions", "must be at least 1"));
        }
        let mut planner = RealFftPlanner::<f32>::new();
        let r2c = planner.plan_fft_forward(fft_size);
        let c2r = planner.plan_fft_inverse(fft_size);
        let bins = fft_size / 2 + 1;
        let scratch_len = r2c.get_scratch_len().max(c2r.get_scratch_len());
        Ok(Convolver {
            block,
            fft_size,
            partitions,
            bins,
            input: vec![0.0; fft_size],
            ring: vec![0.0; partitions * 2 * bins],
            slot: partitions - 1,
            r2c,
            c2r,
            scratch: vec![C32::new(0.0, 0.0); scratch_len],
            frame: vec![0.0; fft_size],
            spectrum: vec![C32::new(0.0, 0.0); bins],
            arch: Arch::new(),
        })
    }

    pub fn block(&self) -> usize {
        self.block
    }
    pub fn fft_size(&self) -> usize {
        self.fft_size
    }
    pub fn partitions(&self) -> usize {
        self.partitions
    }
    pub fn bins(&self) -> usize {
        self.bins
    }

    /// Takes the next B input samples: they enter the last K samples, whose spectrum replaces
    /// the oldest in the ring.
    pub fn push(&mut self, x: &[f32]) -> Result<(), CoreError> {
        let (b, k, f) = (self.block, self.fft_size, self.bins);
        if x.len() != b {
            return Err(CoreError::invalid("block", format!("expected {b} samples, got {}", x.len())));
        }
        self.input.copy_within(b.., 0);
        self.input[k - b..].copy_from_slice(x);
        self.frame.copy_from_slice(&self.input);
        self.r2c
            .process_with_scratch(&mut self.frame, &mut self.spectrum, &mut self.scratch)
            .map_err(|e| CoreError::invalid("push", e.to_string()))?;
        self.slot = (self.slot + 1) % self.partitions;
        to_planar(&self.spectrum, &mut self.ring[self.slot * 2 * f..][..2 * f]);
        Ok(())
    }

    /// The block's output spectra `[channel][2][F]` through `filters`
    /// `[channel][partition][2][F]`: Σ_p X[i − p] · H[p], written into `out`.
    pub fn apply(&self, filters: &[f32], out: &mut [f32]) -> Result<(), CoreError> {
        let (p, f) = (self.partitions, self.bins);
        if filters.is_empty() || filters.len() % (p * 2 * f) != 0 {
            return Err(CoreError::invalid(
                "filters",
                format!("{} values are not [channel][{p} partitions][2][{f} bins]", filters.len()),
            ));
        }
        let channels = filters.len() / (p * 2 * f);
        if out.len() != channels * 2 * f {
            return Err(CoreError::invalid("out", format!("expected {channels} × 2 × {f} values")));
        }
        // The ring's spectra from the newest input (partition 0) back to the oldest.
        let rows: Vec<Planar> = (0..p).map(|q| planar(&self.ring[((self.slot + p - q) % p) * 2 * f..][..2 * f])).collect();
        for (h, o) in filters.chunks_exact(p * 2 * f).zip(out.chunks_exact_mut(2 * f)) {
            let h: Vec<Planar> = h.chunks_exact(2 * f).map(planar).collect();
            let (re, im) = o.split_at_mut(f);
            self.arch.dispatch(MultiplyAccumulate { rows: &rows, filters: &h, out: (re, im) });
        }
        Ok(())
    }

    /// The last B samples of the inverse FFT of each spectrum `[channel][2][F]`: the block's
    /// output `[channel][B]`.
    pub fn inverse(&mut self, spectra: &[f32], out: &mut [f32]) -> Result<(), CoreError> {
        let (f, b, k) = (self.bins, self.block, self.fft_size);
        if spectra.is_empty() || spectra.len() % (2 * f) != 0 || out.len() != spectra.len() / (2 * f) * b {
            return Err(CoreError::invalid(
                "spectra",
                format!("expected [channel][2][{f}] spectra for [channel][{b}] samples"),
            ));
        }
        let scale = 1.0 / k as f32;
        for (s, o) in spectra.chunks_exact(2 * f).zip(out.chunks_exact_mut(b)) {
            let (re, im) = s.split_at(f);
            for ((z, &r), &i) in self.spectrum.iter_mut().zip(re).zip(im) {
                *z = C32::new(r, i);
            }
            // A real signal has no imaginary part at 0 Hz (nor at K/2 for an even K).
            self.spectrum[0].im = 0.0;
            if k % 2 == 0 {
                self.spectrum[f - 1].im = 0.0;
            }
            self.c2r
                .process_with_scratch(&mut self.spectrum, &mut self.frame, &mut self.scratch)
                .map_err(|e| CoreError::invalid("inverse", e.to_string()))?;
            for (y, x) in o.iter_mut().zip(&self.frame[k - b..]) {
                *y = x * scale;
            }
        }
        Ok(())
    }
}

fn check_sizes(block: usize, fft_size: usize) -> Result<(), CoreError> {
    if block == 0 {
        return Err(CoreError::invalid("block", "must be at least 1 sample"));
    }
    if fft_size < 2 * block {
        return Err(CoreError::invalid("fft_size", format!("{fft_size} is below twice the block ({block})")));
    }
    Ok(())
}

fn to_planar(spectrum: &[C32], out: &mut [f32]) {
    let (re, im) = out.split_at_mut(spectrum.len());
    for ((z, r), i) in spectrum.iter().zip(re).zip(im) {
        *r = z.re;
        *i = z.im;
    }
}

/// Planar spectra `[channel][partition][2][F]` of real filters `[channel][n]` cut into
/// `partitions` partitions of `block` taps (zero-padded), each transformed at `fft_size`.
pub fn partition(filters: &[f32], channels: usize, block: usize, fft_size: usize, partitions: usize) -> Result<Vec<f32>, CoreError> {
    check_sizes(block, fft_size)?;
    if channels == 0 || filters.len() % channels != 0 {
        return Err(CoreError::invalid("filters", format!("{} samples are not {channels} channels", filters.len())));
    }
    let n = filters.len() / channels;
    if partitions * block < n {
        return Err(CoreError::invalid(
            "partitions",
            format!("filters of {n} taps do not fit in {partitions} partitions of {block}"),
        ));
    }
    let r2c = RealFftPlanner::<f32>::new().plan_fft_forward(fft_size);
    let f = fft_size / 2 + 1;
    let mut out = vec![0.0f32; channels * partitions * 2 * f];
    let mut frame = vec![0.0f32; fft_size];
    let mut spectrum = r2c.make_output_vec();
    let mut scratch = r2c.make_scratch_vec();
    for (h, rows) in filters.chunks_exact(n).zip(out.chunks_exact_mut(partitions * 2 * f)) {
        for (p, row) in rows.chunks_exact_mut(2 * f).enumerate() {
            frame.fill(0.0);
            let start = (p * block).min(n);
            let taps = &h[start..(start + block).min(n)];
            frame[..taps.len()].copy_from_slice(taps);
            r2c.process_with_scratch(&mut frame, &mut spectrum, &mut scratch)
                .map_err(|e| CoreError::invalid("partition", e.to_string()))?;
            to_planar(&spectrum, row);
        }
    }
    Ok(out)
}

/// Folds per-bin mixing filters into partitioned filters, `out[e][p] = Σ_d mix[e][d] · h[d][p]`
/// bin by bin, for `h` `[direction][partition][2][F]` and `mix` `[channel][direction][2][F]`
/// (e.g. the spectra of an HRIR per ear and direction); `out` is `[channel][partition][2][F]`.
/// With one partition it mixes one block's direction spectra into channels.
pub fn fold(h: &[f32], directions: usize, mix: &[f32], channels: usize) -> Result<Vec<f32>, CoreError> {
    if directions == 0 || channels == 0 || mix.is_empty() || mix.len() % (2 * channels * directions) != 0 {
        return Err(CoreError::invalid(
            "mix",
            format!("{} values are not [{channels} channels][{directions} directions][2][bins]", mix.len()),
        ));
    }
    let f = mix.len() / (2 * channels * directions);
    if h.is_empty() || h.len() % (2 * directions * f) != 0 {
        return Err(CoreError::invalid(
            "filters",
            format!("{} values are not [{directions} directions][partitions][2][{f} bins]", h.len()),
        ));
    }
    let partitions = h.len() / (2 * directions * f);
    let mut out = vec![0.0f32; channels * partitions * 2 * f];
    let arch = Arch::new();
    let mixes: Vec<Planar> = mix.chunks_exact(2 * f).map(planar).collect();
    // Partition by partition, every channel in turn, so that a partition of every direction
    // is read from memory once and then from cache.
    for p in 0..partitions {
        let parts: Vec<Planar> = (0..directions).map(|d| planar(&h[(d * partitions + p) * 2 * f..][..2 * f])).collect();
        for (e, m) in mixes.chunks_exact(directions).enumerate() {
            let (re, im) = out[(e * partitions + p) * 2 * f..][..2 * f].split_at_mut(f);
            arch.dispatch(MultiplyAccumulate { rows: &parts, filters: m, out: (re, im) });
        }
    }
    Ok(out)
}

/// A planar complex row: (real parts, imaginary parts), of equal length.
type Planar<'a> = (&'a [f32], &'a [f32]);

fn planar(row: &[f32]) -> Planar<'_> {
    row.split_at(row.len() / 2)
}

/// `out[i] = Σ_q rows[q][i] · filters[q][i]`, complex, on planar rows: the one kernel of both
/// the convolution (rows = input spectra, newest first) and the fold (rows = one partition of
/// each direction). Planar rows make a complex multiply-add four real fused multiply-adds on
/// full SIMD lanes, with no shuffles.
struct MultiplyAccumulate<'a> {
    rows: &'a [Planar<'a>],
    filters: &'a [Planar<'a>],
    out: (&'a mut [f32], &'a mut [f32]),
}

impl WithSimd for MultiplyAccumulate<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let MultiplyAccumulate { rows, filters, out: (out_re, out_im) } = self;
        for (q, ((x_re, x_im), (h_re, h_im))) in rows.iter().zip(filters).enumerate() {
            let (or, or_t) = S::as_mut_simd_f32s(out_re);
            let (oi, oi_t) = S::as_mut_simd_f32s(out_im);
            let (xr, xr_t) = S::as_simd_f32s(x_re);
            let (xi, xi_t) = S::as_simd_f32s(x_im);
            let (hr, hr_t) = S::as_simd_f32s(h_re);
            let (hi, hi_t) = S::as_simd_f32s(h_im);
            let v = or.iter_mut().zip(oi.iter_mut()).zip(xr.iter().zip(xi)).zip(hr.iter().zip(hi));
            let t = or_t.iter_mut().zip(oi_t.iter_mut()).zip(xr_t.iter().zip(xi_t)).zip(hr_t.iter().zip(hi_t));
            // (a + ib)(c + id) = (ac − bd) + i(ad + bc)
            if q == 0 {
                for (((re, im), (&a, &b)), (&c, &d)) in v {
                    *re = simd.mul_add_f32s(a, c, simd.mul_f32s(simd.neg_f32s(b), d));
                    *im = simd.mul_add_f32s(a, d, simd.mul_f32s(b, c));
                }
                for (((re, im), (&a, &b)), (&c, &d)) in t {
                    *re = a.mul_add(c, -b * d);
                    *im = a.mul_add(d, b * c);
                }
            } else {
                for (((re, im), (&a, &b)), (&c, &d)) in v {
                    *re = simd.mul_add_f32s(a, c, simd.mul_add_f32s(simd.neg_f32s(b), d, *re));
                    *im = simd.mul_add_f32s(a, d, simd.mul_add_f32s(b, c, *im));
                }
                for (((re, im), (&a, &b)), (&c, &d)) in t {
                    *re = a.mul_add(c, (-b).mul_add(d, *re));
                    *im = a.mul_add(d, b.mul_add(c, *im));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn direct(x: &[f32], h: &[f32]) -> Vec<f64> {
        let mut y = vec![0.0f64; x.len() + h.len() - 1];
        for (i, &a) in x.iter().enumerate() {
            for (j, &b) in h.iter().enumerate() {
                y[i + j] += a as f64 * b as f64;
            }
        }
        y
    }

    fn noise(n: usize, seed: u32) -> Vec<f32> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (s >> 8) as f32 / 16_777_216.0 - 0.5
            })
            .collect()
    }

    #[test]
    fn block_by_block_output_equals_direct_convolution() {
        // Two filters, a block that does not divide their length, an odd FFT size: the
        // concatenated blocks equal the direct sum to float32 rounding (1e-5 of the peak).
        let (block, n, len) = (48, 301, 1000);
        let x = noise(len, 1);
        let h = [noise(n, 2), noise(n, 3)].concat();
        let p = n.div_ceil(block);
        let k = 2 * block + 5;
        let mut conv = Convolver::new(block, p, k).unwrap();
        let spectra = partition(&h, 2, block, k, p).unwrap();
        let mut y = vec![vec![]; 2];
        let mut s = vec![0.0f32; 2 * 2 * conv.bins()];
        let mut o = vec![0.0f32; 2 * block];
        for i in 0..(len + n - 1).div_ceil(block) {
            let xb: Vec<f32> = (0..block).map(|j| *x.get(i * block + j).unwrap_or(&0.0)).collect();
            conv.push(&xb).unwrap();
            conv.apply(&spectra, &mut s).unwrap();
            conv.inverse(&s, &mut o).unwrap();
            for c in 0..2 {
                y[c].extend_from_slice(&o[c * block..][..block]);
            }
        }
        for c in 0..2 {
            let r = direct(&x, &h[c * n..][..n]);
            let peak = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (i, v) in r.iter().enumerate() {
                assert!((y[c][i] as f64 - v).abs() < 1e-5 * peak, "channel {c} sample {i}");
            }
        }
    }

    #[test]
    fn fold_equals_the_sum_of_complex_products() {
        // 37 bins: both the SIMD body and the scalar tail of the kernel are used.
        let (d, p, f, e) = (3, 4, 37, 2);
        let (h, g) = (noise(2 * d * p * f, 4), noise(2 * e * d * f, 5));
        let z = |a: &[f32], row: usize, i: usize| C32::new(a[row * 2 * f + i], a[row * 2 * f + f + i]);
        let out = fold(&h, d, &g, e).unwrap();
        for ei in 0..e {
            for pi in 0..p {
                for fi in 0..f {
                    let want: C32 = (0..d).map(|di| z(&g, ei * d + di, fi) * z(&h, di * p + pi, fi)).sum();
                    assert!((z(&out, ei * p + pi, fi) - want).norm() < 1e-5, "{ei} {pi} {fi}");
                }
            }
        }
        assert!(fold(&h, d, &g[1..], e).is_err());
    }

    #[test]
    fn bad_shapes_are_errors_not_panics() {
        assert!(Convolver::new(64, 2, 100).is_err());
        assert!(Convolver::new(0, 2, 100).is_err());
        assert!(Convolver::new(64, 0, 128).is_err());
        let mut conv = Convolver::new(64, 2, 128).unwrap();
        assert!(conv.push(&[0.0; 63]).is_err());
        let mut out = vec![0.0f32; 130];
        assert!(conv.apply(&[0.0; 130], &mut out).is_err());
        assert!(conv.inverse(&[0.0; 129], &mut [0.0; 64]).is_err());
        assert!(partition(&[0.0; 200], 1, 64, 128, 2).is_err());
    }
}
