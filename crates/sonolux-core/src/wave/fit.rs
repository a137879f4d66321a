//! Wall admittances fitted to a material's absorption per band.
//!
//! A wall is locally reacting: its normal velocity is v = Y(s) p / (ρc), with Y the specific
//! (ρc-normalised) admittance. Y is a conductance plus a sum of series mass–spring–damper
//! branches, each of impedance D·s + E + F/s with D, E, F ≥ 0. Every such branch, and so the sum,
//! is a positive-real function: the wall is passive, which is what keeps the scheme stable
//! (Bilbao, Hamilton, Botts and Savioja, "Finite volume time domain room acoustics simulation
//! under general impedance boundary conditions", IEEE/ACM TASLP 24(1), 2016).
//!
//! The fit. One branch is centred on each band below [`FIT_LIMIT_RATIO`] × the grid's maximum
//! frequency, with the band's own bandwidth (Q = 1/(r^½ − r^−½), r the ratio of neighbouring
//! band centres: Q = √2 for octaves, 4.3 for thirds), as pffdtd centres one branch per octave
//! (Hamilton, pffdtd, `fit_to_Sabs_oct_11`). The branch peak conductances and the constant
//! conductance are then fitted, non-negative, by projected Levenberg–Marquardt to the band
//! targets, in decibels of reflected energy: for each band, 10·lg of the mean of |R(f)|² over
//! the band (R = (1 − Y)/(1 + Y), normal incidence) against 10·lg(1 − α_n). That is what a
//! plane wave reflected off the wall returns per band, which is what the tests measure.
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

use num_complex::Complex64 as C64;

use super::settings::AbsorptionKind;
use crate::error::CoreError;

/// Bands centred up to this multiple of the grid's maximum frequency get a branch: the grid
/// carries some energy above its maximum frequency, and it should meet walls that absorb sensibly.
pub const FIT_LIMIT_RATIO: f64 = 2.0;

/// A series mass–spring–damper branch of specific impedance `mass_s`·s + `resistance` + `stiffness_per_s`/s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Branch {
    pub mass_s: f64,
    pub resistance: f64,
    pub stiffness_per_s: f64,
}

/// A wall's specific admittance: `conductance` + Σ 1 / branch impedance.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Admittance {
    pub conductance: f64,
    pub branches: Vec<Branch>,
}

impl Admittance {
    /// Y(s) at any complex s (s = jω on the frequency axis).
    pub fn at(&self, s: C64) -> C64 {
        let mut y = C64::new(self.conductance, 0.0);
        for b in &self.branches {
            y += 1.0 / (b.mass_s * s + b.resistance + b.stiffness_per_s / s);
        }
        y
    }

    /// Plane-wave reflection coefficient at normal incidence.
    pub fn reflection(&self, frequency_hz: f64) -> C64 {
        let y = self.at(C64::new(0.0, std::f64::consts::TAU * frequency_hz));
        (1.0 - y) / (1.0 + y)
    }

    pub fn normal_absorption(&self, frequency_hz: f64) -> f64 {
        1.0 - self.reflection(frequency_hz).norm_sqr()
    }

    pub fn is_rigid(&self) -> bool {
        self.conductance == 0.0 && self.branches.is_empty()
    }
}

/// A material's fit and how well it meets its targets, per fitted band.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialFit {
    pub admittance: Admittance,
    /// The bands fitted (the first `n` of the material's bands).
    pub n_bands_fitted: usize,
    /// Normal-incidence absorption asked for and obtained (band means of 1 − |R|²).
    pub target_normal: Vec<f64>,
    pub fitted_normal: Vec<f64>,
    /// 10·lg(mean |R|²) − 10·lg(1 − target) per band: the error in reflected level, dB.
    pub error_db: Vec<f64>,
    /// Whether a random-incidence coefficient was above what a locally reacting wall absorbs.
    pub clamped: bool,
}

