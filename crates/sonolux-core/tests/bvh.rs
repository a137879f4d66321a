//! The BVH against the brute-force oracle, and watertightness at shared edges and vertices.

use glam::Vec3;
use rayon::prelude::*;
use sonolux_core::geometry::intersect_triangle;
use sonolux_core::rng::Stream;
use sonolux_core::sampling::uniform_sphere;
use sonolux_core::bvh::{Nodes, Shape};
use sonolux_core::{Bvh, Hit, Mesh, Ray};

mod oracle;
mod rooms;

use oracle::brute_force;

fn random_point(s: &mut Stream, scale: f32) -> Vec3 {
    Vec3::new(s.uniform_f32(), s.uniform_f32(), s.uniform_f32()) * scale
}

/// A soup of random triangles of assorted sizes, with a few degenerate ones mixed in.
fn random_soup(n: usize, seed: u64) -> Mesh {
    let mut s = Stream::new(seed, 0, 0);
    let mut v = Vec::new();
    let mut t = Vec::new();
    for i in 0..n {
        let c = random_point(&mut s, 10.0);
        let size = 0.05 + 2.0 * s.uniform_f32().powi(3);
        let k = v.len() as u32;
        v.push(c + (random_point(&mut s, 2.0) - Vec3::ONE) * size);
        v.push(c + (random_point(&mut s, 2.0) - Vec3::ONE) * size);
        if i % 97 == 0 {
            v.push(v[k as usize]); // a zero-area triangle
        } else {
            v.push(c + (random_point(&mut s, 2.0) - Vec3::ONE) * size);
        }
        t.push([k, k + 1, k + 2]);
    }
    let m = vec![0; n];
    Mesh::new(v, t, m).unwrap()
}

fn random_rays(n: usize, seed: u64) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let mut s = Stream::new(seed, 1, i as u64);
            let o = random_point(&mut s, 14.0) - Vec3::splat(2.0);
            let d = uniform_sphere(s.uniform(), s.uniform()).as_vec3();
            Ray::new(o, d)
        })
        .collect()
}

/// Rays through the corners and edge midpoints of random triangles of the mesh (and slightly
/// beside them): where the watertight test is decided by its f64 fallback and where a box
/// test that rounded the wrong way would cull the hit.
fn rays_at_edges_and_vertices(mesh: &Mesh, n: usize, seed: u64) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let mut s = Stream::new(seed, 2, i as u64);
            let tri = (s.next_u64() % mesh.triangles.len() as u64) as usize;
            let [a, b, c] = mesh.corners(tri);
            let target = match i % 4 {
                0 => [a, b, c][(s.next_u64() % 3) as usize],
                1 => 0.5 * (a + b),
                2 => 0.5 * (b + c),
                _ => a + (b - a) * s.uniform_f32(),
            };
            let o = random_point(&mut s, 14.0) - Vec3::splat(2.0);
            // Every other ray is nudged by an ulp-sized step so both sides of the edge are hit.
            let d = if i % 2 == 0 { target - o } else { (target - o) * (1.0 + f32::EPSILON) };
            Ray::new(o, d)
        })
        .collect()
}

/// How many rays the BVH and the brute-force oracle answer differently (distance compared to
/// the bit; the triangle may differ only where two are hit at exactly the same t), with an
/// example. Also checks that `occluded` agrees with the closest hit on a range that ends at a
/// ray-dependent distance, for every ray.
fn disagreements(mesh: &Mesh, bvh: &Bvh, rays: &[Ray]) -> (usize, String) {
    let bad: Vec<String> = rays
        .par_iter()
        .enumerate()
        .filter_map(|(i, r)| {
            let (a, b) = (bvh.closest_hit(r, 0.0, f32::INFINITY), brute_force(mesh, r));
            let same = match (a, b) {
                (None, None) => true,
                (Some(x), Some(y)) => x.t.to_bits() == y.t.to_bits(),
                _ => false,
            };
            let t_end = [0.5f32, 3.0, 12.0][i % 3];
            let occluded_ok = bvh.occluded(r, 0.0, t_end) == b.is_some_and(|h| h.t < t_end);
            (!same || !occluded_ok).then(|| format!("{:?} → {:?}: bvh {a:?} brute {b:?} occluded ok {occluded_ok}", r.origin, r.dir))
        })
        .collect();
    (bad.len(), bad.first().cloned().unwrap_or_default())
}

