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
//! per band, the relative error of its absorption exponent −ln(1 − α_st) weighed as the band's
//! samples all at that error, its gradient by each branch's
//! weight exact (dα = Re(G·dY), G = −2 Σ w R̄ dR/dY); the curve's levels and phases stay
//! residuals, so the fit meets α_st by moving the normal-incidence level as little as it can (a
//! tenth of a decibel for the rising material at 125 Hz). Pruning drops a branch only while the
//! worst band stays within [`HALF_JND`] (or the full dictionary's fit's α_st error).
//! The fit is kept if its worst band is no farther than the first fit's. Before session 8 this
//! was an outer loop that refitted the targets, whose refits changed branches and jumped (the
//! rising material at 125 Hz stayed at 0.025 for 0.05); now it is 0.0500 (docs/waves-walls.md, "Walls").

use num_complex::Complex64 as C64;

use super::admittance::{admittance_from_normal, admittance_from_random, band_edges, normal_absorption_of, paris_absorption, Admittance, Branch, Discretisation, Plane};
pub use super::admittance::{grid_random_absorption_in_band, random_absorption_in_band};
pub use super::fit_targets::band_decay_times;
use super::fit_targets::{delivered, grid_normal_target, ripple_error, RandomTarget};
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
    /// The tolerance the fit held each band's in-band ripple to ([`band_ripple`]): [`HALF_JND`],
    /// or where the full dictionary's own fit cannot meet it, that fit's ripple + half of it.
    pub ripple_tolerance: f64,
}

/// The fit's acceptance, a tolerance on **absorption** (session 12; before, 0.15 dB per band and
/// 0.3 dB RMS of reflected level, which a wall of α 0.02–0.05 met with no absorption at all:
/// −10·lg(0.98) = 0.09 dB). What a wall's error does to a room is what T30 shows. By Eyring's
/// formula (C. F. Eyring, "Reverberation time in 'dead' rooms", JASA 1, 1930),
/// T = 0.161·V / (Σ Sᵢ·aᵢ + 4mV) with each surface's absorption exponent a = −ln(1 − α) (= α, Sabine's, for small α);
/// so a relative error ε in every aᵢ moves T by at most ε, whatever the room. The just noticeable
/// difference of a reverberation time is 5 % (ISO 3382-1:2009, table A.1); the fit keeps every
/// band's exponent within half of it, [`HALF_JND`] × a. In decibels of reflected energy
/// L = 10·lg(1 − α) = −4.343·a, that is a tolerance relative to the level itself: 2.5 % of L.
pub const HALF_JND: f64 = 0.025;
/// The floor under the relative tolerance: the absorption exponent at and below which the fit's
/// tolerance is the absolute [`HALF_JND`] × 0.01 (a band asking 0 or 0.001 may absorb 2.5·10⁻⁴).
/// An absolute error Δa in any material moves T by at most Δa / ā, ā the room's mean exponent
/// (air included); the least absorbing rooms measured are reverberation chambers, built to absorb
/// as little as they can, whose ā is about 0.01–0.03 (ISO 354:2003 §6.1.4 allows at most 6.5 m²
/// of absorption in 200 m³, ā ≈ 0.03 for a cube). So with ā ≥ 0.01 the floor moves T by at most
/// half a JND too, and together with the relative part by at most one JND in such a chamber.
pub const ABSORPTION_FLOOR: f64 = 0.01;

/// The tolerance on a band's absorption exponent a = −ln(1 − α) (absolute; see [`HALF_JND`]).
pub fn exponent_tolerance(alpha: f64) -> f64 {
    HALF_JND * exponent(alpha).max(ABSORPTION_FLOOR)
}

/// Eyring's absorption exponent a = −ln(1 − α) of an absorption α (α < 1).
pub fn exponent(alpha: f64) -> f64 {
    -(1.0 - alpha).ln()
}

/// The error of an absorption `alpha` against `wanted` as a fraction of the tolerance's scale:
/// |a − a_wanted| / max(a_wanted, floor) in exponents (≤ [`HALF_JND`] is within tolerance).
pub fn relative_error(alpha: f64, wanted: f64) -> f64 {
    HALF_JND * (exponent(alpha.min(1.0 - 1e-12)) - exponent(wanted)).abs() / exponent_tolerance(wanted)
}

