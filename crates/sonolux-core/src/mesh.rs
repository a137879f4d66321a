//! Triangle meshes with a material per triangle, and the checks a scene needs before tracing:
//! degenerate triangles (reported, then skipped), open and non-manifold edges (where sound or
//! light could leak), inconsistently wound neighbours, surface area per material, enclosed
//! volume, and whether points lie inside the closed volume (generalised winding number).

use std::collections::HashMap;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::error::CoreError;
use crate::geometry::{triangle_cross, Aabb};

/// A triangle mesh. Indices are validated on construction.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Material id of each triangle.
    pub material: Vec<u32>,
    /// True for triangles whose area is zero (or numerically so); tracers skip them.
    pub degenerate: Vec<bool>,
}

/// What the sound tracer reads about a triangle once the BVH says a ray hit it, side by side in
/// one aligned 32-byte record (one cache line): its unit normal ([`Mesh::normal`]), its
/// material and its first corner (the point that puts a hit back on the triangle's plane,
/// `sound/leave.rs`). Three arrays (normals, materials, triangles then vertices) cost a large
/// mesh up to four cache misses a hit, two of them one after the other.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct HitRecord {
    pub normal: Vec3,
    pub material: u32,
    pub corner: Vec3,
    unused: u32,
}

/// What [`Mesh::report`] finds.
#[derive(Clone, Debug, Default)]
pub struct MeshReport {
    pub n_triangles: usize,
    /// Indices of degenerate triangles.
    pub degenerate: Vec<u32>,
    /// Edges used by one triangle only (after welding equal vertex positions).
    pub n_open_edges: usize,
    /// Midpoints of the first open edges, to say where a leak is.
    pub open_edge_midpoints: Vec<Vec3>,
    /// Edges shared by more than two triangles.
    pub n_nonmanifold_edges: usize,
    /// Edges whose two triangles run it in the same direction (one of them is flipped).
    pub n_inconsistent_edges: usize,
    /// Σ v0·(v1×v2)/6: positive when the normals face out of the enclosed volume.
    pub signed_volume: f64,
    /// Surface area per material id (index = id), degenerate triangles excluded.
    pub area_by_material: Vec<f64>,
    pub bounds: Aabb,
}

/// How many open-edge positions a report lists.
const MAX_LISTED_EDGES: usize = 20;

