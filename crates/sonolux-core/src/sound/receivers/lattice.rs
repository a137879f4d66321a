//! Receivers on a floor-plan lattice (the scene's receiver grid): which spheres a segment
//! crosses, found from the lattice's arithmetic instead of a walk through cells
//! ([`Receivers::crossings`]' fast path; the cell walk stays for any other set of points).

use glam::DVec3;

use super::{Crossing, Receivers};

/// Receivers on a floor-plan lattice: centres (x0 + i sx, y0 + j sy, z), i < nx, j < ny, with
/// sx and sy at least a sphere's diameter; `point[j * nx + i]` is the receiver there, or
/// `u32::MAX` where the lattice has no receiver (a grid clipped by a wall).
#[derive(Clone, Debug)]
pub(super) struct Lattice {
    x0: f64,
    y0: f64,
    sx: f64,
    sy: f64,
    nx: usize,
    ny: usize,
    z: f64,
    point: Vec<u32>,
    /// 1 / sx and 1 / sy: indices by products (they pick which spheres get the exact chord test).
    inv_sx: f64,
    inv_sy: f64,
    /// How far from the lattice's points a segment is looked at: wider than the spheres by
    /// twice the lattice's tolerance (how far a centre may lie off it and still count as on it) and a hair, so that neither a centre off the lattice by its
    /// tolerance nor a rounding of the clip or of an index's product loses a chord.
    pad: f64,
}

impl Lattice {
    /// The lattice of the search grid `floor_plan_lattice` found (its box's corner `lo`, cells
    /// and dimensions); None when two receivers share a point (a receiver's channels): those take
    /// the cell walk, which lists every sphere of a cell (a lattice would keep only the last).
    pub(super) fn new(centres: &[DVec3], lo: DVec3, cell: DVec3, dims: [usize; 3], radius_m: f64) -> Option<Lattice> {
        let (x0, y0) = (lo.x + 0.5 * cell.x, lo.y + 0.5 * cell.y);
        let mut point = vec![u32::MAX; dims[0] * dims[1]];
        for (k, c) in centres.iter().enumerate() {
            let i = (((c.x - x0) / cell.x).round() as usize).min(dims[0] - 1);
            let j = (((c.y - y0) / cell.y).round() as usize).min(dims[1] - 1);
            if point[j * dims[0] + i] != u32::MAX {
                return None;
            }
            point[j * dims[0] + i] = k as u32;
        }
        let tol = lattice_tolerance(centres);
        let pad = radius_m * (1.0 + 1e-9) + 2.0 * tol;
        Some(Lattice { x0, y0, sx: cell.x, sy: cell.y, nx: dims[0], ny: dims[1], z: lo.z + radius_m, point, inv_sx: 1.0 / cell.x, inv_sy: 1.0 / cell.y, pad })
    }
}

impl Receivers {
    /// [`Receivers::crossings`] on a floor-plan lattice: the stretch of the segment inside the
    /// spheres' slab (z within r of the lattice's height) seen from above is a short 2D segment;
    /// the spheres it can cross have their centres within r of it. Along the 2D segment's major
    /// axis each lattice column in its reach (± r) holds those within r·h/|major| of the line's
    /// crossing of that column (h the 2D direction's length): one row, two where spheres nearly
    /// touch. Each such sphere is tested by its exact chord, as the cell walk tests it, so the
    /// same spheres give the same chords; without the walk's stepping, stamps and cell lists.
    #[inline(never)]
    pub(super) fn walk_lattice(&self, lat: &Lattice, origin: DVec3, dir: DVec3, length: f64, mut f: impl FnMut(Crossing)) {
        let pad = lat.pad;
        let (mut t0, mut t1) = (0.0f64, length);
        if dir.z != 0.0 {
            let inv = 1.0 / dir.z;
            let (a, b) = ((lat.z - pad - origin.z) * inv, (lat.z + pad - origin.z) * inv);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        } else if (origin.z - lat.z).abs() > pad {
            return;
        }
        if !(t0 <= t1) {
            return;
        }
        let (pa, pb) = (origin + dir * t0, origin + dir * t1);
        // Most stretches are short (the segment crosses the slab at a slant): the lattice points
        // within pad of the stretch's box are at most 2 × 2, tested without the column walk's
        // set-up and its loops of varying length (half of paper-large's segments reach here and
        // test 0.7 spheres on average: the walk's branches cost more than its tests).
        let span = |a: f64, b: f64, p0: f64, inv: f64, n: usize| index_span((a.min(b) - pad - p0) * inv, (a.max(b) + pad - p0) * inv, n);
        let ((i0, i1), (j0, j1)) = (span(pa.x, pb.x, lat.x0, lat.inv_sx, lat.nx), span(pa.y, pb.y, lat.y0, lat.inv_sy, lat.ny));
        if i0 > i1 || j0 > j1 {
            return;
        }
        if i1 - i0 <= 1 && j1 - j0 <= 1 {
            for (i, j) in [(i0, j0), (i0 + 1, j0), (i0, j0 + 1), (i0 + 1, j0 + 1)] {
                let k = if i <= i1 && j <= j1 { lat.point[j * lat.nx + i] } else { u32::MAX };
                if let Some(crossing) = (k != u32::MAX).then(|| self.chord(k, self.centres[k as usize], origin, dir, length)).flatten() {
                    f(crossing);
                }
            }
            return;
        }
        let h = (dir.x * dir.x + dir.y * dir.y).sqrt();
        // Along x (columns) when the 2D direction leans to x, else along y: swap the axes.
        let x_major = dir.x.abs() >= dir.y.abs();
        let (u0, su, inv_su, nu, v0, inv_sv, nv) =
            if x_major { (lat.x0, lat.sx, lat.inv_sx, lat.nx, lat.y0, lat.inv_sy, lat.ny) } else { (lat.y0, lat.sy, lat.inv_sy, lat.ny, lat.x0, lat.inv_sx, lat.nx) };
        let (ua, ub, va) = if x_major { (pa.x, pb.x, pa.y) } else { (pa.y, pb.y, pa.x) };
        let (du, dv) = if x_major { (dir.x, dir.y) } else { (dir.y, dir.x) };
        let (lo_u, hi_u) = (ua.min(ub) - pad, ua.max(ub) + pad);
        // Indices by products with the reciprocals, not divisions: they only choose which
        // spheres get the exact chord test, and `pad`'s hair covers their rounding.
        let (first, last) = index_span((lo_u - u0) * inv_su, (hi_u - u0) * inv_su, nu);
        if first > last {
            return;
        }
        // The line's v where it crosses column u: va + slope (u − ua); the spheres' centres
        // within pad · h / |du| of it (|du| ≥ h/√2; a vertical segment: its one point).
        let (slope, reach) = if du != 0.0 { (dv / du, pad * h / du.abs()) } else { (0.0, pad) };
        for i in first..=last {
            let u = u0 + i as f64 * su;
            let v = va + slope * (u - ua);
            let (j0, j1) = index_span((v - reach - v0) * inv_sv, (v + reach - v0) * inv_sv, nv);
            for j in j0..=j1 {
                let cell = if x_major { j * lat.nx + i } else { i * lat.nx + j };
                let k = lat.point[cell];
                if k == u32::MAX {
                    continue;
                }
                if let Some(crossing) = self.chord(k, self.centres[k as usize], origin, dir, length) {
                    f(crossing);
                }
            }
        }
    }
}

