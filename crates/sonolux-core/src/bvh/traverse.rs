//! Walking the 8-wide BVH with one ray: the box test of a node's eight children at once, the
//! nearest-first order, and the watertight test of eight triangles at once.
//!
//! Written once over [`Lanes`], so the AVX2 and portable paths are the same code. Every
//! function here is `#[inline(always)]`: under `pulp`'s `vectorize` they are compiled for the
//! CPU features it enables.

use glam::{Vec3, Vec3A};

use super::lanes::Lanes;
use super::{Node8, Packet, LEAF, PACKET_INDEX};
use crate::geometry::{pick, Hit, Ray, BOX_EXIT_WIDEN};

/// Per (kz, sign of dir[kz]): the watertight test's axes (kx, ky, kz) as `Ray::new` picks them:
/// kx, ky the next two axes after kz, swapped when the ray runs down kz (Woop, Benthin and
/// Wald 2013, fig. 4). Index 2·kz + (dir[kz] < 0).
const FRAMES: [[usize; 3]; 6] = [[1, 2, 0], [2, 1, 0], [2, 0, 1], [0, 2, 1], [0, 1, 2], [1, 0, 2]];
/// Lane indices that broadcast lane `axis` of a vector to all eight ([`Lanes::permute`]).
const BROADCAST: [[u32; 8]; 3] = [[0; 8], [1; 8], [2; 8]];

/// Stack entries kept in a fixed array; deeper stacks (pathological trees) spill to the heap.
const STACK: usize = 32;

/// A ray's values as the lanes want them, computed once per query.
pub(super) struct TravRay<L: Lanes> {
    /// Origin and inverse direction per axis, for the box test.
    org: [L::F; 3],
    inv: [L::F; 3],
    /// Per axis, the plane (of `Node8::bounds`) that the ray meets first, and last.
    near: [usize; 3],
    far: [usize; 3],
    /// The triangle test's frame: the axes (kx, ky, kz), origin along them and shear.
    k: [usize; 3],
    org_k: [L::F; 3],
    shear: [L::F; 3],
    t_min: L::F,
}

