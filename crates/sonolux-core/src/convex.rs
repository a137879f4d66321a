//! Closed convex rooms, a shoebox first among them: seen from inside, the nearest wall along a
//! ray is the first of the room's planes that the ray leaves through, so a hit costs one dot
//! product and one division per plane, with no hierarchy to walk and no way to leak.
//!
//! The planes are tested all at once: their normals and offsets are stored lane by lane
//! ([`PlaneBlock`], four planes a block, a shoebox's six in two), so that the distances to every
//! plane are a few vector multiplies and divisions with no branch, and the nearest is the first
//! lane holding their minimum. A branchy loop over the planes mispredicted at every segment (the
//! nearest wall is as good as random): before this layout the plane loop was 45 % of a bake of
//! a paper room with one receiver (docs/convex.md, "Where a convex segment's time goes").
//!
//! The triangles of each plane are kept so that a hit still names its triangle (and so its
//! material): a point on a plane is located among that plane's few triangles by their edges.
//! A caller that needs only the material ([`Surfaces::exact_triangles`] false: the sound tracer
//! without level of detail) skips that search on planes whose triangles share one material.
//! [`Surfaces`] is what both tracers ask: these planes when they apply, the BVH otherwise.

use glam::DVec3;

use crate::bvh::Bvh;
use crate::mesh::{HitRecord, Mesh};

/// Rooms with more planes than this are left to the BVH: a linear scan would cost more.
pub const MAX_FACES: usize = 32;

/// One plane of the room: points p with `normal · p = offset`, `normal` pointing out.
#[derive(Clone, Copy, Debug)]
struct Face {
    normal: DVec3,
    /// −normal: the side a ray inside the room comes from (negated once, here).
    inward: DVec3,
    offset: f64,
    /// This face's triangles are `tris[first..first + count]`.
    first: u32,
    count: u32,
    /// Whether all of this face's triangles have one material (then any of them names it).
    one_material: bool,
}

/// Planes tested at once: one lane a plane.
const LANES: usize = 4;

/// [`LANES`] planes, component by component (structure of arrays). A block's unused lanes hold
/// a zero normal: a ray never moves towards them.
#[derive(Clone, Copy, Debug, Default)]
struct PlaneBlock {
    nx: [f64; LANES],
    ny: [f64; LANES],
    nz: [f64; LANES],
    offset: [f64; LANES],
}

/// A triangle of a face, as three inward edge normals in its plane: a point p of the plane lies
/// inside when `edge[k] · p ≥ limit[k]` for every k.
#[derive(Clone, Copy, Debug)]
struct FaceTriangle {
    id: u32,
    edge: [DVec3; 3],
    limit: [f64; 3],
}

/// The six planes of a box whose walls face the axes (every normal has two zero components):
/// per axis, the plane on its low side (normal component < 0) and on its high side.
///
/// A ray can leave only through one plane an axis, chosen by the sign of its direction along
/// it, so the nearest exit is the smallest of three distances (the slab test, Kay & Kajiya 1986)
/// instead of a search over six. Each distance is computed with the same operations on the same
/// numbers as the test of every plane (whose other products are exact zeros), so both give the
/// same bits.
#[derive(Clone, Copy, Debug)]
struct AxisBox {
    /// `[axis][side]`: the face's index, its normal's non-zero component, its offset.
    face: [[u32; 2]; 3],
    normal: [[f64; 2]; 3],
    offset: [[f64; 2]; 3],
}

impl AxisBox {
    fn new(faces: &[Face]) -> Option<AxisBox> {
        if faces.len() != 6 {
            return None;
        }
        let mut b = AxisBox { face: [[u32::MAX; 2]; 3], normal: [[0.0; 2]; 3], offset: [[0.0; 2]; 3] };
        for (k, f) in faces.iter().enumerate() {
            let n = f.normal.to_array();
            let axis = (0..3).find(|&a| n[a] != 0.0)?;
            if (0..3).any(|a| a != axis && n[a] != 0.0) {
                return None;
            }
            let side = usize::from(n[axis] > 0.0);
            if b.face[axis][side] != u32::MAX {
                return None;
            }
            (b.face[axis][side], b.normal[axis][side], b.offset[axis][side]) = (k as u32, n[axis], f.offset);
        }
        Some(b)
    }

