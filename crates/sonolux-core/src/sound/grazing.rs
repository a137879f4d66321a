//! Sound travelling nearly parallel to two parallel surfaces (a flat floor under a flat ceiling):
//! the tracer's stand-in for the pair's grazing mode (docs/waves-grazing.md).
//!
//! Why. Between two parallel locally reacting planes a distance D apart, of normalised
//! admittances β_a and β_b, the field's dependence across the gap is one of the 1D modes
//! cos(κz) + (jkβ_a/κ) sin(κz), whose κ solves the boundary conditions at both planes
//! (Morse and Ingard, *Theoretical Acoustics*, 1968, §9.4). For small admittance
//! κ_n² ≈ (nπ/D)² + jk ε_n (β_a + β_b)/D, ε₀ = 1 and ε_n = 2 otherwise: the grazing mode
//! (n = 0) loses energy at half the rate of the others, not at none (Kuttruff, *Room Acoustics*,
//! 6th ed., §3.5, the damping constants of axial, tangential and oblique modes). A ray has no
//! such floor: one launched at cos θ → 0 to the pair's normal meets it ever more rarely and, by
//! the plane-wave α(θ) = 4g cos θ/(cos θ + g)², ever more weakly, so a specular tracer keeps it
//! for ever. Counted in the direction cosine u = |cos θ|, the modes of the pair sit at
//! u_n = nπ/(kD); the rays that stand for mode n are those with u in [u_n, u_{n+1}): each mode
//! the same share π/(kD) of the diffuse field's uniform u, as the lattice count of the modes
//! (its boundary plane n = 0 included, Weyl's surface term) gives each. The rays below
//! u₁ = π/(kD) therefore stand for the grazing mode: they lose energy along their path at the
//! mode's rate, Im κ₀²/k per metre (the energy of exp(−j√(k² − κ₀²) x)), and not at their hits on
//! the pair's planes (their absorption is the mode's). Every other ray is untouched.
//!
//! Where the mode's energy is. The grazing mode is not uniform across the gap: its energy density
//! is |ψ₀(z)|² = |cos κ₀z + (jkβ_a/κ₀) sin κ₀z|², κ₀ complex, lower by the absorbing plane and
//! higher by the other (paper-large's first ray band: 0.73 of its mean at the floor, 1.24 at the
//! ceiling, 0.78 at the talker's 1.5 m). A source at height z_s feeds the mode in proportion to
//! |ψ₀(z_s)|² and a receiver at z_r reads it in proportion to |ψ₀(z_r)|² (the modal expansion of
//! the Green's function, Morse and Ingard §9.4–9.5: a mode's term is ψ(s)ψ(r)/Λ). So a ray of
//! the grazing mode carries `profile`, |ψ₀|² over its mean across the gap, both ways: its
//! deposits are weighed by the profile where they are made, and its energy by the profile at its
//! source when it meets the pair's planes for the first time still specular from its source (the
//! change tallied as re-weighted, the source's coupling to the mode). Before it first meets the
//! pair the ray is not yet the gap's mode (the direct sound and the reflections off other walls
//! only; their field across the gap is free field), so neither weight applies. The mean of the
//! profile across the gap is 1: deposits over the gap keep the ray's energy.
//!
//! Python finds the pairs (python/sonolux/sound/grazing.py: parallel planes that both cover the
//! room's plan) and solves κ₀ per pair and band at the band's centre; this table carries the
//! result into the segment and the bounce. Measured: docs/waves-grazing.md.

use glam::DVec3;

use crate::CoreError;

