//! Rays, boxes and the watertight ray–triangle test.
//!
//! The triangle test is the one of Woop, Benthin and Wald, "Watertight Ray/Triangle
//! Intersection" (JCGT 2013): the ray is sheared into its own frame so that the edge functions
//! of two triangles that share an edge are computed from the same numbers, with opposite signs.
//! A ray through a shared edge or vertex therefore hits at least one of the triangles: sound
//! and light cannot leak through the seams of a closed mesh.

use glam::{Vec3, Vec3A};

/// A ray with the values that every triangle test of it needs, computed once.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    /// 1 / dir per axis, for the box test; a zero component gives ±1e30 rather than ±inf so that
    /// a ray lying in a slab plane computes 0 · 1e30 = 0 (inside) instead of 0 · inf = NaN.
    pub inv_dir: Vec3,
    // Shear frame of the watertight test: kz is the axis of the largest |dir| component.
    pub(crate) kx: usize,
    pub(crate) ky: usize,
    pub(crate) kz: usize,
    pub(crate) sx: f32,
    pub(crate) sy: f32,
    pub(crate) sz: f32,
}

impl Ray {
    /// A ray from `origin` along `dir` (need not be unit length; `t` is in units of `dir`).
    ///
    /// Written without branches: the axes depend on the direction, which is random in the
    /// tracers, so branches on it would be mispredicted about half the time (each query of a
    /// sound ray's next surface starts here, on the critical path of the ray's bounces).
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        let a = dir.abs().to_array();
        let d = dir.to_array();
        // kz: the axis of the largest |component|, the first one on ties (x, then y).
        let x_largest = (a[0] >= a[1]) & (a[0] >= a[2]);
        let kz = (!x_largest as usize) * (1 + !(a[1] >= a[2]) as usize);
        // Keep the winding of the sheared triangle independent of the ray's sign: swap kx and ky
        // when the ray runs down kz.
        let (next, after) = ((kz + 1) % 3, (kz + 2) % 3);
        let swap = (pick(d, kz) < 0.0) as usize;
        let (kx, ky) = (next ^ ((next ^ after) * swap), after ^ ((next ^ after) * swap));
        // The three reciprocals in one SIMD division; 1/d[kz] is among them (d[kz], the largest
        // |component|, is zero only for a zero direction, which no query asks about).
        let safe = Vec3::select(dir.cmpeq(Vec3::ZERO), Vec3::splat(1e-30).copysign(dir), dir);
        let inv_dir = Vec3::from(Vec3A::ONE / Vec3A::from(safe));
        let sz = pick(inv_dir.to_array(), kz);
        Ray {
            origin,
            dir,
            inv_dir,
            kx,
            ky,
            kz,
            sx: pick(d, kx) * sz,
            sy: pick(d, ky) * sz,
            sz,
        }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// `v[k]` for k < 3, selected by bit masks: indexing by a run-time axis compiles to branches on
/// it, and the axes of a random ray are unpredictable.
#[inline(always)]
pub(crate) fn pick(v: [f32; 3], k: usize) -> f32 {
    let lane = |i: usize| v[i].to_bits() & ((k == i) as u32).wrapping_neg();
    f32::from_bits(lane(0) | lane(1) | lane(2))
}

/// The nearest hit found so far along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray in units of its direction.
    pub t: f32,
    /// Index of the triangle in the mesh (not in the BVH's order).
    pub triangle: u32,
}

