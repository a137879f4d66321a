//! The sound tracer's kernel on the paper's rooms without Python around it: for profiling
//! (`perf record`) and for checking that a change keeps the bits of a bake.
//!
//!   cargo run --release -p sonolux-core --example sound_kernel -- [ROOM] [one|grid] [air|noair] [RAYS] [THREADS] [REPEATS] [BANDS] [flat|rising]
//!
//! ROOM is paper-small, paper-medium or paper-large (default large), built as the scene files
//! under python/sonolux/data/scenes build them: walls and ceiling absorb 5 %, the floor 30 %,
//! scattering 0.1, the talker at the centre 1.5 m high, receivers every metre at 1.5 m (radius
//! 0.25 m) or the one receiver `benchmarks/sound.py` gives the peer. The settings (seven
//! octaves, 48 kHz, the early part, the stored late bins of 10 ms (compact storage) and the
//! maximum time, the air at 20 °C and 50 %) are those
//! the library hands the core for these scenes. Prints the time per ray and per segment (the
//! best of REPEATS bakes) and a hash of the field's counts and the statistics.

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::time::Instant;

use glam::DVec3;
#[path = "../tests/common/mod.rs"]
mod common;

use sonolux_core::sound::{trace_sound, Acoustics, Directivity, Estimator, Receivers, SoundSettings, SoundSource};
use sonolux_core::Bvh;

/// The paper's rooms: size (m), the library's max_time_s and early part (bins at 48 kHz), the
/// one receiver of the peer comparison, and the grid's extent (x and y from 1 m to size − 1 m,
/// or half a step in from the walls when the room is narrow).
struct Room {
    size: [f64; 3],
    max_time_s: f64,
    early_bins: f64,
    one: [f64; 3],
    grid: ([f64; 2], [f64; 2]),
}

