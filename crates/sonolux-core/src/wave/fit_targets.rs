//! What the wall fit ([`super::fit`]) asks of each band: how much of each frequency the waves
//! deliver (the weight of its samples), the normal-incidence level a random-incidence band asks
//! of the grid's wall, and the grid's diffuse-field absorption a reactive fit is held to. Split
//! from fit.rs (session 12) to keep each file readable in one sitting; the physics is unchanged.

use num_complex::Complex64 as C64;

use super::admittance::{admittance_from_random, band_frequencies, diffuse_absorption, incidences, Admittance, Discretisation, Incidence, Plane, RANDOM_FREQUENCIES};
use super::fit::{relative_error, Column, POINTS_PER_BAND};

/// What the waves deliver at `f` Hz, as a weight in the fit: all of it below the hybrid's
/// crossover f_max/√2 (the energy of the wave bands; the grid is made for f_max = crossover·√2,
/// docs/waves-hybrid.md), and above it the share of power the join keeps of the waves'
/// pressure, G² = H(2 − H), H = cos²(π/2 · lg(f/f_w)/lg(f_r/f_w)) from the last wave band's
/// centre f_w to the first ray band's f_r (`synthesis.band_split_weights`); nothing above f_r.
/// With no band on one side of the crossover there is nothing to weigh: 1.
pub(super) fn delivered(f: f64, centres_hz: &[f64], max_frequency_hz: f64) -> f64 {
    let crossover = max_frequency_hz / std::f64::consts::SQRT_2;
    let below = centres_hz.iter().copied().filter(|&c| c < crossover).fold(f64::NAN, f64::max);
    let above = centres_hz.iter().copied().filter(|&c| c >= crossover).fold(f64::NAN, f64::min);
    if f < crossover || below.is_nan() || above.is_nan() {
        return 1.0;
    }
    if f >= above {
        return 0.0;
    }
    let h = (0.5 * std::f64::consts::PI * (f / below).ln() / (above / below).ln()).cos().powi(2);
    h * (2.0 - h)
}

/// The normal-incidence absorption a random-incidence band asks of the grid's wall: the band mean
/// of 1 − |R|² at normal incidence on the grid of the conductance whose band-mean diffuse-field
/// absorption on the grid is `alpha` (bisection; the absorption grows with g up to the peak
/// beyond which Paris' clamp keeps it).
pub(super) fn grid_normal_target(alpha: f64, (lo, hi): (f64, f64), scheme: Discretisation) -> f64 {
    let freqs: Vec<(f64, Vec<Incidence>)> = band_frequencies(lo, hi, RANDOM_FREQUENCIES).into_iter().map(|f| incidences(f, Some(scheme))).collect();
    let absorbs = |g: f64| freqs.iter().map(|(_, dirs)| diffuse_absorption(C64::new(g, 0.0), dirs).0).sum::<f64>() / freqs.len() as f64;
    if alpha <= 0.0 {
        return 0.0;
    }
    let (mut a, mut b) = (0.0, 1.25 * admittance_from_random(alpha).0);
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if absorbs(m) < alpha {
            a = m;
        } else {
            b = m;
        }
    }
    let g = 0.5 * (a + b);
    let planes = band_frequencies(lo, hi, POINTS_PER_BAND);
    1.0 - planes.iter().map(|&f| Plane::new(f, Some(scheme)).reflection(C64::new(g, 0.0)).norm_sqr()).sum::<f64>() / planes.len() as f64
}

/// What a reactive random-incidence fit asks of each band's α_st, where it is sampled (each
/// frequency's f̃ and the diffuse field's directions on the grid), and how much of each band the
/// waves deliver (the mean of [`delivered`] over its curve samples).
pub(super) struct RandomTarget {
    pub(super) wanted: Vec<f64>,
    freqs: Vec<Vec<(f64, Vec<Incidence>)>>,
    pub(super) band_weights: Vec<f64>,
}

impl RandomTarget {
    /// `band_samples`: where each band's samples of the fit's curve are; `weights`: theirs.
    pub(super) fn new(edges: &[(f64, f64)], wanted: Vec<f64>, scheme: Option<Discretisation>, band_samples: &[std::ops::Range<usize>], weights: &[f64]) -> RandomTarget {
        let freqs = edges.iter().map(|&(lo, hi)| band_frequencies(lo, hi, RANDOM_FREQUENCIES).into_iter().map(|f| incidences(f, scheme)).collect()).collect();
        let band_weights = band_samples.iter().map(|r| weights[r.clone()].iter().sum::<f64>() / r.len() as f64).collect();
        RandomTarget { wanted, freqs, band_weights }
    }

    /// The worst band's relative error in the absorption exponent of α_st ([`relative_error`]),
    /// weighted by what the waves deliver of it.
    pub(super) fn worst_of(&self, y: &Admittance) -> f64 {
        let tau = std::f64::consts::TAU;
        self.freqs
            .iter()
            .zip(&self.wanted)
            .zip(&self.band_weights)
            .map(|((freqs, w), bw)| {
                let a = freqs.iter().map(|(fe, dirs)| diffuse_absorption(y.at(C64::new(0.0, tau * fe)), dirs).0).sum::<f64>() / freqs.len() as f64;
                bw * relative_error(a, *w)
            })
            .fold(0.0, f64::max)
    }

    /// Each band's α_st of the columns `cols` weighted `theta`, and its derivatives by each
    /// weight when asked.
    pub(super) fn absorption(&self, cols: &[Column], theta: &[f64], jacobian: bool) -> Vec<(f64, Vec<f64>)> {
        self.freqs
            .iter()
            .map(|freqs| {
                let mut mean = 0.0;
                let mut grad = vec![0.0; if jacobian { cols.len() } else { 0 }];
                for (f, dirs) in freqs {
                    let shapes: Vec<C64> = cols.iter().map(|c| c.shape(*f)).collect();
                    let y: C64 = shapes.iter().zip(theta).map(|(h, t)| h * t).sum();
                    let (a, g) = diffuse_absorption(y, dirs);
                    mean += a;
                    for (d, h) in grad.iter_mut().zip(&shapes) {
                        *d += (g * h).re;
                    }
                }
                let n = freqs.len() as f64;
                (mean / n, grad.into_iter().map(|d| d / n).collect())
            })
            .collect()
    }

    /// The worst band's relative error, weighted as [`Self::worst_of`].
    pub(super) fn worst(&self, cols: &[Column], theta: &[f64]) -> f64 {
        let bands = self.absorption(cols, theta, false);
        bands.iter().zip(&self.wanted).zip(&self.band_weights).map(|(((a, _), w), bw)| bw * relative_error(*a, *w)).fold(0.0, f64::max)
    }
}