/// The whole numbers k in [a, b] that index a lattice of n points (0 ≤ k < n), as (first, last);
/// first > last when there are none (a NaN end gives none). ⌈a⌉ and ⌊b⌋ by truncation and a
/// comparison: `ceil` and `floor` are library calls without SSE4.1.
#[inline(always)]
fn index_span(a: f64, b: f64, n: usize) -> (usize, usize) {
    let top = n as f64 - 1.0;
    if !(a <= top && b >= 0.0 && a <= b) {
        return (1, 0);
    }
    let (a, b) = (a.max(0.0), b.min(top));
    // a ≥ 0: truncation is the floor; b ≥ 0 likewise. Through i64 (n ≤ 4096): one
    // instruction each way, where usize's conversions are a branch and several.
    let first = a as i64 + i64::from(a > (a as i64) as f64);
    let last = b as i64;
    (first as usize, last as usize)
}

/// How far (m) a point may lie off a floor-plan lattice and still count as on it: 1e-9 of the
/// largest coordinate (at least 1e-9 m).
fn lattice_tolerance(centres: &[DVec3]) -> f64 {
    1e-9 * centres.iter().map(|c| c.abs().max_element()).fold(1.0, f64::max)
}

/// The search grid of receivers that lie on a regular floor-plan lattice (one height, x and y
/// on steps of sx and sy at least a sphere's diameter, as the scene's receiver grid): cells of
/// sx × sy × 2r centred on the lattice points, so that each sphere lies in its own cell and a
/// segment tests one sphere per cell it crosses. None for any other set of points.
pub(super) fn floor_plan_lattice(centres: &[DVec3], radius: f64) -> Option<(DVec3, DVec3, [usize; 3])> {
    let first = *centres.first()?;
    let tol = lattice_tolerance(centres);
    if centres.iter().any(|c| (c.z - first.z).abs() > tol) {
        return None;
    }
    let mut axes = [(0.0, 0.0, 0usize); 2]; // (origin, step, count) of x and y
    for (a, axis) in axes.iter_mut().enumerate() {
        let mut v: Vec<f64> = centres.iter().map(|c| c[a]).collect();
        v.sort_by(f64::total_cmp);
        v.dedup_by(|x, y| (*x - *y).abs() <= tol);
        let step = if v.len() > 1 { v[1] - v[0] } else { 2.0 * radius };
        if !(step >= 2.0 * radius) {
            return None;
        }
        let count = ((v[v.len() - 1] - v[0]) / step).round() as usize + 1;
        if count > 4096 || v.iter().any(|x| {
            let k = (x - v[0]) / step;
            (k - k.round()).abs() * step > tol
        }) {
            return None;
        }
        *axis = (v[0], step, count);
    }
    let [(x0, sx, nx), (y0, sy, ny)] = axes;
    let lo = DVec3::new(x0 - 0.5 * sx, y0 - 0.5 * sy, first.z - radius);
    Some((lo, DVec3::new(sx, sy, 2.0 * radius), [nx, ny, 1]))
}
