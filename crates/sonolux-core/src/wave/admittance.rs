//! Wall admittances: the passive model of a locally reacting wall, the conversions between
//! absorption coefficients and real admittances (Paris' formula), London's random-incidence
//! absorption of any admittance and its gradient (what the fits of reactive walls meet), band
//! edges, and how a wall reflects on the grid.
//!
//! A wall is locally reacting: its normal velocity is v = Y(s) p / (ρc), with Y the specific
//! (ρc-normalised) admittance. Y is a conductance plus a sum of series mass–spring–damper
//! branches, each of impedance D·s + E + F/s with D, E, F ≥ 0. Every such branch, and so the sum,
//! is a positive-real function: the wall is passive, which is what keeps the scheme stable
//! (Bilbao, Hamilton, Botts and Savioja, "Finite volume time domain room acoustics simulation
//! under general impedance boundary conditions", IEEE/ACM TASLP 24(1), 2016).

use num_complex::Complex64 as C64;

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

// Paris' random-incidence absorption and its inverse are shared with the tracer's locally
// reacting walls (one wall model on both sides of the crossover): they live in `crate::wall`.
pub use crate::wall::{admittance_from_random, paris_absorption};

/// Normal-incidence absorption of a real specific admittance g: 4g/(1 + g)².
pub fn normal_absorption_of(g: f64) -> f64 {
    4.0 * g / ((1.0 + g) * (1.0 + g))
}

/// The smaller real admittance with normal-incidence absorption `alpha` (inverse of the above).
pub(crate) fn admittance_from_normal(alpha: f64) -> f64 {
    if alpha <= 0.0 {
        return 0.0;
    }
    let alpha = alpha.min(1.0);
    (2.0 - alpha - 2.0 * (1.0 - alpha).sqrt()) / alpha
}

/// Sample frequencies per band and angles of London's integral ([`random_absorption_in_band`]).
pub(crate) const RANDOM_FREQUENCIES: usize = 16;
const RANDOM_ANGLES: usize = 90;

/// The band-mean random-incidence absorption of a locally reacting wall of admittance `y` over
/// the band `(lo, hi)` Hz: ∫₀^{π/2} (1 − |R(θ)|²) sin 2θ dθ with R = (cos θ − Y)/(cos θ + Y), Y at
/// s = j2πf (London 1950; Kuttruff eq. 2.42), by the midpoint rule over 90 angles and 16
/// frequencies spaced evenly in log frequency.
pub fn random_absorption_in_band(y: &Admittance, (lo, hi): (f64, f64)) -> f64 {
    let freqs = band_frequencies(lo, hi, RANDOM_FREQUENCIES);
    freqs.iter().map(|&f| random_absorption(y.at(C64::new(0.0, std::f64::consts::TAU * f))).0).sum::<f64>() / freqs.len() as f64
}

/// `n` frequencies spaced evenly in log frequency over the band (lo, hi) (midpoints).
pub(crate) fn band_frequencies(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| lo * (hi / lo).powf((i as f64 + 0.5) / n as f64)).collect()
}

/// London's random-incidence absorption of a locally reacting wall of admittance `y` at one
/// frequency, ∫₀^{π/2} (1 − |R(θ)|²) sin 2θ dθ by the midpoint rule over [`RANDOM_ANGLES`]
/// angles, and G with dα = Re(G·dY): G = −2 Σ w (R̄ dR/dY), dR/dY = −2cos θ/(cos θ + Y)².
pub(crate) fn random_absorption(y: C64) -> (f64, C64) {
    let mut a = 0.0;
    let mut g = C64::new(0.0, 0.0);
    for k in 0..RANDOM_ANGLES {
        let theta = (k as f64 + 0.5) / RANDOM_ANGLES as f64 * std::f64::consts::FRAC_PI_2;
        let c = theta.cos();
        let w = (2.0 * theta).sin() * std::f64::consts::FRAC_PI_2 / RANDOM_ANGLES as f64;
        let d = c + y;
        let r = (c - y) / d;
        a += w * (1.0 - r.norm_sqr());
        g -= 2.0 * w * r.conj() * (-2.0 * c / (d * d));
    }
    (a, g)
}

