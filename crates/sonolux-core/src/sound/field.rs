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

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;

use glam::DVec3;


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
        let k = t * self.sample_rate_hz;
        if k < self.early_bins as f64 {
            return (k >= 0.0).then_some(k as usize);
        }
        let j = ((t - self.early_s()) / self.late_bin_s) as usize;
        (j < self.late_bins).then_some(self.early_bins + j)
    }

    /// The direction bin of sound arriving from unit direction `from` (pointing from the
    /// receiver towards where the sound comes from).
    #[inline]
    pub fn direction_bin(&self, from: DVec3) -> usize {
        let w = std::f64::consts::TAU / self.n_azimuth as f64;
        let az = from.y.atan2(from.x);
        // floor(x) as truncation minus one below a negative non-integer: the same integer as
        // `f64::floor`, without its libm call (no SSE4.1 in the baseline target).
        let x = (az + 0.5 * w) / w;
        let whole = x as i64;
        let a = (whole - i64::from(x < whole as f64)).rem_euclid(self.n_azimuth as i64) as usize;
        let e = (((from.z.clamp(-1.0, 1.0) + 1.0) * 0.5 * self.n_elevation as f64) as usize).min(self.n_elevation - 1);
        e * self.n_azimuth + a
    }

    /// Flat index of the first band of (receiver, time, direction) in the accumulator, whose
    /// order is [time][receiver][direction][band]: the deposits of one reflection (to every
    /// receiver, at nearby times) and of one ray (at growing times) then stay close in memory,
    /// which matters more than anything else for the speed of diffuse rain.
    #[inline]
    pub fn index(&self, receiver: usize, time: usize, direction: usize) -> usize {
        ((time * self.n_receivers + receiver) * self.n_directions() + direction) * self.n_bands
    }

    pub fn len(&self) -> usize {
        self.n_receivers * self.n_time() * self.n_directions() * self.n_bands
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Fixed-point energies, shared by all workers: integer adds commute, so the sums are the same
/// bits whatever the threads' interleaving, with a single copy in memory.
///
/// Workers do not add one deposit at a time: a locked add into a field of hundreds of megabytes
/// waits for its own cache miss, and nothing else can run meanwhile. Each worker collects its
/// deposits in a [`Deposits`] batch instead; a flush groups the batch by shard (a contiguous
/// 1/256 of the field), locks each shard it touches once and adds with plain loads and stores,
/// whose cache misses overlap.
#[derive(Debug)]
pub struct Accumulator {
    counts: Vec<AtomicU64>,
    /// Held while a flush writes to its part of `counts`; shard k holds
    /// `counts[k << shard_bits..(k + 1) << shard_bits]`.
    shards: Vec<Mutex<()>>,
    shard_bits: u32,
    /// Energy of one count, in the field's unit (J/m²).
    pub quantum: f64,
    saturated: AtomicBool,
}

/// Deposits a flush takes at once: enough for the misses to overlap, small enough for L1/L2.
const BATCH: usize = 4096;
/// The field is cut into about this many shards.
const SHARDS: usize = 256;

/// A worker's deposits not yet added to the field: (index, counts) pairs.
#[derive(Debug, Default)]
pub struct Deposits {
    pending: Vec<(usize, u64)>,
    /// Scratch of a flush: the pending adds grouped by shard, and where each group starts.
    grouped: Vec<(usize, u64)>,
    starts: Vec<usize>,
}

impl Deposits {
    pub fn new() -> Deposits {
        Deposits { pending: Vec::with_capacity(BATCH), ..Default::default() }
    }
}

impl Accumulator {
    pub fn new(len: usize, quantum: f64) -> Accumulator {
        let shard_bits = (len.div_ceil(SHARDS).max(1024)).next_power_of_two().trailing_zeros();
        let n_shards = (len >> shard_bits) + 1;
        Accumulator {
            counts: (0..len).map(|_| AtomicU64::new(0)).collect(),
            shards: (0..n_shards).map(|_| Mutex::new(())).collect(),
            shard_bits,
            quantum,
            saturated: AtomicBool::new(false),
        }
    }

    /// Adds `energy[b]` to the bands starting at `base` (through the worker's batch `buf`),
    /// rounding each to a whole number of quanta up or down at random with the probability that
    /// keeps the expectation exact: `u` is uniform in [0, 1) (one number serves all bands: each
    /// band's rounding is still unbiased). Callers key `u` by the deposit alone
    /// ([`crate::rng::keyed_uniform`]), never by a stream other receivers also draw from.
    #[inline]
    pub fn deposit(&self, buf: &mut Deposits, base: usize, energy: &[f64], u: f64) {
        let inv = 1.0 / self.quantum;
        for (b, &e) in energy.iter().enumerate() {
            if e <= 0.0 {
                continue;
            }
            let x = e * inv;
            let whole = x as u64; // x > 0: truncation is the floor
            let add = whole + u64::from(u < x - whole as f64);
            if add > 0 {
                buf.pending.push((base + b, add));
            }
        }
        if buf.pending.len() >= BATCH {
            self.flush(buf);
        }
    }

    /// Adds a worker's pending deposits to the field. Call it before reading the field.
    pub fn flush(&self, buf: &mut Deposits) {
        if buf.pending.is_empty() {
            return;
        }
        // Group by shard (a counting sort: the order within a shard does not matter).
        let n = self.shards.len();
        buf.starts.clear();
        buf.starts.resize(n + 1, 0);
        for &(i, _) in &buf.pending {
            buf.starts[(i >> self.shard_bits) + 1] += 1;
        }
        for k in 0..n {
            buf.starts[k + 1] += buf.starts[k];
        }
        buf.grouped.clear();
        buf.grouped.resize(buf.pending.len(), (0, 0));
        let mut fill = buf.starts.clone();
        for &(i, a) in &buf.pending {
            let k = i >> self.shard_bits;
            buf.grouped[fill[k]] = (i, a);
            fill[k] += 1;
        }
        let mut overflow = false;
        for k in 0..n {
            let group = &buf.grouped[buf.starts[k]..buf.starts[k + 1]];
            if group.is_empty() {
                continue;
            }
            let _held = self.shards[k].lock().unwrap_or_else(|e| e.into_inner());
            for &(i, a) in group {
                // Plain load and store: the shard's lock makes them exclusive.
                let c = &self.counts[i];
                let (sum, o) = c.load(Ordering::Relaxed).overflowing_add(a);
                c.store(sum, Ordering::Relaxed);
                overflow |= o;
            }
        }
        // A sum that wraps past 2⁶⁴ is flagged (the quantum leaves 16× headroom, so it is a bug).
        if overflow {
            self.saturated.store(true, Ordering::Relaxed);
        }
        buf.pending.clear();
    }

    pub fn saturated(&self) -> bool {
        self.saturated.load(Ordering::Relaxed)
    }

    pub fn len(&self) -> usize {
        self.counts.len()
    }

    pub fn is_empty(&self) -> bool {
        self.counts.is_empty()
    }

    #[inline]
    pub fn get(&self, i: usize) -> u64 {
        self.counts[i].load(Ordering::Relaxed)
    }

    /// The counts as plain integers.
    pub fn to_vec(&self) -> Vec<u64> {
        self.counts.iter().map(|c| c.load(Ordering::Relaxed)).collect()
    }

    /// Adds another accumulator of the same layout (exact, in any order).
    pub fn merge(&mut self, other: &Accumulator) {
        let mut overflow = other.saturated();
        for (c, o) in self.counts.iter_mut().zip(&other.counts) {
            let (sum, wrapped) = c.get_mut().overflowing_add(o.load(Ordering::Relaxed));
            *c.get_mut() = sum;
            overflow |= wrapped;
        }
        if overflow {
            self.saturated.store(true, Ordering::Relaxed);
        }
    }
}

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
    fn stochastic_rounding_is_unbiased() {
        let acc = Accumulator::new(1, 1.0);
        let mut rng = Stream::new(1, 2, 3);
        let mut buf = Deposits::new();
        for _ in 0..100_000 {
            acc.deposit(&mut buf, 0, &[0.3], rng.uniform());
        }
        acc.flush(&mut buf);
        let mean = acc.get(0) as f64 / 100_000.0;
        // Binomial standard error sqrt(0.21/1e5) ≈ 0.0014; allow 5 of them.
        assert!((mean - 0.3).abs() < 0.0073, "{mean}");
    }
}
