//! Absorption and scattering that depend on the angle of incidence, α(θ, f) and s(θ, f), for
//! materials whose surface is described (a profile, docs/scene.md `surface`), so that the rays
//! and the image sources absorb and scatter at each reflection what the same surface model gives
//! the wave solver's walls.
//!
//! A scene's plain scattering coefficient is ISO 17497-1's random-incidence one (Vorländer and
//! Mommertz, Applied Acoustics 60(2), 2000), applied at every angle as ODEON and CATT do. A
//! surface model turns it into s(θ, f): for the phase-grating wells of Kowalczyk, van Walstijn
//! and Murphy (IEEE TASLP 19(3), 2011), each well reflecting locally with
//! R_n = (cos θ − β_n)/(cos θ + β_n), β_n = j·tan(k d_n), the specular share is |⟨R_n⟩|²/⟨|R_n|²⟩
//! (Mommertz and Vorländer's phase-locked average), so s(θ) = 1 − |⟨R⟩|²/⟨|R|²⟩. The Python
//! library computes that per band (python/sonolux/acoustics/surface.py); this table carries it
//! into the bounce, with the absorption α(θ) = 1 − ⟨|R_n|²⟩ of the same wells (each well's
//! admittance the material's conductance plus j·tan(k d_n), as the waves' walls).
//!
//! The table holds α and s at `n_cos` nodes evenly spaced in cos θ over [0, 1] (θ from the
//! normal), per material and band; between nodes it is linear in cos θ. Materials without a
//! profile have no rows and keep their coefficients (the same bits as without a table).

use crate::CoreError;

/// α(cos θ) and s(cos θ) per band for the materials that have a surface profile.
#[derive(Clone, Debug, PartialEq)]
pub struct ScatteringByAngle {
    n_bands: usize,
    n_cos: usize,
    /// Per material: the first value of its rows in `table`, or None (its coefficient at every angle).
    row: Vec<Option<usize>>,
    /// `[profiled material][α, s][cos node][band]`, flattened.
    table: Vec<f64>,
}

impl ScatteringByAngle {
    /// From `rows[material]`: None, or Some(values) holding `2 × n_cos × n_bands` values in
    /// [0, 1] (`[α, s][cos node][band]`, nodes evenly spaced in cos θ from 0, grazing, to 1,
    /// normal).
    pub fn new(n_bands: usize, n_cos: usize, rows: &[Option<Vec<f64>>]) -> Result<Self, CoreError> {
        if n_bands == 0 || n_cos < 2 {
            return Err(CoreError::invalid("by_angle", format!("needs at least 2 angles and 1 band, got {n_cos} and {n_bands}")));
        }
        let mut row = Vec::with_capacity(rows.len());
        let mut table = Vec::new();
        for (m, r) in rows.iter().enumerate() {
            match r {
                None => row.push(None),
                Some(values) => {
                    if values.len() != 2 * n_cos * n_bands {
                        return Err(CoreError::invalid("by_angle", format!("material {m}: {} values given, 2 × {n_cos} angles × {n_bands} bands expected", values.len())));
                    }
                    if values.iter().any(|s| !(0.0..=1.0).contains(s)) {
                        return Err(CoreError::invalid("by_angle", format!("material {m}: every absorption and scattering coefficient must lie in [0, 1]")));
                    }
                    row.push(Some(table.len()));
                    table.extend_from_slice(values);
                }
            }
        }
        Ok(ScatteringByAngle { n_bands, n_cos, row, table })
    }

    pub fn n_bands(&self) -> usize {
        self.n_bands
    }

    /// Materials the table speaks for (profiled or not).
    pub fn n_materials(&self) -> usize {
        self.row.len()
    }

    /// Whether material `material` has a profile (its scattering depends on the angle).
    #[inline]
    pub fn profiled(&self, material: usize) -> bool {
        matches!(self.row.get(material), Some(Some(_)))
    }

    /// Whether every profiled material scatters every band alike at every angle.
    pub fn uniform(&self) -> bool {
        let half = self.n_cos * self.n_bands;
        self.table.chunks(2 * half).all(|rows| rows[half..].chunks(self.n_bands).all(|s| s.iter().all(|&x| x == s[0])))
    }

    /// Writes into `out` (n_bands) material `material`'s s at cos θ = `cos_incidence` (clamped
    /// to [0, 1]); false (nothing written) when the material has no profile.
    #[inline]
    pub fn scattering(&self, material: usize, cos_incidence: f64, out: &mut [f64]) -> bool {
        self.at(material, 1, cos_incidence, out)
    }

    /// Writes into `out` material `material`'s α at cos θ = `cos_incidence`; false (nothing
    /// written) when the material has no profile.
    #[inline]
    pub fn absorption(&self, material: usize, cos_incidence: f64, out: &mut [f64]) -> bool {
        self.at(material, 0, cos_incidence, out)
    }

    #[inline]
    fn at(&self, material: usize, which: usize, cos_incidence: f64, out: &mut [f64]) -> bool {
        let Some(Some(first)) = self.row.get(material) else {
            return false;
        };
        let nb = self.n_bands;
        let start = first + which * self.n_cos * nb;
        let x = cos_incidence.clamp(0.0, 1.0) * (self.n_cos - 1) as f64;
        let i = (x as usize).min(self.n_cos - 2);
        let t = x - i as f64;
        let a = &self.table[start + i * nb..start + (i + 1) * nb];
        let b = &self.table[start + (i + 1) * nb..start + (i + 2) * nb];
        for k in 0..nb {
            out[k] = a[k] + (b[k] - a[k]) * t;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_linearly_in_cos_and_keeps_a_constant_exactly() {
        // Two bands, three nodes (cos 0, 0.5, 1). Absorption: band 0 constant, band 1 falling;
        // scattering: band 0 rises linearly, band 1 is constant.
        let rows = vec![None, Some(vec![0.3, 0.2, 0.3, 0.1, 0.3, 0.0, 0.0, 0.1, 0.2, 0.1, 0.4, 0.1])];
        let t = ScatteringByAngle::new(2, 3, &rows).unwrap();
        let mut out = [0.0; 2];
        assert!(!t.scattering(0, 0.3, &mut out) && !t.absorption(0, 0.3, &mut out));
        for c in [0.0, 0.1, 0.25, 0.5, 0.77, 1.0, 1.5, -0.2] {
            let cc = f64::clamp(c, 0.0, 1.0);
            assert!(t.scattering(1, c, &mut out));
            assert!((out[0] - 0.4 * cc).abs() < 1e-15, "{c}: {out:?}");
            assert_eq!(out[1], 0.1, "a constant row is the constant, bit for bit");
            assert!(t.absorption(1, c, &mut out));
            assert_eq!(out[0], 0.3);
            assert!((out[1] - 0.2 * (1.0 - cc)).abs() < 1e-15, "{c}: {out:?}");
        }
        assert!(!t.uniform());
    }

    #[test]
    fn refuses_a_table_of_the_wrong_shape_or_range() {
        assert!(ScatteringByAngle::new(2, 1, &[]).is_err());
        assert!(ScatteringByAngle::new(2, 3, &[Some(vec![0.1; 6])]).is_err());
        assert!(ScatteringByAngle::new(1, 2, &[Some(vec![0.1, 0.1, 0.1, 1.2])]).is_err());
        assert!(ScatteringByAngle::new(1, 2, &[Some(vec![0.1; 4])]).unwrap().uniform());
    }
}