/// Directions of the grid's diffuse field: [`RANDOM_ANGLES`] polar angles θ from the wall's normal
/// and this many azimuths ψ over [0, π/4] (the grid's dispersion is symmetric under ψ → −ψ and
/// ψ → π/2 − ψ about an axis). ψ enters only through the dispersion's anisotropy: 1, 2 and 8
/// azimuths fit paper-small's floor (0.3) to a conductance within 4·10⁻⁷ of each other
/// (measured 2026-11-27), and each azimuth costs as much as London's whole integral.
const GRID_AZIMUTHS: usize = 2;

/// One direction of a diffuse field meeting a grid-aligned wall at one frequency: its Paris weight
/// (sin 2θ dθ dψ, summing to 1 over the half space), e^{jφ} with φ = k_nΔx/2 and σ·cos(ωΔt/2).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Incidence {
    weight: f64,
    half_cell: C64,
    scale: f64,
}

/// The directions of a diffuse field meeting a wall along the grid's axes at frequency `f`, and
/// the frequency at which the wall's branches are evaluated (the bilinear transform's f̃).
///
/// On the grid a plane wave of wave vector k meets the wall with R = (e^{−jφ} − Y(s̃)·σ·cos(ωΔt/2))
/// / (e^{jφ} + Y(s̃)·σ·cos(ωΔt/2)), φ = k_nΔx/2, σ = sin(ωΔt/2)/(λ sin φ) (`tests/wave_oblique.rs`,
/// measured there within 0.1 dB), and k's length along each direction u is the scheme's,
/// sin²(ωΔt/2) = λ² Σᵢ sin²(k uᵢ Δx/2) (the interior update's dispersion relation, Newton's
/// method from the axis' root). As Δx → 0, σ·cos → 1/cos θ and φ → 0: London's R. Without a
/// grid (`None`) the directions are London's, θ only.
pub(crate) fn incidences(f: f64, scheme: Option<Discretisation>) -> (f64, Vec<Incidence>) {
    let d_theta = std::f64::consts::FRAC_PI_2 / RANDOM_ANGLES as f64;
    let Some(d) = scheme else {
        let dirs = (0..RANDOM_ANGLES)
            .map(|k| {
                let theta = (k as f64 + 0.5) * d_theta;
                Incidence { weight: (2.0 * theta).sin() * d_theta, half_cell: C64::new(1.0, 0.0), scale: 1.0 / theta.cos() }
            })
            .collect();
        return (f, dirs);
    };
    let half = std::f64::consts::PI * f * d.time_step_s;
    let target = half.sin().powi(2);
    let lambda2 = d.courant * d.courant;
    let axis = (half.sin() / d.courant).min(1.0).asin();
    let mut dirs = Vec::with_capacity(RANDOM_ANGLES * GRID_AZIMUTHS);
    for k in 0..RANDOM_ANGLES {
        let theta = (k as f64 + 0.5) * d_theta;
        for a in 0..GRID_AZIMUTHS {
            let psi = (a as f64 + 0.5) / GRID_AZIMUTHS as f64 * std::f64::consts::FRAC_PI_4;
            let u = [theta.sin() * psi.cos(), theta.sin() * psi.sin(), theta.cos()];
            // K = |k|Δx/2: λ² Σ sin²(K uᵢ) = sin²(ωΔt/2), increasing in K up to the cut-off.
            let mut kk = axis;
            for _ in 0..30 {
                let f_k: f64 = lambda2 * u.iter().map(|ui| (kk * ui).sin().powi(2)).sum::<f64>() - target;
                let slope: f64 = lambda2 * u.iter().map(|ui| ui * (2.0 * kk * ui).sin()).sum::<f64>();
                let step = f_k / slope;
                kk -= step;
                if step.abs() < 1e-14 {
                    break;
                }
            }
            let phi = kk * u[2];
            let scale = half.sin() / (d.courant * phi.sin()) * half.cos();
            dirs.push(Incidence { weight: (2.0 * theta).sin() * d_theta / GRID_AZIMUTHS as f64, half_cell: C64::from_polar(1.0, phi), scale });
        }
    }
    (half.tan() / (std::f64::consts::PI * d.time_step_s), dirs)
}

