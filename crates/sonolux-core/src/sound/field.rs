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

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use glam::DVec3;
use memmap2::MmapMut;

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

/// Fixed-point energies, shared by all workers: integer adds commute, so the sums are the same
/// bits whatever the threads' interleaving, with a single copy in memory.
///
/// Workers do not add one deposit at a time: a locked add into a field of hundreds of megabytes
/// waits for its own cache miss, and nothing else can run meanwhile. Each worker collects its
/// deposits in a [`Deposits`] batch instead; a flush groups the batch by shard (a contiguous
/// part of the field, about 1/256 of it), locks each shard it touches once and adds with plain
/// loads and stores, whose cache misses overlap.
///
/// The shards are anonymous memory maps (zero pages until written) and, on Linux, asked for
/// transparent huge pages (`madvise(MADV_HUGEPAGE)`; the machine's setting is often
/// "madvise", where nothing else gets them). A deposit lands anywhere in a field of hundreds of
/// megabytes: with 4 KiB pages nearly every one missed the TLB and walked page tables that
/// do not fit in the cache (a second memory access); with 2 MiB pages the whole field's
/// translations fit in the second-level TLB. Where the map or the advice is refused, the
/// shard is an ordinary zeroed allocation (same results, 4 KiB pages).
#[derive(Debug)]
pub struct Accumulator {
    /// Shard k holds the counts `k << shard_bits..(k + 1) << shard_bits`; its lock is held
    /// while a flush writes to it.
    shards: Vec<Mutex<Shard>>,
    shard_bits: u32,
    /// Where each shard's counts start in memory (they never move), and the processor's
    /// prefetch (pulp's safe token for SSE): a flush's prefetches.
    addresses: Vec<usize>,
    #[cfg(target_arch = "x86_64")]
    sse: Option<pulp::core_arch::x86::Sse>,
    len: usize,
    /// Energy of one count, in the field's unit (J/m²).
    pub quantum: f64,
    saturated: AtomicBool,
}

/// Deposits a flush takes at once: enough for the misses to overlap, small enough for L1/L2.
const BATCH: usize = 4096;
/// The field is cut into about this many shards.
const SHARDS: usize = 256;
/// Fields above this many counts (8 MiB) get shards of at least 2 MiB (2¹⁸ counts), the size
/// of a huge page: a power of two at least that large is a whole number of them, and Linux
/// places such maps on huge-page boundaries.
const HUGE_FIELD: usize = 1 << 20;
const HUGE_PAGE_COUNTS: usize = 1 << 18;

/// Whether a bake of `rays` rays (all sources) into `receivers` receivers should ask for huge
/// pages for a field of `counts` counts: when there are at least two rays a count for every
/// receiver. Huge pages cost ≈ 13 ns more a count to fault in (above) and save ≈ 100 ns a
/// deposit: they pay from 0.13 deposits a count. A ray
/// through paper-large's grid of 207 spheres deposits 19 times (0.09 a receiver), so the
/// break-even is near 1.4 rays × receivers a count; 2 leaves a margin for rooms that deposit
/// less (fewer crossings a receiver).
pub fn huge_pages_pay(rays: u64, receivers: usize, counts: usize) -> bool {
    rays as f64 * receivers as f64 >= 2.0 * counts as f64
}

/// The memory of one shard: zero-initialised u64 counts.
#[derive(Debug)]
enum Shard {
    Mapped(MmapMut),
    Heap(Vec<u64>),
}

impl Shard {
    fn zeroed(n: usize, huge: bool) -> Shard {
        match MmapMut::map_anon(n.max(1) * 8) {
            Ok(map) => {
                // Advice only: refused (no THP in this kernel), the pages are 4 KiB.
                #[cfg(target_os = "linux")]
                if huge && n >= HUGE_PAGE_COUNTS {
                    let _ = map.advise(memmap2::Advice::HugePage);
                }
                Shard::Mapped(map)
            }
            Err(_) => Shard::Heap(vec![0; n.max(1)]),
        }
    }

    #[inline]
    fn counts(&self) -> &[u64] {
        match self {
            Shard::Mapped(m) => bytemuck::cast_slice(&m[..]),
            Shard::Heap(v) => v,
        }
    }

    #[inline]
    fn counts_mut(&mut self) -> &mut [u64] {
        match self {
            Shard::Mapped(m) => bytemuck::cast_slice_mut(&mut m[..]),
            Shard::Heap(v) => v,
        }
    }
}

