//! Wall admittances: the passive model of a locally reacting wall, the conversions between
//! absorption coefficients and real admittances (Paris' formula), band edges, and how a wall
//! reflects on the grid.
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
/// update with a discrete plane wave (docs/waves.md); as Δx → 0 it is (1 − Y)/(1 + Y). The
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
