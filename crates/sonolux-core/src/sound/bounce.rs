//! A reflection's choice between diffuse and specular, one choice for all the ray's bands.
//!
//! When every band scatters alike the bounce is diffuse with probability s, an analogue
//! choice: no band is re-weighted.
//!
//! When the bands scatter unlike (s per band, or level of detail's s' per bounce), the choice is
//! **hero-band sampling**: one-sample multiple importance sampling over the bands with the
//! balance heuristic (Veach and Guibas, "Optimally combining sampling techniques for Monte
//! Carlo rendering", SIGGRAPH 1995, eq. 16; Veach's thesis, 1997, §9.2.4), as Wilkie, Nawaz,
//! Droske, Weidlich and Hanika ("Hero wavelength spectral sampling", EGSR 2014, §3) do over
//! wavelengths.
//! - Each ray draws a hero band h, uniform over the NB bands, once ([`hero_band`]).
//! - At every bounce it chooses diffuse with the hero's probability s_h at that bounce.
//! - A path of bounce choices then has probability P_j = Π c_j (c_j = s_j diffuse, 1 − s_j
//!   specular) under band j's own sampling, and probability (1/NB) Σ_j P_j overall (the hero
//!   uniform). Band b's physical share of the path is P_b, so its weight is
//!   w_b = P_b / ((1/NB) Σ_j P_j): unbiased, and at most NB whatever the path's length.
//! - The choice this replaces (diffuse with the mean scattering p, each band re-weighted by
//!   s_b / p or (1 − s_b) / (1 − p)) was unbiased too, but a band's second moment grew by
//!   (1 − s_b)² / (1 − p) > 1 a specular bounce, without bound along long specular chains; in a
//!   room with s rising from 0.05 to 0.8 across bands the 125 Hz T30 came out 0.4 s instead of
//!   1.3 s at practical ray counts (tests/hero.rs).
//!
//! The ray keeps Q_j = P_j / mean_k P_k (mean 1, so nothing underflows on long paths); at a
//! bounce Q_j ← Q_j c_j / m and e_b ← e_b c_b / m, m = mean_k Q_k c_k (the mean's old value is
//! 1). The change of e_b is tallied as re-weighted, so the energy budget closes as before.

use super::Scene;
use crate::rng::{keyed_uniform_of_ray, Stream};

/// Whether the bounce's choice is hero-band sampled: some material scatters its bands unlike,
/// or level of detail makes each bounce's scattering its own.
#[inline(always)]
pub(super) fn hero_sampled(scene: &Scene) -> bool {
    !scene.uniform_scattering || scene.lod.is_some()
}

/// The `receiver` slot of the hero band's keyed draw: no receiver has it (a deposit's is
/// first_receiver + its index), so the draw is not one of any deposit's rounding.
const HERO_SLOT: u64 = u64::MAX;

/// The hero band of the ray whose [`crate::rng::ray_key`] is `ray_key`: uniform over `nb`
/// bands, keyed by the ray alone (the same whatever thread or ray range traces it, and its
/// stream's draws are left as they were).
#[inline]
pub(super) fn hero_band(ray_key: u64, nb: usize) -> usize {
    let u = keyed_uniform_of_ray(ray_key, HERO_SLOT, 0);
    ((u * nb as f64) as usize).min(nb - 1)
}

/// Bands alike: whether the bounce is diffuse, drawn with probability `p` (the material's
/// scattering) from the ray's stream; no draw when p is 0 or 1.
#[inline(always)]
pub(super) fn alike(rng: &mut Stream, p: f64) -> bool {
    p >= 1.0 || (p > 0.0 && rng.uniform() < p)
}

