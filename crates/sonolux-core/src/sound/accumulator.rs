//! The field's accumulator: fixed-point energies with unbiased stochastic rounding, added in
//! batches into one shared array (sound/field.rs has the layout). Integer sums do not depend on
//! their order, so the result is the same bits for any thread count and for any split of a
//! bake into ranges of rays.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use memmap2::MmapMut;

#[cfg(doc)]
use super::Layout;

/// Counts the accumulator keeps a cell for `n_bands` bands: the next power of two up to 8 where
/// that adds at most one count in seven (7 bands → 8, the octaves 125 Hz–8 kHz), else the bands
/// packed. A padded cell of 8 counts fills one aligned 64-byte cache line, where 7 packed bands
/// of 8 bytes straddle 1.75 lines on average (a cell starts at any multiple of 8 bytes), and the
/// flush adds it as one line (docs/convex.md, session 12). 5 or 6 bands would take 33–60 % more
/// memory for it, unmeasured, so they stay packed. The padding counts are never written.
pub fn band_stride(n_bands: usize) -> usize {
    let padded = n_bands.next_power_of_two();
    if n_bands <= 8 && 7 * (padded - n_bands) <= n_bands {
        padded
    } else {
        n_bands
    }
}

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
    /// Counts in the field's packed order (cells × bands), the bands of a cell, and the counts
    /// kept a cell ([`band_stride`]: the shards hold cells × stride counts).
    len: usize,
    n_bands: usize,
    stride: usize,
    /// Energy of one count, in the field's unit (J/m²).
    pub quantum: f64,
    /// 1 / quantum, once (a division a deposit less; the same value).
    inv_quantum: f64,
    saturated: AtomicBool,
}

/// Pending adds (of up to [`CHUNK`] bands each) a flush takes at once: enough for the misses to
/// overlap, small enough for L1/L2 (about 4096 counts, as the flush of single counts took).
const BATCH: usize = 512;
/// Counts one pending add holds: a whole cell of up to 8 bands (padded to [`band_stride`], so
/// one aligned cache line at 7 and 8 bands), or 8 bands of a wider cell.
const CHUNK: usize = 8;
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
    n_bands: usize,
    stride: usize,
}

impl Counts<'_> {
    /// Band `band` of cell `cell` ([`Layout::cell`]).
    #[inline]
    pub fn at(&self, cell: usize, band: usize) -> u64 {
        let i = cell * self.stride + band;
        self.shards[i >> self.shard_bits][i & ((1 << self.shard_bits) - 1)]
    }

    /// Count `i` of the packed order ([`Layout::index`] + band).
    #[inline]
    pub fn get(&self, i: usize) -> u64 {
        self.at(i / self.n_bands, i % self.n_bands)
    }
}

/// A pending add: `n` counts (a cell's bands, or [`CHUNK`] of them) starting at count `index`
/// of the shards, all in one shard.
#[derive(Clone, Copy, Debug, Default)]
struct Add {
    index: usize,
    n: usize,
    counts: [u64; CHUNK],
}

/// A worker's deposits not yet added to the field: one [`Add`] a cell deposited into (two or
/// more for cells of over 8 bands).
#[derive(Debug, Default)]
pub struct Deposits {
    pending: Vec<Add>,
    /// Scratch of a flush: the pending adds grouped by shard, and where each group starts.
    grouped: Vec<Add>,
    starts: Vec<usize>,
    fill: Vec<usize>,
}

impl Deposits {
    pub fn new() -> Deposits {
        Deposits { pending: Vec::with_capacity(BATCH), ..Default::default() }
    }
}

impl Accumulator {
    /// A field of `len` counts (one band a cell), all zero. Its memory (8 bytes a count) is the
    /// caller's to estimate and bound ([`super::SoundSettings::validate`]): the maps take no more.
    pub fn new(len: usize, quantum: f64) -> Accumulator {
        Accumulator::with_pages(len, quantum, false)
    }