fn room(name: &str) -> Room {
    match name {
        "paper-small" => Room { size: [6.0, 2.5, 2.0], max_time_s: 1.46357523834808, early_bins: 4176.0, one: [1.0, 1.25, 1.5], grid: ([1.0, 5.0], [0.25, 2.25]) },
        "paper-medium" => Room { size: [12.0, 5.0, 4.0], max_time_s: 2.917908118760158, early_bins: 4608.0, one: [6.0, 0.5, 1.5], grid: ([1.0, 11.0], [0.5, 4.5]) },
        "paper-large" => Room { size: [24.0, 10.0, 8.0], max_time_s: 5.799238604096075, early_bins: 5520.0, one: [12.0, 3.0, 1.5], grid: ([1.0, 23.0], [1.0, 9.0]) },
        other => panic!("unknown room {other}: paper-small, paper-medium or paper-large"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |k: usize, default: &str| args.get(k).cloned().unwrap_or_else(|| default.to_string());
    let name = arg(0, "paper-large");
    let grid = arg(1, "one") == "grid";
    let air = arg(2, "noair") == "air";
    let rays: u64 = arg(3, "200000").parse().expect("RAYS");
    let threads: usize = arg(4, "1").parse().expect("THREADS");
    let repeats: usize = arg(5, "3").parse().expect("REPEATS");
    // BANDS other than 7 (the kernel is compiled for 6, 7 and 18, any other count at run time):
    // the octaves' air repeated, the same materials in every band.
    let nb: usize = arg(6, "7").parse().expect("BANDS");
    // `rising`: the scattering rises from 0.05 to 0.8 across the bands (the bands scatter
    // unlike: hero-band sampling, sound/bounce.rs), instead of 0.1 in every band.
    let rising = arg(7, "flat") == "rising";
    let r = room(&name);
    let [l, w, h] = r.size;
    // Materials: 0 the floor, 1 walls and ceiling (tests/common's order: floor, ceiling, 4 walls).
    let mesh = common::shoebox(l as f32, w as f32, h as f32, [0, 1, 1, 1, 1, 1]);
    let bvh = Bvh::build(&mesh).expect("bvh");
    let acoustics = Acoustics {
        n_bands: nb,
        absorption: [vec![0.3; nb], vec![0.05; nb]].concat(),
        scattering: if rising { (0..2 * nb).map(|i| 0.05 + 0.75 * (i % nb) as f64 / (nb - 1).max(1) as f64).collect() } else { vec![0.1; 2 * nb] },
    };
    let sources = [SoundSource { position: DVec3::new(l / 2.0, w / 2.0, 1.5), power_w: 1.0, directivity: Directivity::Omni }];
    let centres = if grid {
        let (xs, ys) = r.grid;
        let mut c = Vec::new();
        let mut y = ys[0];
        while y <= ys[1] + 1e-9 {
            let mut x = xs[0];
            while x <= xs[1] + 1e-9 {
                c.push(DVec3::new(x, y, 1.5));
                x += 1.0;
            }
            y += 1.0;
        }
        c
    } else {
        vec![DVec3::from_array(r.one)]
    };
    let receivers = Receivers::new(centres, 0.25);
    // ISO 9613-1 energy attenuation at 20 °C, 50 %, 101.325 kPa, octaves 125 Hz–8 kHz (1/m):
    // what python/sonolux/scene/summary.py hands the core for these scenes.
    let octaves_air_per_m = [0.00010254490270413848, 0.0003034917968652891, 0.0006294033499920638, 0.001074094207547551, 0.0022692532644438272, 0.006774032137364035, 0.023926674578535357];
    let settings = SoundSettings {
        rays,
        first_ray: 0,
        end_ray: rays,
        seed: 1,
        first_receiver: 0,
        only_source: None,
        threads,
        estimator: Estimator::Paper,
        speed_of_sound_m_s: 343.21462268256795,
        air_attenuation_per_m: if air { (0..nb).map(|b| octaves_air_per_m[b % 7]).collect() } else { vec![0.0; nb] },
        energy_drop_db: 60.0,
        max_time_s: r.max_time_s,
        sample_rate_hz: 48_000.0,
        early_s: r.early_bins / 48_000.0,
        late_bin_s: 0.01,
        n_azimuth: 8,
        n_elevation: 1,
        max_field_bytes: 1 << 34,
    };
    let mut best = f64::INFINITY;
    let mut best_cpu = f64::INFINITY;
    let mut hash = 0u64;
    let mut per_ray = (0.0, 0.0);
    for _ in 0..repeats.max(1) {
        let (start, cpu) = (Instant::now(), cpu_seconds());
        let res = trace_sound(&mesh, &bvh, &acoustics, &sources, &receivers, &settings, |_| true).expect("bake");
        let seconds = start.elapsed().as_secs_f64();
        best = best.min(seconds);
        best_cpu = best_cpu.min(cpu_seconds() - cpu);
        let st = &res.stats;
        per_ray = (st.segments as f64 / st.rays as f64, st.deposits as f64 / st.rays as f64);
        let mut hasher = DefaultHasher::new();
        res.field.to_vec().hash(&mut hasher);
        let energies: Vec<Option<Vec<f64>>> = ["emitted", "absorbed_surfaces", "absorbed_air", "escaped", "remaining", "reweighted"].iter().map(|k| st.energy(k)).collect();
        format!("{:?}", (st.rays, st.segments, st.deposits, st.surface_hits, st.free_paths, st.mean_free_path(), energies)).hash(&mut hasher);
        hash = hasher.finish();
    }
    let segments = per_ray.0 * rays as f64;
    println!(
        "{name} {} {} {rays} rays {threads}T: best {best:.3} s, {:.0} rays/s, {:.1} ns/segment wall x threads, {:.1} ns/segment CPU, {:.1} segments and {:.2} deposits a ray, hash {hash:016x}",
        if grid { "grid" } else { "one" },
        if air { "air" } else { "noair" },
        rays as f64 / best,
        best * 1e9 / segments * threads as f64,
        best_cpu * 1e9 / segments,
        per_ray.0,
        per_ray.1
    );
}

/// CPU time of this process so far, exited threads included (Linux's /proc/self/stat, user +
/// system, in clock ticks of 10 ms): on a shared machine the wall time counts others' work too.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return f64::NAN };
    // The fields after the command name (in parentheses, which may hold spaces): utime and
    // stime are the 12th and 13th.
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |k: usize| fields.get(k).and_then(|f| f.parse::<f64>().ok()).unwrap_or(f64::NAN);
    (ticks(11) + ticks(12)) / 100.0
}
