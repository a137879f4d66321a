//! Described surfaces in the waves: a material with a profile of wells (docs/scene.md
//! `surface`) gives every boundary face the well of its patch, behind the material's own fitted
//! wall, so that the waves see the surface the rays are told of (sound/scattering.rs).
//!
//! The model is the phase grating of Kowalczyk, van Walstijn and Murphy (IEEE TASLP 19(3),
//! 528–537, 2011): the surface is tiled with patches, each a rigid-backed well of one of the
//! profile's depths. A well of depth d has at its mouth the specific admittance j·tan(kd), whose
//! Foster expansion tan x = Σ_n 2x/((n − ½)²π² − x²) is a sum of series mass–spring branches
//! 1/(D s + F_n/s), D = d/(2c), F_n = (n − ½)²π²c/(2d): the solver's own passive branches
//! (Bilbao, Hamilton, Botts and Savioja 2016; `boundary.rs`), so the wall stays stable by
//! construction (tests/wave_scattering.rs measured the scattering these wells give).
//!
//! Truncation. The branches whose resonances (2n − 1)c/(4d) lie at or below the grid's
//! `max_frequency_hz`, and three more, are kept. The rest of the sum is, below its resonances, a
//! pure compliance Σ_{n>N} 2d/((n − ½)²π²c) (the residual compliance of a truncated modal sum):
//! it is added to the last kept branch (its 1/F), so that the low-frequency limit Y → s·d/c is
//! exact. With three branches Y is within 0.31 % of j·tan(kd) up to kd = 1.2 (unit test: 0.4 %).
//!
//! The material's own wall (its fit to the absorption, `fit.rs`) sits at the mouth in parallel:
//! each patch's admittance is the fit's plus the well's, Y_n = Y_m + j·tan(k d_n), the admittance
//! the rays' table is computed from (python/sonolux/acoustics/surface.py: β_n = g + j·tan(k d_n)).
//!
//! Which depth a patch has: patches are the cubes of side `patch_m` on a lattice from the world
//! origin; a face belongs to the patch holding its boundary point (the node moved half a cell
//! towards the wall), and the patch's depth is drawn by a fixed hash (SplitMix64, Steele, Lea and
//! Flood 2014) of the material and the patch's lattice coordinates: equally likely, the same on
//! every machine and thread count.

use crate::error::CoreError;

use super::admittance::{Admittance, Branch};
use super::fit::MaterialFit;
use super::grid::Grid;
use super::voxel::Face;

/// A material's wells: depths (m), each equally likely, one per cubic patch of side `patch_m`.
#[derive(Clone, Debug, PartialEq)]
pub struct Wells {
    pub depths_m: Vec<f64>,
    pub patch_m: f64,
}

impl Wells {
    pub fn validate(&self, material: usize) -> Result<(), CoreError> {
        let ok = !self.depths_m.is_empty() && self.depths_m.iter().all(|d| d.is_finite() && *d >= 0.0) && self.depths_m.iter().any(|d| *d > 0.0);
        if !(ok && self.patch_m > 0.0 && self.patch_m.is_finite()) {
            return Err(CoreError::invalid("wells", format!("material {material}: depths {:?} (at least one, each ≥ 0, one > 0) and patch {} m (positive) expected", self.depths_m, self.patch_m)));
        }
        Ok(())
    }
}

/// The Foster branches of a rigid-backed well of depth `depth_m` (module doc: the branches up to
/// `max_frequency_hz` and three more, the rest folded into the last as a compliance). None for d = 0.
pub fn well_branches(depth_m: f64, speed_of_sound_m_s: f64, max_frequency_hz: f64) -> Vec<Branch> {
    if depth_m <= 0.0 {
        return Vec::new();
    }
    let (d, c) = (depth_m, speed_of_sound_m_s);
    let n_kept = well_branch_count(d, c, max_frequency_hz);
    let compliance = |n: usize| {
        let a = (n as f64 - 0.5) * std::f64::consts::PI;
        2.0 * d / (a * a * c)
    };
    // Σ_n 1/F_n over all n is d/c; the last kept branch takes what the dropped ones held.
    let kept: f64 = (1..=n_kept).map(compliance).sum();
    let residual = (d / c - kept).max(0.0);
    (1..=n_kept)
        .map(|n| {
            let extra = if n == n_kept { residual } else { 0.0 };
            Branch { mass_s: d / (2.0 * c), resistance: 0.0, stiffness_per_s: 1.0 / (compliance(n) + extra) }
        })
        .collect()
}

