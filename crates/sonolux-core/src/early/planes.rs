//! Coplanar triangles merged into planes, the reflectors of the image-source model, and the
//! connected pieces of each plane (panels) with the size that level of detail needs.
//!
//! As in ODEON and RAVEN, an image source belongs to a plane, not to a triangle: a wall cut
//! into a hundred triangles has one image, valid wherever the reflection point falls on any of
//! them. Planes are two-sided (a thin screen reflects from both faces), so a plane's normal is
//! put in a canonical orientation and triangles facing either way join it. Whether a reflection
//! point lies on the plane's surface is asked of the BVH (the closest hit must be one of the
//! plane's triangles), so a plane's polygon is never built explicitly.

use std::collections::HashMap;

use glam::DVec3;

use crate::mesh::Mesh;

/// Normals closer than this (component-wise, after canonical orientation) share a plane.
pub(crate) const NORMAL_TOLERANCE: f64 = 1e-4;

/// One reflecting plane: n·x = offset, n canonical (its first non-zero component positive).
#[derive(Clone, Debug)]
pub struct Plane {
    pub normal: DVec3,
    pub offset_m: f64,
    /// The plane's (non-degenerate) triangles.
    pub triangles: Vec<u32>,
    /// Welded corner positions of those triangles (for the image tree's pruning).
    pub vertices: Vec<DVec3>,
}

impl Plane {
    /// Signed distance of `p` from the plane, along the canonical normal.
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset_m
    }

    /// The mirror image of `p` in the plane.
    #[inline]
    pub fn mirror(&self, p: DVec3) -> DVec3 {
        p - 2.0 * self.distance(p) * self.normal
    }
}

/// A connected piece of one plane (triangles sharing corners), seen as the rectangle with the
/// same second moments of area: a rectangle a × b has variances a²/12 and b²/12 along its sides.
#[derive(Clone, Debug)]
pub struct Panel {
    /// Unit direction of the panel's longer side (in its plane).
    pub axis_a: DVec3,
    pub size_a_m: f64,
    pub size_b_m: f64,
    pub area_m2: f64,
}

/// The mesh's planes and panels.
#[derive(Clone, Debug)]
pub struct Planes {
    pub planes: Vec<Plane>,
    /// Plane of each triangle (u32::MAX for degenerate ones).
    pub plane_of_triangle: Vec<u32>,
    pub panels: Vec<Panel>,
    /// Panel of each triangle (u32::MAX for degenerate ones).
    pub panel_of_triangle: Vec<u32>,
}

/// The canonical normal and offset of a triangle's plane.
fn canonical_plane(mesh: &Mesh, tri: usize) -> (DVec3, f64) {
    let [a, b, c] = mesh.corners(tri).map(|v| v.as_dvec3());
    let mut n = (b - a).cross(c - a).normalize();
    let first = if n.x.abs() > NORMAL_TOLERANCE { n.x } else if n.y.abs() > NORMAL_TOLERANCE { n.y } else { n.z };
    if first < 0.0 {
        n = -n;
    }
    let offset = n.dot((a + b + c) / 3.0);
    (n, offset)
}

impl Planes {
    /// Groups the mesh's triangles by plane; `offset_tolerance_m` is how far two triangles' planes
    /// may lie apart and still merge (a CAD model's rounding: about 1 mm).
    pub fn build(mesh: &Mesh, offset_tolerance_m: f64) -> Planes {
        let n = mesh.triangles.len();
        let mut plane_of_triangle = vec![u32::MAX; n];
        let mut planes: Vec<Plane> = Vec::new();
        // Candidate planes by quantised key; a triangle whose key differs only by rounding
        // still finds its plane through the neighbouring keys.
        let mut by_key: HashMap<[i64; 4], Vec<u32>> = HashMap::new();
        let tol = offset_tolerance_m.max(1e-9);
        let key = |nrm: DVec3, d: f64| -> [i64; 4] {
            let q = |x: f64, s: f64| (x / s).floor() as i64;
            [q(nrm.x, 4.0 * NORMAL_TOLERANCE), q(nrm.y, 4.0 * NORMAL_TOLERANCE), q(nrm.z, 4.0 * NORMAL_TOLERANCE), q(d, 4.0 * tol)]
        };
        for t in 0..n {
            if mesh.degenerate[t] {
                continue;
            }
            let (nrm, d) = canonical_plane(mesh, t);
            let k = key(nrm, d);
            let mut found = None;
            'search: for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        for dd in -1..=1 {
                            let kk = [k[0] + dx, k[1] + dy, k[2] + dz, k[3] + dd];
                            for &p in by_key.get(&kk).map(|v| v.as_slice()).unwrap_or(&[]) {
                                let pl = &planes[p as usize];
                                if (pl.normal - nrm).abs().max_element() < NORMAL_TOLERANCE && (pl.offset_m - d).abs() < tol {
                                    found = Some(p);
                                    break 'search;
                                }
                            }
                        }
                    }
                }
            }
            let p = found.unwrap_or_else(|| {
                planes.push(Plane { normal: nrm, offset_m: d, triangles: Vec::new(), vertices: Vec::new() });
                let p = planes.len() as u32 - 1;
                by_key.entry(k).or_default().push(p);
                p
            });
            planes[p as usize].triangles.push(t as u32);
            plane_of_triangle[t] = p;
        }
        for pl in &mut planes {
            let mut seen = HashMap::new();
            for &t in &pl.triangles {
                for v in mesh.corners(t as usize) {
                    seen.entry([v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]).or_insert(v.as_dvec3());
                }
            }
            let mut vs: Vec<DVec3> = seen.into_values().collect();
            vs.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
            pl.vertices = vs;
        }
        let (panels, panel_of_triangle) = panels(mesh, &planes, n);
        Planes { planes, plane_of_triangle, panels, panel_of_triangle }
    }
}

