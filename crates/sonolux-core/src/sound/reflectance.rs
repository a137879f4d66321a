//! How much a surface absorbs of the sound that meets it: the wall model of the tracer and of the
//! image sources ([`crate::early::image_sources`]), one table for both so that a hybrid of the two
//! counts every path with the same energy.
//!
//! Two models, both from the material's random-incidence (statistical) coefficient α per band:
//! - [`WallModel::RandomIncidence`] (the default, and every plain bake's bits): α whatever the
//!   angle of incidence, as ODEON, CATT and pyroomacoustics apply it.
//! - [`WallModel::LocallyReacting`]: the wall of the wave solver. Each band gets the real
//!   admittance g whose random-incidence absorption by Paris' formula is α (the very g the waves'
//!   fit starts from, [`crate::wall::admittance_from_random`]), and sound meeting it at θ from the
//!   normal loses α(θ) = 1 − |(cos θ − g)/(cos θ + g)|² = 4g·cos θ/(cos θ + g)² ([`crate::wall`];
//!   Kuttruff, *Room Acoustics*, §2.3; London, JASA 22, 1950). Its mean over a diffuse field is α,
//!   so a diffuse room decays as with the default; where the field is not diffuse (hard,
//!   specular walls over one absorbing floor) sound grazing a surface is absorbed by it, as in
//!   the waves, instead of not at all. With it, the hybrid of waves below the crossover and rays
//!   above has one wall model on both sides (docs/waves-hybrid.md, "Why").
//!
//! Absorption is a property of the incident wave: it is applied on incidence, before the
//! reflected energy is split into its specular (1 − s) and scattered (s) parts, so it acts on the
//! whole reflection, whatever direction the energy then leaves in. This is how the scattering
//! coefficient is defined (ISO 17497-1:2004, §3.2: s is the share of the *reflected* energy that
//! is not specular; Vorländer, *Auralization*, 2008, §11.3).
//!
//! A locally reacting wall cannot absorb more than 0.951 at random incidence (Paris' maximum,
//! at g ≈ 0.64). A band whose coefficient is above that (measured coefficients of porous
//! absorbers reach 1, which no locally reacting wall does: their reaction is extended) keeps its
//! coefficient at every angle, and [`Walls::kept_constant`] names it. The waves clamp such a
//! band to the maximum instead (docs/waves-hybrid.md); the bake prints both.

use super::Acoustics;
use crate::wall::{admittance_from_random, locally_reacting_absorption, max_random_absorption};

/// How a wall's absorption depends on the angle of incidence.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum WallModel {
    /// The material's coefficient at every angle.
    #[default]
    RandomIncidence,
    /// A locally reacting wall whose random-incidence absorption is the coefficient.
    LocallyReacting,
}

impl WallModel {
    /// The names the scene and the binding use.
    pub const NAMES: [&'static str; 2] = ["random-incidence", "locally-reacting"];

    pub fn name(self) -> &'static str {
        match self {
            WallModel::RandomIncidence => Self::NAMES[0],
            WallModel::LocallyReacting => Self::NAMES[1],
        }
    }

    pub fn from_name(name: &str) -> Option<WallModel> {
        match name {
            "random-incidence" => Some(WallModel::RandomIncidence),
            "locally-reacting" => Some(WallModel::LocallyReacting),
            _ => None,
        }
    }
}

/// The walls of a bake: per material and band, the admittance of the locally reacting model.
#[derive(Clone, Debug, Default)]
pub struct Walls {
    model: WallModel,
    /// `[material][band]`, flattened as [`Acoustics::absorption`]: Paris' g of each coefficient,
    /// or a negative value for a band that keeps its coefficient (above Paris' maximum). Empty
    /// for [`WallModel::RandomIncidence`].
    admittance: Vec<f64>,
    /// 1 − α of every coefficient, computed once for the tracer's kernel, which multiplies a
    /// ray's energy by it at each reflection under [`WallModel::RandomIncidence`].
    kept: Vec<f64>,
}

impl Walls {
    pub fn new(model: WallModel, acoustics: &Acoustics) -> Walls {
        let admittance = match model {
            WallModel::RandomIncidence => Vec::new(),
            WallModel::LocallyReacting => {
                let peak = max_random_absorption();
                // A rigid band is exactly rigid (the bisection would leave a g of 1e-60).
                acoustics.absorption.iter().map(|&a| if a > peak { -1.0 } else if a <= 0.0 { 0.0 } else { admittance_from_random(a).0 }).collect()
            }
        };
        let kept = acoustics.absorption.iter().map(|&a| 1.0 - a).collect();
        Walls { model, admittance, kept }
    }

    pub fn model(&self) -> WallModel {
        self.model
    }