    /// [`Accumulator::with_pages`] for `cells` cells of `n_bands` bands each, every cell kept in
    /// [`band_stride`] counts (8 × stride bytes a cell: the caller's estimate counts those).
    pub fn for_bands(cells: usize, n_bands: usize, quantum: f64, huge: bool) -> Accumulator {
        let stride = band_stride(n_bands.max(1));
        let mut acc = Accumulator::with_pages(cells * stride, quantum, huge);
        acc.len = cells * n_bands.max(1);
        acc.n_bands = n_bands.max(1);
        acc.stride = stride;
        acc
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
            n_bands: 1,
            stride: 1,
            quantum,
            inv_quantum: 1.0 / quantum,
            saturated: AtomicBool::new(false),
        }
    }

    /// Adds `energy[b]` to band b of cell `cell` ([`Layout::cell`]; through the worker's batch `buf`),
    /// rounding each to a whole number of quanta up or down at random with the probability that
    /// keeps the expectation exact: `u` is uniform in [0, 1) (one number serves all bands: each
    /// band's rounding is still unbiased). Callers key `u` by the deposit alone
    /// ([`crate::rng::keyed_uniform`]), never by a stream other receivers also draw from.
    #[inline]
    pub fn deposit(&self, buf: &mut Deposits, cell: usize, energy: &[f64], u: f64) {
        debug_assert!(energy.len() <= self.n_bands);
        let base = cell * self.stride;
        let inv = self.inv_quantum;
        // A cell of up to 8 counts is one add of its whole stride (the padding's adds are 0: a
        // padded cell of 8 is one aligned line, added at once); a wider one, chunks of 8 bands.
        let cell_counts = if self.stride <= CHUNK { self.stride } else { energy.len() };
        for (k, chunk) in energy.chunks(CHUNK).enumerate() {
            let mut add = Add { index: base + k * CHUNK, n: (cell_counts - k * CHUNK).min(CHUNK), counts: [0; CHUNK] };
            let mut any = 0;
            for (b, &e) in chunk.iter().enumerate() {
                if e <= 0.0 {
                    continue;
                }
                let x = e * inv;
                // x > 0: truncation is the floor. Below 2⁶³ (always: the quantum leaves 16×
                // headroom under 2⁶³ for a whole bin) through i64, one instruction each way on
                // x86-64 without AVX-512 (u64's conversions are a branch and several): the
                // same integers.
                let whole = if x < 9.2e18 { x as i64 as u64 } else { x as u64 };
                let a = whole + u64::from(u < x - if x < 9.2e18 { whole as i64 as f64 } else { whole as f64 });
                add.counts[b] = a;
                any |= a;
            }
            if any == 0 {
                continue;
            }
            // A chunk of packed bands (a stride not a power of two) may cross a shard's end:
            // split it there, each part added under its own shard's lock. (A cell of a power of
            // two of counts never does: shards hold a power of two of at least 1024 counts.)
            let room = (1usize << self.shard_bits) - (add.index & ((1 << self.shard_bits) - 1));
            if add.n > room {
                let mut rest = Add { index: add.index + room, n: add.n - room, counts: [0; CHUNK] };
                rest.counts[..add.n - room].copy_from_slice(&add.counts[room..add.n]);
                add.n = room;
                buf.pending.push(rest);
            }
            buf.pending.push(add);
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
        for add in &buf.pending {
            self.prefetch(add.index);
            if add.index % CHUNK + add.n > CHUNK {
                self.prefetch(add.index + add.n - 1);
            }
            buf.starts[(add.index >> self.shard_bits) + 1] += 1;
        }
        for k in 0..n {
            buf.starts[k + 1] += buf.starts[k];
        }
        buf.grouped.clear();
        buf.grouped.resize(buf.pending.len(), Add::default());
        buf.fill.clear();
        buf.fill.extend_from_slice(&buf.starts);
        for add in &buf.pending {
            let k = add.index >> self.shard_bits;
            buf.grouped[buf.fill[k]] = *add;
            buf.fill[k] += 1;
        }
        let mask = (1usize << self.shard_bits) - 1;
        let mut overflow = 0u64;
        for k in 0..n {
            let group = &buf.grouped[buf.starts[k]..buf.starts[k + 1]];
            if group.is_empty() {
                continue;
            }
            let mut shard = self.shards[k].lock().unwrap_or_else(|e| e.into_inner());
            let counts = shard.counts_mut();
            for add in group {
                let at = &mut counts[add.index & mask..][..add.n];
                // A whole line of 8 (cells of 7 and 8 bands) as one fixed-length loop, which
                // the compiler puts in vector lanes; a wrap past 2⁶⁴ shows as sum < add.
                if let Ok(at) = <&mut [u64; CHUNK]>::try_from(&mut *at) {
                    let sum: [u64; CHUNK] = std::array::from_fn(|l| at[l].wrapping_add(add.counts[l]));
                    overflow |= (0..CHUNK).fold(0, |o, l| o | u64::from(sum[l] < add.counts[l]));
                    *at = sum;
                    continue;
                }
                for (c, &a) in at.iter_mut().zip(&add.counts) {
                    let (sum, o) = c.overflowing_add(a);
                    *c = sum;
                    overflow |= u64::from(o);
                }
            }
        }
        let overflow = overflow != 0;
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

    /// Count `i` of the packed order ([`Layout::index`] + band; locks its shard: to read many,
    /// use [`Accumulator::read`]).
    pub fn get(&self, i: usize) -> u64 {
        assert!(i < self.len, "count {i} of a field of {}", self.len);
        let i = i / self.n_bands * self.stride + i % self.n_bands;
        let shard = self.shards[i >> self.shard_bits].lock().unwrap_or_else(|e| e.into_inner());
        shard.counts()[i & ((1 << self.shard_bits) - 1)]
    }

    /// Calls `f` with the whole field, every shard locked once (after tracing).
    pub fn read<R>(&self, f: impl FnOnce(&Counts) -> R) -> R {
        let guards: Vec<_> = self.shards.iter().map(|s| s.lock().unwrap_or_else(|e| e.into_inner())).collect();
        let counts = Counts { shards: guards.iter().map(|g| g.counts()).collect(), shard_bits: self.shard_bits, n_bands: self.n_bands, stride: self.stride };
        f(&counts)
    }

    /// The counts as plain integers, in the packed order (the padding dropped).
    pub fn to_vec(&self) -> Vec<u64> {
        let (nb, stride) = (self.n_bands, self.stride);
        self.read(|c| {
            let all = c.shards.iter().flat_map(|s| s.iter().copied());
            // Slot k of a cell (a counter instead of a division a count).
            let mut k = 0;
            all.filter(|_| {
                let kept = k < nb;
                k = if k + 1 == stride { 0 } else { k + 1 };
                kept
            })
            .take(self.len)
            .collect()
        })
    }

    /// Adds another accumulator of the same layout (exact, in any order).
    pub fn merge(&mut self, other: &Accumulator) {
        assert_eq!((self.len, self.stride), (other.len, other.stride), "merging fields of different sizes");
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
    fn padded_bands_read_back_in_the_packed_order() {
        // 1 to 9 bands (7 → 8, the others packed, chunked above 8), small and huge-page fields: every reader
        // (get, read's at/get, to_vec, merge) sees the packed [cell][band] order, and the
        // padding is never written.
        for nb in 1..=9 {
            let stride = band_stride(nb);
            assert_eq!(stride, if nb == 7 { 8 } else { nb });
            for cells in [1, 700, HUGE_FIELD / 4 + 3] {
                let acc = Accumulator::for_bands(cells, nb, 1.0, true);
                assert_eq!(acc.len(), cells * nb);
                let mut rng = Stream::new(6, nb as u64, cells as u64);
                let mut want = vec![0u64; cells * nb];
                let mut buf = Deposits::new();
                for _ in 0..5000 {
                    let cell = ((rng.uniform() * cells as f64) as usize).min(cells - 1);
                    let energy: Vec<f64> = (0..nb).map(|_| (rng.uniform() * 20.0).floor()).collect();
                    acc.deposit(&mut buf, cell, &energy, 0.5);
                    for (b, e) in energy.iter().enumerate() {
                        want[cell * nb + b] += *e as u64;
                    }
                }
                acc.flush(&mut buf);
                assert_eq!(acc.to_vec(), want);
                let last = cells * nb - 1;
                assert_eq!(acc.get(last), want[last]);
                acc.read(|c| {
                    assert!((0..cells).all(|cell| (0..nb).all(|b| c.at(cell, b) == want[cell * nb + b] && c.get(cell * nb + b) == want[cell * nb + b])));
                    // The padding is never written.
                    assert!(c.shards.iter().flat_map(|s| s.iter().enumerate()).all(|(i, &v)| i % stride < nb || v == 0));
                });
                let mut merged = Accumulator::for_bands(cells, nb, 1.0, false);
                merged.merge(&acc);
                merged.merge(&acc);
                assert_eq!(merged.to_vec(), want.iter().map(|c| 2 * c).collect::<Vec<_>>());
            }
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
