//! The sound field's layout and its accumulator.
//!
//! Energy is binned per receiver, arrival time, incident direction and frequency band. Time bins
//! are one sample wide for the early part (so early reflections keep their exact times) and
//! `late_bin_s` wide after it. Directions are azimuth sectors centred on 0° (front, +x), growing
//! counter-clockwise (sector 2 of 8 is centred on +90°, the left), times elevation bands of
//! equal solid angle (bands of sin(elevation)).
//!
//! While tracing, energy is summed as unsigned integers in units of `quantum` (fixed point) with
//! unbiased stochastic rounding, added in batches into one shared array. Integer sums do not depend
//! on their order, so the result is the same bits for any thread count and for any split of a
//! bake into ranges of rays.

use glam::DVec3;

pub use super::accumulator::{band_stride, huge_pages_pay, Accumulator, Counts, Deposits};

/// Shape of the field: time bins × receivers × directions × bands while accumulating.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    pub n_receivers: usize,
    pub n_azimuth: usize,
    pub n_elevation: usize,
    pub n_bands: usize,
    pub sample_rate_hz: f64,
    /// Number of one-sample bins at the start.
    pub early_bins: usize,
    /// Width of each later bin in seconds, and how many there are.
    pub late_bin_s: f64,
    pub late_bins: usize,
}

impl Layout {
    pub fn n_directions(&self) -> usize {
        self.n_azimuth * self.n_elevation
    }

    pub fn n_time(&self) -> usize {
        self.early_bins + self.late_bins
    }

    pub fn early_s(&self) -> f64 {
        self.early_bins as f64 / self.sample_rate_hz
    }

    /// Total duration covered by the bins.
    pub fn duration_s(&self) -> f64 {
        self.early_s() + self.late_bins as f64 * self.late_bin_s
    }

    /// Start time of each bin, and its width: the time axis of the file.
    pub fn bin_starts_and_widths(&self) -> (Vec<f64>, Vec<f64>) {
        let mut starts = Vec::with_capacity(self.n_time());
        let mut widths = Vec::with_capacity(self.n_time());
        for k in 0..self.early_bins {
            starts.push(k as f64 / self.sample_rate_hz);
            widths.push(1.0 / self.sample_rate_hz);
        }
        for j in 0..self.late_bins {
            starts.push(self.early_s() + j as f64 * self.late_bin_s);
            widths.push(self.late_bin_s);
        }
        (starts, widths)
    }

    /// The bin of an arrival at time t, if within the covered duration.
    #[inline]
    pub fn time_bin(&self, t: f64) -> Option<usize> {
        self.time_bin_after(t, self.early_s())
    }

    /// [`Layout::time_bin`] with the early part's duration `early_s` (= [`Layout::early_s`])
    /// computed once by the caller: the sound kernel's deposits, one division fewer each.
    #[inline]
    pub fn time_bin_after(&self, t: f64, early_s: f64) -> Option<usize> {
        debug_assert_eq!(early_s.to_bits(), self.early_s().to_bits());
        let k = t * self.sample_rate_hz;
        if k < self.early_bins as f64 {
            return (k >= 0.0).then_some(k as usize);
        }
        let j = ((t - early_s) / self.late_bin_s) as usize;
        (j < self.late_bins).then_some(self.early_bins + j)
    }

    /// The direction bin of sound arriving from unit direction `from` (pointing from the
    /// receiver towards where the sound comes from).
    #[inline]
    pub fn direction_bin(&self, from: DVec3) -> usize {
        let w = std::f64::consts::TAU / self.n_azimuth as f64;
        // The azimuth in sector widths from the first sector's edge: from a cheap angle where
        // that is clearly inside a sector (the same floor), else from `atan2`.
        let x = quick_sectors(from.x, from.y, w).unwrap_or_else(|| (from.y.atan2(from.x) + 0.5 * w) / w);
        // floor(x) as truncation minus one below a negative non-integer: the same integer as
        // `f64::floor`, without its libm call (no SSE4.1 in the baseline target).
        let whole = x as i64;
        // x lies in [−n/2 + ½, n/2 + ½] (atan2 is within [−π, π]): the floor is within one turn of
        // [0, n), so one addition or subtraction of n wraps it, without an integer division.
        let n = self.n_azimuth as i64;
        let k = whole - i64::from(x < whole as f64);
        let a = (if k < 0 { k + n } else if k >= n { k - n } else { k }) as usize;
        let e = (((from.z.clamp(-1.0, 1.0) + 1.0) * 0.5 * self.n_elevation as f64) as usize).min(self.n_elevation - 1);
        e * self.n_azimuth + a
    }

