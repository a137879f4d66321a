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
/// convex room's hits are computed in f64 on its planes already.
#[inline(always)]
pub(super) fn on_surface(scene: &Scene, point: DVec3, normal: DVec3, tri: usize) -> DVec3 {
    if scene.surfaces.traces_planes() {
        return point;
    }
    let corner = scene.mesh.vertices[scene.mesh.triangles[tri][0] as usize].as_dvec3();
    point - normal * normal.dot(point - corner)
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
