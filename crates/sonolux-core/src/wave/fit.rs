//! A material's absorption per band fitted to a passive wall admittance ([`super::admittance`]).
//!
//! The fit. The target is a smooth curve: 10·lg(1 − α_n) interpolated linearly in log frequency
//! between the band centres (flat beyond the outer ones), sampled 16 times per band, for the
//! bands centred below [`FIT_LIMIT_RATIO`] × the grid's maximum frequency. A smooth curve, not
//! band means, because a response of any spectrum must average to the band's value: a fit that
//! met band means with peaks and dips inside bands would reflect a band-limited pulse wrongly.
//! First, a convex step: non-negative least squares (Lawson and Hanson, "Solving Least Squares
//! Problems", 1974, ch. 23) of Y(f) against the real admittance g(f) whose absorption the curve
//! asks (weighted so that the residual is the error in R, relative to |R|), over a dictionary of
//! a conductance and resonant branches every third of an octave from two octaves below the first
//! band to above the last, each in three bandwidths (Q = 0.7, 2 and 5). Resonant branches
//! vanish at DC, so the wall is rigid to static pressure, as real walls are. NNLS leaves only
//! a few branches; then projected Levenberg–Marquardt refines their peak conductances against
//! the curve in decibels of reflected energy, free to use the phase of Y (the absorption
//! depends on |R| only). pffdtd fits one branch per octave to band values the same way in spirit
//! (Hamilton, pffdtd, `fit_to_Sabs_oct_11`, Nelder–Mead on absorption); the dictionary and the
//! smooth target are ours, for third-octave data and for flat reflection inside each band.
//!
//! The target α_n. Impedance-tube data is normal-incidence already ([`AbsorptionKind::NormalIncidence`]).
//! The coefficients of room acoustics are random-incidence ("statistical"): for those the band
//! is first given the real admittance g whose random-incidence absorption, by Paris' formula
//! α_st = 8g[1 + g/(1 + g) − 2g·ln((1 + g)/g)] (E. T. Paris, "On the coefficient of sound
//! absorption measured by the reverberation method", Phil. Mag. 5, 1928; also A. London, JASA 22,
//! 1950), equals the coefficient, and α_n = 4g/(1 + g)² is its normal-incidence absorption.
//! A locally reacting wall cannot absorb more than 0.951 at random incidence; higher values are
//! clamped there, and the fit reports it. The wall then absorbs oblique waves as a locally
//! reacting wall does, by itself: in a diffuse field it absorbs the material's coefficient.
//!
//! That holds for a conductance. A fit with resonant branches meets the normal-incidence level
//! with some reactance, and a reactive wall absorbs less at random incidence than the real g of
//! the same α_n (London, "The determination of reverberant sound absorption coefficients from
//! acoustic impedance measurements", JASA 22, 1950; Kuttruff, "Room Acoustics", eq. 2.42): up
//! to 0.03 less, before 2026-11-27. So a reactive random-incidence fit is made again with each
//! band's random-incidence absorption inside the Levenberg–Marquardt step: the fitted wall's
//! band-mean α_st = ∫₀^{π/2} (1 − |R(θ)|²) sin 2θ dθ, R = (cos θ − Y)/(cos θ + Y)
//! ([`random_absorption_in_band`]: 90 angles, 16 frequencies in the band), is one more residual
//! per band, [`RANDOM_DB_PER_ABSORPTION`] × (α_st − coefficient), its gradient by each branch's
//! weight exact (dα = Re(G·dY), G = −2 Σ w R̄ dR/dY); the curve's levels and phases stay
//! residuals, so the fit meets α_st by moving the normal-incidence level as little as it can (a
//! tenth of a decibel for the rising material at 125 Hz). Pruning drops a branch only while the
//! worst band stays within [`RANDOM_TOLERANCE`] (or the full dictionary's fit's α_st error).
//! The fit is kept if its worst band is no farther than the first fit's. Before session 8 this
//! was an outer loop that refitted the targets, whose refits changed branches and jumped (the
//! rising material at 125 Hz stayed at 0.025 for 0.05); now it is 0.0500 (docs/waves-walls.md, "Walls").

use num_complex::Complex64 as C64;

