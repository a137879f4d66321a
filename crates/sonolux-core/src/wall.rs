//! A locally reacting wall: its absorption at each angle of incidence, its random-incidence
//! (statistical) absorption, and the real admittance whose random-incidence absorption is a
//! material's coefficient. Shared by the wave solver ([`crate::wave`], whose walls are locally
//! reacting by construction) and the sound tracer and image sources ([`crate::sound::reflectance`],
//! which may use the same wall), so that both sides of the hybrid's crossover absorb alike.
//!
//! A locally reacting wall of specific (ρc-normalised) admittance β = g + jb reflects a plane
//! wave arriving at θ from its normal with R(θ) = (cos θ − β)/(cos θ + β), so it absorbs
//!
//!   α(θ) = 1 − |R(θ)|² = 4g·cos θ / ((cos θ + g)² + b²)
//!
//! (Kuttruff, *Room Acoustics*, 5th ed., 2009, §2.3 "Sound reflection at oblique incidence", for
//! a wall whose impedance does not depend on the angle; Morse and Ingard, *Theoretical
//! Acoustics*, 1968, §6.3). Averaged over a diffuse field (every direction alike, each weighted
//! by the energy it brings to the wall, cos θ), ∫₀^{π/2} α(θ) sin 2θ dθ is the random-incidence
//! absorption (Kuttruff §2.5 "Random sound incidence"): for a real g, Paris' formula (E. T.
//! Paris, Phil. Mag. 5, 1928; A. London, "The determination of reverberant sound absorption
//! coefficients from acoustic impedance measurements", JASA 22, 1950, for the complex β).

/// Absorption of a locally reacting wall of specific admittance `g` + j`b` at incidence
/// cos θ = `cos_incidence` (from the normal, ≥ 0): 4g·cos θ / ((cos θ + g)² + b²).
#[inline]
pub fn locally_reacting_absorption(g: f64, b: f64, cos_incidence: f64) -> f64 {
    let c = cos_incidence.max(0.0);
    let d = (c + g) * (c + g) + b * b;
    if d > 0.0 {
        4.0 * g * c / d
    } else {
        0.0
    }
}

/// Random-incidence absorption of a wall of real specific admittance g (Paris 1928):
/// 8g[1 + g/(1 + g) − 2g·ln((1 + g)/g)].
pub fn paris_absorption(g: f64) -> f64 {
    if g <= 0.0 {
        return 0.0;
    }
    8.0 * g * (1.0 + g / (1.0 + g) - 2.0 * g * ((1.0 + g) / g).ln())
}

/// The admittance at which Paris' absorption peaks (0.951 at g ≈ 0.64), by golden section.
pub(crate) fn paris_peak() -> f64 {
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

/// The most a locally reacting wall absorbs at random incidence (0.951, Paris' peak).
pub fn max_random_absorption() -> f64 {
    paris_absorption(paris_peak())
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

    /// The diffuse-field mean of α(θ), ∫ α(θ) sin 2θ dθ by the midpoint rule, is Paris'
    /// closed form (the two are independent: one is the integral, the other its antiderivative
    /// evaluated). Tolerance 1e-6: the rule's error with 20,000 intervals.
    #[test]
    fn the_diffuse_mean_of_the_angular_absorption_is_paris() {
        for g in [0.001, 0.00665, 0.0506, 0.3, 0.64, 2.0] {
            let n = 20_000;
            let h = std::f64::consts::FRAC_PI_2 / n as f64;
            let mean: f64 = (0..n).map(|i| (i as f64 + 0.5) * h).map(|t| locally_reacting_absorption(g, 0.0, t.cos()) * (2.0 * t).sin() * h).sum();
            assert!((mean - paris_absorption(g)).abs() < 1e-6, "g {g}: {mean} vs {}", paris_absorption(g));
        }
        // Normal incidence: 4g/(1 + g)²; grazing: nothing.
        assert!((locally_reacting_absorption(0.3, 0.0, 1.0) - 1.2 / 1.69).abs() < 1e-15);
        assert_eq!(locally_reacting_absorption(0.3, 0.0, 0.0), 0.0);
        // A reactance absorbs less at the same conductance: |R|² from the complex form.
        let (g, b, c) = (0.2, 0.5, 0.7);
        let r = num_complex::Complex64::new(c - g, -b) / num_complex::Complex64::new(c + g, b);
        assert!((locally_reacting_absorption(g, b, c) - (1.0 - r.norm_sqr())).abs() < 1e-15);
    }
}