/// Ray–triangle intersection, watertight. Returns `t` in (t_min, t_max) or `None`.
/// Both sides of the triangle are hit (rooms are seen from inside, obstacles from outside).
#[inline]
pub fn intersect_triangle(ray: &Ray, v0: Vec3, v1: Vec3, v2: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
    let (kx, ky, kz) = (ray.kx, ray.ky, ray.kz);
    // Vertices relative to the ray origin.
    let a = v0 - ray.origin;
    let b = v1 - ray.origin;
    let c = v2 - ray.origin;
    // Shear and scale so that the ray becomes the +z axis of a unit frame.
    let ax = a[kx] - ray.sx * a[kz];
    let ay = a[ky] - ray.sy * a[kz];
    let bx = b[kx] - ray.sx * b[kz];
    let by = b[ky] - ray.sy * b[kz];
    let cx = c[kx] - ray.sx * c[kz];
    let cy = c[ky] - ray.sy * c[kz];
    // Scaled barycentric coordinates (2D edge functions).
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    // On an edge in single precision: decide it in double precision, as the paper advises.
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) =
            (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    // Scaled hit distance, compared without dividing.
    let az = ray.sz * a[kz];
    let bz = ray.sz * b[kz];
    let cz = ray.sz * c[kz];
    let t_scaled = u * az + v * bz + w * cz;
    let t = t_scaled / det;
    if t > t_min && t < t_max {
        Some(t)
    } else {
        None
    }
}

/// 1 + 2γ(3), γ(n) = nε/(1 − nε) with ε half the f32 machine epsilon: the factor by which a
/// slab test widens its exit distance to cover its own rounding (Ize, "Robust BVH Ray
/// Traversal", JCGT 2013). `Aabb::hit` and the BVH's 8-wide box test both use it.
pub(crate) const BOX_EXIT_WIDEN: f32 = 1.0 + 2.0 * 3.0 * f32::EPSILON * 0.5 / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Aabb {
        Aabb::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    #[inline]
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    #[inline]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Half the surface area: the SAH only needs ratios.
    #[inline]
    pub fn half_area(&self) -> f32 {
        let e = self.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// Slab test; returns the entry distance if the ray meets the box within (t_min, t_max).
    /// The exit distance is widened by 2γ(3) (Ize, "Robust BVH Ray Traversal", JCGT 2013) so
    /// that rounding never culls a box that the watertight triangle test would hit.
    #[inline]
    pub fn hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        let t0 = (self.min - ray.origin) * ray.inv_dir;
        let t1 = (self.max - ray.origin) * ray.inv_dir;
        let near = t0.min(t1);
        let far = t0.max(t1);
        let enter = near.x.max(near.y).max(near.z).max(t_min);
        let exit = (far.x.min(far.y).min(far.z) * BOX_EXIT_WIDEN).min(t_max);
        if enter <= exit {
            Some(enter)
        } else {
            None
        }
    }
}

/// Points this close to 0 in a coordinate are offset by a fixed distance in it, not in ulps
/// (Wächter and Binder 2019, `origin()`): near 0 the ulps of f32 are too fine to cover the
/// absolute rounding error of a hit point.
const OFFSET_NEAR_ZERO: f32 = 1.0 / 32.0;
/// The fixed distance (times the normal's component) used there (`float_scale()`).
const OFFSET_FIXED: f32 = 1.0 / 65536.0;
/// Elsewhere the offset in ulps of the coordinate (times the normal's component: `int_scale()`).
const OFFSET_ULPS: f32 = 256.0;

/// The origin of a ray that leaves a surface at `point` on the side `normal` (unit) faces: the
/// point rounded to f32 (the BVH's precision) and moved off the surface by a number of ulps of
/// each coordinate proportional to the normal's component, so that the new ray cannot hit the
/// surface it leaves at t ≈ 0. Wächter and Binder, "A Fast and Robust Method for Avoiding
/// Self-Intersection", *Ray Tracing Gems* ch. 6 (2019), `offset_ray`, with their constants: the
/// offset scales with the coordinates' own rounding error, where a fixed fraction of the
/// scene's size (what the tracers did before) is too large for thin parts of large scenes and
/// lost in the rounding far from the origin. It assumes `point` lies on the surface to within a
/// few ulps (the paper computes it from barycentrics; the sound tracer puts it back on the
/// triangle's plane in f64).
///
/// One addition of ours: each coordinate is rounded to the f32 strictly on the side of
/// `towards` (a point the ray came from, in the air), not to the nearest. The normal offset
/// moves only the coordinates the normal has; rounded to the nearest, a hit a fraction of an
/// ulp from a neighbouring wall (a corner, an edge) could land on that wall's plane, and a ray
/// that starts on a plane and leaves through it is not stopped by it (t = 0 is not a hit).
/// Written without branches (every condition is a 0/1 integer or a select): which way a
/// coordinate rounds is a coin toss, and this is on the path from one query to the next.
#[inline(always)]
pub fn offset_origin(point: glam::DVec3, normal: glam::DVec3, towards: glam::DVec3) -> glam::DVec3 {
    #[cfg(target_arch = "x86_64")]
    {
        use pulp::core_arch::x86::{Sse, Sse2};
        // SSE and SSE2 are part of every x86-64 CPU: these checks are constants.
        if let (Some(sse), Some(sse2)) = (Sse::try_new(), Sse2::try_new()) {
            return offset_origin_sse2(sse, sse2, point, normal, towards);
        }
    }
    offset_origin_lane_by_lane(point, normal, towards)
}

