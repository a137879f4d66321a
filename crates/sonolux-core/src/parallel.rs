//! The parallel driver both tracers share: work is cut into fixed chunks of ray indices, worker
//! threads take chunks in turn and each fills its own accumulator, while the calling thread
//! reports progress and watches for cancellation.
//!
//! Results do not depend on which thread traced which chunk as long as the accumulators merge
//! associatively: the tracers sum in integers (fixed point), so the bits are the same for any
//! thread count and for any split of a run into ranges.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// What the caller learns while a run goes on.
pub struct Progress {
    pub done: u64,
    pub total: u64,
    pub elapsed: Duration,
}

/// The number of workers `threads` asks for: itself, or one per core for 0.
pub fn workers(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        threads
    }
}

/// Runs `work(acc, start..end)` over `total` items in chunks of `chunk` on `threads` workers
/// (0 = all cores). `progress` is called on the calling thread about every 100 ms; when it
/// returns false the run stops after the chunks under way (the result then says so).
/// Returns one accumulator per worker and whether the run was cancelled.
pub fn run_chunks<A: Send>(
    total: u64,
    chunk: u64,
    threads: usize,
    make: impl Fn() -> A + Sync,
    work: impl Fn(&mut A, std::ops::Range<u64>) + Sync,
    mut progress: impl FnMut(&Progress) -> bool,
) -> (Vec<A>, bool) {
    let chunk = chunk.max(1);
    // Never more workers than chunks: an idle worker would only hold memory.
    let threads = workers(threads).min(total.div_ceil(chunk).max(1) as usize);
    let next = AtomicU64::new(0);
    let done = AtomicU64::new(0);
    let stop = AtomicBool::new(false);
    let running = AtomicU64::new(threads as u64);
    let start = Instant::now();
    let accs = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut acc = make();
                    while !stop.load(Ordering::Relaxed) {
                        let s = next.fetch_add(chunk, Ordering::Relaxed);
                        if s >= total {
                            break;
                        }
                        let e = (s + chunk).min(total);
                        work(&mut acc, s..e);
                        done.fetch_add(e - s, Ordering::Relaxed);
                    }
                    running.fetch_sub(1, Ordering::Release);
                    acc
                })
            })
            .collect();
        while running.load(Ordering::Acquire) > 0 {
            std::thread::sleep(Duration::from_millis(20));
            if start.elapsed().as_millis() % 100 < 20 || running.load(Ordering::Acquire) == 0 {
                let p = Progress { done: done.load(Ordering::Relaxed), total, elapsed: start.elapsed() };
                if !progress(&p) {
                    stop.store(true, Ordering::Relaxed);
                }
            }
        }
        handles.into_iter().map(|h| h.join().expect("a worker thread panicked")).collect::<Vec<A>>()
    });
    let cancelled = stop.load(Ordering::Relaxed) && done.load(Ordering::Relaxed) < total;
    (accs, cancelled)
}

/// Fills `out`, cut into blocks of `block` items (the last may be shorter), on `threads` workers
/// (0 = all cores): `fill(k, block_k)` for every block k, each worker taking a contiguous run of
/// blocks. Each item is written once, so the result does not depend on the thread count.
pub fn fill_blocks<T: Send>(out: &mut [T], block: usize, threads: usize, fill: impl Fn(usize, &mut [T]) + Sync) {
    if out.is_empty() || block == 0 {
        return;
    }
    let n_blocks = out.len().div_ceil(block);
    let per_worker = n_blocks.div_ceil(workers(threads).min(n_blocks));
    let fill = &fill;
    std::thread::scope(|scope| {
        for (g, run) in out.chunks_mut(per_worker * block).enumerate() {
            scope.spawn(move || {
                for (k, b) in run.chunks_mut(block).enumerate() {
                    fill(g * per_worker + k, b);
                }
            });
        }
    });
}
