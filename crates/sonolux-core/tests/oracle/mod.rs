//! The brute-force oracle of the BVH tests, the ray sets they trace, and the comparison of a
//! tree's answers with the oracle's: the same distance to the bit, and the same triangle
//! except at an exact tie (two triangles hit at the same t, where each answer is a hit at
//! that t: a ray through a shared edge or vertex).
//!
//! Shared by several test crates, each of which uses a part (hence `dead_code`).
#![allow(dead_code)]

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use sonolux_core::bvh::{Nodes, Shape};
use sonolux_core::geometry::{intersect_triangle, offset_origin};
use sonolux_core::rng::Stream;
use sonolux_core::sampling::uniform_sphere;
use sonolux_core::{Bvh, Hit, Mesh, Ray};

use crate::rooms::Room;

/// The oracle: test every triangle, in index order, t in (0, ∞). At an exact tie the first
/// triangle in the mesh's order is kept.
pub fn brute_force(mesh: &Mesh, ray: &Ray) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for i in 0..mesh.triangles.len() {
        if mesh.degenerate[i] {
            continue;
        }
        let [a, b, c] = mesh.corners(i);
        let t_max = best.map_or(f32::INFINITY, |h| h.t);
        if let Some(t) = intersect_triangle(ray, a, b, c, 0.0, t_max) {
            best = Some(Hit { t, triangle: i as u32 });
        }
    }
    best
}

/// Whether `answer` is the oracle's: both none, or the same t to the bit and the same
/// triangle, or (an exact tie) another triangle that the ray hits at exactly that t too.
pub fn same_as_oracle(mesh: &Mesh, ray: &Ray, answer: Option<Hit>, oracle: Option<Hit>) -> bool {
    match (answer, oracle) {
        (None, None) => true,
        (Some(a), Some(o)) if a.t.to_bits() == o.t.to_bits() => {
            let [p, q, r] = mesh.corners(a.triangle as usize);
            a.triangle == o.triangle || intersect_triangle(ray, p, q, r, 0.0, f32::INFINITY).map(f32::to_bits) == Some(a.t.to_bits())
        }
        _ => false,
    }
}

/// The trees every agreement test runs: whatever `Bvh::build` makes of the mesh (the hull at
/// the root, or what the builder puts there next) and the SAH tree alone, each on full and on
/// compressed nodes, each walked on AVX2 lanes (where the CPU has them) and portable ones.
pub fn every_tree(mesh: &Mesh) -> Vec<(String, Bvh)> {
    let mut out = Vec::new();
    for (shape, shape_name) in [(Shape::Auto, "built"), (Shape::Sah, "sah")] {
        for nodes in [Nodes::Full, Nodes::Compressed] {
            let bvh = Bvh::build_shaped(mesh, nodes, shape).unwrap();
            assert_eq!(bvh.is_compressed(), nodes == Nodes::Compressed);
            let name = format!("{shape_name} tree (hull slots {}), {nodes:?} nodes", bvh.hull_slots());
            out.push((format!("{name}, {}", bvh.simd_name()), bvh.clone()));
            if bvh.simd_name() != "portable" {
                out.push((format!("{name}, portable"), bvh.portable()));
            }
        }
    }
    out
}

/// A ray's origin and direction to the bit, for a report that can be replayed.
pub fn ray_bits(r: &Ray) -> String {
    let hex = |v: Vec3| v.to_array().map(|x| format!("{:#010x}", x.to_bits())).join(",");
    format!("origin {:?} [{}] dir {:?} [{}]", r.origin, hex(r.origin), r.dir, hex(r.dir))
}

/// The ray a report of [`ray_bits`] names.
pub fn ray_from_bits(origin: [u32; 3], dir: [u32; 3]) -> Ray {
    Ray::new(Vec3::from_array(origin.map(f32::from_bits)), Vec3::from_array(dir.map(f32::from_bits)))
}