/// How many branches [`well_branches`] keeps for a well of depth `depth_m`: those resonating at
/// (2n − 1)c/(4d) ≤ `max_frequency_hz`, and three more (0 for d ≤ 0). The memory estimate counts
/// them before anything is built (settings.rs).
pub fn well_branch_count(depth_m: f64, speed_of_sound_m_s: f64, max_frequency_hz: f64) -> usize {
    if depth_m <= 0.0 {
        return 0;
    }
    ((4.0 * depth_m * max_frequency_hz / speed_of_sound_m_s + 1.0) / 2.0).floor().max(0.0) as usize + 3
}

/// Each face's wall: a material without wells keeps its own (index = material id); a material
/// with wells has one wall per depth, appended after the materials' walls.
pub(crate) struct WallChoice {
    /// Per material: (first wall, depth count, patch side m) of its wells, or None.
    wells: Vec<Option<(u32, u32, f64)>>,
}

/// The walls of every material and of every (material, depth), and how faces choose among them.
pub(crate) fn expand(mut fits: Vec<MaterialFit>, wells: &[Option<Wells>], speed_of_sound_m_s: f64, max_frequency_hz: f64) -> Result<(Vec<MaterialFit>, WallChoice), CoreError> {
    if !wells.is_empty() && wells.len() != fits.len() {
        return Err(CoreError::invalid("wells", format!("{} entries given; the mesh names {} materials", wells.len(), fits.len())));
    }
    let mut choice = WallChoice { wells: vec![None; fits.len()] };
    for (m, w) in wells.iter().enumerate() {
        let Some(w) = w else { continue };
        w.validate(m)?;
        choice.wells[m] = Some((fits.len() as u32, w.depths_m.len() as u32, w.patch_m));
        for &d in &w.depths_m {
            let base = &fits[m];
            let mut branches = base.admittance.branches.clone();
            branches.extend(well_branches(d, speed_of_sound_m_s, max_frequency_hz));
            let admittance = Admittance { conductance: base.admittance.conductance, branches };
            fits.push(MaterialFit { admittance, ..base.clone() });
        }
    }
    Ok((fits, choice))
}

impl WallChoice {
    /// Every face takes its material's wall.
    pub fn none() -> WallChoice {
        WallChoice { wells: Vec::new() }
    }

    /// The wall of `face`, whose triangle is of material `material`.
    #[inline]
    pub fn wall(&self, grid: &Grid, face: &Face, material: u32) -> u32 {
        let Some(Some((first, n, patch_m))) = self.wells.get(material as usize) else {
            return material;
        };
        // The face's boundary point: the node moved half a cell towards the wall.
        let axis = face.dir as usize / 2;
        let sign = if face.dir % 2 == 1 { 0.5 } else { -0.5 };
        let mut p = grid.position(face.node as usize);
        p[axis] += sign * grid.spacing_m;
        let q = (p / *patch_m).floor();
        let key = [material as u64, q.x as i64 as u64, q.y as i64 as u64, q.z as i64 as u64];
        let h = key.iter().fold(0x9e37_79b9_7f4a_7c15u64, |h, &k| splitmix64(h ^ k));
        first + (h % *n as u64) as u32
    }
}