/// On the full-precision tree and on the compressed one (docs/bvh.md, "Compressed nodes").
fn assert_agrees(mesh: &Mesh, rays: &[Ray], what: &str) {
    for nodes in [Nodes::Full, Nodes::Compressed] {
        let bvh = Bvh::build_with(mesh, nodes).unwrap();
        assert_eq!(bvh.is_compressed(), nodes == Nodes::Compressed);
        let (n, example) = disagreements(mesh, &bvh, rays);
        assert_eq!(n, 0, "{what}, {nodes:?} nodes: {n} of {} rays differ, e.g. {example}", rays.len());
    }
}

#[test]
fn bvh_agrees_with_brute_force_on_a_million_rays() {
    for (n_tris, n_rays, seed) in [(300, 1_000_000, 1), (3000, 100_000, 2), (7, 100_000, 3), (2, 20_000, 4)] {
        let mesh = random_soup(n_tris, seed);
        assert_agrees(&mesh, &random_rays(n_rays, seed), &format!("{n_tris} triangles, random rays"));
        assert_agrees(&mesh, &rays_at_edges_and_vertices(&mesh, n_rays / 4, seed), &format!("{n_tris} triangles, edge rays"));
    }
}

/// Several million rays, random and aimed at edges and vertices, on soups of several sizes.
#[test]
#[ignore = "slow: several million brute-force rays (make test-all)"]
fn bvh_agrees_with_brute_force_on_millions_of_rays() {
    for (n_tris, n_rays, seed) in [(200, 4_000_000, 11), (2000, 1_000_000, 12), (20_000, 200_000, 13)] {
        let mesh = random_soup(n_tris, seed);
        assert_agrees(&mesh, &random_rays(n_rays, seed), &format!("{n_tris} triangles, random rays"));
        assert_agrees(&mesh, &rays_at_edges_and_vertices(&mesh, n_rays, seed), &format!("{n_tris} triangles, edge rays"));
    }
}

/// Triangles from 1e-4 m to 1 km side by side (a room model's scale range), coincident
/// triangles (which no split separates), and a chain of ever smaller nested triangles (a deep
/// tree whose traversal stack outgrows its fixed part).
#[test]
fn huge_tiny_coincident_and_nested_triangles() {
    let mut s = Stream::new(21, 0, 0);
    let (mut v, mut t) = (Vec::new(), Vec::new());
    let tri = |v: &mut Vec<Vec3>, t: &mut Vec<[u32; 3]>, a: Vec3, b: Vec3, c: Vec3| {
        let k = v.len() as u32;
        v.extend([a, b, c]);
        t.push([k, k + 1, k + 2]);
    };
    // Two huge floor triangles and a huge wall.
    tri(&mut v, &mut t, Vec3::new(-500.0, -500.0, 0.0), Vec3::new(500.0, -500.0, 0.0), Vec3::new(500.0, 500.0, 0.0));
    tri(&mut v, &mut t, Vec3::new(-500.0, -500.0, 0.0), Vec3::new(500.0, 500.0, 0.0), Vec3::new(-500.0, 500.0, 0.0));
    tri(&mut v, &mut t, Vec3::new(-500.0, 7.0, 0.0), Vec3::new(500.0, 7.0, 0.0), Vec3::new(0.0, 7.0, 300.0));
    // Tiny triangles scattered near the origin.
    for _ in 0..2000 {
        let c = random_point(&mut s, 4.0);
        let size = 1e-4 * (1.0 + 100.0 * s.uniform_f32());
        let p = |s: &mut Stream| c + (random_point(s, 2.0) - Vec3::ONE) * size;
        let (a, b, cc) = (p(&mut s), p(&mut s), p(&mut s));
        tri(&mut v, &mut t, a, b, cc);
    }
    // Twenty copies of one triangle.
    for _ in 0..20 {
        tri(&mut v, &mut t, Vec3::new(1.0, 1.0, 1.0), Vec3::new(2.0, 1.0, 1.0), Vec3::new(1.0, 2.0, 1.5));
    }
    // Nested triangles halving in size towards (3, 3, 3): one split peels one off each level.
    for k in 0..120 {
        let h = 0.5f32.powi(k / 4) * 2.0;
        let c = Vec3::splat(3.0);
        tri(&mut v, &mut t, c + Vec3::new(h, 0.0, 0.1 * h), c + Vec3::new(0.0, h, 0.0), c + Vec3::new(-h, -h, 0.3 * h));
    }
    let n = t.len();
    let mesh = Mesh::new(v, t, vec![0; n]).unwrap();
    let mut rays = random_rays(100_000, 21);
    // Rays from inside the nested chain, and at the tiny triangles' corners.
    rays.extend((0..20_000).map(|i| {
        let mut s = Stream::new(22, 0, i);
        Ray::new(Vec3::splat(3.0) + (random_point(&mut s, 2.0) - Vec3::ONE) * 1e-3, uniform_sphere(s.uniform(), s.uniform()).as_vec3())
    }));
    rays.extend(rays_at_edges_and_vertices(&mesh, 50_000, 23));
    assert_agrees(&mesh, &rays, "mixed scales");
}