/// The answers of one tree to ray `i` that the oracle's (`oracle`) are checked against:
/// `closest_hit` on (0, ∞), the tracer's `closest_hit_from`, and `occluded` on (0, t_end)
/// with t_end 0.5, 2 or 8 (m along a unit direction: where a visibility test to a receiver
/// ends); whether they are right, and what they are (formatted only when asked). (A range
/// that ends within the triangle test's own rounding of a hit is not asked here: there the
/// box test and the triangle test can decide differently, `tests/bvh_rooms.rs`,
/// `known_disagreement_occluded_at_a_hit_within_its_rounding`.)
fn answers(mesh: &Mesh, bvh: &Bvh, r: &Ray, i: usize, oracle: Option<Hit>) -> (bool, impl Fn() -> String) {
    let t_end = [0.5f32, 2.0, 8.0][i % 3];
    let (a, b) = (bvh.closest_hit(r, 0.0, f32::INFINITY), bvh.closest_hit_from(r.origin, r.dir));
    let seen = bvh.occluded(r, 0.0, t_end);
    let agree = same_as_oracle(mesh, r, a, oracle) && same_as_oracle(mesh, r, b, oracle) && seen == oracle.is_some_and(|h| h.t < t_end);
    // The one known class of disagreement (tests/bvh_rooms.rs, `known_disagreement_*`): hits
    // within the triangle test's own rounding (`origin_rounding_m`), which the exact box tests
    // can cull where brute force, which has no boxes, keeps them: a hit that near the origin,
    // or the tree's answer a real hit of the ray that near the oracle's (at a shared edge:
    // which is nearer is not decided at that precision).
    let bound = |h: Hit| origin_rounding_m(mesh, r, h.triangle);
    let near = |h: Option<Hit>| h.is_some_and(|h| h.t < bound(h));
    let close = |x: Option<Hit>| match (x, oracle) {
        (Some(x), Some(o)) => {
            let [p, q, s] = mesh.corners(x.triangle as usize);
            (x.t - o.t).abs() <= bound(x) + bound(o) && intersect_triangle(r, p, q, s, 0.0, f32::INFINITY) == Some(x.t)
        }
        _ => false,
    };
    let rounding = near(oracle) || near(a) || near(b) || (close(a) && close(b) && seen == oracle.is_some_and(|h| h.t < t_end));
    let ok = agree || rounding;
    (ok, move || format!("closest_hit {a:?}, closest_hit_from {b:?}, occluded to {t_end} {seen}"))
}

/// A bound of the watertight test's absolute error in t for `triangle` (Woop, Benthin and Wald
/// 2013): its t is a difference of the corners' coordinates relative to the origin, sheared
/// along the ray's dominant axis k; each is rounded a few times by at most ε/2 of a value up to
/// 2R (R: the corners' largest coordinate distance from the origin), so t's error is a few
/// ε·R/|d_k|. 8 ε·R/|d_k| is taken: a stated bound of the form of pbrt's conservative δt
/// (Pharr, Jakob and Humphreys, *Physically Based Rendering* 3rd ed. §3.9.6); the three
/// disagreements found lie within it (`known_disagreement_*` assert so).
pub fn origin_rounding_m(mesh: &Mesh, r: &Ray, triangle: u32) -> f32 {
    let reach = mesh.corners(triangle as usize).iter().map(|p| (*p - r.origin).abs().max_element()).fold(0.0f32, f32::max);
    8.0 * f32::EPSILON * reach / r.dir.abs().max_element()
}

/// For each tree with a ray whose answers differ from the oracle's: (tree, how many rays,
/// the first such ray with both answers). Empty when all agree.
pub fn disagreements(mesh: &Mesh, trees: &[(String, Bvh)], rays: &[Ray]) -> Vec<(String, usize, String)> {
    let bad: Vec<(usize, usize)> = rays
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, r)| {
            let oracle = brute_force(mesh, r);
            trees.iter().enumerate().filter_map(move |(k, (_, bvh))| (!answers(mesh, bvh, r, i, oracle).0).then_some((k, i)))
        })
        .collect();
    let mut out = Vec::new();
    for (k, (name, bvh)) in trees.iter().enumerate() {
        let mine: Vec<usize> = bad.iter().filter(|(j, _)| *j == k).map(|&(_, i)| i).collect();
        if let Some(&i) = mine.iter().min() {
            let (r, oracle) = (&rays[i], brute_force(mesh, &rays[i]));
            out.push((name.clone(), mine.len(), format!("ray {i}: {}: {}; brute force {oracle:?}", ray_bits(r), answers(mesh, bvh, r, i, oracle).1())));
        }
    }
    out
}

/// Panics with every tree's count and first example when any tree differs from the oracle.
pub fn assert_all_agree(mesh: &Mesh, trees: &[(String, Bvh)], rays: &[Ray], what: &str) {
    let bad = disagreements(mesh, trees, rays);
    let report: Vec<String> = bad.iter().map(|(tree, n, e)| format!("  {tree}: {n} of {} rays, e.g. {e}", rays.len())).collect();
    assert!(bad.is_empty(), "{what}: the BVH differs from brute force\n{}", report.join("\n"));
}

/// Rays from uniform points of the room's air in uniform directions.
pub fn air_rays(room: &Room, n: usize, seed: u64) -> Vec<Ray> {
    (0..n)
        .into_par_iter()
        .map(|i| {
            let mut s = Stream::new(seed, 5, i as u64);
            let o = room.air_point(&mut s);
            Ray::new(o, uniform_sphere(s.uniform(), s.uniform()).as_vec3())
        })
        .collect()
}

