//! The Biot–Tolstoy–Medwin edge integral of one wedge, binned in time, with a bounded amount of
//! work everywhere, zone boundaries included.
//!
//! The diffracted impulse response of an edge (Svensson, Fred and Vanderkooy, "An analytic
//! secondary source model of edge diffraction impulse responses", JASA 106(5), 1999, eq. 11;
//! free field 1/r):
//!
//!   h(τ) = −ν/(4π) ∫ δ(τ − (m + l)/c) β(z) / (m l) dz,   ν = π / θ_w,
//!   β = Σ±± sin(ν(π ± θ_S ± θ_R)) / (cosh(νη) − cos(ν(π ± θ_S ± θ_R))),
//!   η = cosh⁻¹((m l + (z − z_S)(z − z_R)) / (r_S r_R)),
//!
//! m and l the distances from the source and the receiver to the edge point z, (r, θ, z) the
//! cylindrical coordinates about the edge with θ measured from one face through the air. It is
//! integrated per time sample, over the part of the edge whose path falls in that sample, each
//! side of the apex (the point of the shortest path) apart (Torres, Svensson and Kleiner,
//! "Computation of edge diffraction for more accurate room acoustics auralization", JASA 109(2),
//! 2001).
//!
//! **Zone boundaries.** Each term of β is s c / (sinh²(νη/2) + s²) with s = sin(νφ/2),
//! c = cos(νφ/2) (φ = π ± θ_S ± θ_R). When the receiver nears a shadow or reflection boundary one
//! s tends to 0, and since η grows linearly from the apex, the term becomes a Lorentzian in z of
//! width ∝ |s| and height ∝ 1/|s|: its integral stays finite and flips sign across the boundary
//! (that flip is what cancels the jump of the geometric sound), but a numerical rule needs ever
//! more points to find it. Svensson and Calamia ("Edge-diffraction impulse responses near
//! specular-zone and shadow-zone boundaries", Acta Acustica united with Acustica 92, 2006) treat
//! it analytically in the first time sample. We do the same with our own expansion about the
//! apex z_a: there
//!
//!   cosh η − 1 = (r_S + r_R)² (z − z_a)² / (r_S r_R (m l + r_S r_R − (z − z_S)(z − z_R)))
//!
//! exactly (no cancellation, so η keeps its precision as it goes to 0), hence to second order
//! sinh²(νη/2) ≈ a² (z − z_a)² with a² = ν² κ / 2, κ = (r_S + r_R)² / (r_S r_R D₀), D₀ the
//! denominator's value at the apex, and m l ≈ m₀ l₀. The model term s c / (a² Δz² + s²) / (m₀ l₀)
//! integrates in closed form (an arctangent); the first time sample on each side integrates the
//! integrand minus the model numerically (a bounded function, whose integral vanishes as s → 0)
//! and adds the model's integral as an impulse at the model's mean arrival time. At s → 0± the
//! two sides together give ∓ 1/(2L) (L = m₀ + l₀): half the geometric wave, with the sign that
//! makes the sum continuous.
//!
//! **Bounded work.** Each bin gets one Gauss–Kronrod 7–15 estimate (15 integrand calls); further
//! adaptive refinement draws from a budget of [`REFINEMENT_CALLS`] per edge part, a hard cap, so
//! an edge part never costs more than 15 calls a bin plus that budget.

// The quadrature tables are QUADPACK's, digit for digit.
#![allow(clippy::excessive_precision)]

use std::f64::consts::PI;

use num_complex::Complex64;

/// Frequencies per band at which |H|² is averaged.
pub const FREQUENCIES_PER_BAND: usize = 24;

/// Integrand calls that adaptive refinement may spend on one edge part, beyond the 15 calls of
/// each bin's first estimate: a hard cap.
pub const REFINEMENT_CALLS: u64 = 60_000;

/// Source and receiver about one wedge, in its cylindrical coordinates.
#[derive(Clone, Copy, Debug)]
pub struct WedgeGeometry {
    pub nu: f64,
    pub r_s: f64,
    pub theta_s: f64,
    pub z_s: f64,
    pub r_r: f64,
    pub theta_r: f64,
    pub z_r: f64,
}

/// The near-apex model of one β term: −ν/(4π) · s c / (a² Δz² + s²) / (m₀ l₀).
#[derive(Clone, Copy, Debug)]
struct ApexTerm {
    s: f64,
    weight: f64,
}

impl WedgeGeometry {
    pub fn new(open_angle_rad: f64, (r_s, theta_s, z_s): (f64, f64, f64), (r_r, theta_r, z_r): (f64, f64, f64)) -> WedgeGeometry {
        WedgeGeometry { nu: PI / open_angle_rad, r_s, theta_s, z_s, r_r, theta_r, z_r }
    }