/// The AVX2 path (where the CPU has it) and the portable one give the same bits.
#[test]
fn simd_and_portable_traversal_give_the_same_bits() {
    let mesh = random_soup(3000, 31);
    let bvh = Bvh::build(&mesh).unwrap();
    let portable = bvh.clone().portable();
    assert_eq!(portable.simd_name(), "portable");
    let mut rays = random_rays(200_000, 31);
    rays.extend(rays_at_edges_and_vertices(&mesh, 100_000, 31));
    let differ = rays
        .par_iter()
        .filter(|r| {
            let (a, b) = (bvh.closest_hit(r, 0.0, f32::INFINITY), portable.closest_hit(r, 0.0, f32::INFINITY));
            a.map(|h| (h.t.to_bits(), h.triangle)) != b.map(|h| (h.t.to_bits(), h.triangle)) || bvh.occluded(r, 0.1, 4.0) != portable.occluded(r, 0.1, 4.0)
        })
        .count();
    assert_eq!(differ, 0, "{} ({}) and portable traversal differ on {differ} rays", bvh.simd_name(), bvh.simd_name());
}

/// The sound tracer's query (`closest_hit_from`: the ray set up inside the kernel) gives the hits
/// of `closest_hit` on a ray built outside it, to the bit, on both lanes.
#[test]
fn closest_hit_from_gives_the_same_bits_as_closest_hit() {
    let mesh = random_soup(3000, 37);
    for bvh in [Bvh::build(&mesh).unwrap(), Bvh::build(&mesh).unwrap().portable()] {
        let mut rays = random_rays(100_000, 37);
        rays.extend(rays_at_edges_and_vertices(&mesh, 50_000, 37));
        let key = |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.triangle));
        let differ = rays.par_iter().filter(|r| key(bvh.closest_hit_from(r.origin, r.dir)) != key(bvh.closest_hit(r, 0.0, f32::INFINITY))).count();
        assert_eq!(differ, 0, "{}: {differ} rays differ", bvh.simd_name());
    }
}

/// The same mesh gives the same tree, bit for bit, on one thread and on several.
#[test]
fn build_is_deterministic_whatever_the_thread_count() {
    let mesh = random_soup(50_000, 41);
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| Bvh::build(&mesh).unwrap())
    };
    let (one, two, four) = (on(1), on(2), on(4));
    assert!(one.node_count() > 100, "{} nodes", one.node_count());
    assert_eq!(one.fingerprint(), two.fingerprint());
    assert_eq!(one.fingerprint(), four.fingerprint());
    assert_eq!(one.fingerprint(), on(1).fingerprint());
    // And the fingerprint does see a change: a mesh with one vertex moved builds another tree.
    let mut moved = mesh.clone();
    moved.vertices[7].x += 0.25;
    assert_ne!(Bvh::build(&moved).unwrap().fingerprint(), one.fingerprint());
}

