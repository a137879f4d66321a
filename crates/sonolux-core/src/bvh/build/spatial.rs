//! A binary tree with spatial splits (SBVH: Stich, Friedrich and Dietrich, "Spatial splits in
//! bounding volume hierarchies", HPG 2009), as a probe of what they would give this tracer's
//! rooms (docs/bvh.md, "Wide nodes by cost"): serial, not the default build.
//!
//! Per node, as Embree's `HeuristicArraySpatialSAH` (kernels/builders/heuristic_spatial_array.h):
//! the best binned object split first; where its two sides' boxes overlap by more than
//! [`OVERLAP`] of the root's area (Stich et al.'s α), also the best spatial split, binned over
//! the node's box: a reference that straddles bins is clipped into each (Embree's `bin2` and
//! `splitPolygon`), counted as entering its first bin and leaving its last; the SAH of a
//! boundary is A_L·P_L + A_R·P_R with P the packets of the references entering left of it and
//! leaving right of it. The spatial split is taken when it is cheaper and the node's budget of
//! extra references allows (the root's is [`REPLICATION`] − 1 of the triangles, Embree's
//! `max_spatial_split_replications` 1.2; split between the children by their counts).
//!
//! Watertight: a reference's box is the box of its triangle clipped to the reference's slab,
//! computed in f64 and rounded outward to f32, then cut to the reference's box before the
//! split (which encloses the piece already), so the leaves' boxes together enclose every point
//! of every triangle; a leaf tests the whole triangle, so a hit is a hit of the triangle.

use glam::{DVec3, Vec3};

use super::{packets, Binary, Extent, LEAF_TRIANGLES};
use crate::geometry::Aabb;
use crate::mesh::Mesh;

const BINS: usize = 32;
/// Spatial splits are tried where the object split's sides overlap by this share of the root's
/// surface area (Stich et al. 2009, §4: α = 10⁻⁵).
const OVERLAP: f32 = 1e-5;
/// At most this many references a triangle, on average (Embree's default replication, 1.2).
pub(super) const REPLICATION: f32 = 1.2;

/// A triangle, or the part of it inside `bounds`.
#[derive(Clone, Copy)]
pub(super) struct Ref {
    pub(super) id: u32,
    pub(super) bounds: Aabb,
}

/// The box of triangle `id`'s part with lo ≤ p[axis] ≤ hi, within `within`; computed in f64
/// (Sutherland–Hodgman against the two planes) and rounded outward to f32.
fn clipped(mesh: &Mesh, id: u32, axis: usize, lo: f32, hi: f32, within: &Aabb) -> Aabb {
    let mut poly: Vec<DVec3> = mesh.corners(id as usize).iter().map(|v| v.as_dvec3()).collect();
    for (plane, keep_above) in [(lo as f64, true), (hi as f64, false)] {
        let inside = |p: &DVec3| if keep_above { p[axis] >= plane } else { p[axis] <= plane };
        let mut out = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            if inside(&a) {
                out.push(a);
            }
            if inside(&a) != inside(&b) {
                let mut c = a + (b - a) * ((plane - a[axis]) / (b[axis] - a[axis]));
                c[axis] = plane;
                out.push(c);
            }
        }
        poly = out;
        if poly.is_empty() {
            return Aabb::EMPTY;
        }
    }
    let mut b = Aabb::EMPTY;
    for p in &poly {
        let down = Vec3::new(down(p.x), down(p.y), down(p.z));
        let up = Vec3::new(up(p.x), up(p.y), up(p.z));
        b.grow(down);
        b.grow(up);
    }
    let b = Aabb { min: b.min.max(within.min), max: b.max.min(within.max) };
    if (0..3).any(|a| b.min[a] > b.max[a]) {
        Aabb::EMPTY
    } else {
        b
    }
}

/// The largest f32 at most x, and the smallest at least x (x finite).
fn down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x {
        step(f, -1.0)
    } else {
        f
    }
}
fn up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        step(f, 1.0)
    } else {
        f
    }
}