    /// [`ConvexRoom::nearest_plane`] for the box: (plane, distance ≥ 0), without a branch on the
    /// data. The side of each axis is chosen by the sign bit of the direction, so that a ray
    /// parallel to an axis (±0) meets that side's plane at gap / +0 = +∞ (or NaN for an origin on
    /// the plane, which the minimum skips) instead of being masked; an origin inside the room
    /// (every tracer's) has gap > 0 there. At an exact tie (an edge) the plane of the lower axis.
    /// Also the plane's normal · dir (its only non-zero product; NaN with no plane).
    #[inline(always)]
    fn nearest_plane(&self, origin: DVec3, dir: DVec3) -> (usize, f64, f64) {
        let (o, d) = (origin.to_array(), dir.to_array());
        let mut t = [0.0; 3];
        let mut towards = [0.0; 3];
        let mut k = [0u32; 3];
        for a in 0..3 {
            let side = usize::from(d[a].is_sign_positive());
            let n = self.normal[a][side];
            towards[a] = n * d[a];
            t[a] = (self.offset[a][side] - n * o[a]) / towards[a];
            k[a] = self.face[a][side];
        }
        // The first lane holding the smallest, by plain comparisons: the same lane and distance
        // as the rule below whenever no lane is NaN (a NaN lane in the second or third place
        // loses every comparison, as `f64::min` skips it); a NaN in the first place makes
        // `low` NaN, and the rule below decides.
        let (i01, m01) = if t[1] < t[0] { (1, t[1]) } else { (0, t[0]) };
        let (a, low) = if t[2] < m01 { (2, t[2]) } else { (i01, m01) };
        if low.is_nan() {
            return Self::nearest_of_lanes(t, towards, k);
        }
        (k[a] as usize, low.max(0.0), towards[a])
    }

    /// [`AxisBox::nearest_plane`]'s rule with NaN lanes (an origin on a plane the ray runs
    /// along: 0 / +0): the smallest by `f64::min`, which skips NaN, and the first lane holding it.
    #[cold]
    fn nearest_of_lanes(t: [f64; 3], towards: [f64; 3], k: [u32; 3]) -> (usize, f64, f64) {
        let low = t[0].min(t[1]).min(t[2]);
        let mask = (0..3).fold(0u32, |m, a| m | (u32::from(t[a] == low) << a));
        // No finite or infinite distance at all (a NaN direction): plane 0 at +∞.
        let (plane, t, towards) = match mask.trailing_zeros() as usize {
            a @ 0..3 => (k[a] as usize, low, towards[a]),
            _ => (0, f64::INFINITY, f64::NAN),
        };
        (plane, t.max(0.0), towards)
    }
}

/// The planes of a closed convex mesh, with their triangles.
#[derive(Clone, Debug)]
pub struct ConvexRoom {
    faces: Vec<Face>,
    /// The faces' planes lane by lane: plane k is lane k % LANES of block k / LANES.
    blocks: Vec<PlaneBlock>,
    /// The same planes as a box facing the axes, when they are one.
    axis_box: Option<AxisBox>,
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
    /// The same normal facing the side the ray comes from: −normal when normal · dir > 0 (a
    /// plane ahead, every exit but a degenerate one), else normal. The same bits as testing
    /// `normal.dot(dir)`: the planes' test computed that product already.
    pub facing: DVec3,
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
            let one_material = members.iter().all(|&i| mesh.material[i] == mesh.material[members[0]]);
            faces.push(Face { normal, inward: -normal, offset, first: tris.len() as u32, count: members.len() as u32, one_material });
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
        let mut blocks = vec![PlaneBlock::default(); faces.len().div_ceil(LANES)];
        for (k, f) in faces.iter().enumerate() {
            let (b, l) = (&mut blocks[k / LANES], k % LANES);
            (b.nx[l], b.ny[l], b.nz[l], b.offset[l]) = (f.normal.x, f.normal.y, f.normal.z, f.offset);
        }
        let axis_box = AxisBox::new(&faces);
        Some(ConvexRoom { faces, blocks, axis_box, tris })
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
    /// a rounding error outside a wall meets that wall at once instead of escaping. The exit's
    /// triangle is the one holding the exit point.
    #[inline]
    pub fn exit(&self, origin: DVec3, dir: DVec3) -> Exit {
        self.exit_with(origin, dir, true)
    }

