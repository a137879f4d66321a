//! Receiver patterns: how a receiver weighs sound by the direction it arrives from (omni, the
//! first-order microphone family, a measured table). `receivers.rs` holds the spheres and the
//! grid that finds them; it applies these patterns to every deposit.

use std::sync::Arc;

use glam::DVec3;

use super::pattern::Pattern;

/// How a receiver weighs sound by the unit direction it arrives from (pointing from the
/// receiver towards where the sound comes from): an energy gain per band.
#[derive(Clone, Debug, PartialEq)]
pub enum ReceiverPattern {
    /// Gain 1 from every direction.
    Omni,
    /// The first-order family, pressure sensitivity a + (1 − a) cos θ, θ from the unit `axis`
    /// (Eargle, *The Microphone Book*, 2004, ch. 5), with energy gain |a + (1 − a) cos θ|^power:
    /// `power` 2 is the microphone's energy (1 on its axis: ISO 3382-1 A.2.4 calibrates the
    /// figure-of-eight's maximum to the omni's); `power` 1 with a = 0 is |cos θ|, the weight of
    /// the product |p_L · p| that JLFC integrates.
    FirstOrder { axis: DVec3, a: f64, power: f64 },
    /// A measured gain per band on the pattern's grid, kept at its level ([`Pattern::measured`]).
    Table(Arc<Pattern>),
}

impl ReceiverPattern {
    pub fn is_omni(&self) -> bool {
        matches!(self, ReceiverPattern::Omni)
    }

    /// Multiplies `energy` (one value a band) by the gain towards `from` (unit).
    #[inline]
    pub fn weigh(&self, from: DVec3, energy: &mut [f64], scratch: &mut [f64]) {
        match self {
            ReceiverPattern::Omni => {}
            ReceiverPattern::FirstOrder { axis, a, power } => {
                let g = (a + (1.0 - a) * axis.dot(from)).abs().powf(*power);
                energy.iter_mut().for_each(|e| *e *= g);
            }
            ReceiverPattern::Table(p) => {
                let g = &mut scratch[..energy.len()];
                p.gains(from, g);
                energy.iter_mut().zip(g.iter()).for_each(|(e, g)| *e *= g);
            }
        }
    }

    /// Multiplies `energy` by the mean gain over the sphere: sound from every direction alike
    /// (a source inside the receiver's sphere).
    pub fn weigh_mean(&self, energy: &mut [f64]) {
        match self {
            ReceiverPattern::Omni => {}
            ReceiverPattern::FirstOrder { a, power, .. } => {
                // The mean over the sphere of |a + (1 − a) x|^power, x = cos θ uniform in [−1, 1].
                let g = first_order_mean(*a, *power);
                energy.iter_mut().for_each(|e| *e *= g);
            }
            ReceiverPattern::Table(p) => energy.iter_mut().zip(p.mean_gain()).for_each(|(e, g)| *e *= g),
        }
    }

    /// The largest gain in any direction and band (bounds the field's fixed-point range).
    pub fn peak(&self) -> f64 {
        match self {
            ReceiverPattern::Omni => 1.0,
            ReceiverPattern::FirstOrder { a, power, .. } => a.abs().max((2.0 * a - 1.0).abs()).max(1.0).powf(*power),
            ReceiverPattern::Table(p) => p.max_gain(),
        }
    }

    /// Checks that the pattern fits a bake of `n_bands` bands.
    pub fn check(&self, n_bands: usize) -> Result<(), String> {
        match self {
            ReceiverPattern::FirstOrder { axis, a, power } if !(axis.is_finite() && (axis.length() - 1.0).abs() < 1e-6 && (0.0..=1.0).contains(a) && *power > 0.0 && power.is_finite()) => {
                Err(format!("a first-order pattern needs a unit axis, a in [0, 1] and a power > 0 (got axis {:?}, a {a}, power {power})", axis.to_array()))
            }
            ReceiverPattern::Table(p) if p.n_bands() != n_bands => Err(format!("its pattern has {} bands, the bake {n_bands}", p.n_bands())),
            _ => Ok(()),
        }
    }
}

/// The mean over the sphere of |a + (1 − a) cos θ|^power: with x = cos θ uniform in [−1, 1],
/// b = 1 − a and y = a + b x, (1/2b) ∫ |y|^p dy over [a − b, a + b] =
/// (|a + b|^(p+1) − sgn(a − b) |a − b|^(p+1)) / (2 b (p + 1)); a^p when b = 0.
pub fn first_order_mean(a: f64, power: f64) -> f64 {
    let b = 1.0 - a;
    if b.abs() < 1e-12 {
        return a.abs().powf(power);
    }
    let (hi, lo) = (a + b, a - b);
    (hi.abs().powf(power + 1.0) - lo.signum() * lo.abs().powf(power + 1.0)) / (2.0 * b * (power + 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_means_match_closed_forms() {
        // Mean energy over the sphere of (a + (1 − a) cos θ)²: a² + (1 − a)²/3 (random-incidence
        // response; Eargle 2004 ch. 5: 1/3 for the cardioid and figure-of-eight, 1/4 hyper).
        for a in [0.0, 0.25, 0.5, 0.75, 1.0] {
            let exact = a * a + (1.0 - a) * (1.0 - a) / 3.0;
            assert!((first_order_mean(a, 2.0) - exact).abs() < 1e-12, "a = {a}");
        }
        // |cos θ|: mean 1/2.
        assert!((first_order_mean(0.0, 1.0) - 0.5).abs() < 1e-12);
        let p = ReceiverPattern::FirstOrder { axis: DVec3::Y, a: 0.0, power: 2.0 };
        let mut e = [2.0, 4.0];
        p.weigh(DVec3::new(1.0, 1.0, 0.0).normalize(), &mut e, &mut [0.0; 2]);
        assert!((e[0] - 1.0).abs() < 1e-12 && (e[1] - 2.0).abs() < 1e-12);
        assert_eq!(p.peak(), 1.0);
        assert!((ReceiverPattern::FirstOrder { axis: DVec3::Y, a: 0.25, power: 2.0 }.peak() - 1.0).abs() < 1e-12);
    }
}