/// The next f32 after finite `f` towards the sign of `towards` (`f32::next_up` / `next_down`,
/// written out for the crate's minimum Rust version, 1.85).
fn step(f: f32, towards: f32) -> f32 {
    if f == 0.0 {
        return f32::from_bits(1).copysign(towards);
    }
    let away_from_zero = (f > 0.0) == (towards > 0.0);
    f32::from_bits(if away_from_zero { f.to_bits() + 1 } else { f.to_bits() - 1 })
}

fn extent_of(refs: &[Ref]) -> Extent {
    refs.iter().fold(Extent::EMPTY, |e, r| {
        let mut c = e.centroids;
        c.grow(r.bounds.center());
        Extent { bounds: e.bounds.union(&r.bounds), centroids: c }
    })
}

/// The binary tree over `refs`; leaves' triangles appended to `order`.
pub(super) fn build(mesh: &Mesh, refs: Vec<Ref>, order: &mut Vec<u32>) -> Binary {
    let budget = ((REPLICATION - 1.0) * refs.len() as f32) as usize;
    let root_area = extent_of(&refs).bounds.half_area();
    node(mesh, refs, budget, root_area * OVERLAP, 0, order)
}

fn node(mesh: &Mesh, refs: Vec<Ref>, budget: usize, min_overlap: f32, depth: usize, order: &mut Vec<u32>) -> Binary {
    let ext = extent_of(&refs);
    let n = refs.len();
    if n <= LEAF_TRIANGLES || depth >= 64 {
        let start = order.len();
        order.extend(refs.iter().map(|r| r.id));
        return Binary::Leaf { bounds: ext.bounds, start, end: order.len() };
    }
    let object = object_split(&refs, &ext);
    let mut chosen: Option<(Vec<Ref>, Vec<Ref>)> = None;
    if let Some((cost, axis, boundary, lb, rb)) = object {
        let overlap = Aabb { min: lb.min.max(rb.min), max: lb.max.min(rb.max) };
        let overlaps = (0..3).all(|a| overlap.min[a] <= overlap.max[a]) && overlap.half_area() > min_overlap;
        if overlaps && budget > 0 {
            if let Some((s_cost, s_axis, pos, grow)) = spatial_split(mesh, &refs, &ext.bounds) {
                if s_cost < cost && grow <= budget {
                    chosen = Some(spatial_partition(mesh, &refs, s_axis, pos));
                }
            }
        }
        if chosen.as_ref().is_none_or(|(l, r)| l.is_empty() || r.is_empty()) {
            let scale = BINS as f32 / ext.centroids.extent()[axis];
            let bin = |r: &Ref| (((r.bounds.center()[axis] - ext.centroids.min[axis]) * scale) as usize).min(BINS - 1);
            let (l, r): (Vec<Ref>, Vec<Ref>) = refs.iter().partition(|r| bin(r) < boundary);
            chosen = Some((l, r));
        }
    }
    let (l, r) = match chosen {
        Some((l, r)) if !l.is_empty() && !r.is_empty() => (l, r),
        _ => {
            let mut refs = refs;
            let r = refs.split_off(n / 2);
            (refs, r)
        }
    };
    let extra = (l.len() + r.len()).saturating_sub(n);
    let left_budget = budget.saturating_sub(extra) * l.len() / (l.len() + r.len());
    let right_budget = budget.saturating_sub(extra) - left_budget;
    let a = node(mesh, l, left_budget, min_overlap, depth + 1, order);
    let b = node(mesh, r, right_budget, min_overlap, depth + 1, order);
    Binary::Inner { bounds: ext.bounds, children: Box::new([a, b]) }
}

/// The best binned object split: (SAH, axis, first bin of the right side, both sides' boxes).
fn object_split(refs: &[Ref], ext: &Extent) -> Option<(f32, usize, usize, Aabb, Aabb)> {
    let mut best = None;
    for axis in 0..3 {
        let e = ext.centroids.extent()[axis];
        if e <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / e;
        let mut boxes = [Aabb::EMPTY; BINS];
        let mut counts = [0usize; BINS];
        for r in refs {
            let b = (((r.bounds.center()[axis] - ext.centroids.min[axis]) * scale) as usize).min(BINS - 1);
            boxes[b] = boxes[b].union(&r.bounds);
            counts[b] += 1;
        }
        sweep(&boxes, &counts, &counts, axis, &mut best);
    }
    best
}