/// The diffuse-field absorption of a wall of admittance `y` (at the frequency of `dirs`), the mean
/// of 1 − |R|² over the directions with Paris' weights, and G with dα = Re(G·dY):
/// G = −2 Σ w (R̄ dR/dY), dR/dY = −2σ·cos(ωΔt/2)·cos φ/(e^{jφ} + Yσ·cos(ωΔt/2))².
pub(crate) fn diffuse_absorption(y: C64, dirs: &[Incidence]) -> (f64, C64) {
    let mut a = 0.0;
    let mut g = C64::new(0.0, 0.0);
    for d in dirs {
        let ys = y * d.scale;
        let den = d.half_cell + ys;
        let r = (d.half_cell.conj() - ys) / den;
        a += d.weight * (1.0 - r.norm_sqr());
        g -= 2.0 * d.weight * r.conj() * (-2.0 * d.scale * d.half_cell.re / (den * den));
    }
    (a, g)
}

/// The band-mean diffuse-field absorption on the grid `scheme` (London's with `None`) of a wall
/// of admittance `y` over the band `(lo, hi)` Hz, at [`RANDOM_FREQUENCIES`] frequencies.
pub fn grid_random_absorption_in_band(y: &Admittance, (lo, hi): (f64, f64), scheme: Option<Discretisation>) -> f64 {
    let freqs = band_frequencies(lo, hi, RANDOM_FREQUENCIES);
    freqs
        .iter()
        .map(|&f| {
            let (f_eval, dirs) = incidences(f, scheme);
            diffuse_absorption(y.at(C64::new(0.0, std::f64::consts::TAU * f_eval)), &dirs).0
        })
        .sum::<f64>()
        / freqs.len() as f64
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

/// The grid a wall is fitted for. On the grid, a plane wave meeting a wall along an axis at
/// normal incidence reflects with
///
///   R = (e^{−jkΔx/2} − Y(s̃)·cos(ωΔt/2)) / (e^{jkΔx/2} + Y(s̃)·cos(ωΔt/2)),
///
/// k from the scheme's dispersion (sin(kΔx/2) = sin(ωΔt/2)/λ) and s̃ = j(2/Δt)·tan(ωΔt/2) (the
/// branches' time discretisation is a bilinear transform). Derived from the boundary node's
/// update with a discrete plane wave (docs/waves-walls.md); as Δx → 0 it is (1 − Y)/(1 + Y). The
/// e^{∓jkΔx/2} is the half cell of air between the node and the wall: it adds a reactance of
/// about kΔx/2 to the wall's, which changes |R| in first order wherever Y has a reactance of its
/// own, by up to 2 dB at the maximum frequency. Fitting to this R instead of the continuous one
/// removes that error for walls along the grid's axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Discretisation {
    pub time_step_s: f64,
    pub courant: f64,
}

/// A sample frequency as the wall meets it: where the branches are evaluated (f̃ with
/// 2πf̃ = (2/Δt)·tan(ωΔt/2)), e^{jkΔx/2} and cos(ωΔt/2). For the continuous wall: (f, 1, 1).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Plane {
    pub(crate) f_eval: f64,
    a: C64,
    c: f64,
}

impl Plane {
    pub(crate) fn new(f: f64, scheme: Option<Discretisation>) -> Plane {
        let Some(d) = scheme else { return Plane { f_eval: f, a: C64::new(1.0, 0.0), c: 1.0 } };
        let half = std::f64::consts::PI * f * d.time_step_s;
        let half_kh = (half.sin() / d.courant).min(1.0).asin();
        Plane { f_eval: half.tan() / (std::f64::consts::PI * d.time_step_s), a: C64::from_polar(1.0, half_kh), c: half.cos() }
    }

    pub(crate) fn reflection(&self, y: C64) -> C64 {
        (self.a.conj() - y * self.c) / (self.a + y * self.c)
    }