/// [`offset_origin_lane_by_lane`] with the three coordinates in the lanes of SSE2 registers
/// (through `pulp`'s safe wrappers of the intrinsics): the same IEEE operations lane by lane,
/// so the same bits (tested), in about a third of the instructions. It sits on the chain from
/// one BVH query of a ray to the next; Wächter and Binder's own form works on vectors too
/// (*Ray Tracing Gems* ch. 6, listing 6-1). The one difference: a normal component that is NaN
/// or beyond ±2²³ gives other ulps (the scalar cast saturates, SSE2's gives i32::MIN); unit
/// normals never do.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn offset_origin_sse2(sse: pulp::core_arch::x86::Sse, sse2: pulp::core_arch::x86::Sse2, point: glam::DVec3, normal: glam::DVec3, towards: glam::DVec3) -> glam::DVec3 {
    use std::arch::x86_64::__m128d;
    // f64 pairs (x, y) and (z, 0); f32 lanes (x, y, z, 0).
    let (x01, x2) = (sse2._mm_set_pd(point.y, point.x), sse2._mm_set_sd(point.z));
    let (t01, t2) = (sse2._mm_set_pd(towards.y, towards.x), sse2._mm_set_sd(towards.z));
    let p = sse._mm_movelh_ps(sse2._mm_cvtpd_ps(x01), sse2._mm_cvtpd_ps(x2));
    let n = sse._mm_movelh_ps(sse2._mm_cvtpd_ps(sse2._mm_set_pd(normal.y, normal.x)), sse2._mm_cvtpd_ps(sse2._mm_set_sd(normal.z)));
    let (back01, back2) = (sse2._mm_cvtps_pd(p), sse2._mm_cvtps_pd(sse._mm_movehl_ps(p, p)));
    // The rounding's step toward `towards`, per f64 pair, then packed to the four i32 lanes
    // (each 64-bit mask is all ones or zeros, so either half of it will do).
    let up01 = sse2._mm_and_pd(sse2._mm_cmpgt_pd(t01, x01), sse2._mm_cmple_pd(back01, x01));
    let up2 = sse2._mm_and_pd(sse2._mm_cmpgt_pd(t2, x2), sse2._mm_cmple_pd(back2, x2));
    let down01 = sse2._mm_and_pd(sse2._mm_cmplt_pd(t01, x01), sse2._mm_cmpge_pd(back01, x01));
    let down2 = sse2._mm_and_pd(sse2._mm_cmplt_pd(t2, x2), sse2._mm_cmpge_pd(back2, x2));
    let pack = |a: __m128d, b: __m128d| sse2._mm_castps_si128(sse._mm_shuffle_ps::<0b10_00_10_00>(sse2._mm_castpd_ps(a), sse2._mm_castpd_ps(b)));
    let step = sse2._mm_sub_epi32(pack(down01, down2), pack(up01, up2)); // masks are −1: up +1, down −1
    let ulps = sse2._mm_add_epi32(sse2._mm_cvttps_epi32(sse._mm_mul_ps(sse._mm_set1_ps(OFFSET_ULPS), n)), step);
    // Adding to the bits moves away from 0: a negative coordinate takes the opposite count.
    let bits = sse2._mm_castps_si128(p);
    let sign = sse2._mm_srai_epi32::<31>(bits);
    let by_ulps = sse2._mm_castsi128_ps(sse2._mm_add_epi32(bits, sse2._mm_sub_epi32(sse2._mm_xor_si128(ulps, sign), sign)));
    let fixed = sse._mm_add_ps(p, sse._mm_mul_ps(sse._mm_set1_ps(OFFSET_FIXED), n));
    let near_zero = sse._mm_cmplt_ps(sse._mm_andnot_ps(sse._mm_set1_ps(-0.0), p), sse._mm_set1_ps(OFFSET_NEAR_ZERO));
    let out = sse._mm_or_ps(sse._mm_and_ps(near_zero, fixed), sse._mm_andnot_ps(near_zero, by_ulps));
    let (o01, o2) = (sse2._mm_cvtps_pd(out), sse2._mm_cvtps_pd(sse._mm_movehl_ps(out, out)));
    glam::DVec3::new(sse2._mm_cvtsd_f64(o01), sse2._mm_cvtsd_f64(sse2._mm_unpackhi_pd(o01, o01)), sse2._mm_cvtsd_f64(o2))
}

