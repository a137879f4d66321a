//! Closed convex rooms, a shoebox first among them: seen from inside, the nearest wall along a
//! ray is the first of the room's planes that the ray leaves through, so a hit costs one dot
//! product and one division per plane, with no hierarchy to walk and no way to leak.
//!
//! The triangles of each plane are kept so that a hit still names its triangle (and so its
//! material): a point on a plane is located among that plane's few triangles by their edges.
//! [`Surfaces`] is what both tracers ask: these planes when they apply, the BVH otherwise.

use glam::{DVec3, Vec3};

use crate::bvh::Bvh;
use crate::geometry::Ray;
use crate::mesh::Mesh;

/// Rooms with more planes than this are left to the BVH: a linear scan would cost more.
pub const MAX_FACES: usize = 32;

/// One plane of the room: points p with `normal · p = offset`, `normal` pointing out.
#[derive(Clone, Copy, Debug)]
struct Face {
    normal: DVec3,
    offset: f64,
    /// This face's triangles are `tris[first..first + count]`.
    first: u32,
    count: u32,
}

/// A triangle of a face, as three inward edge normals in its plane: a point p of the plane lies
/// inside when `edge[k] · p ≥ limit[k]` for every k.
#[derive(Clone, Copy, Debug)]
struct FaceTriangle {
    id: u32,
    edge: [DVec3; 3],
    limit: [f64; 3],
}

/// The planes of a closed convex mesh, with their triangles.
#[derive(Clone, Debug)]
pub struct ConvexRoom {
    faces: Vec<Face>,
    tris: Vec<FaceTriangle>,
}

/// Where a ray from inside leaves the room.
#[derive(Clone, Copy, Debug)]
pub struct Exit {
    pub t: f64,
    /// Index of the triangle in the mesh.
    pub triangle: u32,
    /// Outward unit normal of the plane.
    pub normal: DVec3,
}

impl ConvexRoom {
    /// The room's planes, or None when the mesh is not closed and convex or has more than
    /// [`MAX_FACES`] distinct planes.
    pub fn new(mesh: &Mesh) -> Option<ConvexRoom> {
        if mesh.is_closed_convex() {
            Self::of_convex(mesh)
        } else {
            None
        }
    }