use super::admittance::{admittance_from_normal, admittance_from_random, band_edges, band_frequencies, diffuse_absorption, incidences, normal_absorption_of, paris_absorption, Admittance, Branch, Discretisation, Incidence, Plane, RANDOM_FREQUENCIES};
pub use super::admittance::{grid_random_absorption_in_band, random_absorption_in_band};
use super::lsq::{nnls, solve_dense};
use super::settings::AbsorptionKind;
use crate::error::CoreError;

/// Bands centred up to this multiple of the grid's maximum frequency are fitted (the top one's
/// upper half and a quarter band beyond reach above it: the little energy the grid carries
/// there meets walls that absorb sensibly).
pub const FIT_LIMIT_RATIO: f64 = 1.0;

/// A material's fit and how well it meets its targets, per fitted band.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialFit {
    pub admittance: Admittance,
    /// The bands fitted (the first `n` of the material's bands).
    pub n_bands_fitted: usize,
    /// Normal-incidence absorption asked for and obtained (band means of 1 − |R|², on the grid
    /// when fitted for one).
    pub target_normal: Vec<f64>,
    pub fitted_normal: Vec<f64>,
    /// 10·lg(mean |R|²) − 10·lg(1 − target) per band: the error in reflected level, dB.
    pub error_db: Vec<f64>,
    /// Whether a random-incidence coefficient was above what a locally reacting wall absorbs.
    pub clamped: bool,
}

/// A reactive random-incidence fit's α_st is asked within this of every band's coefficient
/// (absolute); pruning keeps it there (or where the full dictionary's fit left it).
pub const RANDOM_TOLERANCE: f64 = 0.003;
/// The weight of a band's α_st residual, dB per unit of absorption: an α_st error of
/// [`RANDOM_TOLERANCE`] costs as much as the band's [`POINTS_PER_BAND`] samples of the curve
/// each [`PRUNE_BAND_DB`] off (√16 · 0.15 / 0.003 = 200).
const RANDOM_DB_PER_ABSORPTION: f64 = 200.0;

/// Samples of the target curve per band.
const POINTS_PER_BAND: usize = 16;
/// The reflected level is not asked below −23 dB (α_n up to 0.995).
const MIN_REFLECTED_ENERGY: f64 = 0.005;
/// The dictionary's branch bandwidths, and its spacing in octaves.
const DICTIONARY_Q: [f64; 3] = [0.7, 2.0, 5.0];
const DICTIONARY_STEP_OCTAVES: f64 = 1.0 / 3.0;
/// Branches are dropped while the fit stays within this of the curve (RMS over its samples)
/// and of every band's target, dB (or within 0.1 and 0.05 dB of the full dictionary's errors,
/// if those are larger).
const PRUNE_RMS_DB: f64 = 0.3;
/// The weight of R's phase against the phase of the real admittance that absorbs as asked, in
/// dB of level error per radian. Absorption data say nothing of phase, but a fit free to choose
/// it can meet a level with a large reactance, a wall that is partly a pressure release and
/// moves the room's modes by tens of percent. Real walls of low absorption are nearly rigid;
/// the least reactance that meets the curve is the sensible choice.
const PHASE_DB_PER_RAD: f64 = 2.0;
const PRUNE_BAND_DB: f64 = 0.15;