impl Mesh {
    /// Builds a mesh; fails on non-finite coordinates or out-of-range indices.
    pub fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>, material: Vec<u32>) -> Result<Mesh, CoreError> {
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(CoreError::invalid("vertices", format!("vertex {i} has a non-finite coordinate {:?}", vertices[i])));
        }
        if material.len() != triangles.len() {
            return Err(CoreError::invalid(
                "material_ids",
                format!("{} material ids for {} triangles", material.len(), triangles.len()),
            ));
        }
        let n = vertices.len() as u64;
        for (i, t) in triangles.iter().enumerate() {
            if t.iter().any(|&k| k as u64 >= n) {
                return Err(CoreError::invalid("triangles", format!("triangle {i} = {t:?} names a vertex beyond the {n} given")));
            }
        }
        let degenerate = triangles
            .iter()
            .map(|t| is_degenerate(vertices[t[0] as usize], vertices[t[1] as usize], vertices[t[2] as usize]))
            .collect();
        Ok(Mesh { vertices, triangles, material, degenerate })
    }

    #[inline]
    pub fn corners(&self, tri: usize) -> [Vec3; 3] {
        let t = self.triangles[tri];
        [self.vertices[t[0] as usize], self.vertices[t[1] as usize], self.vertices[t[2] as usize]]
    }

    /// Unit geometric normal, (v1 − v0) × (v2 − v0) normalised.
    #[inline]
    pub fn normal(&self, tri: usize) -> Vec3 {
        let [a, b, c] = self.corners(tri);
        triangle_cross(a, b, c).normalize_or_zero()
    }

    /// Each triangle's [`HitRecord`]: what a tracer reads about the triangle a ray hit.
    pub fn hit_records(&self) -> Vec<HitRecord> {
        (0..self.triangles.len())
            .map(|i| HitRecord { normal: self.normal(i), material: self.material[i], corner: self.vertices[self.triangles[i][0] as usize], unused: 0 })
            .collect()
    }

    pub fn area(&self, tri: usize) -> f64 {
        let [a, b, c] = self.corners(tri);
        0.5 * (b.as_dvec3() - a.as_dvec3()).cross(c.as_dvec3() - a.as_dvec3()).length()
    }

    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for v in &self.vertices {
            b.grow(*v);
        }
        b
    }

    /// Topology and measures of the mesh.
    pub fn report(&self) -> MeshReport {
        let mut r = MeshReport { n_triangles: self.triangles.len(), bounds: self.bounds(), ..Default::default() };
        let n_materials = self.material.iter().map(|&m| m as usize + 1).max().unwrap_or(0);
        r.area_by_material = vec![0.0; n_materials];

        // Weld vertices that sit at the same position, so that unwelded files (STL) are judged
        // by their shape, not by how they were written.
        let mut canonical: HashMap<[u32; 3], u32> = HashMap::with_capacity(self.vertices.len());
        let weld: Vec<u32> = self
            .vertices
            .iter()
            .enumerate()
            .map(|(i, v)| *canonical.entry([v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]).or_insert(i as u32))
            .collect();

        // Per undirected edge: how often it is run low→high and high→low.
        let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::with_capacity(self.triangles.len() * 3 / 2);
        for (i, t) in self.triangles.iter().enumerate() {
            if self.degenerate[i] {
                r.degenerate.push(i as u32);
                continue;
            }
            let [a, b, c] = self.corners(i);
            let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
            r.signed_volume += a.dot(b.cross(c)) / 6.0;
            r.area_by_material[self.material[i] as usize] += 0.5 * (b - a).cross(c - a).length();
            let w = [weld[t[0] as usize], weld[t[1] as usize], weld[t[2] as usize]];
            for k in 0..3 {
                let (p, q) = (w[k], w[(k + 1) % 3]);
                let e = edges.entry((p.min(q), p.max(q))).or_insert((0, 0));
                if p < q {
                    e.0 += 1
                } else {
                    e.1 += 1
                }
            }
        }
        let mut open: Vec<(u32, u32)> = Vec::new();
        for (&key, &(fwd, back)) in &edges {
            match fwd + back {
                1 => open.push(key),
                2 if fwd != 1 => r.n_inconsistent_edges += 1,
                2 => {}
                _ => r.n_nonmanifold_edges += 1,
            }
        }
        r.n_open_edges = open.len();
        open.sort_unstable(); // a stable report, whatever the hash order
        r.open_edge_midpoints = open
            .iter()
            .take(MAX_LISTED_EDGES)
            .map(|&(p, q)| 0.5 * (self.vertices[p as usize] + self.vertices[q as usize]))
            .collect();
        r
    }

    /// Generalised winding number of each point (Jacobson et al. 2013): the signed solid angle
    /// that the mesh subtends, over 4π. About ±1 inside a closed mesh, 0 outside; inside an
    /// obstacle whose normals face the other way it cancels to 0 again. Robust to small holes.
    pub fn winding_numbers(&self, points: &[Vec3]) -> Vec<f64> {
        points
            .par_iter()
            .map(|p| {
                let p = p.as_dvec3();
                let mut omega = 0.0;
                for i in 0..self.triangles.len() {
                    if self.degenerate[i] {
                        continue;
                    }
                    let [a, b, c] = self.corners(i);
                    omega += solid_angle(a.as_dvec3() - p, b.as_dvec3() - p, c.as_dvec3() - p);
                }
                // Normals facing out give a positive solid angle from inside.
                -omega / (4.0 * std::f64::consts::PI)
            })
            .collect()
    }

    /// True when the mesh is closed and bounds one convex volume: every vertex lies on the inner
    /// side of every face's plane. Then no surface can block a line between two interior points,
    /// and tracers may skip visibility tests. Large meshes (over 10⁸ vertex–plane pairs) are
    /// reported non-convex without checking.
    pub fn is_closed_convex(&self) -> bool {
        let live: Vec<usize> = (0..self.triangles.len()).filter(|&i| !self.degenerate[i]).collect();
        if live.is_empty() || live.len() as u64 * self.vertices.len() as u64 > 100_000_000 {
            return false;
        }
        let r = self.report();
        if r.n_open_edges > 0 || r.n_nonmanifold_edges > 0 || r.n_inconsistent_edges > 0 {
            return false;
        }
        let scale = r.bounds.extent().length() as f64;
        let inward = if r.signed_volume > 0.0 { -1.0 } else { 1.0 };
        live.iter().all(|&i| {
            let [a, b, c] = self.corners(i);
            let n = triangle_cross(a, b, c).as_dvec3().normalize() * inward;
            let a = a.as_dvec3();
            self.vertices.iter().all(|v| n.dot(v.as_dvec3() - a) >= -1e-6 * scale)
        })
    }

    /// Distance from each point to the nearest non-degenerate triangle.
    pub fn distance_to_surface(&self, points: &[Vec3]) -> Vec<f64> {
        points
            .par_iter()
            .map(|p| {
                let p = p.as_dvec3();
                (0..self.triangles.len())
                    .filter(|&i| !self.degenerate[i])
                    .map(|i| {
                        let [a, b, c] = self.corners(i);
                        (closest_point_on_triangle(p, a.as_dvec3(), b.as_dvec3(), c.as_dvec3()) - p).length()
                    })
                    .fold(f64::INFINITY, f64::min)
            })
            .collect()
    }
}