    /// The planes of a mesh already known to be closed and convex.
    pub fn of_convex(mesh: &Mesh) -> Option<ConvexRoom> {
        let live: Vec<usize> = (0..mesh.triangles.len()).filter(|&i| !mesh.degenerate[i]).collect();
        let inside = mesh.vertices.iter().map(|v| v.as_dvec3()).sum::<DVec3>() / mesh.vertices.len() as f64;
        let scale = live.iter().flat_map(|&i| mesh.corners(i)).map(|v| (v.as_dvec3() - inside).length()).fold(0.0, f64::max);
        // Group the triangles by plane: normals within 1e-5 rad, offsets within 1e-6 of the size
        // (far looser than f32 rounding of vertices on one plane, far tighter than a real corner).
        let mut planes: Vec<(DVec3, f64, Vec<usize>)> = Vec::new();
        for &i in &live {
            let [a, b, c] = mesh.corners(i).map(|v| v.as_dvec3());
            let mut n = (b - a).cross(c - a).normalize();
            if n.dot(a - inside) < 0.0 {
                n = -n;
            }
            let offset = n.dot(a);
            match planes.iter_mut().find(|(m, o, _)| m.dot(n) > 1.0 - 5e-11 && (o - offset).abs() <= 1e-6 * scale) {
                Some(p) => p.2.push(i),
                None => planes.push((n, offset, vec![i])),
            }
            if planes.len() > MAX_FACES {
                return None;
            }
        }
        let mut faces = Vec::with_capacity(planes.len());
        let mut tris = Vec::with_capacity(live.len());
        for (normal, offset, members) in planes {
            faces.push(Face { normal, offset, first: tris.len() as u32, count: members.len() as u32 });
            for i in members {
                let corners = mesh.corners(i).map(|v| v.as_dvec3());
                let mut edge = [DVec3::ZERO; 3];
                let mut limit = [0.0; 3];
                for k in 0..3 {
                    let (p, q, opposite) = (corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3]);
                    let mut e = normal.cross(q - p).normalize();
                    if e.dot(opposite - p) < 0.0 {
                        e = -e;
                    }
                    edge[k] = e;
                    limit[k] = e.dot(p);
                }
                tris.push(FaceTriangle { id: i as u32, edge, limit });
            }
        }
        Some(ConvexRoom { faces, tris })
    }

    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// Whether `p` lies strictly inside every plane.
    pub fn contains(&self, p: DVec3) -> bool {
        self.faces.iter().all(|f| f.normal.dot(p) < f.offset)
    }

    /// Whether `p` lies inside or within `tolerance` outside of every plane (a light on a wall).
    pub fn holds(&self, p: DVec3, tolerance: f64) -> bool {
        self.faces.iter().all(|f| f.normal.dot(p) <= f.offset + tolerance)
    }

    /// Where the ray origin + t·dir (unit dir, origin inside or on the boundary) leaves the
    /// room: the smallest t over the planes it moves towards, never below 0, so that an origin
    /// a rounding error outside a wall meets that wall at once instead of escaping.
    #[inline]
    pub fn exit(&self, origin: DVec3, dir: DVec3) -> Exit {
        // The smallest gap / towards over the planes ahead, compared as cross products
        // (towards > 0) so that only the winner costs a division.
        let (mut best_gap, mut best_towards) = (f64::INFINITY, 1.0);
        let mut best = 0usize;
        for (k, f) in self.faces.iter().enumerate() {
            let towards = f.normal.dot(dir);
            if towards > 0.0 {
                let gap = f.offset - f.normal.dot(origin);
                if gap * best_towards < best_gap * towards {
                    (best_gap, best_towards, best) = (gap, towards, k);
                }
            }
        }
        let face = &self.faces[best];
        let t = (best_gap / best_towards).max(0.0);
        Exit { t, triangle: self.locate(face, origin + dir * t), normal: face.normal }
    }

    /// The triangle of `face` that holds `p` (a point on its plane): the first that contains it,
    /// else (a point a rounding error off every one) the one it lies least outside of.
    #[inline]
    fn locate(&self, face: &Face, p: DVec3) -> u32 {
        let tris = &self.tris[face.first as usize..(face.first + face.count) as usize];
        if tris.len() == 1 {
            return tris[0].id;
        }
        let mut best = (f64::NEG_INFINITY, tris[0].id);
        for tri in tris {
            let inside = (0..3).map(|k| tri.edge[k].dot(p) - tri.limit[k]).fold(f64::INFINITY, f64::min);
            if inside >= 0.0 {
                return tri.id;
            }
            if inside > best.0 {
                best = (inside, tri.id);
            }
        }
        best.1
    }
}

/// What a tracer asks for the nearest surface along a ray: a convex room's planes when every
/// ray of it starts inside the room, else the BVH. Both tracers hold one.
pub struct Surfaces<'a> {
    bvh: &'a Bvh,
    room: Option<ConvexRoom>,
    /// Unit normal of each mesh triangle, computed once (the BVH path asks for one a segment).
    normals: Vec<Vec3>,
}

impl<'a> Surfaces<'a> {
    /// `convex`: whether the mesh is closed and convex (known to the caller); `starts_inside`:
    /// whether the tracer's rays all start inside the room (its sources or lights).
    pub fn new(mesh: &'a Mesh, bvh: &'a Bvh, convex: bool, starts_inside: impl Fn(&ConvexRoom) -> bool) -> Surfaces<'a> {
        let room = if convex { ConvexRoom::of_convex(mesh) } else { None };
        let room = room.filter(starts_inside);
        let normals = if room.is_some() { Vec::new() } else { (0..mesh.triangles.len()).map(|i| mesh.normal(i)).collect() };
        Surfaces { bvh, room, normals }
    }

    /// The nearest surface along origin + t·dir (unit dir): its distance, mesh triangle and unit
    /// normal (facing either way; the planes' is precomputed).
    #[inline]
    pub fn nearest(&self, origin: DVec3, dir: DVec3) -> Option<(f64, usize, DVec3)> {
        match &self.room {
            Some(room) => {
                let exit = room.exit(origin, dir);
                Some((exit.t, exit.triangle as usize, exit.normal))
            }
            None => {
                let hit = self.bvh.closest_hit(&Ray::new(origin.as_vec3(), dir.as_vec3()), 0.0, f32::INFINITY)?;
                let tri = hit.triangle as usize;
                Some((hit.t as f64, tri, self.normals[tri].as_dvec3()))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
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
}
