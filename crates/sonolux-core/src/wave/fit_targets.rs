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

/// The levels (dB under the start of the decay) between which a decay curve's regression line
/// gives T30 and EDT (ISO 3382-1:2009 §A.2.2: T30 from −5 to −35 dB, EDT from 0 to −10 dB).
const T30_RANGE_DB: (f64, f64) = (-5.0, -35.0);
const EDT_RANGE_DB: (f64, f64) = (0.0, -10.0);
/// Points of the regression, equally spaced in time between the range's levels.
const REGRESSION_POINTS: usize = 48;
/// The spectra a band's decay is weighed with, as powers k of f per unit of log frequency
/// (the fit's samples are equally spaced in log f): pink noise (0), white noise (1), and a
/// source whose radiated power rises 6 dB an octave (2: a point source of constant volume
/// velocity radiates P = ρω²Q²/(8πc), Kuttruff, "Room Acoustics", ch. 1, the point source); the
/// band's decay is taken at the worst of the three.
const SPECTRUM_TILTS: [i32; 3] = [0, 1, 2];

/// T30 and EDT of a band whose components decay with relative rates `rates` (each sample's
/// energy decay constant over the band's mean one) and are given the powers `power` (the
/// spectrum at each sample), in units of the single exponential decay's of rate 1.
///
/// The band's decay curve. A band-filtered decay is the sum of its frequencies' decays
/// (Kuttruff, "Room Acoustics", ch. 3 on the decay of a room's modes and ch. 5 on reverberation:
/// a room's decay is the sum of its modes' energies,
/// each decaying with its own damping constant; ensemble-averaged, the band's components add in
/// energy). After the source stops, a component whose energy decays as e^{−r x} (x = 2δ̄t, δ̄
/// the band's mean damping constant) holds in the steady state an energy ∝ w/r for the power w
/// it is given, so the band's decay is E(x) = Σ (wᵢ/rᵢ) e^{−rᵢx} / Σ wᵢ/rᵢ; this is also the
/// backward integral of the band's squared impulse response (M. R. Schroeder, "New method of
/// measuring reverberation time", JASA 37, 1965: the integrated impulse response is the ensemble
/// average of the noise decays), what T30 and EDT are read from. Its level is straight when all
/// rᵢ are equal and bends up otherwise: ln E = −⟨r⟩x + Var(r)x²/2 − … (the cumulants of r under
/// the weights w/r), so a ripple of variance Var(r) inside the band lengthens T30 by about
/// Var(r)·(x₅ + x₃₅)/2 ≈ 4.6·Var(r) of itself (x₅, x₃₅ = 5 and 35 dB in nepers of energy), and
/// EDT by about a quarter of that.
pub fn band_decay_times(rates: &[f64], power: &[f64]) -> (f64, f64) {
    let w: Vec<f64> = rates.iter().zip(power).map(|(r, p)| p / r.max(1e-9)).collect();
    let total: f64 = w.iter().sum();
    let level = |x: f64| 10.0 * (rates.iter().zip(&w).map(|(r, w)| w * (-r * x).exp()).sum::<f64>() / total).log10();
    // The time (in x) at which the decay reaches `db`: it falls monotonically, bisect.
    let at = |db: f64| {
        if db >= 0.0 {
            return 0.0;
        }
        let mut hi = 1.0;
        while level(hi) > db {
            hi *= 2.0;
            if hi > 1e9 {
                return f64::INFINITY;
            }
        }
        let mut lo = 0.0;
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if level(mid) > db {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    // Least squares slope of the level over the range, as 60 dB over it (dB per unit x).
    let time = |(top, bottom): (f64, f64)| {
        let (x0, x1) = (at(top), at(bottom));
        if !x1.is_finite() {
            return f64::INFINITY;
        }
        let xs: Vec<f64> = (0..REGRESSION_POINTS).map(|i| x0 + (x1 - x0) * i as f64 / (REGRESSION_POINTS - 1) as f64).collect();
        let mx = xs.iter().sum::<f64>() / xs.len() as f64;
        let ls: Vec<f64> = xs.iter().map(|&x| level(x)).collect();
        let ml = ls.iter().sum::<f64>() / ls.len() as f64;
        let slope = xs.iter().zip(&ls).map(|(x, l)| (x - mx) * (l - ml)).sum::<f64>() / xs.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
        // A single exponential of rate 1 falls 10·lg(e) dB per unit x.
        (10.0 / std::f64::consts::LN_10) / -slope
    };
    (time(T30_RANGE_DB), time(EDT_RANGE_DB))
}

/// How far the in-band ripple of a fitted wall moves its band's T30 and EDT, as a relative error
/// (the worst of T30 and EDT and of the spectra [`SPECTRUM_TILTS`]). The ripple is the fit's
/// deviation from the target curve, e(f) = a_fit(f) − a_target(f) in absorption exponents
/// (a = −ln|R|² per sample, `fitted_db`, `target_db`) over the band's (`band_target_db`), laid on
/// a band that would otherwise decay as one exponential: rates 1 + e(f) at the band's sample
/// frequencies `f`, given the power the waves deliver there (`delivered`, [`delivered`]: a hybrid's
/// band above the crossover decays partly in the rays), each decay time over that of its own
/// mean rate, so that what is measured is
/// the ripple's shape alone (the band's mean absorption is held by the band's own check). By
/// [`band_decay_times`]' expansion, T30 lengthens by about 4.6·Var(e): half a JND for an RMS
/// ripple of √(0.025/4.6) = 7.4 % of the band's exponent, a sinusoid of ±10.4 %. The rates are a
/// room's all of this wall (the worst case: other surfaces only dilute a wall's ripple, as in
/// [`super::fit::HALF_JND`]'s argument); a band asking less than the floor
/// ([`super::fit::ABSORPTION_FLOOR`]) is taken in a room whose other absorption makes up the
/// floor, as the floor's own argument. The target curve's own slope inside the band is the
/// curve's, an interpolation between band values that the data do not fix, and is left out.
pub(crate) fn ripple_error(fitted_db: &[f64], target_db: &[f64], band_target_db: f64, f: &[f64], delivered: &[f64]) -> f64 {
    let neper = std::f64::consts::LN_10 / 10.0;
    let scale = (-band_target_db * neper).max(super::fit::ABSORPTION_FLOOR);
    // Only the samples the waves deliver (a zero weight's rate may be anything).
    let kept: Vec<usize> = (0..f.len()).filter(|&i| delivered[i] > 0.0).collect();
    if kept.is_empty() {
        return 0.0;
    }
    let rates: Vec<f64> = kept.iter().map(|&i| 1.0 + (target_db[i] - fitted_db[i]) * neper / scale).collect();
    let mut worst = 0.0f64;
    for tilt in SPECTRUM_TILTS {
        let w: Vec<f64> = kept.iter().map(|&i| (f[i] / f[0]).powi(tilt) * delivered[i]).collect();
        let mean = rates.iter().zip(&w).map(|(r, w)| r * w).sum::<f64>() / w.iter().sum::<f64>();
        let (t30, edt) = band_decay_times(&rates, &w);
        worst = worst.max((t30 * mean - 1.0).abs()).max((edt * mean - 1.0).abs());
    }
    worst
}