/// Samples of the target curve per band.
pub(super) const POINTS_PER_BAND: usize = 16;
/// The reflected level is not asked below −23 dB (α_n up to 0.995).
const MIN_REFLECTED_ENERGY: f64 = 0.005;
/// The dictionary's branch bandwidths, and its spacing in octaves.
const DICTIONARY_Q: [f64; 3] = [0.7, 2.0, 5.0];
const DICTIONARY_STEP_OCTAVES: f64 = 1.0 / 3.0;
/// The weight of R's phase against the phase of the real admittance that absorbs as asked, in
/// dB of level error per radian. Absorption data say nothing of phase, but a fit free to choose
/// it can meet a level with a large reactance, a wall that is partly a pressure release and
/// moves the room's modes by tens of percent. Real walls of low absorption are nearly rigid;
/// the least reactance that meets the curve is the sensible choice.
const PHASE_DB_PER_RAD: f64 = 2.0;

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
    let (mut admittance, mut ripple_tolerance) = if rigid { (Admittance::default(), HALF_JND) } else { problem.solve() };
    if random && !rigid && !admittance.branches.is_empty() {
        // A reactive fit: fitted again with each band's α_st inside the Levenberg–Marquardt
        // residuals (see the module's doc); kept if its worst band is no farther.
        let top = paris_absorption(admittance_from_random(1.0).0);
        let wanted: Vec<f64> = absorption[..n_fit].iter().map(|&a| a.min(top)).collect();
        let mut refit = Problem::new(&centres_hz[..n_fit], &edges[..n_fit], &target, scheme, &weights);
        refit.random = Some(RandomTarget::new(&edges[..n_fit], wanted, scheme, &refit.band_samples, &refit.weights));
        let (candidate, tolerance) = refit.solve();
        let worst = |y: &Admittance| refit.random.as_ref().map_or(0.0, |r| r.worst_of(y));
        if worst(&candidate) <= worst(&admittance) {
            (admittance, ripple_tolerance) = (candidate, tolerance);
        }
    }
    let levels = problem.band_levels(&admittance);
    let fitted_normal: Vec<f64> = levels.iter().map(|l| 1.0 - 10f64.powf(l / 10.0)).collect();
    let error_db = levels.iter().zip(&problem.band_target_db).map(|(l, t)| l - t).collect();
    Ok(MaterialFit { admittance, n_bands_fitted: n_fit, target_normal: target, fitted_normal, error_db, clamped, ripple_tolerance })
}

/// Each band's error in T30 and EDT from the in-band ripple of the wall `y` against the curve
/// a fit of `target_normal` (a [`MaterialFit`]'s, the first `target_normal.len()` bands of
/// `centres_hz`) asks ([`ripple_error`], every sample weighted alike): what the fit's pruning
/// holds within [`HALF_JND`] (or its fallback), for tests and logs.
pub fn band_ripple(centres_hz: &[f64], target_normal: &[f64], scheme: Option<Discretisation>, y: &Admittance) -> Vec<f64> {
    let n = target_normal.len().min(centres_hz.len());
    let problem = Problem::new(&centres_hz[..n], &band_edges(centres_hz)[..n], &target_normal[..n], scheme, &|_| 1.0);
    let l: Vec<f64> = problem.planes.iter().map(|p| 10.0 * p.reflection(y.at(C64::new(0.0, std::f64::consts::TAU * p.f_eval))).norm_sqr().log10()).collect();
    problem.band_samples.iter().zip(&problem.band_target_db).map(|(r, &t)| ripple_error(&l[r.clone()], &problem.target_db[r.clone()], t, &problem.freqs[r.clone()], &problem.weights[r.clone()])).collect()
}

/// A column of the dictionary: the conductance (`q` = 0) or a resonant branch of unit peak
/// conductance centred at `centre_hz` with quality factor `q`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Column {
    centre_hz: f64,
    q: f64,
}

impl Column {
    pub(super) fn shape(&self, f: f64) -> C64 {
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
    /// What a level error is relative to, dB, at each sample and per band: the target level's
    /// magnitude, or the floor's ([`ABSORPTION_FLOOR`]) if that is larger. A level error over it
    /// is the relative error of the absorption exponent (see [`HALF_JND`]).
    scale_db: Vec<f64>,
    band_scale_db: Vec<f64>,
    /// The largest of `scale_db`: the phase residual's scale.
    scale_max_db: f64,
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
        let floor_scale_db = 10.0 / std::f64::consts::LN_10 * ABSORPTION_FLOOR;
        let scale_db: Vec<f64> = target_db.iter().map(|l: &f64| l.abs().max(floor_scale_db)).collect();
        let scale_max_db = scale_db.iter().fold(floor_scale_db, |a, &b| a.max(b));
        let band_scale_db = band_target_db.iter().map(|l| l.abs().max(floor_scale_db)).collect();
        Problem { freqs, planes, target_db, target_g, target_r, band_target_db, scale_db, band_scale_db, scale_max_db, band_samples, columns, random: None, weights }
    }

