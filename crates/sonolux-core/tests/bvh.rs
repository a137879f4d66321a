//! The BVH against the brute-force oracle, and watertightness at shared edges and vertices.

use glam::Vec3;
use rayon::prelude::*;
use sonolux_core::geometry::intersect_triangle;
use sonolux_core::rng::Stream;
use sonolux_core::sampling::uniform_sphere;
use sonolux_core::{Bvh, Hit, Mesh, Ray};

/// The oracle: test every triangle.
fn brute_force(mesh: &Mesh, ray: &Ray) -> Option<Hit> {
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

#[test]
fn bvh_agrees_with_brute_force_on_a_million_rays() {
    for (n_tris, n_rays, seed) in [(300, 1_000_000, 1), (3000, 100_000, 2), (7, 100_000, 3)] {
        let mesh = random_soup(n_tris, seed);
        let bvh = Bvh::build(&mesh).unwrap();
        let rays = random_rays(n_rays, seed);
        let mismatches: Vec<String> = rays
            .par_iter()
            .filter_map(|r| {
                let (a, b) = (bvh.closest_hit(r, 0.0, f32::INFINITY), brute_force(&mesh, r));
                // Same distance; the triangle may differ only where two are hit at the same t.
                let same = match (a, b) {
                    (None, None) => true,
                    (Some(x), Some(y)) => x.t == y.t,
                    _ => false,
                };
                (!same).then(|| format!("{:?}: bvh {a:?} brute {b:?}", r.origin))
            })
            .collect();
        assert!(mismatches.is_empty(), "{} of {n_rays} differ, e.g. {}", mismatches.len(), mismatches[0]);
        // And any-hit agrees with closest-hit within a range.
        for r in rays.iter().take(20_000) {
            let t = brute_force(&mesh, r).map_or(f32::INFINITY, |h| h.t);
            assert_eq!(bvh.occluded(r, 0.0, 5.0), t < 5.0);
        }
    }
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
}