    /// [`ConvexRoom::exit`]; with `exact` false the triangle is only one of the exit plane's
    /// with the exit point's material (its first), found without a search when all the
    /// plane's triangles share a material.
    #[inline(always)]
    pub fn exit_with(&self, origin: DVec3, dir: DVec3, exact: bool) -> Exit {
        let (k, t, towards) = self.nearest_plane(origin, dir);
        let face = &self.faces[k];
        let triangle = if !exact && face.one_material { self.tris[face.first as usize].id } else { self.locate(face, origin + dir * t) };
        // With no plane ahead (t = +∞, towards NaN) the product is computed as the caller would.
        let towards = if towards.is_nan() { face.normal.dot(dir) } else { towards };
        Exit { t, triangle, normal: face.normal, facing: if towards > 0.0 { face.inward } else { face.normal } }
    }

    /// The plane the ray leaves through and the distance to it (≥ 0): every plane's distance
    /// gap / towards (towards = normal · dir > 0: the planes ahead; the others +∞), computed
    /// lane by lane with the same operations, in the same order, as the dot products of glam,
    /// then the first plane holding the smallest. No plane ahead (a zero or non-finite dir):
    /// plane 0 at +∞. Also that plane's normal · dir, bit for bit as glam's dot product computes
    /// it (NaN with no plane ahead).
    #[inline(always)]
    fn nearest_plane(&self, origin: DVec3, dir: DVec3) -> (usize, f64, f64) {
        if let Some(b) = &self.axis_box {
            return b.nearest_plane(origin, dir);
        }
        self.nearest_of_all_planes(origin, dir)
    }

    /// [`ConvexRoom::nearest_plane`] by testing every plane.
    #[inline]
    fn nearest_of_all_planes(&self, origin: DVec3, dir: DVec3) -> (usize, f64, f64) {
        let mut best_t = f64::INFINITY;
        let mut best = 0usize;
        let mut best_towards = f64::NAN;
        for (j, b) in self.blocks.iter().enumerate() {
            let mut t = [f64::INFINITY; LANES];
            let mut towards = [0.0; LANES];
            for l in 0..LANES {
                towards[l] = b.nx[l] * dir.x + b.ny[l] * dir.y + b.nz[l] * dir.z;
                let gap = b.offset[l] - (b.nx[l] * origin.x + b.ny[l] * origin.y + b.nz[l] * origin.z);
                let q = gap / towards[l];
                t[l] = if towards[l] > 0.0 { q } else { f64::INFINITY };
            }
            // The block's smallest and its first lane, without a branch on the data (which
            // plane is nearest is as good as random from one segment to the next).
            // Plain compares (no NaN handling: a NaN lane would need a NaN origin).
            let min = |a: f64, b: f64| if b < a { b } else { a };
            let low = min(min(t[0], t[1]), min(t[2], t[3]));
            let mask = (0..LANES).fold(0u32, |m, l| m | (u32::from(t[l] == low) << l));
            let first = mask.trailing_zeros() as usize; // LANES and more when low is NaN: unused then
            let better = low < best_t;
            best = if better { j * LANES + first } else { best };
            best_towards = if better { towards[first & (LANES - 1)] } else { best_towards };
            best_t = if better { low } else { best_t };
        }
        (best, best_t.max(0.0), best_towards)
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
    /// Whether a hit must name the very triangle hit (true unless [`Surfaces::exact_triangles`]
    /// says otherwise); when false, a convex room's hit names a triangle of the exit plane with
    /// the hit's material.
    exact: bool,
    /// Each mesh triangle's normal, material and corner in one record, made once for the BVH
    /// path (which asks for one a segment; empty on the planes' path).
    records: Vec<HitRecord>,
}

impl<'a> Surfaces<'a> {
    /// `convex`: whether the mesh is closed and convex (known to the caller); `starts_inside`:
    /// whether the tracer's rays all start inside the room (its sources or lights).
    pub fn new(mesh: &'a Mesh, bvh: &'a Bvh, convex: bool, starts_inside: impl Fn(&ConvexRoom) -> bool) -> Surfaces<'a> {
        let room = if convex { ConvexRoom::of_convex(mesh) } else { None };
        let room = room.filter(starts_inside);
        let records = if room.is_some() { Vec::new() } else { mesh.hit_records() };
        Surfaces { bvh, room, exact: true, records }
    }

