//! A tabulated source directivity: per band, the energy gain on a regular (θ, φ) grid in the
//! source's own frame, and the importance sampler that emits rays by it.
//!
//! **Frame.** θ is the angle from the source's `forward` vector (0 to π), φ the angle around it,
//! from `up` (φ = 0) towards `left` = up × forward (φ = 90°): a right-handed frame with x
//! forward, y left and z up, as AES69 (SOFA) and ISO 3382 describe sources.
//!
//! **Grid.** `n_theta` ≥ 2 nodes θ_i = i·π/(n_theta − 1) (both poles included) and `n_phi` ≥ 1
//! nodes φ_j = j·2π/n_phi (periodic; `n_phi` = 1 is an axially symmetric pattern). Between the
//! nodes the gain is bilinear in (θ, φ).
//!
//! **Normalisation.** A pattern is a shape; the power is the source's. Each band is scaled so
//! that its gain integrates to 4π over the sphere (exactly, for the bilinear surface: see
//! [`row_weights`]), i.e. its mean over directions is 1, the gain of an omnidirectional source.
//! A source of power W then radiates W in every band, W·g_b(ω)/(4π) per steradian.
//!
//! **Emission by importance.** Rays are drawn from a density p(ω) that is constant over each
//! grid cell and proportional to the cell's energy summed over bands (exact inverse-CDF: a cell
//! by its share, then a direction uniform in solid angle within it). A ray then carries, in
//! band b, the weight g_b(ω) / (4π p(ω)) times its share of the power (W / rays): the
//! expectation of the weight is ∫ g_b / (4π) dΩ = 1 in every band, so the radiated power per
//! band is the source's, while rays go where the pattern sends its energy.

use std::f64::consts::PI;

use glam::DVec3;

use crate::error::CoreError;
use crate::sampling::Discrete;

/// A source's directivity as a table of per-band energy gains (see the module docs).
#[derive(Clone, Debug)]
pub struct Pattern {
    n_theta: usize,
    n_phi: usize,
    n_bands: usize,
    /// Normalised gains, `[theta][phi][band]`.
    gain: Vec<f64>,
    forward: DVec3,
    up: DVec3,
    left: DVec3,
    /// The cells `[theta row][phi]`, chosen by their energy summed over bands.
    cells: Discrete,
    /// The emission density (per steradian) in each cell.
    cell_pdf: Vec<f64>,
    /// cos θ_i at every θ node.
    cos_theta: Vec<f64>,
    max_weight: f64,
    max_gain: f64,
    /// The mean gain of each band over the sphere: 1 for a normalised (source) pattern.
    mean_gain: Vec<f64>,
}

impl PartialEq for Pattern {
    fn eq(&self, other: &Pattern) -> bool {
        (self.n_theta, self.n_phi, self.n_bands) == (other.n_theta, other.n_phi, other.n_bands) && self.gain == other.gain && self.forward == other.forward && self.up == other.up
    }
}

/// The integrals over θ in [θ0, θ0 + Δ] of sin θ times the two linear interpolation weights,
/// (θ1 − θ)/Δ and (θ − θ0)/Δ: the exact solid-angle weights of a row's two node rings
/// (per radian of φ), from ∫ sin θ dθ = −cos θ and ∫ θ sin θ dθ = sin θ − θ cos θ.
fn row_weights(theta0: f64, delta: f64) -> (f64, f64) {
    let theta1 = theta0 + delta;
    let band = theta0.cos() - theta1.cos();
    let first_moment = (theta1.sin() - theta1 * theta1.cos()) - (theta0.sin() - theta0 * theta0.cos());
    let w1 = (first_moment - theta0 * band) / delta;
    (band - w1, w1)
}

impl Pattern {
    /// Builds a pattern from raw gains `[theta][phi][band]` (≥ 0, finite, every band with some
    /// energy; any scale: each band is normalised) oriented by `forward` and `up` (not parallel;
    /// `up` is made perpendicular to `forward`).
    pub fn new(n_theta: usize, n_phi: usize, n_bands: usize, gains: &[f64], forward: DVec3, up: DVec3) -> Result<Pattern, CoreError> {
        Pattern::build(n_theta, n_phi, n_bands, gains, forward, up, true)
    }

    /// A pattern that keeps its gains as given (no normalisation): a receiver's measured
    /// response, whose level is meaningful (1 = the response of an ideal omnidirectional
    /// microphone). Its sampler is built but a receiver never emits.
    pub fn measured(n_theta: usize, n_phi: usize, n_bands: usize, gains: &[f64], forward: DVec3, up: DVec3) -> Result<Pattern, CoreError> {
        Pattern::build(n_theta, n_phi, n_bands, gains, forward, up, false)
    }