/// [`offset_origin`] one coordinate at a time: its definition, the path of CPUs other than
/// x86-64, and what the SSE2 form is tested against.
#[inline]
pub fn offset_origin_lane_by_lane(point: glam::DVec3, normal: glam::DVec3, towards: glam::DVec3) -> glam::DVec3 {
    let n = normal.as_vec3().to_array();
    glam::DVec3::from_array(std::array::from_fn(|i| {
        let (x, to) = (point[i], towards[i]);
        let p = x as f32;
        let back = f64::from(p);
        // Ulps toward +∞: one when `towards` is above x and p is not, minus one when below,
        // plus the normal's 256 × n.
        let step = ((to > x) & (back <= x)) as i32 - ((to < x) & (back >= x)) as i32;
        let ulps = (OFFSET_ULPS * n[i]) as i32 + step;
        // Adding to the bits moves away from 0: a negative coordinate takes the opposite count.
        let sign = (p.to_bits() as i32) >> 31; // 0, or −1 when negative
        let by_ulps = f32::from_bits((p.to_bits() as i32).wrapping_add((ulps ^ sign) - sign) as u32);
        let fixed = p + OFFSET_FIXED * n[i];
        let near_zero = ((p.abs() < OFFSET_NEAR_ZERO) as u32).wrapping_neg(); // all ones or 0
        f64::from(f32::from_bits((fixed.to_bits() & near_zero) | (by_ulps.to_bits() & !near_zero)))
    }))
}