/// The f32 after `x` (up) or before it: `f32::next_up` / `next_down` (Rust 1.86; the MSRV is
/// 1.85), for finite `x`.
fn next_f32(x: f32, up: bool) -> f32 {
    if x == 0.0 {
        return if up { f32::from_bits(1) } else { -f32::from_bits(1) };
    }
    let away_from_zero = up == (x > 0.0);
    f32::from_bits(if away_from_zero { x.to_bits() + 1 } else { x.to_bits() - 1 })
}

/// Rays from uniform points of the room's air aimed exactly at a corner, an edge's midpoint or
/// a point along an edge of a random triangle (where the watertight test is decided by its f64
/// fallback and the box tests' rounding decides what is culled), and, one ray in three, at
/// that target moved by one ulp of one coordinate, or along a direction one ulp longer.
pub fn edge_rays(room: &Room, n: usize, seed: u64) -> Vec<Ray> {
    let mesh = &room.mesh;
    (0..n)
        .into_par_iter()
        .map(|i| {
            let mut s = Stream::new(seed, 6, i as u64);
            let [a, b, c] = mesh.corners((s.next_u64() % mesh.triangles.len() as u64) as usize);
            let (p, q) = [(a, b), (b, c), (c, a)][(s.next_u64() % 3) as usize];
            let mut target = match i % 3 {
                0 => p,
                1 => 0.5 * (p + q),
                _ => p + (q - p) * s.uniform_f32(),
            };
            let o = room.air_point(&mut s);
            let mut d = target - o;
            match (i / 3) % 3 {
                1 => {
                    let k = (s.next_u64() % 3) as usize;
                    target[k] = next_f32(target[k], s.next_u64() % 2 == 0);
                    d = target - o;
                }
                2 => d *= 1.0 + f32::EPSILON,
                _ => {}
            }
            Ray::new(o, d)
        })
        .collect()
}

/// Rays that leave a surface as the sound tracer's do: a point of a triangle (one of its
/// corners, a point on an edge, or inside it: uniform by area), in f64, moved off the
/// triangle by `offset_origin` to the room's air side (rounded towards a point of the air it
/// came from, on that side), along a uniform direction of that side's hemisphere (grazing ones
/// included). The triangle is drawn by area for even rays (where the tracer's reflections
/// are, in a diffuse field) and uniformly by index for odd ones (the small triangles too).
pub fn leaving_rays(room: &Room, n: usize, seed: u64) -> Vec<Ray> {
    let mesh = &room.mesh;
    let mut cdf: Vec<f64> = Vec::with_capacity(mesh.triangles.len());
    let mut total = 0.0;
    for i in 0..mesh.triangles.len() {
        total += if mesh.degenerate[i] { 0.0 } else { mesh.area(i) };
        cdf.push(total);
    }
    (0..n)
        .into_par_iter()
        .map(|i| {
            let mut s = Stream::new(seed, 7, i as u64);
            let tri = if i % 2 == 0 {
                let at = s.uniform() * total;
                cdf.partition_point(|&c| c <= at).min(cdf.len() - 1)
            } else {
                (s.next_u64() % mesh.triangles.len() as u64) as usize
            };
            let [a, b, c] = mesh.corners(tri).map(|p| p.as_dvec3());
            let point = match (i / 2) % 3 {
                0 => [a, b, c][(s.next_u64() % 3) as usize],
                1 => {
                    let (p, q) = [(a, b), (b, c), (c, a)][(s.next_u64() % 3) as usize];
                    p + (q - p) * s.uniform()
                }
                _ => {
                    let (r1, r2) = (s.uniform().sqrt(), s.uniform());
                    a * (1.0 - r1) + b * (r1 * (1.0 - r2)) + c * (r1 * r2)
                }
            };
            let normal = (b - a).cross(c - a).normalize() * room.air_side;
            // The point the ray came from (the tracer's previous hit): a point of the room's
            // air on the triangle's air side. It decides which way each coordinate rounds, so
            // a corner's origin stays inside the room.
            let from = (0..64)
                .map(|_| room.air_point(&mut s).as_dvec3())
                .find(|p| (*p - point).dot(normal) > 0.0)
                .unwrap_or(point + normal);
            let origin = offset_origin(point, normal, from);
            let d: DVec3 = uniform_sphere(s.uniform(), s.uniform());
            let d = if d.dot(normal) < 0.0 { -d } else { d };
            Ray::new(origin.as_vec3(), d.as_vec3())
        })
        .collect()
}
