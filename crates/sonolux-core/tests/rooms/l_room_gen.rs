//! `examples/l-room/make_l_room.py` in Rust, for tests that need its dense 100k-triangle
//! variant (only the plain room is committed as an OBJ file, and the core's tests run without
//! Python). The same arithmetic in f64, in the same order, the same welding of vertices
//! (coordinates rounded to 6 decimals) and the same writing of them (6 significant digits,
//! read back as f32), so the plain room comes out as the committed `l-room.obj`, vertex for
//! vertex and triangle for triangle (tested). The dense variant's sculpture is an icosphere
//! of 6 subdivisions built here (`super::icosphere`, not trimesh's bits or vertex order),
//! displaced by the script's bumps.

use glam::{DVec3, Vec3};
use sonolux_core::Mesh;

const HEIGHT_M: f64 = 3.2;
const FOOTPRINT: [(f64, f64); 8] = [(0.0, 0.0), (7.0, 0.0), (12.0, 0.0), (12.0, 5.0), (7.0, 5.0), (7.0, 9.0), (0.0, 9.0), (0.0, 5.0)];
const GAP_M: f64 = 0.005;
pub const SCULPTURE_CENTRE_M: [f64; 3] = [5.5, 3.8, 1.2];
pub const SCULPTURE_RADIUS_M: f64 = 0.6;

/// The script's `ObjWriter`: vertices welded by their coordinates rounded to 6 decimals, in
/// the order they first appear; triangles by group, groups in the order they first appear.
#[derive(Default)]
struct Writer {
    index: std::collections::HashMap<[u64; 3], u32>,
    vertices: Vec<Vec3>,
    groups: Vec<(&'static str, Vec<[u32; 3]>)>,
}

/// Python's `round(x, 6)` (the exact value rounded to 6 decimals, ties to even: Rust's
/// formatting rounds the same way).
fn round6(x: f64) -> f64 {
    format!("{x:.6}").parse().unwrap()
}

/// The OBJ file's `{:.6g}` read back as f32: 6 significant digits.
fn written(x: f64) -> f32 {
    format!("{x:.5e}").parse().unwrap()
}

type P = DVec3;

impl Writer {
    fn vertex(&mut self, p: P) -> u32 {
        let key = p.to_array().map(round6);
        let n = self.vertices.len() as u32;
        *self.index.entry(key.map(f64::to_bits)).or_insert_with(|| {
            self.vertices.push(Vec3::from_array(key.map(written)));
            n
        })
    }

    fn triangle(&mut self, group: &'static str, a: P, b: P, c: P) {
        let t = [self.vertex(a), self.vertex(b), self.vertex(c)];
        match self.groups.iter_mut().find(|(g, _)| *g == group) {
            Some((_, list)) => list.push(t),
            None => self.groups.push((group, vec![t])),
        }
    }

    /// Quad a-b-c-d as steps × steps pairs of triangles, corners bilinear in (u, v).
    fn quad(&mut self, group: &'static str, a: P, b: P, c: P, d: P, steps: u32) {
        let at = |u: f64, v: f64| a + (b - a) * u + (d - a) * v + (a - b + c - d) * u * v;
        for i in 0..steps {
            for j in 0..steps {
                let s = steps as f64;
                let (u0, u1, v0, v1) = (i as f64 / s, (i + 1) as f64 / s, j as f64 / s, (j + 1) as f64 / s);
                let (p00, p10, p11, p01) = (at(u0, v0), at(u1, v0), at(u1, v1), at(u0, v1));
                self.triangle(group, p00, p10, p11);
                self.triangle(group, p00, p11, p01);
            }
        }
    }