/// Per pair of parallel planes and band: the cosine below which a ray is the pair's grazing
/// mode, and that mode's energy loss per metre.
#[derive(Clone, Debug, PartialEq)]
pub struct GrazingModes {
    n_bands: usize,
    /// The pairs' unit normals.
    normals: Vec<DVec3>,
    /// The pairs' planes, n·x = offset, one [a, b] a pair.
    offsets: Vec<[f64; 2]>,
    /// `[pair][band]`: u₁ = π/(kD), the first non-grazing mode's cosine.
    cos_limit: Vec<f64>,
    /// `[pair][band]`: the grazing mode's energy attenuation, 1/m (Im κ₀²/k).
    rate_per_m: Vec<f64>,
    /// How far from a pair's plane a hit may lie and still be on it, m.
    tolerance_m: f64,
    /// Nodes of each profile, evenly spaced from plane a to plane b (0: no profile, uniform).
    nodes: usize,
    /// `[pair][band][node]`: the grazing mode's energy density over its mean across the gap.
    profile: Vec<f64>,
    /// `[pair]`: the widest of its bands' limits (a ray steeper than it is no band's mode).
    widest: Vec<f64>,
}

impl GrazingModes {
    /// From each pair's normal, its planes' offsets along it, and `[pair][band]` flattened
    /// `cos_limit` (in [0, 1]) and `rate_per_m` (≥ 0, finite).
    pub fn new(n_bands: usize, normals: &[[f64; 3]], offsets: &[[f64; 2]], cos_limit: Vec<f64>, rate_per_m: Vec<f64>) -> Result<Self, CoreError> {
        let n = normals.len();
        let bad = |what: String| Err(CoreError::invalid("grazing", what));
        if n_bands == 0 || offsets.len() != n || cos_limit.len() != n * n_bands || rate_per_m.len() != n * n_bands {
            return bad(format!("{n} normals, {} offset pairs, {} limits and {} rates for {n_bands} bands: one offset pair a normal and one limit and rate a pair and band expected", offsets.len(), cos_limit.len(), rate_per_m.len()));
        }
        let normals: Vec<DVec3> = normals.iter().map(|v| DVec3::from_array(*v)).collect();
        if normals.iter().any(|v| !v.is_finite() || (v.length() - 1.0).abs() > 1e-9) {
            return bad("every normal must be a finite unit vector".into());
        }
        if offsets.iter().any(|o| !(o[0].is_finite() && o[1].is_finite() && o[0] != o[1])) {
            return bad("each pair's two planes must be finite and apart".into());
        }
        if cos_limit.iter().any(|c| !(0.0..=1.0).contains(c)) || rate_per_m.iter().any(|r| !(r.is_finite() && *r >= 0.0)) {
            return bad("every limit must lie in [0, 1] and every rate be finite and ≥ 0".into());
        }
        let extent = offsets.iter().flatten().fold(1.0f64, |m, o| m.max(o.abs()));
        Ok(GrazingModes { n_bands, normals, offsets: offsets.to_vec(), cos_limit, rate_per_m, tolerance_m: 1e-6 * extent, nodes: 0, profile: Vec::new(), widest: Vec::new() })
    }