    /// The admittance g of material `material`'s band `band` in a bake of `n_bands` bands (None
    /// where the band keeps its coefficient, or with the random-incidence model).
    pub fn admittance(&self, material: usize, band: usize, n_bands: usize) -> Option<f64> {
        self.admittance.get(material * n_bands + band).copied().filter(|g| *g >= 0.0)
    }

    /// Whether every band keeps its coefficient at every angle ([`WallModel::RandomIncidence`]).
    pub fn random_incidence(&self) -> bool {
        self.admittance.is_empty()
    }

    /// [`Walls::absorption`] and what the surface keeps, 1 − α per band (`out_kept`), the
    /// random-incidence model's from a table made once: the same numbers, no subtraction a
    /// reflection. `coefficients` is the [`Acoustics::absorption`] the walls were made from.
    #[inline(always)]
    pub fn absorption_and_kept<'a>(&'a self, coefficients: &'a [f64], m: usize, cos_incidence: f64, out: &'a mut [f64], out_kept: &'a mut [f64]) -> (&'a [f64], &'a [f64]) {
        let nb = out.len();
        if self.admittance.is_empty() {
            debug_assert_eq!(coefficients.len(), self.kept.len());
            return (&coefficients[m..m + nb], &self.kept[m..m + nb]);
        }
        let alpha = self.absorption(coefficients, m, cos_incidence, out);
        for b in 0..nb {
            out_kept[b] = 1.0 - alpha[b];
        }
        (alpha, out_kept)
    }

    /// (material, band) of every band that keeps its coefficient at every angle under the
    /// locally reacting model: its coefficient is above what a locally reacting wall absorbs.
    pub fn kept_constant(&self, n_bands: usize) -> Vec<(usize, usize)> {
        self.admittance.iter().enumerate().filter(|(_, g)| **g < 0.0).map(|(i, _)| (i / n_bands, i % n_bands)).collect()
    }

    /// The absorption, per band, of the material whose bands start at `m` in `coefficients`
    /// (the [`Acoustics::absorption`] table) for sound meeting it at cos θ = `cos_incidence`
    /// (from its normal). The coefficients themselves under the random-incidence model (no
    /// copy: the same bits as before this model existed); else written into `out`.
    #[inline]
    pub fn absorption<'a>(&self, coefficients: &'a [f64], m: usize, cos_incidence: f64, out: &'a mut [f64]) -> &'a [f64] {
        let nb = out.len();
        let alpha = &coefficients[m..m + nb];
        if self.admittance.is_empty() {
            return alpha;
        }
        let c = cos_incidence.clamp(0.0, 1.0);
        for b in 0..nb {
            let g = self.admittance[m + b];
            out[b] = if g < 0.0 { alpha[b] } else { locally_reacting_absorption(g, 0.0, c) };
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wall::paris_absorption;

    fn acoustics() -> Acoustics {
        Acoustics { n_bands: 3, absorption: vec![0.05, 0.3, 0.99, 0.0, 0.6, 0.95], scattering: vec![0.1; 6] }
    }

    #[test]
    fn random_incidence_hands_back_the_coefficients() {
        let ac = acoustics();
        let walls = Walls::new(WallModel::RandomIncidence, &ac);
        let mut out = [0.0; 3];
        assert_eq!(walls.absorption(&ac.absorption, 3, 0.2, &mut out), &ac.absorption[3..6]);
        assert!(walls.kept_constant(3).is_empty());
    }

    #[test]
    fn locally_reacting_walls_absorb_by_angle_with_the_coefficient_as_their_mean() {
        let ac = acoustics();
        let walls = Walls::new(WallModel::LocallyReacting, &ac);
        // 0.99 is above Paris' 0.951: kept at every angle.
        assert_eq!(walls.kept_constant(3), vec![(0, 2)]);
        let mut out = [0.0; 3];
        let a = walls.absorption(&ac.absorption, 0, 1.0, &mut out).to_vec();
        let g = walls.admittance(0, 1, 3).unwrap();
        assert!((paris_absorption(g) - 0.3).abs() < 1e-9);
        assert!((a[1] - 4.0 * g / ((1.0 + g) * (1.0 + g))).abs() < 1e-15);
        assert_eq!(a[2], 0.99);
        // A rigid material stays rigid; grazing sound is not absorbed.
        assert_eq!(walls.absorption(&ac.absorption, 3, 0.5, &mut out)[0], 0.0);
        assert_eq!(walls.absorption(&ac.absorption, 0, 0.0, &mut out)[1], 0.0);
        for name in WallModel::NAMES {
            assert_eq!(WallModel::from_name(name).unwrap().name(), name);
        }
        assert_eq!(WallModel::from_name("diffuse"), None);
    }
}