    /// Path length via edge point z.
    #[inline]
    pub fn path(&self, z: f64) -> f64 {
        (self.r_s * self.r_s + (z - self.z_s).powi(2)).sqrt() + (self.r_r * self.r_r + (z - self.z_r).powi(2)).sqrt()
    }

    /// The edge point of the shortest path (on the infinite edge).
    pub fn apex(&self) -> f64 {
        self.z_s + (self.z_r - self.z_s) * self.r_s / (self.r_s + self.r_r)
    }

    /// Puts a receiver that lies within `delta_rad` of a zone boundary on the side that the
    /// geometric arrivals found: `direct` (the emitter is heard), `reflected` (its images in the
    /// reference face θ = 0 and in the other face θ = θ_w are heard). Ray tests in single
    /// precision decide a boundary to about the scene's ray offset; the diffracted wave's sign
    /// flips at the exact boundary. Without this a receiver in between could hear both the
    /// geometric wave and the diffracted half-wave that stands in for it, or neither. The
    /// receiver moves by at most `delta_rad`, which changes nothing else measurably.
    pub fn settle_on_side(&mut self, delta_rad: f64, direct: bool, reflected: [bool; 2]) {
        let open = PI / self.nu;
        // (boundary angle of θ_R, whether the geometric wave is present, its lit side's sign).
        let boundaries = [
            (self.theta_s + PI, direct, -1.0),
            (self.theta_s - PI, direct, 1.0),
            (PI - self.theta_s, reflected[0], -1.0),
            (2.0 * open - PI - self.theta_s, reflected[1], 1.0),
        ];
        for (at, lit, lit_side) in boundaries {
            if (self.theta_r - at).abs() < delta_rad {
                self.theta_r = at + if lit { lit_side } else { -lit_side } * delta_rad;
            }
        }
    }

    /// How far the receiver is from the zone boundary of each geometric wave the edge bounds,
    /// as |sin(νφ/2)| of that boundary's β term (0 on the boundary): the emitter's own wave
    /// (terms 2 and 3) and its images in the reference face (term 4) and in the other face
    /// (term 1).
    pub fn boundary_distances(&self) -> [f64; 3] {
        let s = self.phis().map(|phi| (0.5 * self.nu * phi).sin().abs());
        [s[1].min(s[2]), s[3], s[0]]
    }

    /// The four φ = π ± θ_S ± θ_R.
    fn phis(&self) -> [f64; 4] {
        [
            PI + self.theta_s + self.theta_r,
            PI + self.theta_s - self.theta_r,
            PI - self.theta_s + self.theta_r,
            PI - self.theta_s - self.theta_r,
        ]
    }

    /// m l + r_S r_R − (z − z_S)(z − z_R), never below r_S r_R.
    fn denominator(&self, z: f64) -> (f64, f64) {
        let (ds, dr) = (z - self.z_s, z - self.z_r);
        let ml = (self.r_s * self.r_s + ds * ds).sqrt() * (self.r_r * self.r_r + dr * dr).sqrt();
        (ml, ml + self.r_s * self.r_r - ds * dr)
    }

    /// −ν/(4π) β / (m l) at edge point z.
    pub fn integrand(&self, z: f64) -> f64 {
        let (ml, den) = self.denominator(z);
        let dz = z - self.apex();
        // cosh η − 1 without cancellation (see the module docs), then η = log1p(y + √(y(y + 2))).
        let y = (self.r_s + self.r_r).powi(2) * dz * dz / (self.r_s * self.r_r * den);
        let eta = (y + (y * (y + 2.0)).sqrt()).ln_1p();
        let sh = (0.5 * self.nu * eta).sinh();
        let mut beta = 0.0;
        for phi in self.phis() {
            let (sn, cn) = (0.5 * self.nu * phi).sin_cos();
            let den = sh * sh + sn * sn;
            if den > 0.0 {
                beta += sn * cn / den;
            }
        }
        -self.nu / (4.0 * PI) * beta / ml
    }

    /// a (the model's sinh(νη/2) ≈ a |Δz|), m₀ l₀, and the path's curvature q (path ≈ L + q Δz²)
    /// at the apex.
    fn apex_constants(&self) -> (f64, f64, f64) {
        let za = self.apex();
        let (ml0, den0) = self.denominator(za);
        let kappa = (self.r_s + self.r_r).powi(2) / (self.r_s * self.r_r * den0);
        let a = self.nu * (0.5 * kappa).sqrt();
        let (m0, l0) = ((self.r_s * self.r_s + (za - self.z_s).powi(2)).sqrt(), (self.r_r * self.r_r + (za - self.z_r).powi(2)).sqrt());
        let q = 0.5 * (self.r_s * self.r_s / m0.powi(3) + self.r_r * self.r_r / l0.powi(3));
        (a, ml0, q)
    }