/// The whole field, read after tracing ([`Accumulator::read`]): every shard's lock held.
pub struct Counts<'a> {
    shards: Vec<&'a [u64]>,
    shard_bits: u32,
}

impl Counts<'_> {
    #[inline]
    pub fn get(&self, i: usize) -> u64 {
        self.shards[i >> self.shard_bits][i & ((1 << self.shard_bits) - 1)]
    }
}

/// A worker's deposits not yet added to the field: (index, counts) pairs.
#[derive(Debug, Default)]
pub struct Deposits {
    pending: Vec<(usize, u64)>,
    /// Scratch of a flush: the pending adds grouped by shard, and where each group starts.
    grouped: Vec<(usize, u64)>,
    starts: Vec<usize>,
    fill: Vec<usize>,
}

impl Deposits {
    pub fn new() -> Deposits {
        Deposits { pending: Vec::with_capacity(BATCH), ..Default::default() }
    }
}

impl Accumulator {
    /// A field of `len` counts, all zero. Its memory (8 bytes a count) is the caller's to
    /// estimate and bound ([`super::SoundSettings::validate`]): the maps take no more.
    pub fn new(len: usize, quantum: f64) -> Accumulator {
        Accumulator::with_pages(len, quantum, false)
    }

    /// [`Accumulator::new`], with `huge` pages asked for when the field is large enough
    /// (above 8 MiB). They cost at first touch (measured on this project's 2-core VM: a 1 GB
    /// field took 1.7 s more to fault in, 2 MiB pages being zeroed fresh from the host) and
    /// pay at every deposit (≈ 100 ns less a deposit in paper-large's full grid): worth it for
    /// long bakes only, which the caller knows ([`huge_pages_pay`]).
    pub fn with_pages(len: usize, quantum: f64, huge: bool) -> Accumulator {
        let least = if huge && len > HUGE_FIELD { HUGE_PAGE_COUNTS } else { 1024 };
        let shard_bits = len.div_ceil(SHARDS).max(least).next_power_of_two().trailing_zeros();
        let size = 1usize << shard_bits;
        let n_shards = len.div_ceil(size).max(1);
        let shards: Vec<Mutex<Shard>> = (0..n_shards).map(|k| Mutex::new(Shard::zeroed(size.min(len - (k * size).min(len)), huge))).collect();
        let addresses = shards.iter().map(|s| s.lock().unwrap_or_else(|e| e.into_inner()).counts().as_ptr() as usize).collect();
        Accumulator {
            shards,
            shard_bits,
            addresses,
            #[cfg(target_arch = "x86_64")]
            sse: pulp::core_arch::x86::Sse::try_new(),
            len,
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
            // x > 0: truncation is the floor. Below 2⁶³ (always: the quantum leaves 16× headroom
            // under 2⁶³ for a whole bin) through i64, one instruction each way on x86-64 without
            // AVX-512 (u64's conversions are a branch and several): the same integers.
            let whole = if x < 9.2e18 { x as i64 as u64 } else { x as u64 };
            let add = whole + u64::from(u < x - if x < 9.2e18 { whole as i64 as f64 } else { whole as f64 });
            if add > 0 {
                buf.pending.push((base + b, add));
            }
        }
        if buf.pending.len() >= BATCH {
            self.flush(buf);
        }
    }