/// Splits each plane into connected pieces (triangles sharing a corner position) and measures
/// each piece's equivalent rectangle.
fn panels(mesh: &Mesh, planes: &[Plane], n: usize) -> (Vec<Panel>, Vec<u32>) {
    let mut panel_of_triangle = vec![u32::MAX; n];
    let mut out = Vec::new();
    for pl in planes {
        // Union–find over the plane's triangles, joined through shared corner positions.
        let m = pl.triangles.len();
        let mut parent: Vec<usize> = (0..m).collect();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        let mut owner: HashMap<[u32; 3], usize> = HashMap::new();
        for (i, &t) in pl.triangles.iter().enumerate() {
            for v in mesh.corners(t as usize) {
                let k = [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
                if let Some(&j) = owner.get(&k) {
                    let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                    parent[a.max(b)] = a.min(b);
                } else {
                    owner.insert(k, i);
                }
            }
        }
        let mut index_of_root: HashMap<usize, usize> = HashMap::new();
        let mut groups: Vec<Vec<u32>> = Vec::new();
        for i in 0..m {
            let r = root(&mut parent, i);
            let g = *index_of_root.entry(r).or_insert_with(|| {
                groups.push(Vec::new());
                groups.len() - 1
            });
            groups[g].push(pl.triangles[i]);
        }
        for g in groups {
            let id = out.len() as u32;
            out.push(measure(mesh, pl.normal, &g));
            for t in g {
                panel_of_triangle[t as usize] = id;
            }
        }
    }
    (out, panel_of_triangle)
}

/// The equivalent rectangle of a set of coplanar triangles: area-weighted second moments in the
/// plane (each triangle's exact second moment about its centroid included), then the principal
/// axes of the 2 × 2 covariance.
fn measure(mesh: &Mesh, normal: DVec3, tris: &[u32]) -> Panel {
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let (mut area, mut c) = (0.0, DVec3::ZERO);
    for &t in tris {
        let [a, b, cc] = mesh.corners(t as usize).map(|x| x.as_dvec3());
        let ar = 0.5 * (b - a).cross(cc - a).length();
        area += ar;
        c += ar * (a + b + cc) / 3.0;
    }
    if !(area > 0.0) {
        return Panel { axis_a: u, size_a_m: 0.0, size_b_m: 0.0, area_m2: 0.0 };
    }
    c /= area;
    // Second moments of a triangle about the origin: (A/12)(Σ xᵢxⱼ + Σ xᵢ²) per component pair.
    let (mut suu, mut svv, mut suv) = (0.0, 0.0, 0.0);
    for &t in tris {
        let p = mesh.corners(t as usize).map(|x| x.as_dvec3() - c);
        let ar = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        let pu = p.map(|x| x.dot(u));
        let pv = p.map(|x| x.dot(v));
        let s = |x: [f64; 3], y: [f64; 3]| {
            let sx: f64 = x.iter().sum();
            let sy: f64 = y.iter().sum();
            (sx * sy + x[0] * y[0] + x[1] * y[1] + x[2] * y[2]) * ar / 12.0
        };
        suu += s(pu, pu);
        svv += s(pv, pv);
        suv += s(pu, pv);
    }
    let (cuu, cvv, cuv) = (suu / area, svv / area, suv / area);
    let mean = 0.5 * (cuu + cvv);
    let diff = (0.25 * (cuu - cvv).powi(2) + cuv * cuv).sqrt();
    let (l1, l2) = (mean + diff, (mean - diff).max(0.0));
    let angle = 0.5 * (2.0 * cuv).atan2(cuu - cvv);
    let axis_a = u * angle.cos() + v * angle.sin();
    Panel { axis_a, size_a_m: (12.0 * l1).sqrt(), size_b_m: (12.0 * l2).sqrt(), area_m2: area }
}