/// A closed box of `k`×`k` quads a face, each split into two triangles along alternating diagonals.
fn tessellated_box(k: u32, size: f32) -> Mesh {
    let mut v = Vec::new();
    let mut t = Vec::new();
    // Six faces: an origin corner and two edge directions (chosen so normals face outward).
    let faces = [
        (Vec3::ZERO, Vec3::Y, Vec3::X),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::ZERO, Vec3::X, Vec3::Z),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::ZERO, Vec3::Z, Vec3::Y),
        (Vec3::X, Vec3::Y, Vec3::Z),
    ];
    let mut index = std::collections::HashMap::new();
    let mut vid = |p: Vec3, v: &mut Vec<Vec3>| -> u32 {
        let key = [(p.x * 1000.0).round() as i64, (p.y * 1000.0).round() as i64, (p.z * 1000.0).round() as i64];
        *index.entry(key).or_insert_with(|| {
            v.push(p);
            (v.len() - 1) as u32
        })
    };
    for (o, e1, e2) in faces {
        for i in 0..k {
            for j in 0..k {
                let p = |a: u32, b: u32| (o + e1 * (a as f32 / k as f32) + e2 * (b as f32 / k as f32)) * size;
                let (a, b, c, d) = (vid(p(i, j), &mut v), vid(p(i + 1, j), &mut v), vid(p(i + 1, j + 1), &mut v), vid(p(i, j + 1), &mut v));
                if (i + j) % 2 == 0 {
                    t.push([a, b, c]);
                    t.push([a, c, d]);
                } else {
                    t.push([a, b, d]);
                    t.push([b, c, d]);
                }
            }
        }
    }
    let n = t.len();
    Mesh::new(v, t, vec![0; n]).unwrap()
}

#[test]
fn closed_box_is_closed_and_rays_through_edges_and_vertices_never_leak() {
    let size = 3.7;
    let mesh = tessellated_box(9, size);
    let r = mesh.report();
    assert_eq!((r.n_open_edges, r.n_inconsistent_edges, r.n_nonmanifold_edges), (0, 0, 0));
    assert!((r.signed_volume - (size as f64).powi(3)).abs() < 1e-3);
    let bvh = Bvh::build(&mesh).unwrap();
    // Aim from several interior points at every vertex and at every edge midpoint.
    let mut targets: Vec<Vec3> = mesh.vertices.clone();
    for t in &mesh.triangles {
        for k in 0..3 {
            targets.push(0.5 * (mesh.vertices[t[k] as usize] + mesh.vertices[t[(k + 1) % 3] as usize]));
        }
    }
    let origins = [Vec3::splat(size / 2.0), Vec3::new(0.3, 1.1, 2.9), Vec3::new(size / 9.0 * 4.0, size / 2.0, size / 9.0)];
    let mut misses = 0;
    for o in origins {
        for &p in &targets {
            let ray = Ray::new(o, p - o);
            match bvh.closest_hit(&ray, 1e-4, f32::INFINITY) {
                Some(h) => assert!((h.t - 1.0).abs() < 1e-4, "hit at t = {} instead of 1", h.t),
                None => misses += 1,
            }
        }
    }
    assert_eq!(misses, 0, "rays leaked through shared edges or vertices");
    // And a million random directions from the centre all hit the box.
    let leaks = (0..1_000_000u64)
        .into_par_iter()
        .filter(|&i| {
            let mut s = Stream::new(9, 0, i);
            let d = uniform_sphere(s.uniform(), s.uniform()).as_vec3();
            bvh.closest_hit(&Ray::new(Vec3::splat(size / 2.0), d), 0.0, f32::INFINITY).is_none()
        })
        .count();
    assert_eq!(leaks, 0);
}

