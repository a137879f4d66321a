//! The nearest-surface query in a dependent chain, as the sound tracer asks it (each query
//! starts where the last one hit), against several chains interleaved and against the same
//! rays queried independently: what bounds a mesh room's segment (docs/bvh-measured.md, "Rays in
//! flight"). CPU time of the thread (/proc/thread-self/schedstat), which a shared machine's
//! load disturbs less than wall time.
//!
//!   cargo run --release -p sonolux-core --example query_chain -- OBJ|box:OBJ X Y Z [QUERIES]
//!
//! e.g. `examples/l-room/l-room.obj 10.8 3 1.6` (the L-room and its talker) or
//! `box:examples/l-room/l-room.obj 10.8 3 1.6` (its bounding box: the convex path).
//! `QUERY_LANES=portable` traverses without SIMD registers; `QUERY_NODES=full|compressed` picks
//! the tree's nodes (default: as `Bvh::build` chooses); `QUERY_TREE=largest-first` or
//! `sah:NODE:PACKET:LEAF_PACKETS` builds the wide tree by the greedy collapse of sessions 1–12
//! or the SAH-optimal one with these costs, on full-precision nodes (`QUERY_SPATIAL_SPLITS=1`:
//! over a binary tree with spatial splits). Each round also prints the node and packet tests a
//! query. `QUERY_HULL=off` puts every triangle in
//! the tree (default: the mesh's hull at the root when it has one, bvh/hull.rs; the
//! `QUERY_TREE` probes are the SAH tree alone).
use glam::{DVec3, Vec3};
use sonolux_core::convex::Surfaces;
use sonolux_core::geometry::offset_origin;
use sonolux_core::mesh::Mesh;
use sonolux_core::rng::Stream;
use sonolux_core::sampling::{cosine_hemisphere, Frame};
use sonolux_core::Bvh;
#[path = "../tests/common/mod.rs"]
mod common;

fn cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat").unwrap().split_whitespace().next().unwrap().parse().unwrap()
}

/// A triangle mesh from an OBJ file's `v` and `f` lines (triangles, 1-based indices), or the
/// bounding box of one (`box:FILE`), one material.
fn load(spec: &str) -> Mesh {
    let (boxed, path) = spec.strip_prefix("box:").map_or((false, spec), |p| (true, p));
    let text = std::fs::read_to_string(path).expect("an OBJ file");
    let mut verts = Vec::new();
    let mut tris = Vec::new();
    for line in text.lines() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => verts.push(Vec3::from_array(std::array::from_fn(|_| w.next().unwrap().parse().unwrap()))),
            Some("f") => tris.push(std::array::from_fn(|_| w.next().unwrap().split('/').next().unwrap().parse::<u32>().unwrap() - 1)),
            _ => {}
        }
    }
    if boxed {
        let hi = verts.iter().fold(Vec3::ZERO, |m, v| m.max(*v));
        return common::shoebox(hi.x, hi.y, hi.z, [0; 6]);
    }
    let n = tris.len();
    Mesh::new(verts, tris, vec![0; n]).unwrap()
}

struct Walker { pos: DVec3, dir: DVec3, rng: Stream, n: u32 }

