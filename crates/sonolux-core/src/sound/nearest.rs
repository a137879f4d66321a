//! How the sound kernel finds the nearest surface along a ray (sound/trace.rs): through
//! [`crate::convex::Surfaces`] (the planes of a convex room inlined, the BVH a call), or, on a
//! mesh whose BVH runs on AVX2, with the BVH's query inlined into a kernel compiled under the
//! same AVX2 token (`V3::vectorize`): no call a segment and no spilling of the kernel's live
//! values around one. The same arithmetic either way, so the same bits.

use glam::DVec3;

use super::Scene;

/// The nearest surface along a ray: distance, mesh triangle, unit normal facing the side the
/// ray comes from; None when the ray leaves the scene.
pub(super) type SurfaceHit = Option<(f64, usize, DVec3)>;

/// How the kernel finds the nearest surface: through [`crate::convex::Surfaces`]' call, or
/// with the BVH's AVX2 query inlined into a kernel compiled under its token.
pub(super) trait Nearest: Copy {
    fn nearest(self, scene: &Scene, origin: DVec3, dir: DVec3) -> SurfaceHit;
}

#[derive(Clone, Copy)]
pub(super) struct Called;

impl Nearest for Called {
    #[inline(always)]
    fn nearest(self, scene: &Scene, origin: DVec3, dir: DVec3) -> SurfaceHit {
        scene.surfaces.nearest_facing(origin, dir)
    }
}

#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(super) struct Inlined(pub(super) pulp::x86::V3);

#[cfg(target_arch = "x86_64")]
impl Nearest for Inlined {
    #[inline(always)]
    fn nearest(self, scene: &Scene, origin: DVec3, dir: DVec3) -> SurfaceHit {
        scene.surfaces.nearest_facing_avx2(self.0, origin, dir)
    }
}
