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

impl SoundStats {
    pub fn new(n_bands: usize) -> SoundStats {
        SoundStats { energy: std::array::from_fn(|_| vec![0; n_bands]), ..Default::default() }
    }

    #[inline]
    pub(crate) fn add_energy(&mut self, which: usize, band: usize, joules: f64) {
        self.energy[which][band] += (joules / ENERGY_QUANTUM).round() as i128;
    }

    /// Adds one ray's free paths: `count` of them, with lengths summing to `sum` and squares to
    /// `sum_sq` (a ray sums its own in f64, the same way on any thread: one conversion a ray).
    #[inline]
    pub(crate) fn add_free_paths(&mut self, count: u64, sum: f64, sum_sq: f64) {
        self.free_path_sum += (sum * (1u64 << 32) as f64).round() as i128;
        self.free_path_sq_sum += (sum_sq * (1u64 << 32) as f64).round() as i128;
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