    /// Whether a hit must name the very triangle it lands on (the light tracer's patches, level
    /// of detail's panels: true, the default) or only a triangle with its material, which
    /// spares a convex room's search among a plane's triangles when they share a material.
    /// The material, distance and normal are the same either way, and so are the bits of a
    /// tracer that reads only those.
    pub fn exact_triangles(mut self, exact: bool) -> Surfaces<'a> {
        self.exact = exact;
        self
    }

    /// The nearest surface along origin + t·dir (unit dir): its distance, mesh triangle and unit
    /// normal (facing either way; the planes' is precomputed). [`Surfaces::nearest_facing`]
    /// turns the normal towards the ray's side.
    /// The planes' test is inlined into the tracer (a call and its frame cost as much as the
    /// test); the BVH's query is a call here ([`Surfaces::nearest_facing_avx2`] inlines it into
    /// a caller compiled for AVX2).
    #[inline(always)]
    pub fn nearest(&self, origin: DVec3, dir: DVec3) -> Option<(f64, usize, DVec3)> {
        match &self.room {
            Some(room) => {
                let exit = room.exit_with(origin, dir, self.exact);
                Some((exit.t, exit.triangle as usize, exit.normal))
            }
            None => self.nearest_in_bvh(origin, dir),
        }
    }

    /// [`Surfaces::nearest`] with the normal facing the side the ray comes from (−n when
    /// n · dir is positive): for the planes the product their test computed, for the BVH the
    /// dot product, the same bits either way.
    #[inline(always)]
    pub fn nearest_facing(&self, origin: DVec3, dir: DVec3) -> Option<(f64, usize, DVec3)> {
        match &self.room {
            Some(room) => {
                let exit = room.exit_with(origin, dir, self.exact);
                Some((exit.t, exit.triangle as usize, exit.facing))
            }
            None => self.nearest_in_bvh(origin, dir).map(|(t, tri, n)| (t, tri, facing(n, dir))),
        }
    }

    /// The [`HitRecord`] of mesh triangle `tri` on the BVH path, in the cache line its hit's
    /// normal was read from; None on the planes' path (no records).
    #[inline(always)]
    pub fn hit_record(&self, tri: usize) -> Option<&HitRecord> {
        self.records.get(tri)
    }

    /// [`Surfaces::nearest_facing`] on the BVH path with its AVX2 query inlined into the caller,
    /// which must run under `v3.vectorize` (`v3` the BVH's [`Bvh::avx2`]; the sound kernel on
    /// a mesh): the same hits, normals and bits.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn nearest_facing_avx2(&self, v3: pulp::x86::V3, origin: DVec3, dir: DVec3) -> Option<(f64, usize, DVec3)> {
        let hit = self.bvh.closest_hit_avx2(v3, origin.as_vec3(), dir.as_vec3())?;
        let tri = hit.triangle as usize;
        Some((hit.t as f64, tri, facing(self.records[tri].normal.as_dvec3(), dir)))
    }

    /// Whether the nearest surface comes from the convex room's planes (in f64), not the BVH.
    #[inline(always)]
    pub fn traces_planes(&self) -> bool {
        self.room.is_some()
    }

    #[inline(never)]
    fn nearest_in_bvh(&self, origin: DVec3, dir: DVec3) -> Option<(f64, usize, DVec3)> {
        let hit = self.bvh.closest_hit_from(origin.as_vec3(), dir.as_vec3())?;
        let tri = hit.triangle as usize;
        Some((hit.t as f64, tri, self.records[tri].normal.as_dvec3()))
    }
}

/// `n`, or −n when n · dir > 0: the normal facing the side a ray along `dir` comes from. The
/// sign bit flipped without a branch (the same bits as −n): which side of a furniture's or a
/// thin wall's triangle a ray meets is as good as random.
#[inline(always)]
fn facing(n: DVec3, dir: DVec3) -> DVec3 {
    let flip = u64::from(n.dot(dir) > 0.0) << 63;
    DVec3::new(f64::from_bits(n.x.to_bits() ^ flip), f64::from_bits(n.y.to_bits() ^ flip), f64::from_bits(n.z.to_bits() ^ flip))
}

#[cfg(test)]
#[path = "convex_tests.rs"]
mod tests;