    fn apex_terms(&self) -> [ApexTerm; 4] {
        let (_, ml0, _) = self.apex_constants();
        self.phis().map(|phi| {
            let (s, c) = (0.5 * self.nu * phi).sin_cos();
            ApexTerm { s, weight: -self.nu / (4.0 * PI) * s * c / ml0 }
        })
    }

    /// The near-apex model of the integrand at z.
    fn apex_model(&self, z: f64, terms: &[ApexTerm; 4], a: f64) -> f64 {
        let dz = z - self.apex();
        terms.iter().filter(|t| t.s != 0.0).map(|t| t.weight / (a * a * dz * dz + t.s * t.s)).sum()
    }
}

/// Kronrod 15-point nodes and weights, and the embedded 7-point Gauss weights (QUADPACK).
const XGK: [f64; 8] = [
    0.991455371120812639206854697526329,
    0.949107912342758524526189684047851,
    0.864864423359769072789712788640926,
    0.741531185599394439863864773280788,
    0.586087235467691130294144845693013,
    0.405845151377397166906606412076961,
    0.207784955007898467600689403773245,
    0.0,
];
const WGK: [f64; 8] = [
    0.022935322010529224963732008058970,
    0.063092092629978553290700663189204,
    0.104790010322250183839876322541518,
    0.140653259715525918745189590510238,
    0.169004726639267902826583426598550,
    0.190350578064785409913256402421014,
    0.204432940075298892414161999234649,
    0.209482141084727828012999174891714,
];
const WG: [f64; 4] = [0.129484966168869693270611432679082, 0.279705391489276667901467771423780, 0.381830050505118944950369775488975, 0.417959183673469387755102040816327];

/// Integrand calls made, and refinement calls still allowed.
#[derive(Clone, Copy, Debug)]
pub struct Budget {
    pub calls: u64,
    pub refinement_left: u64,
}

/// One Gauss–Kronrod 7–15 estimate of ∫ f over [a, b]: (Kronrod, Gauss).
fn gauss_kronrod(f: &impl Fn(f64) -> f64, a: f64, b: f64, budget: &mut Budget) -> (f64, f64) {
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    let fc = f(c);
    let (mut k, mut g) = (WGK[7] * fc, WG[3] * fc);
    for j in 0..7 {
        let x = h * XGK[j];
        let s = f(c - x) + f(c + x);
        k += WGK[j] * s;
        if j % 2 == 1 {
            g += WG[j / 2] * s;
        }
    }
    budget.calls += 15;
    (k * h, g * h)
}

/// ∫ f over [a, b] by adaptive Gauss–Kronrod 7–15 to `tol` absolute, refining only while the
/// budget allows (depth first, so the result is the same on every run).
pub fn integrate(f: &impl Fn(f64) -> f64, a: f64, b: f64, tol: f64, budget: &mut Budget) -> f64 {
    let (k, g) = gauss_kronrod(f, a, b, budget);
    refine(f, a, b, k, g, tol, budget)
}

fn refine(f: &impl Fn(f64) -> f64, a: f64, b: f64, k: f64, g: f64, tol: f64, budget: &mut Budget) -> f64 {
    // A relative floor: below it the estimate is as good as double precision allows, and a
    // non-finite estimate is not refined (neither would ever meet an absolute tolerance).
    if budget.refinement_left < 30 || !(k - g).is_finite() || (k - g).abs() <= tol.max(1e-13 * k.abs()) {
        return k;
    }
    budget.refinement_left -= 30;
    let c = 0.5 * (a + b);
    let (kl, gl) = gauss_kronrod(f, a, c, budget);
    let (kr, gr) = gauss_kronrod(f, c, b, budget);
    refine(f, a, c, kl, gl, 0.5 * tol, budget) + refine(f, c, b, kr, gr, 0.5 * tol, budget)
}