#[test]
fn empty_or_all_degenerate_geometry_is_an_error() {
    let m = Mesh::new(vec![Vec3::ZERO, Vec3::X], vec![[0, 1, 1]], vec![0]).unwrap();
    assert!(Bvh::build(&m).is_err());
    let empty = Mesh::new(vec![], vec![], vec![]).unwrap();
    assert!(Bvh::build(&empty).is_err());
}

#[test]
fn one_triangle() {
    let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]], vec![0]).unwrap();
    let bvh = Bvh::build(&m).unwrap();
    assert_eq!((bvh.node_count(), bvh.packet_count()), (1, 1));
    let hit = bvh.closest_hit(&Ray::new(Vec3::new(0.25, 0.25, 2.0), Vec3::new(0.0, 0.0, -1.0)), 0.0, f32::INFINITY);
    assert_eq!(hit, Some(Hit { t: 2.0, triangle: 0 }));
    assert!(bvh.closest_hit(&Ray::new(Vec3::new(0.25, 0.25, 2.0), Vec3::new(0.0, 0.0, -1.0)), 0.0, 1.5).is_none());
    assert!(bvh.closest_hit(&Ray::new(Vec3::new(0.75, 0.75, 2.0), Vec3::new(0.0, 0.0, -1.0)), 0.0, f32::INFINITY).is_none());
    assert!(bvh.occluded(&Ray::new(Vec3::new(0.25, 0.25, -2.0), Vec3::Z), 0.0, 2.5));
    assert!(!bvh.occluded(&Ray::new(Vec3::new(0.25, 0.25, -2.0), Vec3::Z), 2.5, 9.0));
    assert_eq!(bvh.bounds().min, Vec3::ZERO);
    assert_eq!(bvh.bounds().max, Vec3::new(1.0, 1.0, 0.0));
}

/// The compressed tree gives the full-precision tree's hits, distance and triangle to the bit
/// (a decoded box only lets more children through; the triangle could differ only where two
/// are hit at exactly the same t, which a soup of separate triangles does not have), with the
/// sound tracer's query, on AVX2 and portable lanes, and the same visibility; and
/// `Nodes::Auto` keeps these trees, below the threshold, at full precision.
#[test]
fn compressed_nodes_give_the_full_precision_hits() {
    let mesh = random_soup(20_000, 51);
    let full = Bvh::build_with(&mesh, Nodes::Full).unwrap();
    let compressed = Bvh::build_with(&mesh, Nodes::Compressed).unwrap();
    assert_eq!((full.node_count(), full.packet_count()), (compressed.node_count(), compressed.packet_count()));
    assert!(compressed.memory_bytes() < full.memory_bytes());
    let mut rays = random_rays(200_000, 51);
    rays.extend(rays_at_edges_and_vertices(&mesh, 100_000, 51));
    let key = |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.triangle));
    for (a, b) in [(&full, &compressed), (&full.clone().portable(), &compressed.clone().portable())] {
        let differ = rays
            .par_iter()
            .filter(|r| {
                key(a.closest_hit(r, 0.0, f32::INFINITY)) != key(b.closest_hit(r, 0.0, f32::INFINITY))
                    || key(a.closest_hit_from(r.origin, r.dir)) != key(b.closest_hit_from(r.origin, r.dir))
                    || key(a.closest_hit(r, 0.5, 6.0)) != key(b.closest_hit(r, 0.5, 6.0))
                    || a.occluded(r, 0.1, 4.0) != b.occluded(r, 0.1, 4.0)
            })
            .count();
        assert_eq!(differ, 0, "{}: compressed and full-precision nodes differ on {differ} rays", b.simd_name());
    }
    // (The rule itself, on both sides of the threshold: `bvh::tests`; a mesh above it would take
    // millions of triangles.)
    let small = random_soup(300, 52);
    for m in [&mesh, &small] {
        let auto = Bvh::build(m).unwrap();
        assert_eq!(auto.is_compressed(), auto.node_count() * 224 > sonolux_core::bvh::COMPRESS_ABOVE_BYTES);
    }
    assert!(!Bvh::build(&small).unwrap().is_compressed());
}