    fn build(n_theta: usize, n_phi: usize, n_bands: usize, gains: &[f64], forward: DVec3, up: DVec3, normalise: bool) -> Result<Pattern, CoreError> {
        let bad = |problem: String| Err(CoreError::invalid("directivity pattern", problem));
        if n_theta < 2 || n_phi < 1 || n_bands < 1 {
            return bad(format!("{n_theta} θ × {n_phi} φ nodes × {n_bands} bands: at least 2 × 1 × 1"));
        }
        if gains.len() != n_theta * n_phi * n_bands {
            return bad(format!("{} gains for {n_theta} θ × {n_phi} φ × {n_bands} bands", gains.len()));
        }
        if let Some(g) = gains.iter().find(|g| !(g.is_finite() && **g >= 0.0)) {
            return bad(format!("gain {g} is not a finite value ≥ 0"));
        }
        if !(forward.is_finite() && up.is_finite() && forward.length() > 0.0 && up.length() > 0.0) {
            return bad(format!("forward {:?} and up {:?} must be finite non-zero vectors", forward.to_array(), up.to_array()));
        }
        let f = forward.normalize();
        let u = up - f * up.dot(f);
        if u.length() < 1e-6 * up.length() {
            return bad(format!("up {:?} is parallel to forward {:?}", up.to_array(), forward.to_array()));
        }
        let u = u.normalize();
        let l = u.cross(f);

        let dtheta = PI / (n_theta - 1) as f64;
        let dphi = 2.0 * PI / n_phi as f64;
        let rows: Vec<(f64, f64)> = (0..n_theta - 1).map(|i| row_weights(i as f64 * dtheta, dtheta)).collect();
        let at = |i: usize, j: usize, b: usize| (i * n_phi + j % n_phi) * n_bands + b;
        // The exact integral of one band's bilinear gain over cell (i, j).
        let cell_integral = |g: &[f64], i: usize, j: usize, b: usize| {
            let (w0, w1) = rows[i];
            dphi * (w0 * (g[at(i, j, b)] + g[at(i, j + 1, b)]) + w1 * (g[at(i + 1, j, b)] + g[at(i + 1, j + 1, b)])) / 2.0
        };

        // Normalise each band to a mean gain of 1 over the sphere (a source's pattern).
        let mut gain = gains.to_vec();
        let mut mean_gain = vec![1.0; n_bands];
        for b in 0..n_bands {
            let total: f64 = (0..n_theta - 1).flat_map(|i| (0..n_phi).map(move |j| (i, j))).map(|(i, j)| cell_integral(gains, i, j, b)).sum();
            if !(total > 0.0) {
                return bad(format!("band {b} radiates no energy in any direction"));
            }
            if !normalise {
                mean_gain[b] = total / (4.0 * PI);
                continue;
            }
            let scale = 4.0 * PI / total;
            for i in 0..n_theta {
                for j in 0..n_phi {
                    gain[at(i, j, b)] *= scale;
                }
            }
        }

        // Each cell's energy summed over bands, its emission density, and the largest weight a
        // ray can carry (the bilinear gain is at most the largest of its cell's corners).
        let n_cells = (n_theta - 1) * n_phi;
        let mut mass = vec![0.0; n_cells];
        let mut cell_pdf = vec![0.0; n_cells];
        let mut max_weight = 0.0f64;
        let all: f64 = mean_gain.iter().map(|m| 4.0 * PI * m).sum();
        for i in 0..n_theta - 1 {
            let solid_angle = dphi * ((i as f64 * dtheta).cos() - ((i + 1) as f64 * dtheta).cos());
            for j in 0..n_phi {
                let c = i * n_phi + j;
                mass[c] = (0..n_bands).map(|b| cell_integral(&gain, i, j, b)).sum();
                cell_pdf[c] = mass[c] / (all * solid_angle);
                if mass[c] > 0.0 {
                    for b in 0..n_bands {
                        let corner = [gain[at(i, j, b)], gain[at(i, j + 1, b)], gain[at(i + 1, j, b)], gain[at(i + 1, j + 1, b)]];
                        let top = corner.iter().fold(0.0f64, |m, &g| m.max(g));
                        max_weight = max_weight.max(top / (4.0 * PI * cell_pdf[c]));
                    }
                }
            }
        }
        let max_gain = gain.iter().fold(0.0f64, |m, &g| m.max(g));
        let cells = Discrete::new(&mass).expect("every band has positive energy");
        let cos_theta = (0..n_theta).map(|i| (i as f64 * dtheta).cos()).collect();
        Ok(Pattern { n_theta, n_phi, n_bands, gain, forward: f, up: u, left: l, cells, cell_pdf, cos_theta, max_weight, max_gain, mean_gain })
    }

