//! What a source gives the tracer: each ray's first direction and share of the source's
//! energy, and the energy of one count of the field (the fixed-point quantum every deposit is
//! rounded to).

use std::f64::consts::PI;

use glam::DVec3;

use super::{Directivity, SoundSource};
use crate::rng::Stream;
use crate::sampling::{uniform_cone, uniform_sphere, Frame};

/// The energy of one count of the field: small enough that a single ray's deposits keep their
/// precision (stochastic rounding keeps even smaller ones exact in expectation), large enough
/// that no bin can overflow: a bin's total never exceeds the total emitted energy times 16× the
/// largest geometric weight of a deposit, 4 · 3 / (4π r²).
pub(crate) fn quantum(sources: &[SoundSource], radius: f64, receiver_peak: f64) -> f64 {
    // A ray or a direct deposit carries at most `peak` times its even share (directivity),
    // and a receiver's pattern multiplies it by at most `receiver_peak` (≥ 1).
    let total: f64 = sources.iter().map(|s| s.power_w * s.directivity.peak()).sum::<f64>() * receiver_peak;
    let largest_weight = 4.0 * 3.0 / (4.0 * PI * radius * radius);
    total * largest_weight * 16.0 / 2f64.powi(63)
}

/// The first direction of ray `index`, and the ray's share of the source's energy; `weights`
/// receives the ray's energy per band relative to that share: 1 for the uniform emitters, the
/// importance weight g_b / (4π p) for a tabulated pattern (mean 1 in every band).
pub(super) fn emit(source: &SoundSource, rays: u64, rng: &mut Stream, weights: &mut [f64]) -> (DVec3, f64) {
    let dir = match &source.directivity {
        Directivity::Omni => {
            weights.fill(1.0);
            uniform_sphere(rng.uniform(), rng.uniform())
        }
        Directivity::Cone { axis, cos_half_angle } => {
            weights.fill(1.0);
            uniform_cone(&Frame::from_normal(*axis), *cos_half_angle, rng.uniform(), rng.uniform())
        }
        Directivity::Pattern(p) => p.sample(rng.uniform(), rng.uniform(), rng.uniform(), weights),
    };
    (dir, source.power_w / rays as f64)
}

