//! Tests of convex.rs: the planes against the BVH and against a loop over the planes.

use glam::Vec3;

use super::*;
use crate::geometry::Ray;
use crate::rng::Stream;
use crate::sampling::uniform_sphere;

/// A 3 × 2 × 1.5 box with each wall split into 2 × 2 quads (8 triangles a wall).
fn box_mesh() -> Mesh {
    let size = DVec3::new(3.0, 2.0, 1.5);
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = vertices.len() as u32;
            for j in 0..3 {
                for i in 0..3 {
                    let mut p = DVec3::ZERO;
                    p[axis] = side * size[axis];
                    p[u] = i as f64 * 0.5 * size[u];
                    p[v] = j as f64 * 0.5 * size[v];
                    vertices.push(p.as_vec3());
                }
            }
            for j in 0..2 {
                for i in 0..2 {
                    let q = base + j * 3 + i;
                    // Wound counter-clockwise seen from outside, as a closed mesh must be.
                    let (t1, t2) = ([q, q + 1, q + 4], [q, q + 4, q + 3]);
                    if side == 0.0 {
                        triangles.push([t1[0], t1[2], t1[1]]);
                        triangles.push([t2[0], t2[2], t2[1]]);
                    } else {
                        triangles.push(t1);
                        triangles.push(t2);
                    }
                }
            }
        }
    }
    let material = (0..triangles.len() as u32).collect();
    Mesh::new(vertices, triangles, material).unwrap()
}

#[test]
fn a_box_has_six_faces_and_agrees_with_the_bvh() {
    let mesh = box_mesh();
    let room = ConvexRoom::new(&mesh).expect("a box is convex");
    assert_eq!(room.n_faces(), 6);
    let bvh = Bvh::build(&mesh).unwrap();
    let mut rng = Stream::new(3, 0, 0);
    let mut same = 0;
    let n = 200_000;
    for _ in 0..n {
        let o = DVec3::new(0.01 + 2.98 * rng.uniform(), 0.01 + 1.98 * rng.uniform(), 0.01 + 1.48 * rng.uniform());
        let d = uniform_sphere(rng.uniform(), rng.uniform());
        let exit = room.exit(o, d);
        let hit = bvh.closest_hit(&Ray::new(o.as_vec3(), d.as_vec3()), 0.0, f32::INFINITY).expect("closed box");
        // Same distance to f32 precision, and the same triangle unless the point is on an edge.
        assert!((exit.t - hit.t as f64).abs() < 1e-5 * (1.0 + exit.t), "t {} vs {}", exit.t, hit.t);
        let on_plane = exit.normal.dot(o + d * exit.t);
        assert!((on_plane - exit.normal.dot(mesh.corners(exit.triangle as usize)[0].as_dvec3())).abs() < 1e-9);
        same += usize::from(exit.triangle == hit.triangle);
    }
    // Points within f32 rounding of a shared edge may go either way: a handful at most.
    assert!(same as f64 > 0.9999 * n as f64, "{same} of {n}");
}

/// A prism over a regular `n`-gon (radius 2, height 1.5), wound counter-clockwise seen
/// from outside, with a material per side and one for both caps: n + 2 planes.
fn prism(n: usize) -> Mesh {
    let mut vertices = Vec::new();
    for z in [0.0f32, 1.5] {
        for k in 0..n {
            let a = std::f32::consts::TAU * k as f32 / n as f32 + 0.3;
            vertices.push(Vec3::new(2.0 * a.cos(), 2.0 * a.sin(), z));
        }
    }
    let n32 = n as u32;
    let (mut triangles, mut material) = (Vec::new(), Vec::new());
    for k in 1..n32 - 1 {
        triangles.push([0, k + 1, k]); // bottom, seen from below
        triangles.push([n32, n32 + k, n32 + k + 1]); // top
        material.extend([0, 0]);
    }
    for k in 0..n32 {
        let j = (k + 1) % n32;
        triangles.push([k, j, n32 + j]);
        triangles.push([k, n32 + j, n32 + k]);
        material.extend([1 + k, 1 + k]);
    }
    Mesh::new(vertices, triangles, material).unwrap()
}

/// The rule the planes were tested by before they were tested at once: a loop over the
/// planes ahead comparing gap / towards as cross products. (plane, t).
fn exit_one_by_one(room: &ConvexRoom, origin: DVec3, dir: DVec3) -> (usize, f64) {
    let (mut best_gap, mut best_towards, mut best) = (f64::INFINITY, 1.0, 0usize);
    for (k, f) in room.faces.iter().enumerate() {
        let towards = f.normal.dot(dir);
        if towards > 0.0 {
            let gap = f.offset - f.normal.dot(origin);
            if gap * best_towards < best_gap * towards {
                (best_gap, best_towards, best) = (gap, towards, k);
            }
        }
    }
    (best, (best_gap / best_towards).max(0.0))
}