    /// dR/dY.
    pub(crate) fn slope(&self, y: C64) -> C64 {
        let d = self.a + y * self.c;
        -2.0 * self.c * self.a.re / (d * d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// London's integral of a real admittance is Paris' closed form (to the midpoint rule's
    /// 1e-4 at 90 angles), and its gradient G is the finite difference's in both directions of
    /// a complex Y (relative 1e-5: the difference's own error at a step of 1e-6).
    #[test]
    fn london_is_paris_for_a_conductance_and_its_gradient_is_exact() {
        for g in [0.005, 0.05, 0.3, 1.0] {
            let (a, _) = random_absorption(C64::new(g, 0.0));
            assert!((a - paris_absorption(g)).abs() < 1e-4, "{g}: {a} vs {}", paris_absorption(g));
        }
        for y in [C64::new(0.02, 0.3), C64::new(0.2, -0.5), C64::new(1.5, 0.7)] {
            let (_, grad) = random_absorption(y);
            let h = 1e-6;
            let re = (random_absorption(y + h).0 - random_absorption(y - h).0) / (2.0 * h);
            let im = (random_absorption(y + C64::new(0.0, h)).0 - random_absorption(y - C64::new(0.0, h)).0) / (2.0 * h);
            // dα = Re(G·dY): along Re Y it is Re G, along Im Y it is −Im G.
            assert!((grad.re - re).abs() < 1e-5 * re.abs().max(1e-3), "{y}: {grad} vs {re}");
            assert!((-grad.im - im).abs() < 1e-5 * im.abs().max(1e-3), "{y}: {grad} vs {im}");
        }
    }

    /// The grid's diffuse-field absorption tends to London's as the grid refines (Δt → 0 at a
    /// fixed frequency: within 1e-4 at 10⁵ points per wavelength; first order in kΔx for a reactive
    /// wall, whose |R| the half cell's reactance kΔx/2 moves: 7e-4 off at 1000), falls below it on a coarse
    /// grid for a conductance (cos(ωΔt/2) and the half cell take from the wall's conductance), and
    /// its gradient G is the finite difference's (relative 1e-5, as London's above).
    #[test]
    fn the_grids_diffuse_absorption_is_londons_on_a_fine_grid_and_its_gradient_is_exact() {
        let lambda = 1.0 / 3f64.sqrt();
        let grid = |points_per_wavelength: f64, f: f64| Discretisation { time_step_s: lambda / (points_per_wavelength * f), courant: lambda };
        for y in [C64::new(0.05, 0.0), C64::new(0.3, 0.0), C64::new(0.2, -0.5)] {
            let london = random_absorption(y).0;
            let (_, dirs) = incidences(250.0, Some(grid(1e5, 250.0)));
            let fine = diffuse_absorption(y, &dirs).0;
            assert!((fine - london).abs() < 1e-4, "{y}: {fine} vs {london}");
            let (_, none) = incidences(250.0, None);
            assert!((diffuse_absorption(y, &none).0 - london).abs() < 1e-12);
        }
        let (_, coarse) = incidences(250.0, Some(grid(10.0, 250.0)));
        assert!(diffuse_absorption(C64::new(0.05, 0.0), &coarse).0 < random_absorption(C64::new(0.05, 0.0)).0);
        let (_, dirs) = incidences(350.0, Some(grid(10.0, 500.0)));
        for y in [C64::new(0.02, 0.3), C64::new(0.2, -0.5), C64::new(1.5, 0.7)] {
            let (_, grad) = diffuse_absorption(y, &dirs);
            let h = 1e-6;
            let re = (diffuse_absorption(y + h, &dirs).0 - diffuse_absorption(y - h, &dirs).0) / (2.0 * h);
            let im = (diffuse_absorption(y + C64::new(0.0, h), &dirs).0 - diffuse_absorption(y - C64::new(0.0, h), &dirs).0) / (2.0 * h);
            assert!((grad.re - re).abs() < 1e-5 * re.abs().max(1e-3), "{y}: {grad} vs {re}");
            assert!((-grad.im - im).abs() < 1e-5 * im.abs().max(1e-3), "{y}: {grad} vs {im}");
        }
    }
}