/// Fits one material: `absorption` per band at `centres_hz`, of the given kind, for a grid whose
/// maximum frequency is `max_frequency_hz`.
pub fn fit_material(
    centres_hz: &[f64],
    absorption: &[f64],
    kind: AbsorptionKind,
    max_frequency_hz: f64,
    scheme: Option<Discretisation>,
) -> Result<MaterialFit, CoreError> {
    if centres_hz.is_empty() || centres_hz.len() != absorption.len() {
        return Err(CoreError::invalid("absorption", format!("{} values for {} bands", absorption.len(), centres_hz.len())));
    }
    let mut clamped = false;
    let normal_of = |a: f64, clamped: &mut bool| match kind {
        AbsorptionKind::NormalIncidence => a,
        AbsorptionKind::RandomIncidence => {
            let (g, c) = admittance_from_random(a);
            *clamped |= c;
            normal_absorption_of(g)
        }
    };
    let n_fit = super::settings::bands_fitted(centres_hz, max_frequency_hz).max(1);
    let edges = band_edges(centres_hz);
    let random = kind == AbsorptionKind::RandomIncidence;
    let target: Vec<f64> = match scheme {
        // On a grid a random-incidence band is given the conductance whose diffuse-field
        // absorption *on the grid* is the coefficient, and asks that conductance's normal level
        // on the grid (the module's doc, "What the waves deliver").
        Some(d) if random => absorption[..n_fit]
            .iter()
            .zip(&edges[..n_fit])
            .map(|(&a, &e)| {
                let (g, c) = admittance_from_random(a);
                clamped |= c;
                grid_normal_target(paris_absorption(g), e, d)
            })
            .collect(),
        _ => absorption[..n_fit].iter().map(|&a| normal_of(a, &mut clamped)).collect(),
    };
    let weights = |f: f64| if random && scheme.is_some() { delivered(f, centres_hz, max_frequency_hz) } else { 1.0 };
    let problem = Problem::new(&centres_hz[..n_fit], &edges[..n_fit], &target, scheme, &weights);
    let rigid = target.iter().all(|&a| a <= 0.0);
    let mut admittance = if rigid { Admittance::default() } else { problem.solve() };
    if random && !rigid && !admittance.branches.is_empty() {
        // A reactive fit: fitted again with each band's α_st inside the Levenberg–Marquardt
        // residuals (see the module's doc); kept if its worst band is no farther.
        let top = paris_absorption(admittance_from_random(1.0).0);
        let wanted: Vec<f64> = absorption[..n_fit].iter().map(|&a| a.min(top)).collect();
        let mut refit = Problem::new(&centres_hz[..n_fit], &edges[..n_fit], &target, scheme, &weights);
        refit.random = Some(RandomTarget::new(&edges[..n_fit], wanted, scheme, &refit));
        let candidate = refit.solve();
        let worst = |y: &Admittance| refit.random.as_ref().map_or(0.0, |r| r.worst_of(y));
        if worst(&candidate) <= worst(&admittance) {
            admittance = candidate;
        }
    }
    let levels = problem.band_levels(&admittance);
    let fitted_normal: Vec<f64> = levels.iter().map(|l| 1.0 - 10f64.powf(l / 10.0)).collect();
    let error_db = levels.iter().zip(&problem.band_target_db).map(|(l, t)| l - t).collect();
    Ok(MaterialFit { admittance, n_bands_fitted: n_fit, target_normal: target, fitted_normal, error_db, clamped })
}

