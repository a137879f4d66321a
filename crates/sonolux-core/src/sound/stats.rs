//! What every sound bake reports: rays, segments, hits, escapes (with where they left), the
//! energy balance per band, and the measured mean free path.
//!
//! Energies are summed in fixed point (i128, 2⁻⁸⁰ J a count) so that statistics, like the field,
//! are the same bits for any thread count or split of the bake.

/// One ray that left the scene: a hole in the mesh, or an open scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Escape {
    pub source: u32,
    pub ray: u64,
    /// Where the escaping segment started, and its direction.
    pub from: [f64; 3],
    pub dir: [f64; 3],
}

/// How many escapes a run lists.
pub const LISTED_ESCAPES: usize = 16;
const ENERGY_QUANTUM: f64 = 1.0 / (1u128 << 80) as f64;

#[derive(Clone, Debug, Default)]
pub struct SoundStats {
    pub rays: u64,
    pub segments: u64,
    pub surface_hits: u64,
    pub escaped_rays: u64,
    pub escapes: Vec<Escape>,
    pub deposits: u64,
    /// Visibility (any-hit) tests of the rain and nee connections: one a connection to a
    /// receiver in front of the surface, in a room that is not convex.
    pub shadow_rays: u64,
    /// Receivers drawn from the nee estimator's tree (M a diffuse reflection when the bake has
    /// more than M receivers). With the segments and deposits: the counted work of a bake, the
    /// same on any machine (the automatic estimator ranks by it: docs/progressive.md).
    pub draws: u64,
    pub max_reflections: u64,
    /// Per band, fixed point: emitted, absorbed by surfaces, by air, escaped, left in rays when
    /// they stopped, and the net change from re-weighting at a reflection whose scattering
    /// differs between bands (zero in expectation; exactly zero when scattering is the same in
    /// every band).
    energy: [Vec<i128>; 6],
    /// Sum of the lengths of segments from one surface to the next (2⁻³² m a count), and their number.
    free_path_sum: i128,
    /// Sum of their squares (2⁻³² m² a count), for the variance that Kuttruff's correction of
    /// Eyring's formula needs.
    free_path_sq_sum: i128,
    pub free_paths: u64,
}

/// Indices into the energy tallies.
pub(crate) const EMITTED: usize = 0;
pub(crate) const ABSORBED_SURFACES: usize = 1;
pub(crate) const ABSORBED_AIR: usize = 2;
pub(crate) const ESCAPED: usize = 3;
pub(crate) const REMAINING: usize = 4;
pub(crate) const REWEIGHTED: usize = 5;
pub(crate) const KINDS: usize = 6;

/// `x.round() as i128` (half away from zero, saturating, NaN to 0), to the bit, without the two
/// library calls (`round`, and the f64 → i128 conversion) that cost more than a ray's tallies:
/// below 2⁵² through i64, where x − trunc(x) is exact; above, x is an integer already, and its
/// mantissa shifted by its exponent is its value.
#[inline]
pub(crate) fn round_i128(x: f64) -> i128 {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    if x.abs() < TWO_52 {
        let whole = x as i64;
        let frac = x - whole as f64;
        return i128::from(whole + i64::from(frac >= 0.5) - i64::from(frac <= -0.5));
    }
    let bits = x.to_bits();
    let exponent = ((bits >> 52) & 0x7ff) as i32 - 1075;
    if !(0..75).contains(&exponent) {
        return x as i128; // beyond 2¹²⁷, infinite or NaN: the cast's saturation
    }
    let magnitude = i128::from((bits & ((1u64 << 52) - 1)) | (1u64 << 52)) << exponent;
    if x < 0.0 { -magnitude } else { magnitude }
}

impl SoundStats {
    pub fn new(n_bands: usize) -> SoundStats {
        SoundStats { energy: std::array::from_fn(|_| vec![0; n_bands]), ..Default::default() }
    }

    #[inline]
    pub(crate) fn add_energy(&mut self, which: usize, band: usize, joules: f64) {
        self.energy[which][band] += round_i128(joules / ENERGY_QUANTUM);
    }