    /// Asks the processor to bring count `i`'s cache line closer (a hint: no effect on any
    /// value, nothing where the architecture has no such instruction).
    #[inline(always)]
    fn prefetch(&self, i: usize) {
        #[cfg(target_arch = "x86_64")]
        if let (Some(sse), Some(&start)) = (self.sse, self.addresses.get(i >> self.shard_bits)) {
            let address = start.wrapping_add((i & ((1 << self.shard_bits) - 1)) * 8);
            sse._mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(address as *const i8);
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = i;
    }

    /// Adds a worker's pending deposits to the field. Call it before reading the field.
    pub fn flush(&self, buf: &mut Deposits) {
        if buf.pending.is_empty() {
            return;
        }
        // Group by shard (a counting sort: the order within a shard does not matter). While
        // counting, ask for every count's cache line: the adds below then find them in the
        // cache, their misses overlapped here, where each add used to wait for its own (two
        // thirds of a flush's time in paper-large's grid, the flush 11 % of the bake; now 7 %:
        // docs/convex.md, session 10).
        let n = self.shards.len();
        buf.starts.clear();
        buf.starts.resize(n + 1, 0);
        for &(i, _) in &buf.pending {
            self.prefetch(i);
            buf.starts[(i >> self.shard_bits) + 1] += 1;
        }
        for k in 0..n {
            buf.starts[k + 1] += buf.starts[k];
        }
        buf.grouped.clear();
        buf.grouped.resize(buf.pending.len(), (0, 0));
        buf.fill.clear();
        buf.fill.extend_from_slice(&buf.starts);
        for &(i, a) in &buf.pending {
            let k = i >> self.shard_bits;
            buf.grouped[buf.fill[k]] = (i, a);
            buf.fill[k] += 1;
        }
        let mask = (1usize << self.shard_bits) - 1;
        let mut overflow = false;
        for k in 0..n {
            let group = &buf.grouped[buf.starts[k]..buf.starts[k + 1]];
            if group.is_empty() {
                continue;
            }
            let mut shard = self.shards[k].lock().unwrap_or_else(|e| e.into_inner());
            let counts = shard.counts_mut();
            for &(i, a) in group {
                let (sum, o) = counts[i & mask].overflowing_add(a);
                counts[i & mask] = sum;
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
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Count `i` (locks its shard: to read many, use [`Accumulator::read`]).
    pub fn get(&self, i: usize) -> u64 {
        assert!(i < self.len, "count {i} of a field of {}", self.len);
        let shard = self.shards[i >> self.shard_bits].lock().unwrap_or_else(|e| e.into_inner());
        shard.counts()[i & ((1 << self.shard_bits) - 1)]
    }

    /// Calls `f` with the whole field, every shard locked once (after tracing).
    pub fn read<R>(&self, f: impl FnOnce(&Counts) -> R) -> R {
        let guards: Vec<_> = self.shards.iter().map(|s| s.lock().unwrap_or_else(|e| e.into_inner())).collect();
        let counts = Counts { shards: guards.iter().map(|g| g.counts()).collect(), shard_bits: self.shard_bits };
        f(&counts)
    }

    /// The counts as plain integers.
    pub fn to_vec(&self) -> Vec<u64> {
        self.read(|c| c.shards.iter().flat_map(|s| s.iter().copied()).take(self.len).collect())
    }

    /// Adds another accumulator of the same layout (exact, in any order).
    pub fn merge(&mut self, other: &Accumulator) {
        assert_eq!(self.len, other.len, "merging fields of different sizes");
        let mut overflow = other.saturated();
        // The two may be cut into shards differently (huge pages for one range, not for
        // another): walk both in the field's flat order.
        other.read(|theirs| {
            let mut from = theirs.shards.iter().flat_map(|s| s.iter());
            for mine in self.shards.iter_mut() {
                let mine = mine.get_mut().unwrap_or_else(|e| e.into_inner()).counts_mut();
                for (c, &o) in mine.iter_mut().zip(&mut from) {
                    let (sum, wrapped) = c.overflowing_add(o);
                    *c = sum;
                    overflow |= wrapped;
                }
            }
        });
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

    #[test]
    fn shards_of_any_size_and_page_hold_the_same_counts() {
        // A field over the huge-page threshold (shards of 2 MiB, the last one partial) and
        // small ones: the same deposits give the same counts, read one at a time, all at
        // once, and merged.
        for len in [1, 1000, 5000, HUGE_FIELD + 12_345] {
            let fields: Vec<Accumulator> = [false, true].iter().map(|&huge| Accumulator::with_pages(len, 0.5, huge)).collect();
            let mut rng = Stream::new(4, 0, len as u64);
            let adds: Vec<(usize, f64, f64)> = (0..20_000).map(|_| (((rng.uniform() * len as f64) as usize).min(len - 1), rng.uniform() * 3.0, rng.uniform())).collect();
            for acc in &fields {
                let mut buf = Deposits::new();
                for &(i, e, u) in &adds {
                    acc.deposit(&mut buf, i, &[e], u);
                }
                acc.flush(&mut buf);
            }
            let counts = fields[0].to_vec();
            assert_eq!(counts.len(), len);
            assert_eq!(counts, fields[1].to_vec());
            assert_eq!(counts.iter().sum::<u64>(), adds.iter().map(|&(_, e, u)| (e / 0.5) as u64 + u64::from(u < e / 0.5 - (e / 0.5).floor())).sum::<u64>());
            let last = len - 1;
            assert_eq!(fields[1].get(last), counts[last]);
            let mut merged = Accumulator::with_pages(len, 0.5, true);
            merged.merge(&fields[0]);
            merged.merge(&fields[1]);
            assert_eq!(merged.to_vec(), counts.iter().map(|c| 2 * c).collect::<Vec<_>>());
        }
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