/// What the waves deliver at `f` Hz, as a weight in the fit: all of it below the hybrid's
/// crossover f_max/√2 (the energy of the wave bands; the grid is made for f_max = crossover·√2,
/// docs/waves-hybrid.md), and above it the share of power the join keeps of the waves'
/// pressure, G² = H(2 − H), H = cos²(π/2 · lg(f/f_w)/lg(f_r/f_w)) from the last wave band's
/// centre f_w to the first ray band's f_r (`synthesis.band_split_weights`); nothing above f_r.
/// With no band on one side of the crossover there is nothing to weigh: 1.
fn delivered(f: f64, centres_hz: &[f64], max_frequency_hz: f64) -> f64 {
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
fn grid_normal_target(alpha: f64, (lo, hi): (f64, f64), scheme: Discretisation) -> f64 {
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
struct RandomTarget {
    wanted: Vec<f64>,
    freqs: Vec<Vec<(f64, Vec<Incidence>)>>,
    band_weights: Vec<f64>,
}

impl RandomTarget {
    fn new(edges: &[(f64, f64)], wanted: Vec<f64>, scheme: Option<Discretisation>, problem: &Problem) -> RandomTarget {
        let freqs = edges.iter().map(|&(lo, hi)| band_frequencies(lo, hi, RANDOM_FREQUENCIES).into_iter().map(|f| incidences(f, scheme)).collect()).collect();
        let band_weights = problem.band_samples.iter().map(|r| problem.weights[r.clone()].iter().sum::<f64>() / r.len() as f64).collect();
        RandomTarget { wanted, freqs, band_weights }
    }

    /// The worst band's |α_st − asked| of an admittance, weighted by what the waves deliver of it.
    fn worst_of(&self, y: &Admittance) -> f64 {
        let tau = std::f64::consts::TAU;
        self.freqs
            .iter()
            .zip(&self.wanted)
            .zip(&self.band_weights)
            .map(|((freqs, w), bw)| {
                let a = freqs.iter().map(|(fe, dirs)| diffuse_absorption(y.at(C64::new(0.0, tau * fe)), dirs).0).sum::<f64>() / freqs.len() as f64;
                bw * (a - w).abs()
            })
            .fold(0.0, f64::max)
    }

    /// Each band's α_st of the columns `cols` weighted `theta`, and its derivatives by each
    /// weight when asked.
    fn absorption(&self, cols: &[Column], theta: &[f64], jacobian: bool) -> Vec<(f64, Vec<f64>)> {
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

    /// The worst band's |α_st − asked|, weighted as [`Self::worst_of`].
    fn worst(&self, cols: &[Column], theta: &[f64]) -> f64 {
        let bands = self.absorption(cols, theta, false);
        bands.iter().zip(&self.wanted).zip(&self.band_weights).map(|(((a, _), w), bw)| bw * (a - w).abs()).fold(0.0, f64::max)
    }
}

/// A column of the dictionary: the conductance (`q` = 0) or a resonant branch of unit peak
/// conductance centred at `centre_hz` with quality factor `q`.
#[derive(Clone, Copy, Debug)]
struct Column {
    centre_hz: f64,
    q: f64,
}

impl Column {
    fn shape(&self, f: f64) -> C64 {
        if self.q == 0.0 {
            C64::new(1.0, 0.0)
        } else {
            1.0 / C64::new(1.0, self.q * (f / self.centre_hz - self.centre_hz / f))
        }
    }

    /// The branch of peak conductance `y`: Z = D s + E + F/s with E = 1/y, bandwidth ω₀/Q.
    fn branch(&self, y: f64) -> Branch {
        let w0 = std::f64::consts::TAU * self.centre_hz;
        let bandwidth = w0 / self.q;
        Branch { mass_s: 1.0 / (y * bandwidth), resistance: 1.0 / y, stiffness_per_s: w0 * w0 / (y * bandwidth) }
    }
}

/// One material's fit: the sampled target curve and the dictionary.
struct Problem {
    freqs: Vec<f64>,
    planes: Vec<Plane>,
    /// The target level at each sample frequency (dB), the real admittance that has it, and
    /// that admittance's reflection.
    target_db: Vec<f64>,
    target_g: Vec<f64>,
    target_r: Vec<C64>,
    /// The band level targets, dB, and where each band's samples are.
    band_target_db: Vec<f64>,
    band_samples: Vec<std::ops::Range<usize>>,
    columns: Vec<Column>,
    /// A reactive random-incidence fit's α_st per band, one more residual each.
    random: Option<RandomTarget>,
    /// Each sample's weight in the fit: what the waves deliver there ([`delivered`]; 1 for
    /// normal-incidence data and continuous fits).
    weights: Vec<f64>,
}

impl Problem {
    fn new(centres: &[f64], edges: &[(f64, f64)], target: &[f64], scheme: Option<Discretisation>, weight: &dyn Fn(f64) -> f64) -> Problem {
        let n = centres.len();
        let band_target_db: Vec<f64> = target.iter().map(|&a| 10.0 * (1.0 - a).max(MIN_REFLECTED_ENERGY).log10()).collect();
        let curve = |knots: &[f64], f: f64| {
            let b = centres.partition_point(|&c| c <= f);
            if b == 0 {
                knots[0]
            } else if b == n {
                knots[n - 1]
            } else {
                let x = (f / centres[b - 1]).ln() / (centres[b] / centres[b - 1]).ln();
                knots[b - 1] + x * (knots[b] - knots[b - 1])
            }
        };
        let mut freqs = Vec::new();
        let mut band_samples = Vec::new();
        // An octave below the lowest band (the walls meet the room's lowest modes there) and a
        // quarter band above the highest (where band filters' skirts reach), held flat.
        let (lo, hi) = (edges[0].0, edges[n - 1].1);
        let above = (hi / edges[n - 1].0).powf(0.25);
        for i in 0..POINTS_PER_BAND / 2 {
            freqs.push(lo / 2f64.powf(1.0 - (i as f64 + 0.5) / (POINTS_PER_BAND / 2) as f64));
        }
        for &(lo, hi) in edges {
            let first = freqs.len();
            for i in 0..POINTS_PER_BAND {
                freqs.push(lo * (hi / lo).powf((i as f64 + 0.5) / POINTS_PER_BAND as f64));
            }
            band_samples.push(first..freqs.len());
        }
        for i in 0..POINTS_PER_BAND / 4 {
            freqs.push(hi * above.powf((i as f64 + 0.5) / (POINTS_PER_BAND / 4) as f64));
        }
        // The curve's knots at the band centres, moved until each band's mean reflected energy
        // is the band's target (a band mean leans half on its own knot: Jacobi converges).
        let mut knots = band_target_db.clone();
        let floor_db = 10.0 * MIN_REFLECTED_ENERGY.log10();
        for _ in 0..100 {
            for b in 0..n {
                let r = band_samples[b].clone();
                let mean = freqs[r.clone()].iter().map(|&f| 10f64.powf(curve(&knots, f) / 10.0)).sum::<f64>() / r.len() as f64;
                knots[b] = (knots[b] + band_target_db[b] - 10.0 * mean.log10()).clamp(floor_db, 0.0);
            }
        }
        let target_db: Vec<f64> = freqs.iter().map(|&f| curve(&knots, f)).collect();
        let target_g: Vec<f64> = target_db.iter().map(|&l| admittance_from_normal(1.0 - 10f64.powf(l / 10.0))).collect();
        let mut columns = vec![Column { centre_hz: 0.0, q: 0.0 }];
        let (first, last) = (0.25 * lo, 1.5 * freqs[freqs.len() - 1]);
        let steps = ((last / first).log2() / DICTIONARY_STEP_OCTAVES).ceil() as usize;
        for k in 0..=steps {
            for q in DICTIONARY_Q {
                columns.push(Column { centre_hz: first * 2f64.powf(k as f64 * DICTIONARY_STEP_OCTAVES), q });
            }
        }
        let planes: Vec<Plane> = freqs.iter().map(|&f| Plane::new(f, scheme)).collect();
        let target_r = planes.iter().zip(&target_g).map(|(p, &g)| p.reflection(C64::new(g, 0.0))).collect();
        let weights = freqs.iter().map(|&f| weight(f)).collect();
        Problem { freqs, planes, target_db, target_g, target_r, band_target_db, band_samples, columns, random: None, weights }
    }

    /// NNLS on the admittance, then Levenberg–Marquardt on the levels with the columns it kept.
    fn solve(&self) -> Admittance {
        // Rows: real and imaginary parts of w·(Y − g), w = |dR/dY| / |R| = 2/((1 + g)²|R|).
        let (m, k) = (2 * self.freqs.len(), self.columns.len());
        let mut a = vec![0.0; m * k];
        let mut b = vec![0.0; m];
        for (i, (p, &g)) in self.planes.iter().zip(&self.target_g).enumerate() {
            let r = ((1.0 - g) / (1.0 + g)).abs().max(MIN_REFLECTED_ENERGY.sqrt());
            let w = 2.0 / ((1.0 + g) * (1.0 + g) * r) * self.weights[i].sqrt();
            for (j, c) in self.columns.iter().enumerate() {
                let h = c.shape(p.f_eval) * w;
                a[2 * i * k + j] = h.re;
                a[(2 * i + 1) * k + j] = h.im;
            }
            b[2 * i] = w * g;
        }
        let theta = nnls(&a, &b, m, k);
        // Refine on the whole dictionary (branches NNLS left at zero may enter), then drop the
        // weakest branch while the fit stays within tolerance: every branch costs state and
        // arithmetic at every boundary node and step.
        let theta = self.refine(&self.columns, theta);
        let mut kept: Vec<(Column, f64)> = self.columns.iter().cloned().zip(theta).filter(|(_, t)| *t > 0.0).collect();
        let (cols, theta): (Vec<Column>, Vec<f64>) = kept.iter().cloned().unzip();
        let (rms0, band0) = self.errors(&cols, &theta);
        let (rms_tol, band_tol) = (PRUNE_RMS_DB.max(rms0 + 0.1), PRUNE_BAND_DB.max(band0 + 0.05));
        let random_tol = self.random.as_ref().map_or(f64::INFINITY, |r| RANDOM_TOLERANCE.max(r.worst(&cols, &theta)));
        'prune: loop {
            // Try the three weakest branches, and drop the first whose loss the rest can make up.
            let mut order: Vec<usize> = (0..kept.len()).filter(|&j| kept[j].0.q != 0.0).collect();
            order.sort_by(|&i, &j| self.strength(&kept[i]).total_cmp(&self.strength(&kept[j])));
            for &w in order.iter().take(3) {
                let mut trial = kept.clone();
                trial.remove(w);
                let (cols, start): (Vec<Column>, Vec<f64>) = trial.into_iter().unzip();
                let theta = self.refine(&cols, start);
                let (rms, band) = self.errors(&cols, &theta);
                let random_ok = self.random.as_ref().is_none_or(|r| r.worst(&cols, &theta) <= random_tol);
                if rms <= rms_tol && band <= band_tol && random_ok {
                    kept = cols.into_iter().zip(theta).filter(|(_, t)| *t > 0.0).collect();
                    continue 'prune;
                }
            }
            break;
        }
        let (kept, refined): (Vec<Column>, Vec<f64>) = kept.into_iter().unzip();
        let mut y = Admittance::default();
        for (c, &t) in kept.iter().zip(&refined) {
            if c.q == 0.0 {
                y.conductance += t;
            } else if t > 1e-9 {
                y.branches.push(c.branch(t));
            }
        }
        y
    }

    /// Reflected level (dB) at each sample frequency of the columns `cols` weighted `theta`, and
    /// when asked its derivatives by each weight.
    fn levels(&self, cols: &[Column], theta: &[f64], jacobian: bool) -> (Vec<f64>, Vec<Vec<f64>>) {
        let mut levels = Vec::with_capacity(self.freqs.len());
        let mut jac = Vec::new();
        for p in &self.planes {
            let shapes: Vec<C64> = cols.iter().map(|c| c.shape(p.f_eval)).collect();
            let y: C64 = shapes.iter().zip(theta).map(|(h, t)| h * t).sum();
            let r = p.reflection(y);
            let e = r.norm_sqr();
            levels.push(10.0 * e.log10());
            if jacobian {
                let dr_dy = p.slope(y);
                let s = 10.0 / std::f64::consts::LN_10 / e;
                jac.push(shapes.iter().map(|h| 2.0 * (r.conj() * dr_dy * h).re * s).collect());
            }
        }
        (levels, jac)
    }

    /// The residuals of a fit, two per sample frequency: the reflected level's error (dB), and
    /// [`PHASE_DB_PER_RAD`] × the phase of R against that of the real admittance with the target
    /// level; with their derivatives by each weight when asked.
    fn residuals(&self, cols: &[Column], theta: &[f64], jacobian: bool) -> (Vec<f64>, Vec<Vec<f64>>) {
        let mut res = Vec::with_capacity(2 * self.freqs.len());
        let mut jac = Vec::new();
        for (((p, t), rg), w) in self.planes.iter().zip(&self.target_db).zip(&self.target_r).zip(&self.weights) {
            let shapes: Vec<C64> = cols.iter().map(|c| c.shape(p.f_eval)).collect();
            let y: C64 = shapes.iter().zip(theta).map(|(h, t)| h * t).sum();
            let r = p.reflection(y);
            let e = r.norm_sqr();
            let sw = w.sqrt();
            res.push(sw * (10.0 * e.log10() - t));
            res.push(sw * PHASE_DB_PER_RAD * (r / rg).arg());
            if jacobian {
                let dr_dy = p.slope(y);
                let s = sw * 10.0 / std::f64::consts::LN_10 / e;
                jac.push(shapes.iter().map(|h| 2.0 * (r.conj() * dr_dy * h).re * s).collect());
                jac.push(shapes.iter().map(|h| sw * PHASE_DB_PER_RAD * (dr_dy * h / r).im).collect());
            }
        }
        if let Some(random) = &self.random {
            for (((a, grad), w), bw) in random.absorption(cols, theta, jacobian).into_iter().zip(&random.wanted).zip(&random.band_weights) {
                let k = RANDOM_DB_PER_ABSORPTION * bw.sqrt();
                res.push(k * (a - w));
                if jacobian {
                    jac.push(grad.iter().map(|d| k * d).collect());
                }
            }
        }
        (res, jac)
    }

    /// The band means of |R|² of an admittance, as levels (dB).
    fn band_levels(&self, y: &Admittance) -> Vec<f64> {
        let e: Vec<f64> =
            self.planes.iter().map(|p| p.reflection(y.at(C64::new(0.0, std::f64::consts::TAU * p.f_eval))).norm_sqr()).collect();
        self.band_samples.iter().map(|r| 10.0 * (e[r.clone()].iter().sum::<f64>() / r.len() as f64).log10()).collect()
    }

    /// How much a weighted column adds to Y: its RMS magnitude over the sample frequencies.
    fn strength(&self, column: &(Column, f64)) -> f64 {
        column.1 * (self.planes.iter().map(|p| column.0.shape(p.f_eval).norm_sqr()).sum::<f64>() / self.planes.len() as f64).sqrt()
    }

    /// A fit's RMS level error over the curve's samples and its worst band error, dB.
    fn errors(&self, cols: &[Column], theta: &[f64]) -> (f64, f64) {
        let (l, _) = self.levels(cols, theta, false);
        let w = &self.weights;
        let rms = (l.iter().zip(&self.target_db).zip(w).map(|((a, b), w)| w * (a - b) * (a - b)).sum::<f64>() / w.iter().sum::<f64>()).sqrt();
        let band = self
            .band_samples
            .iter()
            .zip(&self.band_target_db)
            .map(|(r, t)| {
                let mean = l[r.clone()].iter().map(|x| 10f64.powf(x / 10.0)).sum::<f64>() / r.len() as f64;
                let bw = w[r.clone()].iter().sum::<f64>() / r.len() as f64;
                bw * (10.0 * mean.log10() - t).abs()
            })
            .fold(0.0, f64::max);
        (rms, band)
    }

    fn cost(&self, cols: &[Column], theta: &[f64]) -> f64 {
        self.residuals(cols, theta, false).0.iter().map(|r| r * r).sum()
    }

    /// Projected Levenberg–Marquardt on the residuals, weights kept ≥ 0.
    fn refine(&self, cols: &[Column], mut theta: Vec<f64>) -> Vec<f64> {
        let k = theta.len();
        let mut cost = self.cost(cols, &theta);
        let mut mu = 1e-3;
        for _ in 0..200 {
            if cost < 1e-14 || k == 0 {
                break;
            }
            let (r, j) = self.residuals(cols, &theta, true);
            let mut jtj = vec![0.0; k * k];
            let mut jtr = vec![0.0; k];
            for (row, ri) in j.iter().zip(&r) {
                for a in 0..k {
                    jtr[a] += row[a] * ri;
                    for b in 0..k {
                        jtj[a * k + b] += row[a] * row[b];
                    }
                }
            }
            let mut improved = false;
            while mu < 1e12 {
                let mut m = jtj.clone();
                for a in 0..k {
                    m[a * k + a] += mu * jtj[a * k + a] + 1e-12;
                }
                let mut step: Vec<f64> = jtr.iter().map(|x| -x).collect();
                if !solve_dense(&mut m, &mut step, k) {
                    mu *= 10.0;
                    continue;
                }
                let trial: Vec<f64> = theta.iter().zip(&step).map(|(t, s)| (t + s).max(0.0)).collect();
                let c = self.cost(cols, &trial);
                if c < cost {
                    improved = cost - c > 1e-10 * cost;
                    theta = trial;
                    cost = c;
                    mu = (mu / 3.0).max(1e-12);
                    break;
                }
                mu *= 4.0;
            }
            if !improved {
                break;
            }
        }
        theta
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_target_is_a_conductance() {
        let centres = [125.0, 250.0, 500.0, 1000.0];
        let fit = fit_material(&centres, &[0.4; 4], AbsorptionKind::NormalIncidence, 1000.0, None).unwrap();
        assert!(fit.error_db.iter().all(|e| e.abs() < 0.01), "{:?}", fit.error_db);
        assert!((fit.admittance.normal_absorption(333.0) - 0.4).abs() < 0.01);
    }

    #[test]
    fn a_rigid_material_fits_to_a_rigid_wall() {
        let fit = fit_material(&[125.0, 250.0], &[0.0, 0.0], AbsorptionKind::RandomIncidence, 500.0, None).unwrap();
        assert!(fit.admittance.is_rigid(), "{:?}", fit.admittance);
    }
}
