//! Benchmark of the wave solver: air-cell updates per second, per core and on all cores, against
//! this machine's memory bandwidth measured in the same run (a STREAM-like triad), and the cost of
//! whole simulations of the rooms the docs quote.
//!
//!   cargo run --release -p sonolux-core --example wave_bench -- [--quick] [--out FILE]
//!
//! The kernel reads the current and previous fields and writes the next over the previous one:
//! 12 bytes of memory traffic per update once the neighbours come from cache. A grid too large
//! for the caches can therefore run at most at (triad bandwidth)/12 updates per second; the
//! ratio to that bound is printed. `--quick` skips the room simulations (minutes).

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
#[path = "../tests/common/mod.rs"]
mod common;

use sonolux_core::wave::{build_solver, simulate_waves, AbsorptionKind, WaveMaterials, WaveSettings};

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("threads")
}

/// Best of `repeats` triads a[i] = b[i] + s·c[i] over `n` f32: bytes per second as STREAM
/// counts them (12 per element; a write-allocating cache moves 16).
fn triad(n: usize, threads: usize, repeats: usize) -> f64 {
    let (mut a, b, c) = (vec![0f32; n], vec![1f32; n], vec![2f32; n]);
    let p = pool(threads);
    let mut best = f64::INFINITY;
    for _ in 0..repeats {
        let t = Instant::now();
        p.install(|| {
            a.par_chunks_mut(1 << 16).zip(b.par_chunks(1 << 16)).zip(c.par_chunks(1 << 16)).for_each(|((a, b), c)| {
                for ((a, b), c) in a.iter_mut().zip(b).zip(c) {
                    *a = b + 3.0 * c;
                }
            })
        });
        best = best.min(t.elapsed().as_secs_f64());
    }
    std::hint::black_box(&a);
    12.0 * n as f64 / best
}

/// Air-cell updates per second of the bare scheme on a rigid cube of `n`³ cells.
fn kernel(n: usize, threads: usize, steps: usize) -> (f64, u64) {
    let h = 0.05;
    let side = (n as f64 * h) as f32;
    let mesh = common::shoebox(side, side, side, [0; 6]);
    let materials = WaveMaterials { band_centres_hz: vec![125.0], absorption: vec![0.0], wells: Vec::new() };
    let s = WaveSettings { max_frequency_hz: 343.0 / (10.0 * h), threads, memory_limit_bytes: 16 << 30, ..WaveSettings::default() };
    let (mut solver, stats) = build_solver(&mesh, &materials, &s, 0).expect("solver");
    let cells = solver.grid().cells();
    let x: Vec<f32> = (0..cells).map(|i| ((i * 7919) % 1000) as f32 * 1e-3).collect();
    solver.set_state(&x, &x).expect("state");
    solver.step(&[]);
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        for _ in 0..steps {
            solver.step(&[]);
        }
        best = best.min(t.elapsed().as_secs_f64());
    }
    (stats.air_cells as f64 * steps as f64 / best, stats.air_cells)
}