    /// The same table with each pair's and band's grazing-mode profile, `[pair][band][node]`
    /// flattened, `nodes` (≥ 2) evenly spaced from the pair's plane a to its plane b: |ψ₀|² over
    /// its mean across the gap (finite, ≥ 0).
    pub fn with_profiles(mut self, nodes: usize, profile: Vec<f64>) -> Result<Self, CoreError> {
        if nodes < 2 || profile.len() != self.normals.len() * self.n_bands * nodes || profile.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return Err(CoreError::invalid("grazing", format!("{} profile values of {nodes} nodes for {} pairs and {} bands: at least 2 nodes, one value a pair, band and node, each finite and ≥ 0", profile.len(), self.normals.len(), self.n_bands)));
        }
        self.widest = self.cos_limit.chunks(self.n_bands).map(|l| l.iter().fold(0.0f64, |m, &x| m.max(x))).collect();
        (self.nodes, self.profile) = (nodes, profile);
        Ok(self)
    }

    /// The profile of pair `p` in band `b` at `point`, linear between its nodes (1 without).
    #[inline]
    fn profile_at(&self, p: usize, b: usize, point: DVec3) -> f64 {
        if self.nodes == 0 {
            return 1.0;
        }
        let [a, z] = self.offsets[p];
        let x = ((point.dot(self.normals[p]) - a) / (z - a)).clamp(0.0, 1.0) * (self.nodes - 1) as f64;
        let i = (x as usize).min(self.nodes - 2);
        let row = &self.profile[(p * self.n_bands + b) * self.nodes..][..self.nodes];
        row[i] + (x - i as f64) * (row[i + 1] - row[i])
    }

    /// A reflection at `point` (normal `normal`) of a ray along `dir` that has met the pairs in
    /// the bit mask `met`: on a pair's plane met for the first time, its bit is set and, if the
    /// ray is still `specular` from its source at `source`, each band in which it is that pair's
    /// grazing mode takes the profile at the source (module doc), the change tallied into
    /// `reweighted`.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn meet(&self, point: DVec3, normal: DVec3, dir: DVec3, specular: bool, source: DVec3, met: &mut u32, e: &mut [f64], reweighted: &mut [f64]) {
        let Some(p) = self.pair_at(point, normal).filter(|&p| p < 32 && *met & (1 << p) == 0) else { return };
        *met |= 1 << p;
        if !specular || self.nodes == 0 {
            return;
        }
        let u = dir.dot(self.normals[p]).abs();
        for b in (0..e.len()).filter(|&b| u < self.cos_limit[p * self.n_bands + b]) {
            let before = e[b];
            e[b] *= self.profile_at(p, b, source);
            reweighted[b] += e[b] - before;
        }
    }

    /// Whether a ray along `dir`, having met the pairs in `met`, is in some band the grazing mode
    /// of a met pair whose table has profiles: its deposits are then [`Self::weigh`]ed.
    #[inline]
    pub fn profiled(&self, dir: DVec3, met: u32) -> bool {
        self.nodes > 0 && met != 0 && self.normals.iter().zip(&self.widest).enumerate().any(|(p, (n, w))| p < 32 && met & (1 << p) != 0 && dir.dot(*n).abs() < *w)
    }

    /// A deposit `d` (per band) made at `point` by a ray along `dir` that has met the pairs in
    /// `met`: each band in which it is a met pair's grazing mode weighed by that pair's profile
    /// there (a ray along a room's edge is the mode of two pairs; a separable room's modes
    /// multiply).
    #[inline]
    pub fn weigh(&self, dir: DVec3, met: u32, point: DVec3, d: &mut [f64]) {
        for (p, n) in self.normals.iter().enumerate().filter(|&(p, _)| p < 32 && met & (1 << p) != 0) {
            let u = dir.dot(*n).abs();
            for b in (0..d.len()).filter(|&b| u < self.cos_limit[p * self.n_bands + b]) {
                d[b] *= self.profile_at(p, b, point);
            }
        }
    }

    pub fn n_bands(&self) -> usize {
        self.n_bands
    }

    /// Over a segment of `length_m` along `dir`: each band whose ray is some pair's grazing mode
    /// loses what that mode loses over the distance, tallied into `absorbed` (it is the walls').
    #[inline]
    pub fn attenuate(&self, dir: DVec3, length_m: f64, e: &mut [f64], absorbed: &mut [f64]) {
        // One exponential a band: the rates of every pair the ray grazes add (a ray along the
        // intersection of two pairs' planes, a room's edge, is the grazing mode of both).
        for b in 0..e.len() {
            let mut rate = 0.0;
            for (p, n) in self.normals.iter().enumerate() {
                let row = p * self.n_bands;
                if dir.dot(*n).abs() < self.cos_limit[row + b] {
                    rate += self.rate_per_m[row + b];
                }
            }
            if rate > 0.0 {
                let kept = e[b] * super::air::exp(-rate * length_m); // same bits on every machine
                absorbed[b] += e[b] - kept;
                e[b] = kept;
            }
        }
    }

    /// At a reflection at `point` on a surface of normal `normal`: the cosine limits per band
    /// of the pair whose plane it lies on (a ray meeting it below the limit is that pair's
    /// grazing mode, whose loss is taken along the path, not here), or None.
    #[inline]
    pub fn pair_limits(&self, point: DVec3, normal: DVec3) -> Option<&[f64]> {
        self.pair_at(point, normal).map(|p| &self.cos_limit[p * self.n_bands..(p + 1) * self.n_bands])
    }

    /// The pair whose plane a reflection at `point` on a surface of normal `normal` lies on.
    #[inline]
    fn pair_at(&self, point: DVec3, normal: DVec3) -> Option<usize> {
        self.normals.iter().enumerate().position(|(p, n)| {
            let o = point.dot(*n);
            let on_plane = (o - self.offsets[p][0]).abs() <= self.tolerance_m || (o - self.offsets[p][1]).abs() <= self.tolerance_m;
            normal.dot(*n).abs() >= 1.0 - 1e-9 && on_plane
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn floor_and_ceiling() -> GrazingModes {
        GrazingModes::new(2, &[[0.0, 0.0, 1.0]], &[[0.0, 2.0]], vec![0.2, 0.1], vec![0.03, 0.05]).unwrap()
    }

    #[test]
    fn a_grazing_ray_loses_the_modes_rate_along_its_path_and_nothing_at_the_pairs_planes() {
        let g = floor_and_ceiling();
        // cos 0.15 to the floor: grazing in band 0 (limit 0.2), not in band 1 (0.1).
        let dir = DVec3::new((1.0f64 - 0.15 * 0.15).sqrt(), 0.0, 0.15);
        let (mut e, mut absorbed) = ([1.0, 1.0], [0.0, 0.0]);
        g.attenuate(dir, 10.0, &mut e, &mut absorbed);
        assert!((e[0] - (-0.3f64).exp()).abs() < 1e-15 && e[1] == 1.0);
        assert!((e[0] + absorbed[0] - 1.0).abs() < 1e-15 && absorbed[1] == 0.0);
        // On the ceiling: the pair's limits; on a wall or a plane between the two (a table
        // top): none.
        assert_eq!(g.pair_limits(DVec3::new(1.0, 1.0, 2.0), DVec3::new(0.0, 0.0, -1.0)), Some(&[0.2, 0.1][..]));
        assert_eq!(g.pair_limits(DVec3::new(0.0, 1.0, 1.0), DVec3::new(1.0, 0.0, 0.0)), None);
        assert_eq!(g.pair_limits(DVec3::new(1.0, 1.0, 0.8), DVec3::new(0.0, 0.0, 1.0)), None);
    }

    #[test]
    fn a_ray_along_a_rooms_edge_is_the_grazing_mode_of_both_pairs() {
        let g = GrazingModes::new(1, &[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], &[[0.0, 2.0], [0.0, 6.0]], vec![0.2, 0.1], vec![0.03, 0.002]).unwrap();
        let (mut e, mut absorbed) = ([1.0], [0.0]);
        g.attenuate(DVec3::Y, 10.0, &mut e, &mut absorbed);
        assert!((e[0] - (-0.32f64).exp()).abs() < 1e-15 && (e[0] + absorbed[0] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn a_grazing_ray_met_by_its_pair_carries_the_modes_profile_at_its_source_and_its_deposits() {
        // Profile 0.5 at the floor rising to 1.5 at the ceiling (z 0–2 m) in band 0, uniform 1
        // in band 1; limits 0.2 and 0.1.
        let g = floor_and_ceiling().with_profiles(3, vec![0.5, 1.0, 1.5, 1.0, 1.0, 1.0]).unwrap();
        let dir = DVec3::new((1.0f64 - 0.15 * 0.15).sqrt(), 0.0, 0.15);
        let source = DVec3::new(1.0, 1.0, 0.5); // profile 0.75 there in band 0
        // Before it meets the pair: nothing to weigh (its direct sound is free field).
        assert!(!g.profiled(dir, 0));
        // A wall is not the pair's plane.
        let (mut met, mut e, mut rw) = (0u32, [1.0, 1.0], [0.0, 0.0]);
        g.meet(DVec3::new(0.0, 1.0, 1.0), DVec3::X, dir, true, source, &mut met, &mut e, &mut rw);
        assert_eq!((met, e), (0, [1.0, 1.0]));
        // The ceiling, first met, specular from the source: band 0 (in its cone) takes the
        // source's 0.75, band 1 (outside its cone) nothing; the change is re-weighted.
        g.meet(DVec3::new(1.0, 1.0, 2.0), DVec3::NEG_Z, dir, true, source, &mut met, &mut e, &mut rw);
        assert_eq!(met, 1);
        assert!((e[0] - 0.75).abs() < 1e-15 && e[1] == 1.0 && (rw[0] + 0.25).abs() < 1e-15 && rw[1] == 0.0);
        // Met again: no second coupling.
        g.meet(DVec3::new(2.0, 1.0, 0.0), DVec3::Z, dir, true, source, &mut met, &mut e, &mut rw);
        assert!((e[0] - 0.75).abs() < 1e-15);
        // Deposits: band 0 at z = 1.5 weighs 1.25, band 1 is kept.
        assert!(g.profiled(dir, met));
        let mut d = [1.0, 1.0];
        g.weigh(dir, met, DVec3::new(3.0, 1.0, 1.5), &mut d);
        assert!((d[0] - 1.25).abs() < 1e-15 && d[1] == 1.0);
        // A ray scattered off the pair before (not specular from its source) is not coupled.
        let (mut met, mut e, mut rw) = (0u32, [1.0, 1.0], [0.0, 0.0]);
        g.meet(DVec3::new(1.0, 1.0, 2.0), DVec3::NEG_Z, dir, false, source, &mut met, &mut e, &mut rw);
        assert_eq!((met, e, rw), (1, [1.0, 1.0], [0.0, 0.0]));
        // A steep ray is no grazing mode: nothing to weigh.
        assert!(!g.profiled(DVec3::Z, 1));
        // Without profiles: nothing to weigh.
        assert!(!floor_and_ceiling().profiled(dir, 1));
    }

    #[test]
    fn bad_tables_are_refused() {
        assert!(GrazingModes::new(2, &[[0.0, 0.0, 2.0]], &[[0.0, 2.0]], vec![0.2, 0.1], vec![0.0, 0.0]).is_err());
        assert!(GrazingModes::new(2, &[[0.0, 0.0, 1.0]], &[[1.0, 1.0]], vec![0.2, 0.1], vec![0.0, 0.0]).is_err());
        assert!(GrazingModes::new(2, &[[0.0, 0.0, 1.0]], &[[0.0, 2.0]], vec![1.2, 0.1], vec![0.0, 0.0]).is_err());
        assert!(GrazingModes::new(2, &[[0.0, 0.0, 1.0]], &[[0.0, 2.0]], vec![0.2, 0.1], vec![-1.0, 0.0]).is_err());
        assert!(GrazingModes::new(2, &[[0.0, 0.0, 1.0]], &[[0.0, 2.0]], vec![0.2], vec![0.0]).is_err());
        assert!(floor_and_ceiling().with_profiles(1, vec![1.0, 1.0]).is_err());
        assert!(floor_and_ceiling().with_profiles(2, vec![1.0, 1.0, 1.0]).is_err());
        assert!(floor_and_ceiling().with_profiles(2, vec![1.0, 1.0, -1.0, 1.0]).is_err());
    }
}
