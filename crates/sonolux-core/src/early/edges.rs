//! The mesh's diffracting edges: wedges whose open (air) angle exceeds π, and free edges of
//! sheets (a thin screen: open angle 2π).
//!
//! Normals must face the air (a room wound inwards, obstacles outwards; the mesh report counts
//! the edges where neighbours disagree). An edge shared by two triangles whose second face
//! bends away from the first one's air side is convex: its open angle is 2π minus the angle
//! between the faces. Concave edges (a room's corners, open angle below π) and flat ones are
//! left out: their field is fully described by image sources (for open angles π/n exactly; the
//! rest is small and left to the particles). Edges of more than two triangles are skipped.

use std::collections::HashMap;
use std::f64::consts::PI;

use glam::DVec3;

use super::planes::Planes;
use crate::mesh::Mesh;

/// A straight wedge, in the frame of its reference face: z along the edge from `start` to `end`,
/// x into the reference face (perpendicular to the edge), y its normal, into the air. The air
/// lies at angles θ ∈ (0, open_angle) from the reference face; the other face is at the open angle.
#[derive(Clone, Debug)]
pub struct Wedge {
    pub start: DVec3,
    pub end: DVec3,
    pub along: DVec3,
    pub into_face: DVec3,
    pub normal: DVec3,
    pub open_angle_rad: f64,
    /// The planes of the two faces (equal for a free edge).
    pub planes: [u32; 2],
    /// A triangle of each face (equal for a free edge).
    pub triangles: [u32; 2],
}

impl Wedge {
    pub fn length_m(&self) -> f64 {
        (self.end - self.start).length()
    }

    /// Cylindrical coordinates (r, θ, z) of `p`; θ in [0, 2π).
    pub fn cylindrical(&self, p: DVec3) -> (f64, f64, f64) {
        let rel = p - self.start;
        let z = rel.dot(self.along);
        let (x, y) = (rel.dot(self.into_face), rel.dot(self.normal));
        let mut theta = y.atan2(x);
        if theta < 0.0 {
            theta += 2.0 * PI;
        }
        ((x * x + y * y).sqrt(), theta, z)
    }

    /// The direction, perpendicular to the edge, that halves the air's angle.
    pub fn bisector(&self) -> DVec3 {
        let h = 0.5 * self.open_angle_rad;
        self.into_face * h.cos() + self.normal * h.sin()
    }
}

/// The wedges of `mesh` that diffract (open angle above π + 0.01 rad).
pub fn wedges(mesh: &Mesh, planes: &Planes) -> Vec<Wedge> {
    let mut canonical: HashMap<[u32; 3], u32> = HashMap::new();
    let weld: Vec<u32> = mesh
        .vertices
        .iter()
        .enumerate()
        .map(|(i, v)| *canonical.entry([v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]).or_insert(i as u32))
        .collect();
    // Undirected edge → the triangles that use it.
    let mut users: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if mesh.degenerate[t] {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (weld[tri[k] as usize], weld[tri[(k + 1) % 3] as usize]);
            users.entry((a.min(b), a.max(b))).or_default().push(t as u32);
        }
    }
    let mut keys: Vec<(u32, u32)> = users.keys().copied().collect();
    keys.sort_unstable();
    let mut out = Vec::new();
    for key in keys {
        let tris = &users[&key];
        let (a, b) = (mesh.vertices[key.0 as usize].as_dvec3(), mesh.vertices[key.1 as usize].as_dvec3());
        let along = (b - a).normalize();
        // In-face direction perpendicular to the edge, pointing into triangle t.
        let into = |t: u32| -> DVec3 {
            let c = mesh.corners(t as usize).map(|v| v.as_dvec3());
            let centroid = (c[0] + c[1] + c[2]) / 3.0;
            let rel = centroid - a;
            (rel - along * rel.dot(along)).normalize()
        };
        let normal = |t: u32| mesh.normal(t as usize).as_dvec3();
        let plane = |t: u32| planes.plane_of_triangle[t as usize];
        let wedge = match *tris.as_slice() {
            [t] => {
                Wedge { start: a, end: b, along, into_face: into(t), normal: normal(t), open_angle_rad: 2.0 * PI, planes: [plane(t), plane(t)], triangles: [t, t] }
            }
            [t1, t2] => {
                let (d1, d2, n1) = (into(t1), into(t2), normal(t1));
                let between = d1.dot(d2).clamp(-1.0, 1.0).acos();
                // Second face on the air side of the first: concave; behind it: convex.
                let open = if d2.dot(n1) > 0.0 { between } else { 2.0 * PI - between };
                if open < PI + 0.01 {
                    continue;
                }
                Wedge { start: a, end: b, along, into_face: d1, normal: n1, open_angle_rad: open, planes: [plane(t1), plane(t2)], triangles: [t1, t2] }
            }
            _ => continue,
        };
        out.push(wedge);
    }
    out
}