impl<L: Lanes> TravRay<L> {
    /// [`TravRay::new`] of `Ray::new(origin, dir)`, the same values to the bit, with the axis
    /// picks done as lane permutes: the frame's three axes from one small table, and each
    /// value of a picked axis (dir[kx], origin[ky], 1/dir[kz], …) broadcast by one permute,
    /// where `geometry::pick` took a dozen scalar instructions each (seven picks a query, ~87
    /// instructions on the path from a segment's direction to its first box test).
    #[inline(always)]
    pub(super) fn from_origin_dir(l: L, origin: Vec3, dir: Vec3, t_min: f32) -> TravRay<L> {
        // kz: the axis of the largest |component|, the first one on ties (x, then y).
        let a = dir.abs().to_array();
        let x_largest = (a[0] >= a[1]) & (a[0] >= a[2]);
        let kz = (!x_largest as usize) * (1 + !(a[1] >= a[2]) as usize);
        let d = l.load(&[dir.x, dir.y, dir.z, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let swap = (l.bits(l.lt(d, l.splat(0.0))) >> kz) as usize & 1;
        let k = FRAMES[2 * kz + swap];
        // 1/dir as `Ray::new` takes it: one SIMD division, ±1e-30 in place of a zero component.
        let safe = Vec3::select(dir.cmpeq(Vec3::ZERO), Vec3::splat(1e-30).copysign(dir), dir);
        let inv = Vec3::from(Vec3A::ONE / Vec3A::from(safe));
        let inv_l = l.load(&[inv.x, inv.y, inv.z, 1.0, 1.0, 1.0, 1.0, 1.0]);
        let o = l.load(&[origin.x, origin.y, origin.z, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let sz = l.permute(inv_l, &BROADCAST[k[2]]);
        let near = [
            inv.x.is_sign_negative() as usize,
            2 + inv.y.is_sign_negative() as usize,
            4 + inv.z.is_sign_negative() as usize,
        ];
        TravRay {
            org: [l.permute(o, &BROADCAST[0]), l.permute(o, &BROADCAST[1]), l.permute(o, &BROADCAST[2])],
            inv: [l.splat(inv.x), l.splat(inv.y), l.splat(inv.z)],
            near,
            far: [near[0] ^ 1, near[1] ^ 1, near[2] ^ 1],
            k,
            org_k: [l.permute(o, &BROADCAST[k[0]]), l.permute(o, &BROADCAST[k[1]]), l.permute(o, &BROADCAST[k[2]])],
            shear: [l.mul(l.permute(d, &BROADCAST[k[0]]), sz), l.mul(l.permute(d, &BROADCAST[k[1]]), sz), sz],
            t_min: l.splat(t_min),
        }
    }

    #[inline(always)]
    pub(super) fn new(l: L, ray: &Ray, t_min: f32) -> TravRay<L> {
        // (Written out, not mapped through closures: a closure would not inherit the CPU
        // features that `vectorize` enables, and its SIMD calls would not be inlined.)
        let (o, inv) = (ray.origin, ray.inv_dir);
        let near = [
            inv.x.is_sign_negative() as usize,
            2 + inv.y.is_sign_negative() as usize,
            4 + inv.z.is_sign_negative() as usize,
        ];
        TravRay {
            org: [l.splat(o.x), l.splat(o.y), l.splat(o.z)],
            inv: [l.splat(inv.x), l.splat(inv.y), l.splat(inv.z)],
            near,
            far: [near[0] ^ 1, near[1] ^ 1, near[2] ^ 1],
            k: [ray.kx, ray.ky, ray.kz],
            org_k: {
                let o = o.to_array();
                [l.splat(pick(o, ray.kx)), l.splat(pick(o, ray.ky)), l.splat(pick(o, ray.kz))]
            },
            shear: [l.splat(ray.sx), l.splat(ray.sy), l.splat(ray.sz)],
            t_min: l.splat(t_min),
        }
    }
}

/// Which of the node's children the ray meets within (t_min, t_max) (bit per slot), and the
/// entry distances. The slab test of `Aabb::hit`, eight boxes at once: the same roundings, and
/// the same widening of the exit distance that keeps it conservative, applied after the clip to
/// t_max (so to the nearest hit so far as well).
#[inline(always)]
fn hit_children<L: Lanes>(l: L, r: &TravRay<L>, node: &Node8, t_max: f32) -> (u32, [f32; 8]) {
    let b = &node.bounds;
    let (nx, ny, nz) = (slab(l, r, &b[r.near[0]], 0), slab(l, r, &b[r.near[1]], 1), slab(l, r, &b[r.near[2]], 2));
    let (fx, fy, fz) = (slab(l, r, &b[r.far[0]], 0), slab(l, r, &b[r.far[1]], 1), slab(l, r, &b[r.far[2]], 2));
    let enter = l.max(l.max(nx, ny), l.max(nz, r.t_min));
    // The clip to the nearest hit so far is widened with the far planes: a box's entry and a
    // triangle's t in it are rounded apart, so a box entered a few ulps beyond the hit found
    // may still hold a triangle whose computed t is nearer (a shared vertex or edge of two
    // triangles of different boxes; the brute-force oracle takes the nearer).
    let exit = l.mul(l.min(l.min(l.min(fx, fy), fz), l.splat(t_max)), l.splat(BOX_EXIT_WIDEN));
    (l.bits(l.le(enter, exit)), l.store(enter))
}

/// Distances along the ray to eight planes normal to `axis`.
#[inline(always)]
fn slab<L: Lanes>(l: L, r: &TravRay<L>, plane: &[f32; 8], axis: usize) -> L::F {
    l.mul(l.sub(l.load(plane), r.org[axis]), r.inv[axis])
}

/// One corner of eight triangles relative to the origin, in the ray's frame: sheared x and y,
/// and z (not yet scaled).
#[inline(always)]
fn corner<L: Lanes>(l: L, r: &TravRay<L>, p: &Packet, corner: usize) -> (L::F, L::F, L::F) {
    let [kx, ky, kz] = r.k;
    let c = &p.corners;
    let x = l.sub(l.load(&c[3 * corner + kx]), r.org_k[0]);
    let y = l.sub(l.load(&c[3 * corner + ky]), r.org_k[1]);
    let z = l.sub(l.load(&c[3 * corner + kz]), r.org_k[2]);
    (l.sub(x, l.mul(r.shear[0], z)), l.sub(y, l.mul(r.shear[1], z)), z)
}

/// The nearest of a packet's triangles hit with t in (t_min, t_max): (t, lane), t = +∞ when
/// none is. The watertight test of `geometry::intersect_triangle`, eight triangles at once,
/// operation for operation (so the same bits), edge cases decided in f64 lane by lane as there.
/// The nearest lane is found without branches (a horizontal minimum, then the first lane that
/// holds it, as the scalar loop keeps the first on ties): whether a ray hits a packet, and in
/// which lane, is unpredictable, and this test is on the critical path of every query.
#[inline(always)]
fn hit_packet<L: Lanes>(l: L, r: &TravRay<L>, p: &Packet, t_max: f32) -> (f32, usize) {
    let (ax, ay, az) = corner(l, r, p, 0);
    let (bx, by, bz) = corner(l, r, p, 1);
    let (cx, cy, cz) = corner(l, r, p, 2);
    // Scaled barycentric coordinates (edge functions).
    let mut u = l.sub(l.mul(cx, by), l.mul(cy, bx));
    let mut v = l.sub(l.mul(ax, cy), l.mul(ay, cx));
    let mut w = l.sub(l.mul(bx, ay), l.mul(by, ax));
    let zero = l.splat(0.0);
    let on_edge = l.bits(l.or(l.or(l.eq(u, zero), l.eq(v, zero)), l.eq(w, zero)));
    if on_edge != 0 {
        (u, v, w) = edges_in_f64(l, on_edge, [ax, ay, bx, by, cx, cy], [u, v, w]);
    }
    // Outside when some edge function is negative and another positive. (min/max in place of
    // the scalar test's six comparisons: where they could differ, one of u, v, w is NaN, and
    // then so is t, which fails the range test below either way.)
    let outside = l.and(l.lt(l.min(l.min(u, v), w), zero), l.lt(zero, l.max(l.max(u, v), w)));
    let det = l.add(l.add(u, v), w);
    let sz = r.shear[2];
    let t_scaled = l.add(l.add(l.mul(u, l.mul(sz, az)), l.mul(v, l.mul(sz, bz))), l.mul(w, l.mul(sz, cz)));
    // det = 0 needs no test of its own: t is then ±∞ or NaN, outside any (t_min, t_max).
    let t = l.div(t_scaled, det);
    let inside = l.and(l.lt(r.t_min, t), l.lt(t, l.splat(t_max)));
    let inf = l.splat(f32::INFINITY);
    // +∞ in the lanes missed (NaN lanes are never inside, so no NaN is left).
    let t = l.select(outside, inf, l.select(inside, t, inf));
    let nearest = l.hmin(t);
    let lane = l.bits(l.eq(t, nearest)).trailing_zeros() as usize;
    (l.store(nearest)[0], lane & 7)
}

/// The edge functions recomputed in f64 in the lanes where one of them was zero in f32.
#[cold]
#[inline(never)]
fn edges_in_f64<L: Lanes>(l: L, lanes: u32, xy: [L::F; 6], uvw: [L::F; 3]) -> (L::F, L::F, L::F) {
    let [ax, ay, bx, by, cx, cy] = xy.map(|x| l.store(x).map(f64::from));
    let [mut u, mut v, mut w] = uvw.map(|x| l.store(x));
    for i in 0..8 {
        if lanes & (1 << i) != 0 {
            u[i] = (cx[i] * by[i] - cy[i] * bx[i]) as f32;
            v[i] = (ax[i] * cy[i] - ay[i] * cx[i]) as f32;
            w[i] = (bx[i] * ay[i] - by[i] * ax[i]) as f32;
        }
    }
    (l.load(&u), l.load(&v), l.load(&w))
}

/// A wide node the walk can descend: its eight child references and which of them a ray meets.
/// The full-precision [`Node8`] and the compressed [`super::quantized::QNode8`] (whose box test
/// decodes its planes first, `traverse_quantized.rs`) share one walk, so one order of visits.
pub(super) trait WideNode<L: Lanes> {
    /// Slot `slot`'s reference: an interior node's index, or a leaf reference.
    fn child(&self, slot: usize) -> u32;
    /// Which children the ray meets within (t_min, t_max) (bit per slot), and the entry
    /// distances.
    fn hit_children(&self, l: L, r: &TravRay<L>, t_max: f32) -> (u32, [f32; 8]);
}

impl<L: Lanes> WideNode<L> for Node8 {
    #[inline(always)]
    fn child(&self, slot: usize) -> u32 {
        self.child[slot]
    }

    #[inline(always)]
    fn hit_children(&self, l: L, r: &TravRay<L>, t_max: f32) -> (u32, [f32; 8]) {
        hit_children(l, r, self, t_max)
    }
}

/// Starts loading a child that will be visited later.
#[inline(always)]
fn prefetch<L: Lanes, N>(l: L, nodes: &[N], packets: &[Packet], child: u32) {
    if child & LEAF == 0 {
        if let Some(n) = nodes.get(child as usize) {
            l.prefetch(n);
        }
    } else if let Some(p) = packets.get((child & PACKET_INDEX) as usize) {
        l.prefetch(p);
    }
}

/// A leaf reference's packets.
#[inline(always)]
fn leaf_packets(r: u32) -> std::ops::Range<usize> {
    let first = (r & PACKET_INDEX) as usize;
    first..first + ((r & !LEAF) >> 29) as usize + 1
}

/// The traversal stack: child references with the entry distance they were pushed with.
struct Stack {
    items: [(u32, f32); STACK],
    len: usize,
    spill: Vec<(u32, f32)>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Stack {
        Stack { items: [(0, 0.0); STACK], len: 0, spill: Vec::new() }
    }

    #[inline(always)]
    fn push(&mut self, child: u32, t: f32) {
        if self.len < STACK {
            self.items[self.len] = (child, t);
        } else {
            self.spill.push((child, t));
        }
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        if self.len < STACK {
            Some(self.items[self.len])
        } else {
            self.spill.pop()
        }
    }
}

/// Closest hit: children visited nearest entry first; stack entries whose entry distance is
/// beyond the nearest hit found since they were pushed are dropped.
#[inline(always)]
pub(super) fn closest<L: Lanes, N: WideNode<L>>(l: L, nodes: &[N], packets: &[Packet], r: &TravRay<L>, t_max: f32) -> Option<Hit> {
    let mut t_best = t_max;
    let mut triangle = u32::MAX;
    let mut stack = Stack::new();
    let mut current = 0u32; // the root
    loop {
        if current & LEAF == 0 {
            let node = &nodes[current as usize];
            let (mask, enter) = node.hit_children(l, r, t_best);
            match mask.count_ones() {
                0 => {}
                1 => {
                    current = node.child(mask.trailing_zeros() as usize);
                    continue;
                }
                2 => {
                    let a = mask.trailing_zeros() as usize;
                    let b = (mask & (mask - 1)).trailing_zeros() as usize;
                    let (near, far) = if enter[b] < enter[a] { (b, a) } else { (a, b) };
                    prefetch(l, nodes, packets, node.child(far));
                    stack.push(node.child(far), enter[far]);
                    current = node.child(near);
                    continue;
                }
                _ => {
                    // Sort the hit slots by entry distance, the lower slot first on ties (the
                    // order a stable insertion sort gives), then push all but the nearest,
                    // farthest first. Each slot's place is counted, not searched for: the
                    // hit slots entered before it (nearer, or as near and in a lower slot),
                    // one comparison of all eight lanes a slot, so no branch on the
                    // distances (an insertion sort's inner loop mispredicts on them). A slot
                    // not hit is written to the scratch place 8.
                    let lanes = l.load(&enter);
                    let mut order = [(0.0f32, 0u32); 9];
                    for slot in 0..8 {
                        let t = l.splat(enter[slot]);
                        let before = l.bits(l.lt(lanes, t)) | (l.bits(l.eq(lanes, t)) & ((1 << slot) - 1));
                        let place = if mask >> slot & 1 != 0 { (before & mask).count_ones() as usize } else { 8 };
                        order[place] = (enter[slot], node.child(slot));
                    }
                    let n = mask.count_ones() as usize;
                    for &(t, child) in order[1..n].iter().rev() {
                        prefetch(l, nodes, packets, child);
                        stack.push(child, t);
                    }
                    current = order[0].1;
                    continue;
                }
            }
        } else {
            for p in leaf_packets(current) {
                let (t, lane) = hit_packet(l, r, &packets[p], t_best);
                // (Selects rather than a branch: whether a packet is hit is unpredictable.)
                let nearer = t < t_best;
                triangle = if nearer { packets[p].ids[lane] } else { triangle };
                t_best = if nearer { t } else { t_best };
            }
        }
        // Next: the nearest pending child that may still hold a nearer hit.
        loop {
            match stack.pop() {
                None => return (triangle != u32::MAX).then_some(Hit { t: t_best, triangle }),
                Some((child, t)) if t <= t_best * BOX_EXIT_WIDEN => {
                    current = child;
                    break;
                }
                Some(_) => {}
            }
        }
    }
}

/// Any hit: children in slot order, done at the first triangle hit.
#[inline(always)]
pub(super) fn any<L: Lanes, N: WideNode<L>>(l: L, nodes: &[N], packets: &[Packet], r: &TravRay<L>, t_max: f32) -> bool {
    let mut stack = Stack::new();
    let mut current = 0u32;
    loop {
        if current & LEAF == 0 {
            let node = &nodes[current as usize];
            let (mut mask, _) = node.hit_children(l, r, t_max);
            if mask != 0 {
                let first = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                while mask != 0 {
                    let slot = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    stack.push(node.child(slot), 0.0);
                }
                current = node.child(first);
                continue;
            }
        } else if leaf_packets(current).any(|p| hit_packet(l, r, &packets[p], t_max).0 < t_max) {
            return true;
        }
        match stack.pop() {
            None => return false,
            Some((child, _)) => current = child,
        }
    }
}

/// The prepared ray's box-test values (origin, 1/dir, near and far planes per axis, t_min), for
/// the compressed nodes' box test (`traverse_quantized.rs`).
impl<L: Lanes> TravRay<L> {
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    pub(super) fn box_values(&self) -> (&[L::F; 3], &[L::F; 3], [usize; 3], [usize; 3], L::F) {
        (&self.org, &self.inv, self.near, self.far, self.t_min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Past its fixed array the stack spills to the heap and still pops last in, first out.
    #[test]
    fn stack_spills_past_its_array_and_keeps_its_order() {
        let mut s = Stack::new();
        let n = 3 * STACK as u32 + 5;
        for i in 0..n {
            s.push(i, i as f32 * 0.5);
        }
        assert_eq!(s.spill.len(), n as usize - STACK);
        for i in (0..n).rev() {
            assert_eq!(s.pop(), Some((i, i as f32 * 0.5)));
        }
        assert_eq!(s.pop(), None);
    }
}