    /// A closed axis-aligned box, faces out of it.
    fn cuboid(&mut self, group: &'static str, lo: [f64; 3], hi: [f64; 3]) {
        let ([x0, y0, z0], [x1, y1, z1]) = (lo, hi);
        let p = |x, y, z| DVec3::new(x, y, z);
        self.quad(group, p(x0, y0, z0), p(x0, y1, z0), p(x1, y1, z0), p(x1, y0, z0), 1);
        self.quad(group, p(x0, y0, z1), p(x1, y0, z1), p(x1, y1, z1), p(x0, y1, z1), 1);
        self.quad(group, p(x0, y0, z0), p(x1, y0, z0), p(x1, y0, z1), p(x0, y0, z1), 1);
        self.quad(group, p(x0, y1, z0), p(x0, y1, z1), p(x1, y1, z1), p(x1, y1, z0), 1);
        self.quad(group, p(x0, y0, z0), p(x0, y0, z1), p(x0, y1, z1), p(x0, y1, z0), 1);
        self.quad(group, p(x1, y0, z0), p(x1, y1, z0), p(x1, y1, z1), p(x1, y0, z1), 1);
    }
}

fn room(w: &mut Writer, steps_per_m: f64) {
    let h = HEIGHT_M;
    for ((x0, y0), (x1, y1)) in [((0.0, 0.0), (7.0, 5.0)), ((7.0, 0.0), (12.0, 5.0)), ((0.0, 5.0), (7.0, 9.0))] {
        let n = (steps_per_m * f64::max(x1 - x0, y1 - y0)).round().max(1.0) as u32;
        let p = |x, y, z| DVec3::new(x, y, z);
        w.quad("Floor", p(x0, y0, 0.0), p(x1, y0, 0.0), p(x1, y1, 0.0), p(x0, y1, 0.0), n);
        w.quad("Ceiling", p(x0, y0, h), p(x0, y1, h), p(x1, y1, h), p(x1, y0, h), n);
    }
    for k in 0..FOOTPRINT.len() {
        let ((x0, y0), (x1, y1)) = (FOOTPRINT[k], FOOTPRINT[(k + 1) % FOOTPRINT.len()]);
        let group = if (x0, y0) == (7.0, 0.0) { "Window" } else { "Wall" };
        let n = (steps_per_m * f64::max((x1 - x0).hypot(y1 - y0), h)).round().max(1.0) as u32;
        w.quad(group, DVec3::new(x0, y0, 0.0), DVec3::new(x0, y0, h), DVec3::new(x1, y1, h), DVec3::new(x1, y1, 0.0), n);
    }
}

fn table(w: &mut Writer, cx: f64, cy: f64) {
    let (sx, sy, height) = (1.6 / 2.0, 0.8 / 2.0, 0.75);
    let top = height - 0.04;
    w.cuboid("Table", [cx - sx, cy - sy, top], [cx + sx, cy + sy, height]);
    for dx in [-sx + 0.05, sx - 0.1] {
        for dy in [-sy + 0.05, sy - 0.1] {
            w.cuboid("Table", [cx + dx, cy + dy, GAP_M], [cx + dx + 0.05, cy + dy + 0.05, top - GAP_M]);
        }
    }
}

fn chair(w: &mut Writer, cx: f64, cy: f64) {
    let (s, seat) = (0.225, 0.45);
    w.cuboid("Chair", [cx - s, cy - s, seat - 0.04], [cx + s, cy + s, seat]);
    for dx in [-s + 0.02, s - 0.05] {
        for dy in [-s + 0.02, s - 0.05] {
            w.cuboid("Chair", [cx + dx, cy + dy, GAP_M], [cx + dx + 0.03, cy + dy + 0.03, seat - 0.04 - GAP_M]);
        }
    }
    let by = cy - s; // facing north, as every chair of the script
    w.cuboid("Chair", [cx - s, by, seat + GAP_M], [cx + s, by + 0.04, seat + 0.45]);
}

fn sculpture(w: &mut Writer) {
    let (u, faces) = super::icosphere(6);
    let c = DVec3::from_array(SCULPTURE_CENTRE_M);
    let p: Vec<DVec3> = u
        .iter()
        .map(|u| {
            let r = SCULPTURE_RADIUS_M * (1.0 + 0.12 * (7.0 * u.x).sin() * (6.0 * u.y + 1.0).sin() * (5.0 * u.z + 2.0).sin());
            *u * r + c
        })
        .collect();
    for [a, b, cc] in faces {
        w.triangle("Sculpture", p[a as usize], p[b as usize], p[cc as usize]);
    }
}

/// The script's `build(dense)` as a mesh, one material id a group (Floor 0, Ceiling 1, Wall 2,
/// Window 3, Table 4, Chair 5, Cabinet 6, Sculpture 7), triangles in the file's order.
pub fn build(dense: bool) -> Mesh {
    let mut w = Writer::default();
    room(&mut w, if dense { 5.0 } else { 0.0 });
    for (cx, cy) in [(3.5, 2.0), (8.5, 2.0), (3.0, 7.0)] {
        table(&mut w, cx, cy);
        for dx in [-0.4, 0.4] {
            chair(&mut w, cx + dx, cy + 0.75);
        }
    }
    w.cuboid("Cabinet", [10.4, 4.35, GAP_M], [11.9, 4.9, 2.0]);
    if dense {
        sculpture(&mut w);
    }
    let (mut t, mut m) = (Vec::new(), Vec::new());
    for (k, (_, list)) in w.groups.iter().enumerate() {
        t.extend(list);
        m.extend(std::iter::repeat_n(k as u32, list.len()));
    }
    Mesh::new(w.vertices, t, m).unwrap()
}