#[test]
fn planes_tested_at_once_agree_with_the_loop_over_them() {
    // A box (6 planes, 2 blocks) and prisms of 5, 7 and 14 sides (7, 9, 16 planes: blocks
    // partly and wholly filled); origins inside, on and a rounding error outside the walls.
    let meshes = [box_mesh(), prism(5), prism(7), prism(14)];
    for (m, mesh) in meshes.iter().enumerate() {
        let room = ConvexRoom::new(mesh).expect("convex");
        let (lo, hi) = (mesh.vertices.iter().fold(Vec3::INFINITY, |a, v| a.min(*v)).as_dvec3(), mesh.vertices.iter().fold(Vec3::NEG_INFINITY, |a, v| a.max(*v)).as_dvec3());
        let mut rng = Stream::new(11, m as u64, 0);
        let (mut n, mut same) = (0, 0);
        while n < 100_000 {
            let o = lo + (hi - lo) * DVec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            if !room.holds(o, 1e-9) {
                continue;
            }
            let d = uniform_sphere(rng.uniform(), rng.uniform());
            // Every tenth origin moved onto the wall ahead of it (and a hair beyond).
            let o = if n % 10 == 0 { o + d * (room.exit(o, d).t * (1.0 + 1e-15)) } else { o };
            let (plane, t) = exit_one_by_one(&room, o, d);
            let exit = room.exit(o, d);
            // The box's slab test and the test of every plane: the same plane and bits.
            let (k, t_all, towards) = room.nearest_of_all_planes(o, d);
            assert_eq!(t_all.to_bits(), t.to_bits());
            // The product the flip of the normal needs, as the dot product gives it.
            assert_eq!(towards.to_bits(), room.faces[k].normal.dot(d).to_bits());
            assert_eq!(exit.facing, if exit.normal.dot(d) > 0.0 { -exit.normal } else { exit.normal });
            n += 1;
            // The same distance to the bit, the same plane except at an exact tie (an edge).
            assert_eq!(exit.t.to_bits(), t.to_bits(), "mesh {m}: t {} vs {t}", exit.t);
            same += usize::from(exit.normal == room.faces[plane].normal);
            // Without the exact triangle: the same plane, distance and material.
            let quick = room.exit_with(o, d, false);
            assert_eq!((quick.t.to_bits(), quick.normal), (exit.t.to_bits(), exit.normal));
            assert_eq!(mesh.material[quick.triangle as usize], mesh.material[exit.triangle as usize]);
        }
        assert!(same as f64 >= 0.9999 * n as f64, "mesh {m}: {same} of {n}");
    }
    assert_eq!(ConvexRoom::new(&prism(14)).unwrap().blocks.len(), 4);
    assert!(ConvexRoom::new(&box_mesh()).unwrap().axis_box.is_some());
    assert!(ConvexRoom::new(&prism(4)).unwrap().axis_box.is_none(), "a box turned 0.3 rad about z");
}

/// The box's plain comparisons and its rule for NaN lanes (an origin on a wall, the ray
/// along it: 0 / +0) against the loop over the planes ahead, on rays along the axes and
/// diagonals with every sign of zero, from the corners, edges and faces of the box.
#[test]
fn the_box_agrees_with_the_loop_where_lanes_are_nan() {
    let room = ConvexRoom::new(&box_mesh()).unwrap();
    let b = room.axis_box.expect("a box");
    let coords = [[0.0, 1.5, 3.0], [0.0, 1.0, 2.0], [0.0, 0.75, 1.5]];
    let comps = [0.0, -0.0, 1.0, -1.0, 0.6, -0.6];
    let mut nan_lanes = 0;
    for &x in &coords[0] {
        for &y in &coords[1] {
            for &z in &coords[2] {
                let o = DVec3::new(x, y, z);
                for &dx in &comps {
                    for &dy in &comps {
                        for &dz in &comps {
                            let d = DVec3::new(dx, dy, dz);
                            if d.length_squared() == 0.0 {
                                continue;
                            }
                            let d = d.normalize();
                            let (k, t, towards) = b.nearest_plane(o, d);
                            let (plane, t_loop) = exit_one_by_one(&room, o, d);
                            assert_eq!(t.to_bits(), t_loop.to_bits(), "o {o} d {d}");
                            let n = room.faces[k].normal;
                            assert!(k == plane || n.dot(o + d * t) == room.faces[plane].normal.dot(o + d * t), "o {o} d {d}: plane {k} vs {plane}");
                            assert_eq!(towards.to_bits(), n.dot(d).to_bits(), "o {o} d {d}");
                            nan_lanes += usize::from((0..3).any(|a| d[a] == 0.0 && (o[a] == 0.0 || o[a] == coords[a][2])));
                        }
                    }
                }
            }
        }
    }
    assert!(nan_lanes > 1000, "{nan_lanes} rays with a NaN lane");
}

#[test]
fn origins_on_or_slightly_outside_a_wall_do_not_escape() {
    let room = ConvexRoom::new(&box_mesh()).unwrap();
    let exit = room.exit(DVec3::new(3.0 + 1e-12, 1.0, 0.7), DVec3::X);
    assert_eq!(exit.t, 0.0);
    assert!(exit.normal.x > 0.99);
    assert!(room.contains(DVec3::new(1.0, 1.0, 1.0)));
    assert!(!room.contains(DVec3::new(1.0, 1.0, 1.6)));
    assert!(!room.contains(DVec3::new(1.0, 1.0, 1.5)) && room.holds(DVec3::new(1.0, 1.0, 1.5), 1e-9));
    assert!(!room.holds(DVec3::new(1.0, 1.0, 1.5 + 1e-6), 1e-9));
}

#[test]
fn not_convex_or_open_means_none() {
    let mut m = box_mesh();
    m.vertices[4] = Vec3::new(0.3, 1.0, 0.75); // dent the centre of a wall
    assert!(ConvexRoom::new(&m).is_none());
    let mut open = box_mesh();
    open.triangles.truncate(open.triangles.len() - 2);
    open.material.truncate(open.triangles.len());
    open.degenerate.truncate(open.triangles.len());
    assert!(ConvexRoom::new(&open).is_none());
}
