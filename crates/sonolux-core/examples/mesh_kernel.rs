//! The sound kernel on `benchmarks/mesh_room.py`'s rooms without Python around it: for profiling
//! (`perf record`, callgrind) the mesh path against its convex box, and for checking that a
//! change keeps a bake's bits.
//!
//!   python benchmarks/mesh_room.py --dump DIR      (writes DIR/{l-room,l-room-100k,box}.scene)
//!   cargo run --release -p sonolux-core --example mesh_kernel -- DIR/l-room.scene [RAYS] [THREADS] [REPEATS]
//!
//! A `.scene` file is whitespace-separated numbers, the core's inputs as the library hands them
//! to it for the benchmark's bake (paper estimator, air off): vertices, triangles, material ids,
//! absorption and scattering [material][band], the source, the receivers, the settings.
//! Prints the CPU time a segment (the best of REPEATS bakes) and a hash of the field's counts and
//! the statistics. `MESH_TREE=largest-first|sah:NODE:PACKET:LEAF_PACKETS` builds the BVH by
//! the greedy collapse of sessions 1–12 or the SAH-optimal one with these costs (default:
//! `Bvh::build`'s).

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::time::Instant;

use glam::{DVec3, Vec3};
use sonolux_core::sound::{trace_sound, Acoustics, Directivity, Estimator, Receivers, SoundSettings, SoundSource};
use sonolux_core::{Bvh, Mesh};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().expect("a .scene file (benchmarks/mesh_room.py --dump DIR)");
    let rays: u64 = args.get(1).map_or(100_000, |a| a.parse().expect("RAYS"));
    let threads: usize = args.get(2).map_or(1, |a| a.parse().expect("THREADS"));
    let repeats: usize = args.get(3).map_or(3, |a| a.parse().expect("REPEATS"));
    let text = std::fs::read_to_string(path).expect("read the .scene file");
    let mut it = text.split_whitespace().map(|w| w.parse::<f64>().expect("a number"));
    let mut next = || it.next().expect("the .scene file ends early");
    let nv = next() as usize;
    let vertices: Vec<Vec3> = (0..nv).map(|_| DVec3::new(next(), next(), next()).as_vec3()).collect();
    let nt = next() as usize;
    let triangles: Vec<[u32; 3]> = (0..nt).map(|_| [next() as u32, next() as u32, next() as u32]).collect();
    let material: Vec<u32> = (0..nt).map(|_| next() as u32).collect();
    let (nm, nb) = (next() as usize, next() as usize);
    let absorption: Vec<f64> = (0..nm * nb).map(|_| next()).collect();
    let scattering: Vec<f64> = (0..nm * nb).map(|_| next()).collect();
    let source = DVec3::new(next(), next(), next());
    let power_w = next();
    let nr = next() as usize;
    let centres: Vec<DVec3> = (0..nr).map(|_| DVec3::new(next(), next(), next())).collect();
    let radius_m = next();
    let (speed, drop_db, max_time_s, rate_hz, early_s, late_bin_s) = (next(), next(), next(), next(), next(), next());
    let (n_azimuth, n_elevation, seed) = (next() as usize, next() as usize, next() as u64);

    let mesh = Mesh::new(vertices, triangles, material).expect("mesh");
    // MESH_TREE=largest-first|sah|sah:NODE:PACKET:LEAF_PACKETS: how the wide tree is collapsed,
    // to measure the default against (the same hits, so the same bits; docs/bvh.md, "Wide
    // nodes by cost"), on the SAH tree alone. MESH_HULL=off: the SAH tree alone (default: the
    // mesh's hull at the root when it has one, bvh/hull.rs).
    let shape = if std::env::var("MESH_HULL").as_deref() == Ok("off") { sonolux_core::bvh::Shape::Sah } else { sonolux_core::bvh::Shape::Auto };
    let bvh = match std::env::var("MESH_TREE") {
        Ok(t) => Bvh::build_collapsed(&mesh, t.parse().expect("MESH_TREE")),
        Err(_) => Bvh::build_shaped(&mesh, sonolux_core::bvh::Nodes::Auto, shape),
    }
    .expect("bvh");
    let acoustics = Acoustics { n_bands: nb, absorption, scattering };
    let sources = [SoundSource { position: source, power_w, directivity: Directivity::Omni }];
    let receivers = Receivers::new(centres, radius_m);
    let settings = SoundSettings {
        rays,
        first_ray: 0,
        end_ray: rays,
        seed,
        first_receiver: 0,
        only_source: None,
        threads,
        estimator: Estimator::Paper,
        speed_of_sound_m_s: speed,
        air_attenuation_per_m: vec![0.0; nb],
        energy_drop_db: drop_db,
        max_time_s,
        sample_rate_hz: rate_hz,
        early_s,
        late_bin_s,
        n_azimuth,
        n_elevation,
        max_field_bytes: 1 << 34,
    };
    let (mut best, mut best_cpu, mut hash, mut per_ray) = (f64::INFINITY, f64::INFINITY, 0u64, 0.0);
    for _ in 0..repeats.max(1) {
        let (start, cpu) = (Instant::now(), cpu_seconds());
        let res = trace_sound(&mesh, &bvh, &acoustics, &sources, &receivers, &settings, |_| true).expect("bake");
        best = best.min(start.elapsed().as_secs_f64());
        best_cpu = best_cpu.min(cpu_seconds() - cpu);
        let st = &res.stats;
        per_ray = st.segments as f64 / st.rays as f64;
        let mut hasher = DefaultHasher::new();
        res.field.to_vec().hash(&mut hasher);
        let energies: Vec<Option<Vec<f64>>> = ["emitted", "absorbed_surfaces", "absorbed_air", "escaped", "remaining", "reweighted"].iter().map(|k| st.energy(k)).collect();
        format!("{:?}", (st.rays, st.segments, st.deposits, st.surface_hits, st.free_paths, st.mean_free_path(), energies)).hash(&mut hasher);
        hash = hasher.finish();
    }
    let segments = per_ray * rays as f64;
    println!(
        "{path} ({} nodes, {} packets) {rays} rays {threads}T: best {best:.3} s, {:.1} ns/segment wall x threads, {:.1} ns/segment CPU, {per_ray:.1} segments a ray, hash {hash:016x}",
        bvh.node_count(),
        bvh.packet_count(),
        best * 1e9 / segments * threads as f64,
        best_cpu * 1e9 / segments,
    );
}

/// CPU time of this process so far (Linux's /proc/self/stat, user + system, in ticks of 10 ms).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return f64::NAN };
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |k: usize| fields.get(k).and_then(|f| f.parse::<f64>().ok()).unwrap_or(f64::NAN);
    (ticks(11) + ticks(12)) / 100.0
}