impl Walker {
    #[inline(always)]
    fn update(&mut self, hit: Option<(f64, usize, DVec3)>, src: DVec3) {
        self.n += 1;
        match hit {
            Some((t, _, mut normal)) if self.n < 30 => {
                if normal.dot(self.dir) > 0.0 { normal = -normal; }
                let point = self.pos + self.dir * t;
                if self.rng.uniform() < 0.7 {
                    self.dir = cosine_hemisphere(&Frame::from_normal(normal), self.rng.uniform(), self.rng.uniform());
                } else {
                    self.dir = self.dir - 2.0 * self.dir.dot(normal) * normal;
                }
                self.pos = offset_origin(point, normal, self.pos);
            }
            _ => {
                self.pos = src;
                self.dir = sonolux_core::sampling::uniform_sphere(self.rng.uniform(), self.rng.uniform());
                self.n = 0;
            }
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().cloned().expect("OBJ or box:OBJ");
    let src = DVec3::new(args[1].parse().unwrap(), args[2].parse().unwrap(), args[3].parse().unwrap());
    let n: usize = args.get(4).map_or(1_000_000, |a| a.parse().unwrap());
    let mesh = load(&name);
    // QUERY_NODES=full|compressed: the tree's nodes (default: as `Bvh::build` chooses).
    let nodes = match std::env::var("QUERY_NODES").as_deref() {
        Ok("full") => sonolux_core::bvh::Nodes::Full,
        Ok("compressed") => sonolux_core::bvh::Nodes::Compressed,
        _ => sonolux_core::bvh::Nodes::Auto,
    };
    let tree = std::env::var("QUERY_TREE").ok();
    let spatial = std::env::var("QUERY_SPATIAL_SPLITS").is_ok_and(|v| v == "1");
    // QUERY_HULL=off: every triangle in the tree (default: the hull at the root, when the
    // mesh has one; bvh/hull.rs).
    let shape = if std::env::var("QUERY_HULL").as_deref() == Ok("off") { sonolux_core::bvh::Shape::Sah } else { sonolux_core::bvh::Shape::Auto };
    let bvh = match tree.as_deref() {
        Some(t) if spatial => Bvh::build_with_spatial_splits(&mesh, t.parse().expect("QUERY_TREE")).unwrap(),
        Some(t) => Bvh::build_collapsed(&mesh, t.parse().expect("QUERY_TREE")).unwrap(),
        None => Bvh::build_shaped(&mesh, nodes, shape).unwrap(),
    };
    let bvh = match std::env::var("QUERY_LANES").as_deref() {
        Ok("portable") => bvh.portable(),
        _ => bvh,
    };
    let lanes = format!(
        "{}, {} nodes{}, {} nodes, {} packets",
        bvh.simd_name(),
        if bvh.is_compressed() { "compressed" } else { "full" },
        tree.as_deref().map_or(String::new(), |t| format!(" ({t}{})", if spatial { ", spatial splits" } else { "" })),
        bvh.node_count(),
        bvh.packet_count()
    );
    let convex = mesh.is_closed_convex();
    let surf = Surfaces::new(&mesh, &bvh, convex, |r| r.contains(src)).exact_triangles(false);
    let mk = |k: u64| Walker { pos: src, dir: DVec3::X, rng: Stream::new(1, 0, k), n: 100 };
    for round in 0..3 {
        // one chain
        let mut a = mk(1);
        let t0 = cpu_ns();
        for _ in 0..n { let h = surf.nearest(a.pos, a.dir); a.update(h, src); }
        let one = (cpu_ns() - t0) as f64 / n as f64;
        // two chains, both queries first
        let (mut a, mut b) = (mk(1), mk(2));
        let t0 = cpu_ns();
        for _ in 0..n / 2 { let ha = surf.nearest(a.pos, a.dir); let hb = surf.nearest(b.pos, b.dir); a.update(ha, src); b.update(hb, src); }
        let two = (cpu_ns() - t0) as f64 / n as f64;
        // two chains, query+update each
        let (mut a, mut b) = (mk(1), mk(2));
        let t0 = cpu_ns();
        for _ in 0..n / 2 { let ha = surf.nearest(a.pos, a.dir); a.update(ha, src); let hb = surf.nearest(b.pos, b.dir); b.update(hb, src); }
        let two_b = (cpu_ns() - t0) as f64 / n as f64;
        // four chains
        let mut w = [mk(1), mk(2), mk(3), mk(4)];
        let t0 = cpu_ns();
        for _ in 0..n / 4 { let h: [_; 4] = std::array::from_fn(|i| surf.nearest(w[i].pos, w[i].dir)); for i in 0..4 { w[i].update(h[i], src); } }
        let four = (cpu_ns() - t0) as f64 / n as f64;
        // the first chain's rays, recorded, then queried independently
        let mut a = mk(1);
        let mut rec = Vec::with_capacity(n);
        for _ in 0..n { rec.push((a.pos, a.dir)); let h = surf.nearest(a.pos, a.dir); a.update(h, src); }
        let t0 = cpu_ns();
        let mut acc = 0.0;
        for &(p, d) in &rec { acc += surf.nearest(p, d).map_or(0.0, |h| h.0); }
        let indep = (cpu_ns() - t0) as f64 / n as f64;
        std::hint::black_box(acc);
        // FNV-1a of every answer (distance bits, triangle): equal between builds = same hits.
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        for &(p, d) in &rec {
            let (t, tri) = surf.nearest(p, d).map_or((u64::MAX, usize::MAX), |h| (h.0.to_bits(), h.1));
            for w in [t, tri as u64] { hash = (hash ^ w).wrapping_mul(0x0000_0100_0000_01b3); }
        }
        let counts = rec.iter().filter_map(|&(p, d)| bvh.closest_hit_counted(p.as_vec3(), d.as_vec3()).map(|c| c.1));
        let (nodes, packets, to_answer) =
            counts.fold((0u64, 0u64, 0u64), |(a, b, c), w| (a + w.nodes as u64, b + w.packets as u64, c + w.to_answer as u64));
        let per = |x: u64| x as f64 / n as f64;
        let work = format!(
            "; a query: {:.3} node tests ({:.3} on the way to the answer's leaf), {:.3} packet tests",
            per(nodes),
            per(to_answer),
            per(packets)
        );
        println!("{name} ({lanes}) round {round}: ns a query: 1 chain {one:.1}, 2 chains (queries first) {two:.1}, 2 chains (alternating) {two_b:.1}, 4 chains {four:.1}, the first chain's rays queried independently {indep:.1}; answers hash {hash:016x}{work}");
    }
}