    /// NNLS on the admittance, then Levenberg–Marquardt on the levels with the columns it kept.
    fn solve(&self) -> (Admittance, f64) {
        // Rows: real and imaginary parts of w·(Y − g), w = |dR/dY| / |R| = 2/((1 + g)²|R|), the
        // error in R relative to |R| (in dB, over 8.69), and over the sample's scale as the
        // Levenberg–Marquardt residuals are.
        let (m, k) = (2 * self.freqs.len(), self.columns.len());
        let mut a = vec![0.0; m * k];
        let mut b = vec![0.0; m];
        for (i, (p, &g)) in self.planes.iter().zip(&self.target_g).enumerate() {
            let r = ((1.0 - g) / (1.0 + g)).abs().max(MIN_REFLECTED_ENERGY.sqrt());
            let w = 2.0 / ((1.0 + g) * (1.0 + g) * r) * self.weights[i].sqrt() / self.scale_db[i];
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
        let (ripple0, band0) = self.errors(&cols, &theta);
        // Every band's mean within half a JND of T30 ([`HALF_JND`]), and its in-band ripple
        // moving the band's T30 and EDT by less than another half JND ([`ripple_error`]; before
        // session 13, every sample within one JND RMS, which kept 2–3× the branches). Where the
        // full dictionary cannot meet that, within half a tolerance more than it. A reactive
        // random-incidence refit is held to each band's α_st instead of its normal level (which
        // it moves on purpose to meet α_st: the module's doc), and to the same ripple.
        let (ripple_tol, band_tol) = (HALF_JND.max(ripple0 + 0.5 * HALF_JND), HALF_JND.max(band0 + 0.5 * HALF_JND));
        let random_tol = self.random.as_ref().map_or(f64::INFINITY, |r| HALF_JND.max(r.worst(&cols, &theta)));
        'prune: loop {
            // Try the three weakest branches, and drop the first whose loss the rest can make up.
            let mut order: Vec<usize> = (0..kept.len()).filter(|&j| kept[j].0.q != 0.0).collect();
            order.sort_by(|&i, &j| self.strength(&kept[i]).total_cmp(&self.strength(&kept[j])));
            for &w in order.iter().take(3) {
                let mut trial = kept.clone();
                trial.remove(w);
                let (cols, start): (Vec<Column>, Vec<f64>) = trial.into_iter().unzip();
                let theta = self.refine(&cols, start);
                let (ripple, band) = self.errors(&cols, &theta);
                let random_ok = self.random.as_ref().is_none_or(|r| r.worst(&cols, &theta) <= random_tol);
                if ripple <= ripple_tol && (band <= band_tol || self.random.is_some()) && random_ok {
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
        (y, ripple_tol)
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
        for ((((p, t), rg), w), scale) in self.planes.iter().zip(&self.target_db).zip(&self.target_r).zip(&self.weights).zip(&self.scale_db) {
            let shapes: Vec<C64> = cols.iter().map(|c| c.shape(p.f_eval)).collect();
            let y: C64 = shapes.iter().zip(theta).map(|(h, t)| h * t).sum();
            let r = p.reflection(y);
            let e = r.norm_sqr();
            // The level relative to the sample's (the exponent's relative error); the phase, a
            // regulariser of the reactance, alike at every sample as in decibels against the
            // curve's strongest level (else the skirts of a steep material's strong branches
            // could not pass its weak bands and the strong bands would give up their level).
            let (sw, sp) = (w.sqrt() / scale, w.sqrt() / self.scale_max_db);
            res.push(sw * (10.0 * e.log10() - t));
            res.push(sp * PHASE_DB_PER_RAD * (r / rg).arg());
            if jacobian {
                let dr_dy = p.slope(y);
                let s = sw * 10.0 / std::f64::consts::LN_10 / e;
                jac.push(shapes.iter().map(|h| 2.0 * (r.conj() * dr_dy * h).re * s).collect());
                jac.push(shapes.iter().map(|h| sp * PHASE_DB_PER_RAD * (dr_dy * h / r).im).collect());
            }
        }
        if let Some(random) = &self.random {
            for (((a, grad), w), bw) in random.absorption(cols, theta, jacobian).into_iter().zip(&random.wanted).zip(&random.band_weights) {
                // The exponent's relative error. α_st is the data, the normal level its proxy:
                // an α_st error of a tenth of a JND (τ/4) costs as much as the band's samples all
                // a JND (2τ, the curve's RMS tolerance) off, so the level moves for α_st.
                let k = 8.0 * (POINTS_PER_BAND as f64 * bw).sqrt() / ((1.0 - w) * exponent_tolerance(*w) / HALF_JND);
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

    /// A fit's worst band error in the T30 and EDT its in-band ripple causes ([`ripple_error`]),
    /// and its worst band error in mean level, relative to the level asked (its floor's, if
    /// larger): the absorption exponent's relative error; each weighted by what the waves
    /// deliver of the band.
    fn errors(&self, cols: &[Column], theta: &[f64]) -> (f64, f64) {
        let (l, _) = self.levels(cols, theta, false);
        let w = &self.weights;
        let ripple = self
            .band_samples
            .iter()
            .zip(&self.band_target_db)
            .map(|(r, &t)| {
                let bw = w[r.clone()].iter().sum::<f64>() / r.len() as f64;
                bw * ripple_error(&l[r.clone()], &self.target_db[r.clone()], t, &self.freqs[r.clone()], &w[r.clone()])
            })
            .fold(0.0, f64::max);
        let band = self
            .band_samples
            .iter()
            .zip(&self.band_target_db)
            .zip(&self.band_scale_db)
            .map(|((r, t), s)| {
                let mean = l[r.clone()].iter().map(|x| 10f64.powf(x / 10.0)).sum::<f64>() / r.len() as f64;
                let bw = w[r.clone()].iter().sum::<f64>() / r.len() as f64;
                bw * (10.0 * mean.log10() - t).abs() / s
            })
            .fold(0.0, f64::max);
        (ripple, band)
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