    /// Adds one ray's free paths: `count` of them, with lengths summing to `sum` and squares to
    /// `sum_sq` (a ray sums its own in f64, the same way on any thread: one conversion a ray).
    #[inline]
    pub(crate) fn add_free_paths(&mut self, count: u64, sum: f64, sum_sq: f64) {
        self.free_path_sum += round_i128(sum * (1u64 << 32) as f64);
        self.free_path_sq_sum += round_i128(sum_sq * (1u64 << 32) as f64);
        self.free_paths += count;
    }

    pub(crate) fn add_escape(&mut self, e: Escape) {
        self.escaped_rays += 1;
        self.escapes.push(e);
        self.escapes.sort_by_key(|e| (e.source, e.ray));
        self.escapes.truncate(LISTED_ESCAPES);
    }

    pub fn merge(&mut self, o: &SoundStats) {
        self.rays += o.rays;
        self.segments += o.segments;
        self.surface_hits += o.surface_hits;
        self.escaped_rays += o.escaped_rays;
        self.deposits += o.deposits;
        self.shadow_rays += o.shadow_rays;
        self.draws += o.draws;
        self.max_reflections = self.max_reflections.max(o.max_reflections);
        for (a, b) in self.energy.iter_mut().zip(&o.energy) {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
        self.free_path_sum += o.free_path_sum;
        self.free_path_sq_sum += o.free_path_sq_sum;
        self.free_paths += o.free_paths;
        self.escapes.extend_from_slice(&o.escapes);
        self.escapes.sort_by_key(|e| (e.source, e.ray));
        self.escapes.truncate(LISTED_ESCAPES);
    }

    pub(crate) fn finish(&mut self) {
        self.escapes.sort_by_key(|e| (e.source, e.ray));
    }

    /// Energy tally per band in joules: "emitted", "absorbed_surfaces", "absorbed_air",
    /// "escaped", "remaining", "reweighted".
    pub fn energy(&self, which: &str) -> Option<Vec<f64>> {
        let i = ["emitted", "absorbed_surfaces", "absorbed_air", "escaped", "remaining", "reweighted"].iter().position(|w| *w == which)?;
        Some(self.energy[i].iter().map(|&c| c as f64 * ENERGY_QUANTUM).collect())
    }

    /// Relative variance of the free path lengths, γ² = var / mean².
    pub fn free_path_relative_variance(&self) -> f64 {
        let mean = self.mean_free_path();
        let mean_sq = self.free_path_sq_sum as f64 / (1u64 << 32) as f64 / self.free_paths as f64;
        (mean_sq - mean * mean) / (mean * mean)
    }

    pub fn mean_free_path(&self) -> f64 {
        if self.free_paths == 0 {
            return f64::NAN;
        }
        self.free_path_sum as f64 / (1u64 << 32) as f64 / self.free_paths as f64
    }
}

#[cfg(test)]
mod tests {
    use super::round_i128;
    use crate::rng::Stream;

    /// The hand-made conversion gives `round() as i128`'s bits on halves, integers, the 2⁵²
    /// seam, huge, tiny, negative and non-finite values, and on a million random magnitudes.
    #[test]
    fn round_i128_equals_the_library_rounding() {
        let mut values = vec![0.0, -0.0, 0.5, -0.5, 1.5, -1.5, 2.5, -2.5, 0.49999999999999994, -0.49999999999999994,
            4503599627370495.5, -4503599627370495.5, 4503599627370496.0, 4503599627370497.0, 9007199254740993.0,
            1e19, -1e19, 1.7e38, -1.7e38, 1e39, -1e39, f64::MAX, f64::MIN, f64::INFINITY, f64::NEG_INFINITY, f64::NAN,
            f64::MIN_POSITIVE, 5e-324];
        let mut rng = Stream::new(1, 2, 3);
        for _ in 0..1_000_000 {
            let x = (rng.uniform() - 0.5) * 10f64.powf(rng.uniform() * 45.0 - 5.0);
            values.push(x);
            values.push(x.round() + 0.5);
        }
        for x in values {
            assert_eq!(round_i128(x), x.round() as i128, "{x:e}");
        }
    }
}