/// Random-incidence absorption of a wall of real specific admittance g (Paris 1928).
pub fn paris_absorption(g: f64) -> f64 {
    if g <= 0.0 {
        return 0.0;
    }
    8.0 * g * (1.0 + g / (1.0 + g) - 2.0 * g * ((1.0 + g) / g).ln())
}

/// The admittance at which Paris' absorption peaks (0.951 at g ≈ 0.64), by golden section.
fn paris_peak() -> f64 {
    let (mut a, mut b) = (0.1, 2.0);
    let r = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..100 {
        let (c, d) = (b - r * (b - a), a + r * (b - a));
        if paris_absorption(c) > paris_absorption(d) {
            b = d
        } else {
            a = c
        }
    }
    0.5 * (a + b)
}

/// The smaller real admittance with random-incidence absorption `alpha`, and whether `alpha`
/// had to be clamped to the peak.
pub fn admittance_from_random(alpha: f64) -> (f64, bool) {
    let peak = paris_peak();
    if alpha >= paris_absorption(peak) {
        return (peak, alpha > paris_absorption(peak) + 1e-12);
    }
    let (mut lo, mut hi) = (0.0, peak);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if paris_absorption(mid) < alpha {
            lo = mid
        } else {
            hi = mid
        }
    }
    (0.5 * (lo + hi), false)
}

/// Normal-incidence absorption of a real specific admittance g: 4g/(1 + g)².
pub fn normal_absorption_of(g: f64) -> f64 {
    4.0 * g / ((1.0 + g) * (1.0 + g))
}

/// The smaller real admittance with normal-incidence absorption `alpha` (inverse of the above).
fn admittance_from_normal(alpha: f64) -> f64 {
    if alpha <= 0.0 {
        return 0.0;
    }
    let alpha = alpha.min(1.0);
    (2.0 - alpha - 2.0 * (1.0 - alpha).sqrt()) / alpha
}

/// Lower and upper edge of each band: geometric means of neighbouring centres, and the same ratio
/// outwards at the ends (an octave for a single band).
pub fn band_edges(centres_hz: &[f64]) -> Vec<(f64, f64)> {
    let n = centres_hz.len();
    let ratio = |b: usize| {
        if n < 2 {
            2.0
        } else if b + 1 < n {
            centres_hz[b + 1] / centres_hz[b]
        } else {
            centres_hz[b] / centres_hz[b - 1]
        }
    };
    (0..n)
        .map(|b| {
            let lo = if b == 0 { centres_hz[0] / ratio(0).sqrt() } else { (centres_hz[b - 1] * centres_hz[b]).sqrt() };
            let hi = if b + 1 == n { centres_hz[b] * ratio(b).sqrt() } else { (centres_hz[b] * centres_hz[b + 1]).sqrt() };
            (lo, hi)
        })
        .collect()
}

/// Frequencies at which a band's mean reflection is taken: log-spaced across the band.
const POINTS_PER_BAND: usize = 16;
/// The reflected level is not asked below −23 dB (α_n up to 0.995).
const MIN_REFLECTED_ENERGY: f64 = 0.005;

/// Fits one material: `absorption` per band at `centres_hz`, of the given kind, for a grid whose
/// maximum frequency is `max_frequency_hz`.
pub fn fit_material(centres_hz: &[f64], absorption: &[f64], kind: AbsorptionKind, max_frequency_hz: f64) -> Result<MaterialFit, CoreError> {
    if centres_hz.is_empty() || centres_hz.len() != absorption.len() {
        return Err(CoreError::invalid("absorption", format!("{} values for {} bands", absorption.len(), centres_hz.len())));
    }
    let mut clamped = false;
    let target_all: Vec<f64> = absorption
        .iter()
        .map(|&a| match kind {
            AbsorptionKind::NormalIncidence => a,
            AbsorptionKind::RandomIncidence => {
                let (g, c) = admittance_from_random(a);
                clamped |= c;
                normal_absorption_of(g)
            }
        })
        .collect();
    let n_fit = super::settings::bands_fitted(centres_hz, max_frequency_hz).max(1);
    let centres = &centres_hz[..n_fit];
    let target = target_all[..n_fit].to_vec();
    let edges = band_edges(centres_hz);
    let problem = Problem::new(centres, &edges[..n_fit], &target);
    let theta = problem.solve();
    let admittance = problem.admittance(&theta);
    let (levels, _) = problem.levels(&theta, false);
    let fitted_normal: Vec<f64> = levels.iter().map(|l| 1.0 - 10f64.powf(l / 10.0)).collect();
    let error_db = levels.iter().zip(&problem.target_db).map(|(l, t)| l - t).collect();
    Ok(MaterialFit { admittance, n_bands_fitted: n_fit, target_normal: target, fitted_normal, error_db, clamped })
}