/// Both collapses of the binary tree into wide nodes (docs/bvh.md, "Wide nodes by cost") give
/// the brute force's answers on random rays and on rays at edges and vertices, so the same
/// distance to the bit (the triangle may differ only at an exact tie, which a soup of
/// separate triangles does not have, so here it is the same too); the counting walk
/// (`Bvh::closest_hit_counted`) gives the query's own answer; and the cost-optimal tree needs
/// no more node tests than the greedy one on these rays (it minimises their expected number
/// under the surface-area model; the soup's rays are the model's uniform rays, not a
/// guarantee ray by ray, so the sum is compared, not each ray). The tree over spatial splits
/// (references clipped to slabs) gives the same hits too.
#[test]
fn both_collapses_give_the_same_hits_and_the_optimal_one_tests_fewer_nodes() {
    use sonolux_core::bvh::{Collapse, TestCosts};
    for (n_tris, seed) in [(1000, 61), (5000, 62)] {
        let mesh = random_soup(n_tris, seed);
        let mut rays = random_rays(20_000, seed);
        rays.extend(rays_at_edges_and_vertices(&mesh, 10_000, seed));
        let greedy = Bvh::build_collapsed(&mesh, Collapse::LargestFirst).unwrap();
        let optimal = Bvh::build_collapsed(&mesh, Collapse::DEFAULT).unwrap();
        assert_eq!(optimal.fingerprint(), Bvh::build_with(&mesh, Nodes::Full).unwrap().fingerprint(), "the default is the optimal collapse");
        let merged = Bvh::build_collapsed(&mesh, Collapse::SahOptimal(TestCosts { max_leaf_packets: 4, ..TestCosts::MEASURED })).unwrap();
        let mut nodes = [0u64; 2];
        // Spatial splits (a probe, docs/bvh.md): references clipped to their slabs, the same hits.
        // (On the smaller soup only: its serial build clips the soup's long triangles many times.)
        let split = (n_tris <= 1000).then(|| Bvh::build_with_spatial_splits(&mesh, Collapse::DEFAULT).unwrap());
        for (i, bvh) in [Some(&greedy), Some(&optimal), Some(&merged), split.as_ref()].into_iter().flatten().enumerate() {
            let (n, example) = disagreements(&mesh, bvh, &rays);
            assert_eq!(n, 0, "{n_tris} triangles, collapse {i}: {n} of {} rays differ, e.g. {example}", rays.len());
            let key = |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.triangle));
            for r in &rays {
                let (hit, counts) = bvh.closest_hit_counted(r.origin, r.dir).unwrap();
                assert_eq!(key(hit), key(bvh.closest_hit_from(r.origin, r.dir)), "the counting walk's answer");
                assert!(counts.to_answer <= counts.nodes && (hit.is_none() || counts.packets >= 1));
                if i < 2 {
                    nodes[i] += counts.nodes as u64;
                }
            }
        }
        assert!(nodes[1] <= nodes[0], "{n_tris} triangles: optimal collapse {} node tests, greedy {}", nodes[1], nodes[0]);
        assert!(optimal.node_count() < greedy.node_count());
    }
}

/// Rays from uniform points of the L-room's box in uniform directions (some start outside the
/// room, in its notch or in furniture: all the better).
fn rays_in_box(n: usize, seed: u64, lo: Vec3, hi: Vec3) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let mut s = Stream::new(seed, 3, i as u64);
            let o = lo + (hi - lo) * Vec3::new(s.uniform_f32(), s.uniform_f32(), s.uniform_f32());
            Ray::new(o, uniform_sphere(s.uniform(), s.uniform()).as_vec3())
        })
        .collect()
}