    /// The mean gain of each band over the sphere (1 for a source's normalised pattern).
    pub fn mean_gain(&self) -> &[f64] {
        &self.mean_gain
    }

    pub fn n_bands(&self) -> usize {
        self.n_bands
    }

    /// The largest per-band weight a ray can carry (relative to its share of the power).
    pub fn max_weight(&self) -> f64 {
        self.max_weight
    }

    /// The largest gain in any direction and band.
    pub fn max_gain(&self) -> f64 {
        self.max_gain
    }

    fn dtheta(&self) -> f64 {
        PI / (self.n_theta - 1) as f64
    }

    fn dphi(&self) -> f64 {
        2.0 * PI / self.n_phi as f64
    }

    /// World direction of (θ, φ) in the source's frame.
    fn direction(&self, cos_theta: f64, phi: f64) -> DVec3 {
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        self.forward * cos_theta + (self.up * phi.cos() + self.left * phi.sin()) * sin_theta
    }

    /// Cell (row i, column j) and the bilinear coordinates (t, s) in [0, 1] of a unit direction.
    fn locate(&self, dir: DVec3) -> (usize, usize, f64, f64) {
        let theta = dir.dot(self.forward).clamp(-1.0, 1.0).acos();
        let phi = dir.dot(self.left).atan2(dir.dot(self.up)).rem_euclid(2.0 * PI);
        let x = theta / self.dtheta();
        let i = (x.floor() as usize).min(self.n_theta - 2);
        let y = phi / self.dphi();
        let j = (y.floor() as usize).min(self.n_phi - 1);
        (i, j, (x - i as f64).clamp(0.0, 1.0), (y - j as f64).clamp(0.0, 1.0))
    }

    /// The bilinear gain of every band at cell (i, j), coordinates (t, s), written into `out`.
    fn interpolate(&self, i: usize, j: usize, t: f64, s: f64, out: &mut [f64]) {
        let (np, nb) = (self.n_phi, self.n_bands);
        let row = |i: usize, j: usize| (i * np + j % np) * nb;
        let (a, b, c, d) = (row(i, j), row(i, j + 1), row(i + 1, j), row(i + 1, j + 1));
        let g = &self.gain;
        for k in 0..nb {
            out[k] = (1.0 - t) * ((1.0 - s) * g[a + k] + s * g[b + k]) + t * ((1.0 - s) * g[c + k] + s * g[d + k]);
        }
    }

    /// The gain of every band towards the unit world direction `dir`, written into `out`
    /// (one value a band; 1 is an omnidirectional source's gain).
    pub fn gains(&self, dir: DVec3, out: &mut [f64]) {
        let (i, j, t, s) = self.locate(dir);
        self.interpolate(i, j, t, s, out);
    }

    /// The emission density (per steradian) towards the unit world direction `dir`.
    pub fn pdf(&self, dir: DVec3) -> f64 {
        let (i, j, _, _) = self.locate(dir);
        self.cell_pdf[i * self.n_phi + j]
    }

    /// Draws a direction from three uniform numbers in [0, 1) and writes each band's weight
    /// g_b / (4π p) into `weights` (see the module docs).
    pub fn sample(&self, u1: f64, u2: f64, u3: f64, weights: &mut [f64]) -> DVec3 {
        let c = self.cells.sample(u1);
        let (i, j) = (c / self.n_phi, c % self.n_phi);
        let (c0, c1) = (self.cos_theta[i], self.cos_theta[i + 1]);
        let cos_theta = (c0 - u2 * (c0 - c1)).clamp(-1.0, 1.0);
        let t = ((cos_theta.acos() - i as f64 * self.dtheta()) / self.dtheta()).clamp(0.0, 1.0);
        let phi = (j as f64 + u3) * self.dphi();
        self.interpolate(i, j, t, u3, weights);
        let to_weight = 1.0 / (4.0 * PI * self.cell_pdf[c]);
        for w in weights[..self.n_bands].iter_mut() {
            *w *= to_weight;
        }
        self.direction(cos_theta, phi)
    }
}