/// A realistic room simulated for 2 s with one source and one receiver.
fn room(name: &str, size: [f32; 3], max_frequency_hz: f64) -> String {
    // Floor carpet, ceiling tiles, plaster walls (random incidence, octaves 63 Hz–1 kHz).
    let materials = WaveMaterials {
        band_centres_hz: vec![62.5, 125.0, 250.0, 500.0, 1000.0],
        absorption: vec![0.02, 0.08, 0.24, 0.57, 0.69, 0.3, 0.5, 0.7, 0.8, 0.85, 0.1, 0.1, 0.08, 0.05, 0.04],
        wells: Vec::new(),
    };
    let mesh = common::shoebox(size[0], size[1], size[2], [0, 1, 2, 2, 2, 2]);
    let s = WaveSettings { max_frequency_hz, duration_s: 2.0, absorption_kind: AbsorptionKind::RandomIncidence, ..WaveSettings::default() };
    let src = DVec3::new(size[0] as f64 * 0.3, size[1] as f64 * 0.4, 1.5);
    let rcv = DVec3::new(size[0] as f64 * 0.7, size[1] as f64 * 0.6, 1.2);
    let r = simulate_waves(&mesh, &materials, &[src], &[rcv], &s, |_| true).expect("simulation");
    let st = &r.stats;
    let branches: Vec<usize> = st.fits.iter().map(|f| f.admittance.branches.len()).collect();
    println!(
        "{name}: {:.0} m³ to {max_frequency_hz} Hz: Δx {:.1} mm, {} cells ({} air), {} boundary nodes, {} steps, estimate {:.0} MB; setup {:.2} s, run {:.1} s ({:.0} M air updates/s); branches per material {branches:?}",
        size[0] * size[1] * size[2],
        1e3 * st.spacing_m,
        st.cells,
        st.air_cells,
        st.boundary.nodes,
        st.steps,
        st.estimate.total_bytes as f64 / 1e6,
        st.setup_s,
        st.run_s,
        st.air_updates_per_s / 1e6
    );
    format!(
        r#"{{"name": "{name}", "volume_m3": {:.0}, "max_frequency_hz": {max_frequency_hz}, "duration_s": 2.0, "spacing_m": {:.5}, "cells": {}, "air_cells": {}, "boundary_nodes": {}, "steps": {}, "estimate_bytes": {}, "setup_s": {:.3}, "run_s": {:.2}, "air_updates_per_s": {:.4e}, "branches_per_material": {branches:?}}}"#,
        size[0] * size[1] * size[2],
        st.spacing_m,
        st.cells,
        st.air_cells,
        st.boundary.nodes,
        st.steps,
        st.estimate.total_bytes,
        st.setup_s,
        st.run_s,
        st.air_updates_per_s
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let out = args.iter().position(|a| a == "--out").and_then(|i| args.get(i + 1)).cloned();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let started = Instant::now();

    let n_triad = 1 << 25; // 3 × 128 MB: far beyond any cache
    // The triad runs before and after the kernels, best of both: a busy machine only lowers it.
    let mut bw: Vec<(usize, f64)> = [1, cores].iter().map(|&t| (t, triad(n_triad, t, 7))).collect();
    // 256³ cells: two fields of 64 MB, beyond the caches; 64³: 2 MB, inside them.
    let mut runs = Vec::new();
    for (n, steps) in [(256usize, 20usize), (64, 400)] {
        for &t in &[1, cores] {
            let (ups, air) = kernel(n, t, steps);
            runs.push((n, t, ups, air));
        }
    }
    for (t, b) in bw.iter_mut() {
        *b = b.max(triad(n_triad, *t, 7));
        println!("triad on {t} thread(s): {:.2} GB/s (STREAM count, 12 B per element)", *b / 1e9);
    }
    let mut kernels = Vec::new();
    for (n, t, ups, air) in runs {
        let bound = bw.iter().find(|b| b.0 == t).map_or(f64::NAN, |b| b.1 / 12.0);
        println!(
            "{n}³ grid on {t} thread(s): {:.0} M air updates/s ({:.0} M per core), {:.2} of the bandwidth bound {:.0} M/s",
            ups / 1e6,
            ups / 1e6 / t as f64,
            ups / bound,
            bound / 1e6
        );
        kernels.push(format!(
            r#"{{"grid": {n}, "air_cells": {air}, "threads": {t}, "air_updates_per_s": {ups:.4e}, "per_core": {:.4e}, "bandwidth_bound_updates_per_s": {bound:.4e}, "fraction_of_bound": {:.3}}}"#,
            ups / t as f64,
            ups / bound
        ));
    }
    let mut rooms = Vec::new();
    if !quick {
        rooms.push(room("150 m3 room", [6.25, 5.0, 4.8], 500.0));
        rooms.push(room("150 m3 room", [6.25, 5.0, 4.8], 1000.0));
        rooms.push(room("paper-large", [24.0, 10.0, 8.0], 250.0));
    }
    let json = format!(
        "{{\n  \"benchmark\": \"waves\",\n  \"sonolux_version\": \"{}\",\n  \"cpus\": {cores},\n  \"bytes_per_update\": 12,\n  \"triad_bytes_per_s\": {{{}}},\n  \"kernel\": [\n    {}\n  ],\n  \"rooms\": [\n    {}\n  ],\n  \"elapsed_s\": {:.1}\n}}\n",
        sonolux_core::VERSION,
        bw.iter().map(|(t, b)| format!("\"{t}\": {b:.4e}")).collect::<Vec<_>>().join(", "),
        kernels.join(",\n    "),
        rooms.join(",\n    "),
        started.elapsed().as_secs_f64()
    );
    match out {
        Some(path) => {
            let tmp = format!("{path}.tmp");
            std::fs::write(&tmp, &json).and_then(|_| std::fs::rename(&tmp, &path)).expect("writing the results");
            println!("written to {path}");
        }
        None => print!("{json}"),
    }
}