/// Twice the area vector of a triangle: its direction is the normal (v1 − v0) × (v2 − v0).
#[inline]
pub fn triangle_cross(v0: Vec3, v1: Vec3, v2: Vec3) -> Vec3 {
    (v1 - v0).cross(v2 - v0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The offset of Wächter and Binder 2019: 256 ulps times the normal's component away from 0
    /// along the normal, a fixed 2⁻¹⁶ times it within 1/32 of 0, and always to the normal's side.
    #[test]
    fn offset_origin_moves_by_ulps_to_the_normals_side() {
        use glam::DVec3;
        let ulp = |x: f32| f32::from_bits(x.to_bits() + 1) - x;
        // A wall at x = 10 facing −x, one at y = −3 facing +y, the floor z = 0 facing +z.
        let o = offset_origin(DVec3::new(10.0, -3.0, 0.0), DVec3::new(-1.0, 0.0, 0.0), DVec3::new(10.0, -3.0, 0.0));
        assert_eq!(o.x as f32, 10.0 - 256.0 * ulp(9.99999)); // below 10: the ulp of [8, 16)
        assert_eq!((o.y, o.z), (-3.0, 0.0));
        let o = offset_origin(DVec3::new(10.0, -3.0, 0.0), DVec3::new(0.0, 1.0, 0.0), DVec3::new(10.0, -3.0, 0.0));
        assert_eq!(o.y as f32, -3.0 + 256.0 * ulp(2.0));
        let o = offset_origin(DVec3::new(10.0, -3.0, 0.0), DVec3::new(0.0, 0.0, 1.0), DVec3::new(10.0, -3.0, 0.0));
        assert_eq!(o.z as f32, 1.0 / 65536.0);
        // Tilted normals: every coordinate moves to the normal's side (or stays when the
        // component is below 1/256), and the point moves off the plane through it.
        for (p, n) in [([0.5, 7.0, -40.0], [0.6, -0.8, 0.0]), ([-0.01, 0.2, 3.0], [-0.48, 0.6, 0.64])] {
            let (p, n) = (DVec3::from_array(p), DVec3::from_array(n));
            let o = offset_origin(p, n, p + n);
            for i in 0..3 {
                assert!((o[i] - p[i]) * n[i] >= 0.0 && (n[i].abs() < 1.0 / 256.0 || o[i] != p[i]), "{p} {n} → {o}");
            }
            assert!(n.dot(o - p) > 0.0);
        }
        // A point a tenth of an ulp inside a wall x = 6010 (on the floor, near the corner)
        // rounds to the f32 on the side it came from, not onto the wall's plane.
        let p = DVec3::new(6010.0 - 0.1 * f64::from(ulp(6009.0)), 2.0, 0.0);
        let o = offset_origin(p, DVec3::Z, DVec3::new(6005.0, 2.0, 1.0));
        assert!(o.x < 6010.0 && o.x > 6009.99 && o.z > 0.0, "{o}");
    }

    /// The offset in lanes gives the bits of the lane-by-lane one: random points near 0, near the
    /// f32 rounding of their coordinates and far out, unit normals with small and zero
    /// components, and `towards` on either side of each coordinate.
    #[test]
    fn offset_origin_in_lanes_is_the_lane_by_lane_offset() {
        use glam::DVec3;
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for k in 0..200_000 {
            let scale = [0.01, 0.05, 1.0, 12.0, 6000.0][k % 5];
            let mut p = DVec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5) * 2.0 * scale;
            if k % 7 == 0 {
                p.x = f64::from(p.x as f32); // exactly on an f32
            }
            let mut n = DVec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5);
            if k % 3 == 0 {
                n.z = 0.0;
            }
            let n = n.normalize();
            let towards = p + DVec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5) * 1e-6 * scale;
            let (a, b) = (offset_origin_lane_by_lane(p, n, towards), offset_origin(p, n, towards));
            assert_eq!(a.to_array().map(f64::to_bits), b.to_array().map(f64::to_bits), "{p} {n} {towards}");
        }
    }

    #[test]
    fn hits_the_middle_of_a_triangle_at_the_right_distance() {
        let ray = Ray::new(Vec3::new(0.2, 0.2, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let t = intersect_triangle(&ray, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0, f32::INFINITY);
        assert!((t.unwrap() - 5.0).abs() < 1e-6);
    }

    #[test]
    fn misses_outside_and_behind() {
        let ray = Ray::new(Vec3::new(0.8, 0.8, 5.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(intersect_triangle(&ray, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0, f32::INFINITY), None);
        let ray = Ray::new(Vec3::new(0.2, 0.2, 5.0), Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(intersect_triangle(&ray, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0, f32::INFINITY), None);
    }

    #[test]
    fn box_hit_with_axis_parallel_ray_on_the_slab_plane() {
        let b = Aabb { min: Vec3::ZERO, max: Vec3::ONE };
        let ray = Ray::new(Vec3::new(0.0, 0.5, -1.0), Vec3::Z);
        assert!(b.hit(&ray, 0.0, f32::INFINITY).is_some());
    }
}