/// SplitMix64's finaliser (Steele, Lea and Flood, OOPSLA 2014).
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64 as C64;

    #[test]
    fn the_truncated_well_follows_tan_kd() {
        // 6 cm, c = 343 m/s: kd = 1.2 at 1,092 Hz. With f_max low enough for three branches the
        // admittance is within 0.31 % of tan(kd) up to kd = 1.2 (asserted 0.4 %), and the
        // low-frequency limit is exact.
        let (d, c) = (0.06, 343.0);
        let w = Admittance { conductance: 0.0, branches: well_branches(d, c, 300.0) };
        assert_eq!(w.branches.len(), 3);
        for kd in [1e-3, 0.25, 0.5, 0.8, 1.0, 1.2] {
            let omega = kd * c / d;
            let y = w.at(C64::new(0.0, omega));
            let rel = (y.im / f64::tan(kd) - 1.0).abs();
            assert!(y.re.abs() < 1e-12 && rel < 4e-3, "kd {kd}: {y} against j·{}: {rel:.2e}", f64::tan(kd));
        }
        assert!(well_branches(0.0, c, 300.0).is_empty());
        // A deeper well keeps every resonance up to f_max: 0.5 m resonates at 171.5 and 514.5 Hz.
        assert_eq!(well_branches(0.5, c, 600.0).len(), 5);
    }

    #[test]
    fn faces_of_a_patch_share_a_well_and_the_depths_are_equally_likely() {
        // A floor of 40 × 40 m at z = 0 seen from the air nodes at z = h (faces towards −z), on
        // a 5 cm grid; patches of 0.5 m: 6,400 patches of 100 faces each. Depths 0.01, 0.02,
        // 0.03 (walls 2, 3, 4 after two materials); material 0 has none.
        use crate::geometry::Aabb;
        use glam::Vec3;
        let h = 0.05;
        let grid = Grid::over(&Aabb { min: Vec3::new(0.0, 0.0, -0.1), max: Vec3::new(40.0, 40.0, 0.1) }, h).unwrap();
        let fit = |_| MaterialFit { admittance: Admittance { conductance: 0.05, branches: Vec::new() }, n_bands_fitted: 0, target_normal: Vec::new(), fitted_normal: Vec::new(), error_db: Vec::new(), clamped: false, ripple_tolerance: 0.0 };
        let wells = vec![None, Some(Wells { depths_m: vec![0.01, 0.02, 0.03], patch_m: 0.5 })];
        let (walls, choice) = expand(vec![fit(0), fit(1)], &wells, 343.0, 500.0).unwrap();
        assert_eq!(walls.len(), 5);
        assert_eq!(walls[4].admittance.branches.len(), 3);
        let z = (0..grid.dims[2]).find(|&k| (grid.coordinate(2, k) - h).abs() < 1e-9 || grid.coordinate(2, k) > 0.0).unwrap();
        let mut count = [0usize; 3];
        let mut per_patch = std::collections::HashMap::new();
        for i in 0..grid.dims[0] {
            for j in 0..grid.dims[1] {
                let (x, y) = (grid.coordinate(0, i), grid.coordinate(1, j));
                if !(0.0..40.0).contains(&x) || !(0.0..40.0).contains(&y) {
                    continue;
                }
                let face = Face { node: grid.index(i, j, z) as u32, dir: 4, tri: 0 };
                assert_eq!(choice.wall(&grid, &face, 0), 0, "material 0 keeps its wall");
                let w = choice.wall(&grid, &face, 1);
                assert!((2..5).contains(&w));
                count[w as usize - 2] += 1;
                let patch = ((x / 0.5).floor() as i64, (y / 0.5).floor() as i64);
                assert_eq!(*per_patch.entry(patch).or_insert(w), w, "one well a patch");
            }
        }
        // Per depth, patches ~ Binomial(6,400, 1/3): σ ≈ 37.7 patches; 5σ.
        let patches = per_patch.len() as f64;
        let mut by_depth = [0.0f64; 3];
        for w in per_patch.values() {
            by_depth[*w as usize - 2] += 1.0;
        }
        let sigma = (patches * (1.0 / 3.0) * (2.0 / 3.0)).sqrt();
        for n in by_depth {
            assert!((n - patches / 3.0).abs() < 5.0 * sigma, "{by_depth:?} of {patches}");
        }
        assert_eq!(count.iter().sum::<usize>() as f64, patches * 100.0);
    }
}
