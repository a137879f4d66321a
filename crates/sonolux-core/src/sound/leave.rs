//! Where a sound ray that reflects starts again: the hit point put back on its surface, and
//! the offset that keeps the next ray from hitting that surface at t ≈ 0 (docs/bvh.md,
//! "Leaving a surface").

use glam::DVec3;

use super::Scene;
use crate::geometry::offset_origin;

/// The hit point `point` (the ray's origin + t · direction) put back on the plane of mesh
/// triangle `tri` (unit `normal`), in f64: t comes from the BVH's f32 test, whose error grows
/// with the distance travelled, and [`offset_origin`] needs the point on its surface to within
/// a few ulps (Wächter and Binder 2019 compute it from barycentrics for the same reason). A
/// convex room's hits are computed in f64 on its planes already. The corner comes from the
/// triangle's hit record, in the cache line the hit's normal was read from (mesh.rs).
#[inline(always)]
pub(super) fn on_surface(scene: &Scene, point: DVec3, normal: DVec3, tri: usize) -> DVec3 {
    match scene.surfaces.hit_record(tri) {
        Some(r) => point - normal * normal.dot(point - r.corner.as_dvec3()),
        None => point,
    }
}

/// The material of the mesh triangle `tri` a ray hit: from its hit record on the BVH path.
#[inline(always)]
pub(super) fn material(scene: &Scene, tri: usize) -> usize {
    scene.surfaces.hit_record(tri).map_or_else(|| scene.mesh.material[tri], |r| r.material) as usize
}

/// The origin of the ray that leaves the surface at `point` (coming from `from`): the offset
/// of [`offset_origin`] for the BVH; the point itself for a convex room's planes, whose query
/// (f64) only looks at the planes ahead of the ray, so the one it leaves cannot be hit again.
#[inline(always)]
pub(super) fn leave(scene: &Scene, point: DVec3, normal: DVec3, from: DVec3) -> DVec3 {
    if scene.surfaces.traces_planes() {
        return point;
    }
    offset_origin(point, normal, from)
}