/// A triangle is degenerate when its height is below 1e-6 of its longest edge (or it has none).
fn is_degenerate(a: Vec3, b: Vec3, c: Vec3) -> bool {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let longest = (b - a).length().max((c - b).length()).max((a - c).length());
    if longest == 0.0 {
        return true;
    }
    let height = (b - a).cross(c - a).length() / longest;
    height <= 1e-6 * longest
}

/// Signed solid angle of triangle (a, b, c) seen from the origin (Van Oosterom and Strackee 1983).
/// Negative when the triangle's normal faces away from the origin.
fn solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c));
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    -2.0 * numerator.atan2(denominator)
}

/// The point of triangle (a, b, c) nearest to p, by Voronoi regions of its vertices and edges.
fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube with outward normals (12 triangles).
    pub(crate) fn cube() -> Mesh {
        let v: Vec<Vec3> = (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32)).collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let mut t = Vec::new();
        for q in quads {
            t.push([q[0], q[1], q[2]]);
            t.push([q[0], q[2], q[3]]);
        }
        let n = t.len();
        Mesh::new(v, t, vec![0; n]).unwrap()
    }

    #[test]
    fn closed_cube_has_unit_volume_area_six_and_no_open_edges() {
        let r = cube().report();
        assert!((r.signed_volume - 1.0).abs() < 1e-12, "{}", r.signed_volume);
        assert!((r.area_by_material[0] - 6.0).abs() < 1e-12);
        assert_eq!((r.n_open_edges, r.n_nonmanifold_edges, r.n_inconsistent_edges), (0, 0, 0));
    }

    #[test]
    fn removing_a_triangle_opens_three_edges_and_flipping_one_is_inconsistent() {
        let mut m = cube();
        m.triangles.pop();
        m.material.pop();
        m.degenerate.pop();
        assert_eq!(m.report().n_open_edges, 3);
        let mut m = cube();
        m.triangles[0].swap(1, 2);
        assert_eq!(m.report().n_inconsistent_edges, 3);
    }

    #[test]
    fn degenerate_triangles_are_found_and_skipped() {
        let v = vec![Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0), Vec3::Y];
        let m = Mesh::new(v, vec![[0, 1, 2], [0, 1, 3]], vec![0, 0]).unwrap();
        let r = m.report();
        assert_eq!(r.degenerate, vec![0]);
        assert!((r.area_by_material[0] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn winding_number_is_one_inside_zero_outside() {
        let w = cube().winding_numbers(&[Vec3::splat(0.5), Vec3::new(0.1, 0.9, 0.2), Vec3::new(2.0, 0.5, 0.5)]);
        assert!((w[0] - 1.0).abs() < 1e-9 && (w[1] - 1.0).abs() < 1e-9, "{w:?}");
        assert!(w[2].abs() < 1e-9, "{w:?}");
    }

    #[test]
    fn distance_to_surface_of_cube() {
        let d = cube().distance_to_surface(&[Vec3::new(0.5, 0.5, 0.2), Vec3::new(2.0, 0.5, 0.5), Vec3::new(2.0, 2.0, 0.5)]);
        assert!((d[0] - 0.2).abs() < 1e-6 && (d[1] - 1.0).abs() < 1e-6);
        assert!((d[2] - 2f64.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn a_cube_is_convex_and_a_cube_with_a_dent_is_not() {
        assert!(cube().is_closed_convex());
        let mut m = cube();
        m.vertices[7] = Vec3::splat(0.6); // push one corner inwards
        assert!(!m.is_closed_convex());
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        assert!(Mesh::new(vec![Vec3::NAN], vec![], vec![]).is_err());
        assert!(Mesh::new(vec![Vec3::ZERO], vec![[0, 0, 1]], vec![0]).is_err());
        assert!(Mesh::new(vec![Vec3::ZERO], vec![], vec![0]).is_err());
    }
}