/// The least-squares problem of one material: parameters θ = (conductance, peak conductance of
/// each branch), all ≥ 0; residuals = band levels − targets, dB.
struct Problem {
    /// Per band: the sample frequencies' shapes h_k(f) of each parameter (θ_k · h_k sums to Y).
    shapes: Vec<Vec<Vec<C64>>>,
    target_db: Vec<f64>,
    centres: Vec<f64>,
    q: Vec<f64>,
    initial: Vec<f64>,
}

impl Problem {
    fn new(centres: &[f64], edges: &[(f64, f64)], target: &[f64]) -> Problem {
        let n = centres.len();
        let q: Vec<f64> = (0..n)
            .map(|b| {
                let r = (edges[b].1 / edges[b].0).sqrt();
                1.0 / (r.sqrt() - 1.0 / r.sqrt())
            })
            .collect();
        let shapes = (0..n)
            .map(|b| {
                let (lo, hi) = edges[b];
                (0..POINTS_PER_BAND)
                    .map(|i| {
                        let f = lo * (hi / lo).powf((i as f64 + 0.5) / POINTS_PER_BAND as f64);
                        let mut row = vec![C64::new(1.0, 0.0)];
                        for m in 0..n {
                            row.push(1.0 / C64::new(1.0, q[m] * (f / centres[m] - centres[m] / f)));
                        }
                        row
                    })
                    .collect()
            })
            .collect();
        let target_db = target.iter().map(|&a| 10.0 * (1.0 - a).max(MIN_REFLECTED_ENERGY).log10()).collect();
        // Start from each band's real admittance, the smallest of them as the conductance.
        let g: Vec<f64> = target.iter().map(|&a| admittance_from_normal(a)).collect();
        let g0 = g.iter().cloned().fold(f64::INFINITY, f64::min);
        let mut initial = vec![g0];
        initial.extend(g.iter().map(|&x| x - g0));
        Problem { shapes, target_db, centres: centres.to_vec(), q, initial }
    }

    /// Band levels (dB) and, when asked, their derivatives by each parameter.
    fn levels(&self, theta: &[f64], jacobian: bool) -> (Vec<f64>, Vec<Vec<f64>>) {
        let k = theta.len();
        let mut levels = Vec::with_capacity(self.shapes.len());
        let mut jac = Vec::new();
        for band in &self.shapes {
            let (mut e, mut de) = (0.0, vec![0.0; k]);
            for row in band {
                let y: C64 = row.iter().zip(theta).map(|(h, t)| h * t).sum();
                let r = (1.0 - y) / (1.0 + y);
                e += r.norm_sqr();
                if jacobian {
                    let dr_dy = -2.0 / ((1.0 + y) * (1.0 + y));
                    for (d, h) in de.iter_mut().zip(row) {
                        *d += 2.0 * (r.conj() * dr_dy * h).re;
                    }
                }
            }
            levels.push(10.0 * (e / band.len() as f64).log10());
            if jacobian {
                let s = 10.0 / std::f64::consts::LN_10 / e;
                jac.push(de.iter().map(|d| d * s).collect());
            }
        }
        (levels, jac)
    }