    /// Flat number of the cell (receiver, time, direction), whose bands the accumulator keeps
    /// together, in the order [time][receiver][direction]: the deposits of one reflection (to
    /// every receiver, at nearby times) and of one ray (at growing times) then stay close in
    /// memory, which matters more than anything else for the speed of diffuse rain.
    #[inline]
    pub fn cell(&self, receiver: usize, time: usize, direction: usize) -> usize {
        (time * self.n_receivers + receiver) * self.n_directions() + direction
    }

    /// Flat index of the first band of (receiver, time, direction) in the field's
    /// [time][receiver][direction][band] order, bands packed (the order [`Accumulator::get`]
    /// and [`Accumulator::to_vec`] read in; the accumulator itself pads each cell's bands to
    /// [`band_stride`]).
    #[inline]
    pub fn index(&self, receiver: usize, time: usize, direction: usize) -> usize {
        self.cell(receiver, time, direction) * self.n_bands
    }

    /// Number of (receiver, time, direction) cells.
    pub fn cells(&self) -> usize {
        self.n_receivers * self.n_time() * self.n_directions()
    }

    pub fn len(&self) -> usize {
        self.cells() * self.n_bands
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The azimuth of (x, y) in sector widths `w` from the first sector's edge, (atan2(y, x) + w/2) / w,
/// when it lies more than [`QUICK_MARGIN_RAD`] from a sector's edge; None near an edge, near the
/// vertical, or for a NaN, where the caller takes `atan2` itself. The angle comes from the
/// octant's ratio q = min/max of |x|, |y| in [0, 1] by Rajan, Wang, Inkol and Joyal's
/// approximation (IEEE Signal Processing Magazine 23(3), 2006, eq. 9):
/// atan q ≈ (π/4) q − q (q − 1)(0.2447 + 0.0663 q), within 0.0015 rad as published (0.00151
/// measured, in the test); the margin is over ten times that, so the floor of this value is the floor of the exact one (the same bin, the same bits),
/// and about one direction in 25 (8 sectors) pays `atan2`. Costs one division instead of `atan2`'s
/// ≈ 130 instructions.
#[inline]
fn quick_sectors(x: f64, y: f64, w: f64) -> Option<f64> {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ax < ay { (ax, ay) } else { (ay, ax) };
    if !(hi > 1e-150) {
        return None;
    }
    let q = lo / hi;
    let t = FRAC_PI_4 * q - q * (q - 1.0) * (0.2447 + 0.0663 * q);
    // Unfold the octant: atan2's angle, within the approximation's error (≈ π at the back,
    // where atan2 gives ±π by the sign of y: both ends lie in one sector, or at an edge).
    let t = if ay > ax { FRAC_PI_2 - t } else { t };
    let t = if x < 0.0 { PI - t } else { t };
    let t = if y < 0.0 { -t } else { t };
    let sectors = (t + 0.5 * w) / w;
    let from_edge = sectors - (sectors as i64 - i64::from(sectors < (sectors as i64) as f64)) as f64;
    let margin = QUICK_MARGIN_RAD / w;
    (from_edge > margin && from_edge < 1.0 - margin).then_some(sectors)
}

/// How far from a sector's edge [`quick_sectors`] answers: over ten times its angle's worst error.
const QUICK_MARGIN_RAD: f64 = 0.016;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;

    fn layout() -> Layout {
        Layout { n_receivers: 1, n_azimuth: 8, n_elevation: 3, n_bands: 1, sample_rate_hz: 1000.0, early_bins: 80, late_bin_s: 0.01, late_bins: 10 }
    }

    #[test]
    fn time_bins_are_one_sample_early_and_coarse_late() {
        let l = layout();
        assert_eq!(l.time_bin(0.0), Some(0));
        assert_eq!(l.time_bin(0.0799), Some(79));
        assert_eq!(l.time_bin(0.0801), Some(80));
        assert_eq!(l.time_bin(0.0999), Some(81));
        assert_eq!(l.time_bin(0.185), None);
    }

    #[test]
    fn direction_bins_follow_the_convention() {
        let l = layout();
        let level = 8; // middle elevation band
        assert_eq!(l.direction_bin(DVec3::X), level); // front
        assert_eq!(l.direction_bin(DVec3::new(1.0, 0.38, 0.0).normalize()), level); // 20.8° still front
        assert_eq!(l.direction_bin(DVec3::Y), level + 2); // left (+90°)
        assert_eq!(l.direction_bin(-DVec3::Y), level + 6); // right (−90°)
        assert_eq!(l.direction_bin(-DVec3::X), level + 4); // back
        assert_eq!(l.direction_bin(DVec3::new(1e-3, 0.0, 1.0).normalize()), 16); // above
        assert_eq!(l.direction_bin(DVec3::new(1e-3, 0.0, -1.0).normalize()), 0); // below
    }

    #[test]
    fn the_quick_azimuth_gives_the_bins_of_atan2() {
        // The bin as before the quick path: atan2 for every direction.
        fn by_atan2(l: &Layout, from: DVec3) -> usize {
            let w = std::f64::consts::TAU / l.n_azimuth as f64;
            let k = ((from.y.atan2(from.x) + 0.5 * w) / w).floor() as i64;
            let a = k.rem_euclid(l.n_azimuth as i64) as usize;
            let e = (((from.z.clamp(-1.0, 1.0) + 1.0) * 0.5 * l.n_elevation as f64) as usize).min(l.n_elevation - 1);
            e * l.n_azimuth + a
        }
        // The approximation's own error over the octant: the published 0.0015 rad (rounded).
        let worst = (0..=100_000).map(|i| i as f64 / 1e5).map(|q| (q * std::f64::consts::FRAC_PI_4 - q * (q - 1.0) * (0.2447 + 0.0663 * q) - q.atan()).abs()).fold(0.0, f64::max);
        assert!(worst < 0.00151 && worst * 10.0 <= QUICK_MARGIN_RAD, "{worst}");
        let mut rng = Stream::new(9, 0, 0);
        let mut quick = 0usize;
        let mut total = 0usize;
        for n in [1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 36, 360] {
            let l = Layout { n_azimuth: n, ..layout() };
            let w = std::f64::consts::TAU / n as f64;
            let mut check = |d: DVec3| {
                assert_eq!(l.direction_bin(d), by_atan2(&l, d), "{n} sectors, {d:?}");
                quick += usize::from(quick_sectors(d.x, d.y, w).is_some());
                total += 1;
            };
            for _ in 0..200_000 {
                check(crate::sampling::uniform_sphere(rng.uniform(), rng.uniform()));
            }
            // At every sector's edge and near it, at three heights; along the axes with both
            // zeros' signs; straight up and down.
            for k in 0..=n {
                for off in [0.0, 1e-15, 1e-9, 1e-4, 0.0015, 0.01, 0.016, 0.0175, 0.03] {
                    for sign in [-1.0, 1.0] {
                        let a = (k as f64 + 0.5) * w + sign * off;
                        for z in [0.0, 0.5, -0.9] {
                            let h = (1.0f64 - z * z).sqrt();
                            check(DVec3::new(h * a.cos(), h * a.sin(), z));
                        }
                    }
                }
            }
            for (x, y) in [(1.0, 0.0), (1.0, -0.0), (-1.0, 0.0), (-1.0, -0.0), (0.0, 1.0), (-0.0, 1.0), (0.0, -1.0), (-0.0, -1.0), (0.0, 0.0), (-0.0, -0.0)] {
                check(DVec3::new(x, y, if x == 0.0 && y == 0.0 { 1.0 } else { 0.0 }));
            }
        }
        // Most directions take the quick path (8 sectors: 1 − 8 · 2 · 0.016 / 2π ≈ 96 %).
        assert!(quick as f64 > 0.5 * total as f64, "{quick} of {total}");
    }
}