/// Bands unlike: whether the bounce is diffuse, drawn with the `hero` band's scattering of
/// `scat` (this bounce's, per band) from the ray's stream; `q` (the ray's Q_j, module doc) and
/// the energies `e` updated, the change of each band's energy tallied into `reweighted`.
#[inline(always)]
pub(super) fn hero(rng: &mut Stream, hero: usize, scat: &[f64], q: &mut [f64], e: &mut [f64], reweighted: &mut [f64]) -> bool {
    let diffuse = alike(rng, scat[hero]);
    let nb = e.len();
    let share = |s: f64| if diffuse { s } else { 1.0 - s };
    let mut sum = 0.0;
    for j in 0..nb {
        q[j] *= share(scat[j]);
        sum += q[j];
    }
    // The hero's own c_h is never 0 (the bounce was drawn with it), so sum > 0 unless its Q_h
    // underflowed against the other bands': the path then carries nothing.
    let inv_mean = if sum > 0.0 { nb as f64 / sum } else { 0.0 };
    for b in 0..nb {
        q[b] *= inv_mean;
        let before = e[b];
        e[b] *= share(scat[b]) * inv_mean;
        reweighted[b] += e[b] - before;
    }
    diffuse
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The weight is bounded by NB and the estimate of each band's share of a path is
    /// unbiased: over every bounce sequence of length 3, Σ probability × weight = P_b.
    #[test]
    fn weights_are_bounded_and_unbiased() {
        let scat = [0.05, 0.2, 0.5, 0.8];
        let nb = scat.len();
        let share = |s: f64, d: bool| if d { s } else { 1.0 - s };
        for seq in 0..8u32 {
            let d: Vec<bool> = (0..3).map(|k| seq >> k & 1 == 1).collect();
            let p: Vec<f64> = scat.iter().map(|&s| d.iter().map(|&x| share(s, x)).product()).collect();
            let mean = p.iter().sum::<f64>() / nb as f64;
            // The incremental update gives w_b = P_b / mean exactly (to rounding), whatever the hero.
            let (mut q, mut e, mut rw) = (vec![1.0; nb], vec![1.0; nb], vec![0.0; nb]);
            for &x in &d {
                let mut sum = 0.0;
                for j in 0..nb {
                    q[j] *= share(scat[j], x);
                    sum += q[j];
                }
                for b in 0..nb {
                    q[b] *= nb as f64 / sum;
                    e[b] *= share(scat[b], x) * nb as f64 / sum;
                }
            }
            for b in 0..nb {
                assert!((e[b] - p[b] / mean).abs() < 1e-12, "{d:?} band {b}");
                assert!(e[b] <= nb as f64 + 1e-12);
                rw[b] = e[b];
            }
            // Probability of this sequence: (1/NB) Σ_h P_h = mean; mean × w_b = P_b.
            for b in 0..nb {
                assert!((mean * rw[b] - p[b]).abs() < 1e-12);
            }
        }
    }

    /// `hero` itself: over many draws with the hero uniform, each band's mean energy after
    /// three bounces is its unweighted share, 1 (a bounce keeps the energy), within 5 standard
    /// errors; and no weight exceeds NB.
    #[test]
    fn hero_keeps_each_band_in_expectation() {
        let scat = [0.05, 0.2, 0.5, 0.8];
        let nb = scat.len();
        let n = 200_000;
        let (mut sum, mut sq) = (vec![0.0; nb], vec![0.0; nb]);
        for i in 0..n {
            let mut rng = Stream::new(7, 0, i);
            let h = hero_band(crate::rng::ray_key(7, 0, i), nb);
            let (mut q, mut e, mut rw) = (vec![1.0; nb], vec![1.0; nb], vec![0.0; nb]);
            for _ in 0..3 {
                hero(&mut rng, h, &scat, &mut q, &mut e, &mut rw);
            }
            for b in 0..nb {
                assert!(e[b] <= nb as f64 + 1e-12);
                assert!((e[b] - 1.0 - rw[b]).abs() < 1e-12);
                sum[b] += e[b];
                sq[b] += e[b] * e[b];
            }
        }
        for b in 0..nb {
            let mean = sum[b] / n as f64;
            let se = ((sq[b] / n as f64 - mean * mean) / n as f64).sqrt();
            assert!((mean - 1.0).abs() < 5.0 * se, "band {b}: {mean} ± {se}");
        }
    }
}