/// Sweeps a binning: for each boundary b the SAH of entering-left [0, b) and leaving-right
/// [b, BINS); keeps the cheapest in `best`.
#[allow(clippy::type_complexity)]
fn sweep(boxes: &[Aabb; BINS], enter: &[usize; BINS], leave: &[usize; BINS], axis: usize, best: &mut Option<(f32, usize, usize, Aabb, Aabb)>) {
    let mut right = [(Aabb::EMPTY, 0usize); BINS];
    let mut acc = (Aabb::EMPTY, 0usize);
    for b in (1..BINS).rev() {
        acc = (acc.0.union(&boxes[b]), acc.1 + leave[b]);
        right[b] = acc;
    }
    let mut left = (Aabb::EMPTY, 0usize);
    for b in 1..BINS {
        left = (left.0.union(&boxes[b - 1]), left.1 + enter[b - 1]);
        if left.1 == 0 || right[b].1 == 0 {
            continue;
        }
        let cost = left.0.half_area() * packets(left.1) + right[b].0.half_area() * packets(right[b].1);
        if best.as_ref().is_none_or(|s| cost < s.0) {
            *best = Some((cost, axis, b, left.0, right[b].0));
        }
    }
}

/// The best spatial split over the node's box: (SAH, axis, plane, extra references).
fn spatial_split(mesh: &Mesh, refs: &[Ref], bounds: &Aabb) -> Option<(f32, usize, f32, usize)> {
    let mut best: Option<(f32, usize, usize, Aabb, Aabb)> = None;
    let mut planes = [[0.0f32; BINS + 1]; 3];
    for axis in 0..3 {
        let (lo, e) = (bounds.min[axis], bounds.extent()[axis]);
        if e <= 0.0 {
            continue;
        }
        let plane = |b: usize| if b == BINS { bounds.max[axis] } else { lo + e * b as f32 / BINS as f32 };
        planes[axis] = std::array::from_fn(plane);
        let bin = |x: f32| (planes[axis][1..BINS].iter().take_while(|&&p| p <= x).count()).min(BINS - 1);
        let mut boxes = [Aabb::EMPTY; BINS];
        let (mut enter, mut leave) = ([0usize; BINS], [0usize; BINS]);
        for r in refs {
            let (b0, b1) = (bin(r.bounds.min[axis]), bin(r.bounds.max[axis]));
            if b0 == b1 {
                boxes[b0] = boxes[b0].union(&r.bounds);
            } else {
                for (b, bx) in boxes.iter_mut().enumerate().take(b1 + 1).skip(b0) {
                    *bx = bx.union(&clipped(mesh, r.id, axis, planes[axis][b], planes[axis][b + 1], &r.bounds));
                }
            }
            enter[b0] += 1;
            leave[b1] += 1;
        }
        sweep(&boxes, &enter, &leave, axis, &mut best);
    }
    let (cost, axis, b, ..) = best?;
    let pos = planes[axis][b];
    let straddle = refs.iter().filter(|r| r.bounds.min[axis] < pos && r.bounds.max[axis] > pos).count();
    Some((cost, axis, pos, straddle))
}

/// References left and right of the plane p[axis] = pos, straddling ones clipped into both.
fn spatial_partition(mesh: &Mesh, refs: &[Ref], axis: usize, pos: f32) -> (Vec<Ref>, Vec<Ref>) {
    let (mut l, mut r) = (Vec::new(), Vec::new());
    for x in refs {
        if x.bounds.max[axis] <= pos {
            l.push(*x);
        } else if x.bounds.min[axis] >= pos {
            r.push(*x);
        } else {
            let a = clipped(mesh, x.id, axis, f32::NEG_INFINITY, pos, &x.bounds);
            let b = clipped(mesh, x.id, axis, pos, f32::INFINITY, &x.bounds);
            if a.min.x <= a.max.x {
                l.push(Ref { id: x.id, bounds: a });
            }
            if b.min.x <= b.max.x {
                r.push(Ref { id: x.id, bounds: b });
            }
        }
    }
    (l, r)
}