/// The hull at the root (bvh/hull.rs) is chosen where a mesh's large flat faces hold most of its
/// area, and only there: the L-room's eight walls, floor and ceiling in seven slots, not a
/// shoebox (nothing would be left for the tree), not finely tessellated walls (faces of more
/// than 32 triangles), not a soup.
#[test]
fn the_hull_is_put_at_the_root_of_rooms_only() {
    let room = rooms::l_room().mesh;
    assert_eq!(Bvh::build(&room).unwrap().hull_slots(), 7);
    assert_eq!(Bvh::build_shaped(&room, Nodes::Auto, Shape::Sah).unwrap().hull_slots(), 0);
    let shoebox = tessellated_box(1, 4.0);
    assert_eq!(Bvh::build(&shoebox).unwrap().hull_slots(), 0);
    assert_eq!(Bvh::build(&shoebox).unwrap().fingerprint(), Bvh::build_shaped(&shoebox, Nodes::Auto, Shape::Sah).unwrap().fingerprint());
    assert_eq!(Bvh::build(&tessellated_box(9, 4.0)).unwrap().hull_slots(), 0);
    assert_eq!(Bvh::build(&random_soup(300, 5)).unwrap().hull_slots(), 0);
}

/// On the L-room with its hull at the root: the brute-force oracle's distance to the bit on
/// random rays and on rays through edges and vertices (full and compressed nodes, `occluded`
/// included); the SAH tree's answers, distance and triangle, except where two triangles are hit
/// at exactly the same t (a shared edge or vertex: then each tree reports the one it visits
/// first, and both are hits at that t); AVX2 and portable lanes to the bit; and from inside
/// the closed room no ray escapes.
#[test]
fn the_hull_at_the_root_gives_the_same_hits() {
    let room = rooms::l_room().mesh;
    let b = room.bounds();
    let mut rays = rays_in_box(300_000, 61, b.min - Vec3::ONE, b.max + Vec3::ONE);
    rays.extend(rays_at_edges_and_vertices(&room, 200_000, 61));
    assert_agrees(&room, &rays, "L-room, hull at the root");
    // The SAH tree alone too: before the walk widened its clip to the nearest hit so far
    // (traverse::hit_children), 112 of these rays differed from the oracle by an ulp at a
    // vertex shared by a wall and the floor.
    let (n, example) = disagreements(&room, &Bvh::build_shaped(&room, Nodes::Full, Shape::Sah).unwrap(), &rays);
    assert_eq!(n, 0, "L-room, SAH tree: {n} of {} rays differ, e.g. {example}", rays.len());
    let hull = Bvh::build(&room).unwrap();
    let sah = Bvh::build_shaped(&room, Nodes::Auto, Shape::Sah).unwrap();
    assert!(hull.hull_slots() > 0);
    let hit_at = |r: &Ray, tri: u32, t: f32| {
        let [a, b, c] = room.corners(tri as usize);
        intersect_triangle(r, a, b, c, 0.0, f32::INFINITY).map(f32::to_bits) == Some(t.to_bits())
    };
    let (mut ties, mut wrong) = (0, 0);
    let portable = hull.clone().portable();
    for r in &rays {
        match (hull.closest_hit_from(r.origin, r.dir), sah.closest_hit_from(r.origin, r.dir)) {
            (Some(x), Some(y)) if x.t.to_bits() == y.t.to_bits() && x.triangle != y.triangle => {
                ties += 1;
                wrong += usize::from(!(hit_at(r, x.triangle, x.t) && hit_at(r, y.triangle, y.t)));
            }
            (x, y) => wrong += usize::from(x != y),
        }
        wrong += usize::from(hull.closest_hit(r, 0.0, f32::INFINITY) != portable.closest_hit(r, 0.0, f32::INFINITY));
    }
    assert_eq!(wrong, 0, "{wrong} of {} rays differ beyond exact ties ({ties} ties)", rays.len());
    // (Ties are rare: edge rays aim at shared edges, random rays almost never meet one.)
    assert!(ties < rays.len() / 100, "{ties} ties");
    let talker = Vec3::new(10.8, 3.0, 1.6);
    let leaks = (0..1_000_000u64)
        .into_par_iter()
        .filter(|&i| {
            let mut s = Stream::new(62, 0, i);
            hull.closest_hit_from(talker, uniform_sphere(s.uniform(), s.uniform()).as_vec3()).is_none()
        })
        .count();
    assert_eq!(leaks, 0, "rays from the talker left the closed L-room");
}