    fn cost(&self, theta: &[f64]) -> f64 {
        let (l, _) = self.levels(theta, false);
        l.iter().zip(&self.target_db).map(|(a, b)| (a - b) * (a - b)).sum()
    }

    /// Projected Levenberg–Marquardt from the initial guess.
    fn solve(&self) -> Vec<f64> {
        let mut theta = self.initial.clone();
        let mut cost = self.cost(&theta);
        let mut mu = 1e-3;
        let k = theta.len();
        for _ in 0..300 {
            if cost < 1e-14 {
                break;
            }
            let (l, j) = self.levels(&theta, true);
            let r: Vec<f64> = l.iter().zip(&self.target_db).map(|(a, b)| a - b).collect();
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
                let c = self.cost(&trial);
                if c < cost {
                    improved = cost - c > 1e-13 * cost;
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

    fn admittance(&self, theta: &[f64]) -> Admittance {
        let branches = theta[1..]
            .iter()
            .zip(self.centres.iter().zip(&self.q))
            .filter(|(&y, _)| y > 1e-9)
            .map(|(&y, (&fc, &q))| {
                let w0 = std::f64::consts::TAU * fc;
                let bandwidth = w0 / q;
                Branch { mass_s: 1.0 / (y * bandwidth), resistance: 1.0 / y, stiffness_per_s: w0 * w0 / (y * bandwidth) }
            })
            .collect();
        Admittance { conductance: theta[0], branches }
    }
}

/// Solves the k×k system `a`·x = `b` in place (Gaussian elimination, partial pivoting); false
/// when singular.
fn solve_dense(a: &mut [f64], b: &mut [f64], k: usize) -> bool {
    for col in 0..k {
        let pivot = (col..k).max_by(|&i, &j| a[i * k + col].abs().total_cmp(&a[j * k + col].abs())).unwrap_or(col);
        if !(a[pivot * k + col].abs() > 1e-300) {
            return false;
        }
        if pivot != col {
            for c in 0..k {
                a.swap(pivot * k + c, col * k + c);
            }
            b.swap(pivot, col);
        }
        for row in col + 1..k {
            let f = a[row * k + col] / a[col * k + col];
            for c in col..k {
                a[row * k + c] -= f * a[col * k + c];
            }
            b[row] -= f * b[col];
        }
    }
    for row in (0..k).rev() {
        let s: f64 = (row + 1..k).map(|c| a[row * k + c] * b[c]).sum();
        b[row] = (b[row] - s) / a[row * k + row];
    }
    b.iter().all(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paris_peaks_at_0951() {
        let g = paris_peak();
        assert!((paris_absorption(g) - 0.951).abs() < 5e-4, "{}", paris_absorption(g));
        // Small admittances absorb 8g at random incidence.
        assert!((paris_absorption(1e-4) / 8e-4 - 1.0).abs() < 0.01);
        let (g, clamped) = admittance_from_random(0.3);
        assert!(!clamped && (paris_absorption(g) - 0.3).abs() < 1e-9);
        assert!(admittance_from_random(0.99).1);
    }

    #[test]
    fn a_flat_target_is_a_conductance() {
        let centres = [125.0, 250.0, 500.0, 1000.0];
        let fit = fit_material(&centres, &[0.4; 4], AbsorptionKind::NormalIncidence, 1000.0).unwrap();
        assert!(fit.error_db.iter().all(|e| e.abs() < 0.01), "{:?}", fit.error_db);
        assert!((fit.admittance.normal_absorption(333.0) - 0.4).abs() < 0.01);
    }

    #[test]
    fn a_rigid_material_fits_to_a_rigid_wall() {
        let fit = fit_material(&[125.0, 250.0], &[0.0, 0.0], AbsorptionKind::RandomIncidence, 500.0).unwrap();
        assert!(fit.admittance.is_rigid(), "{:?}", fit.admittance);
    }
}