/// The edge point on [from, to] (where the path length is monotone) at which it equals `target`.
fn invert_path(g: &WedgeGeometry, from: f64, to: f64, target: f64) -> f64 {
    let (mut lo, mut hi) = (from, to);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if g.path(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
        if (hi - lo).abs() < 1e-13 * (1.0 + mid.abs()) {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// The binned response of an edge part: `bins[n]` integrates h over
/// [onset + n/fs, onset + (n + 1)/fs); `impulses` are the near-apex model's closed-form parts
/// (not smoothed over a bin), each with the geometric wave whose boundary its term marks.
#[derive(Clone, Debug)]
pub struct BinnedResponse {
    pub onset_s: f64,
    pub bins: Vec<f64>,
    pub impulses: Vec<Impulse>,
    pub integrand_calls: u64,
}

/// One closed-form part of the first sample: at `time_s`, of integral `value`, of the β term
/// that marks the boundary of `wave` (0: the emitter's own wave, 1: its image in the reference
/// face, 2: its image in the other face; [`WedgeGeometry::boundary_distances`]).
/// `stand_in` is the part of it that stands in for that wave across its boundary: `value` times
/// |Δ arctan| / (π/2), which is 1 at the boundary (where the term jumps by half the wave) and
/// falls as (Δz a / s)² away from it, continuous on both sides.
#[derive(Clone, Copy, Debug)]
pub struct Impulse {
    pub time_s: f64,
    pub value: f64,
    pub stand_in: f64,
    pub wave: usize,
}

/// The wave of each β term, in the order of `phis`.
const WAVE_OF_TERM: [usize; 4] = [2, 0, 0, 1];

/// The diffracted impulse response of the edge part [z1, z2], binned at `sample_rate_hz`.
pub fn binned_response(g: &WedgeGeometry, z1: f64, z2: f64, speed_m_s: f64, sample_rate_hz: f64) -> BinnedResponse {
    let z_apex = g.apex();
    let z_min = z_apex.clamp(z1, z2);
    let l0 = g.path(z_min);
    let step = speed_m_s / sample_rate_hz;
    let l_end = g.path(z1).max(g.path(z2));
    let n_bins = ((l_end - l0) / step).ceil().max(1.0) as usize;
    let mut bins = vec![0.0; n_bins];
    let mut impulses = Vec::new();
    let scale = g.nu / (4.0 * PI) / (g.r_s * g.r_r).max(1e-12);
    let f = |z: f64| g.integrand(z);
    let (a, _, q) = g.apex_constants();
    let terms = g.apex_terms();
    let remainder = |z: f64| g.integrand(z) - g.apex_model(z, &terms, a);
    let mut budget = Budget { calls: 0, refinement_left: REFINEMENT_CALLS };
    for (end, sign) in [(z2, 1.0), (z1, -1.0)] {
        if (end - z_min) * sign <= 0.0 {
            continue;
        }
        let l_side = g.path(end);
        let mut z_prev = z_min;
        for (n, bin) in bins.iter_mut().enumerate() {
            let target = l0 + (n + 1) as f64 * step;
            let z_next = if target >= l_side { end } else { invert_path(g, z_prev, end, target) };
            let (lo, hi) = if sign > 0.0 { (z_prev, z_next) } else { (z_next, z_prev) };
            let tol = 1e-10 * scale * (hi - lo).max(1e-6);
            if n == 0 {
                // The first sample: the integrand less the near-apex model, numerically; the
                // model in closed form, one impulse a β term at its mean arrival time.
                *bin += integrate(&remainder, lo, hi, tol, &mut budget);
                let (d1, d2) = (lo - z_apex, hi - z_apex);
                for (k, t) in terms.iter().enumerate().filter(|(_, t)| t.s != 0.0) {
                    let atan = |d: f64| (a * d / t.s).atan();
                    let integral = t.weight / (a * t.s) * (atan(d2) - atan(d1));
                    // ∫ Δz² / (a²Δz² + s²) over [d1, d2] against ∫ 1 / (a²Δz² + s²): the mean Δz².
                    let second = (d2 - d1) / (a * a) - t.s / (a * a * a) * (atan(d2) - atan(d1));
                    let first = (atan(d2) - atan(d1)) / (a * t.s);
                    let mean_dz2 = if first != 0.0 { (second / first).max(0.0) } else { 0.0 };
                    let path = (g.path(z_apex) + q * mean_dz2).clamp(l0, l0 + step);
                    let share = ((atan(d2) - atan(d1)).abs() / (0.5 * PI)).min(1.0);
                    impulses.push(Impulse { time_s: path / speed_m_s, value: integral, stand_in: integral * share, wave: WAVE_OF_TERM[k] });
                }
            } else {
                *bin += integrate(&f, lo, hi, tol, &mut budget);
            }
            z_prev = z_next;
            if z_next == end {
                break;
            }
        }
    }
    BinnedResponse { onset_s: l0 / speed_m_s, bins, impulses, integrand_calls: budget.calls }
}

/// The spectrum of the stand-ins of one `wave` alone.
pub fn stand_in_spectrum(response: &BinnedResponse, wave: usize, freqs_hz: &[f64]) -> Vec<Complex64> {
    freqs_hz
        .iter()
        .map(|&f| response.impulses.iter().filter(|i| i.wave == wave).map(|i| Complex64::from_polar(i.stand_in, -2.0 * PI * f * i.time_s)).sum())
        .collect()
}

/// H(f) of a binned response at each of `freqs_hz`: Σ bin · e^(−j2πf t_n) over the bins'
/// centres, divided by sinc(f / fs) (a bin is the response smoothed by a one-sample box), plus
/// the impulses at their own times.
pub fn spectrum(response: &BinnedResponse, sample_rate_hz: f64, freqs_hz: &[f64]) -> Vec<Complex64> {
    freqs_hz
        .iter()
        .map(|&f| {
            let w = Complex64::from_polar(1.0, -2.0 * PI * f / sample_rate_hz);
            let mut phase = Complex64::from_polar(1.0, -2.0 * PI * f * (response.onset_s + 0.5 / sample_rate_hz));
            let mut sum = Complex64::new(0.0, 0.0);
            for &b in &response.bins {
                sum += phase * b;
                phase *= w;
            }
            let x = PI * f / sample_rate_hz;
            let mut h = sum / (x.sin() / x);
            for i in &response.impulses {
                h += Complex64::from_polar(i.value, -2.0 * PI * f * i.time_s);
            }
            h
        })
        .collect()
}

/// The frequencies of each band at which energies are averaged: midpoints of equal parts.
pub fn band_frequencies(ctx_edges: &[(f64, f64)]) -> Vec<f64> {
    let n = FREQUENCIES_PER_BAND;
    ctx_edges.iter().flat_map(|&(lo, hi)| (0..n).map(move |k| lo + (k as f64 + 0.5) * (hi - lo) / n as f64)).collect()
}

/// The internal sample rate of the binned responses: 16 samples a period of the highest band's
/// top edge, at least 48 kHz.
pub fn internal_rate_hz(band_edges: &[(f64, f64)]) -> f64 {
    band_edges.iter().map(|e| e.1).fold(0.0, f64::max).mul_add(16.0, 0.0).max(48_000.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eta_keeps_its_precision_at_the_apex() {
        // cosh η − 1 from the cancellation-free form equals the naive form where the latter is
        // exact enough, and stays positive and ∝ Δz² very close to the apex.
        let g = WedgeGeometry::new(2.0 * PI, (2.0, 1.0, 0.3), (3.0, 4.0, -0.4));
        for dz in [0.5, 0.1] {
            let z = g.apex() + dz;
            let (ds, dr) = (z - g.z_s, z - g.z_r);
            let naive = ((g.r_s * g.r_s + ds * ds).sqrt() * (g.r_r * g.r_r + dr * dr).sqrt() + ds * dr) / (g.r_s * g.r_r) - 1.0;
            let (_, den) = g.denominator(z);
            let exact = (g.r_s + g.r_r).powi(2) * dz * dz / (g.r_s * g.r_r * den);
            assert!((naive - exact).abs() < 1e-12 * exact.max(1.0), "{naive} {exact}");
        }
    }

    #[test]
    fn across_a_boundary_the_response_jumps_by_the_geometric_wave_with_bounded_work() {
        // A half-plane, source at θ = 60°, receiver 1e-7 rad either side of the shadow boundary
        // at 240°: the response's integral (H at 0 Hz) jumps by 1/L, the direct wave's, up on the
        // shadow side (module docs), and each side costs at most 15 calls a bin plus the
        // refinement budget.
        let total = |eps: f64| {
            let g = WedgeGeometry::new(2.0 * PI, (2.0, 60f64.to_radians(), 0.0), (3.0, 240f64.to_radians() + eps, 0.5));
            let r = binned_response(&g, -30.0, 30.0, 343.0, 96_000.0);
            assert!(r.integrand_calls <= 15 * 2 * r.bins.len() as u64 + REFINEMENT_CALLS, "{} calls", r.integrand_calls);
            (r.bins.iter().sum::<f64>() + r.impulses.iter().map(|x| x.value).sum::<f64>(), g.path(g.apex()))
        };
        let ((shadow, l), (lit, _)) = (total(1e-7), total(-1e-7));
        assert!((shadow - lit - 1.0 / l).abs() < 1e-3 / l, "jump {} against {}", shadow - lit, 1.0 / l);
    }
}
