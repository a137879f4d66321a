//! What emits light, and how a particle leaves it. A closed family, dispatched as an enum:
//!
//! - `Lambert`: a one-sided triangle of uniform radiance (the scene's rectangle and surface
//!   lights); flux per channel, W.
//! - `Point`: a luminaire small against the distances it lights, with a tabulated intensity
//!   distribution (IES LM-63) in its own frame; per channel, W/sr = table value × `scale`.
//! - `Sky`: a window triangle through which a sky shines into the room: the radiance arriving
//!   in world travel direction ω is `radiance(ω) × scale` (transmittance already included), on
//!   the side of the triangle's normal. Directions leave cosine-weighted about the normal and are
//!   weighted by π · area · radiance, so the flux is exact in expectation.
//! - `Sun`: the same window lit by a collimated beam of normal irradiance `irradiance` (W/m²
//!   per channel) travelling along `direction`; it carries area · irradiance · cos.
//!
//! Every particle's flux is value / density divided by the particle count and the probability
//! of choosing its source (sources are chosen in proportion to their flux).

use std::f64::consts::PI;
use std::sync::Arc;

use glam::DVec3;

use crate::error::CoreError;
use crate::light::table::DirectionTable;
use crate::rng::Stream;
use crate::sampling::{cosine_hemisphere, triangle_point, Frame};

#[derive(Clone, Debug)]
pub enum LightSource {
    Lambert { corners: [DVec3; 3], flux: [f64; 3] },
    Point { position: DVec3, frame: Frame, intensity: Arc<DirectionTable>, scale: [f64; 3] },
    Sky { corners: [DVec3; 3], radiance: Arc<DirectionTable>, scale: [f64; 3] },
    Sun { corners: [DVec3; 3], direction: DVec3, irradiance: [f64; 3] },
}

/// Where a particle starts, where it goes and what it carries (W per channel, before the share
/// of the particle count and of the source choice).
pub struct Emission {
    pub origin: DVec3,
    pub direction: DVec3,
    pub flux: [f64; 3],
}

fn area_normal(c: &[DVec3; 3]) -> (f64, DVec3) {
    let n = (c[1] - c[0]).cross(c[2] - c[0]);
    (0.5 * n.length(), n.normalize_or_zero())
}

impl LightSource {
    /// The flux this source sends out, per channel (W): exact for Lambert and Sun, the
    /// table's sub-cell estimate for Point, a quadrature for Sky. It only decides how often a
    /// source is chosen, never what its particles carry.
    pub fn flux(&self) -> [f64; 3] {
        match self {
            LightSource::Lambert { flux, .. } => *flux,
            LightSource::Point { intensity, scale, .. } => scale.map(|s| s * intensity.integral()),
            LightSource::Sky { corners, radiance, scale } => {
                // ∫ L cos dω over the hemisphere by a 32 × 64 midpoint rule in (cos² θ, φ),
                // in which cos θ dω is uniform.
                let (area, n) = area_normal(corners);
                let frame = Frame::from_normal(n);
                let (m, k) = (32, 64);
                let mut sum = 0.0;
                for a in 0..m {
                    for b in 0..k {
                        let d = cosine_hemisphere(&frame, (a as f64 + 0.5) / m as f64, (b as f64 + 0.5) / k as f64);
                        sum += world_value(radiance, d);
                    }
                }
                scale.map(|s| s * area * PI * sum / (m * k) as f64)
            }
            LightSource::Sun { corners, direction, irradiance } => {
                let (area, n) = area_normal(corners);
                let cos = direction.dot(n).max(0.0);
                irradiance.map(|e| e * area * cos)
            }
        }
    }

    /// Checks what a caller handed in (unit vectors, finite non-negative numbers).
    pub fn validate(&self, index: usize) -> Result<(), CoreError> {
        let what = || format!("light source {index}");
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite() && *x >= 0.0);
        let triangle_ok = |c: &[DVec3; 3]| c.iter().all(|p| p.is_finite()) && area_normal(c).0 > 0.0;
        let ok = match self {
            LightSource::Lambert { corners, flux } => triangle_ok(corners) && finite(flux),
            LightSource::Point { position, frame, scale, .. } => {
                let unit = |v: DVec3| (v.length() - 1.0).abs() < 1e-6;
                position.is_finite() && unit(frame.t) && unit(frame.b) && unit(frame.n)
                    && frame.t.dot(frame.b).abs() < 1e-6 && frame.t.dot(frame.n).abs() < 1e-6 && frame.b.dot(frame.n).abs() < 1e-6
                    && finite(scale)
            }
            LightSource::Sky { corners, scale, .. } => triangle_ok(corners) && finite(scale),
            LightSource::Sun { corners, direction, irradiance } => {
                triangle_ok(corners) && (direction.length() - 1.0).abs() < 1e-6 && finite(irradiance)
            }
        };
        if ok { Ok(()) } else { Err(CoreError::invalid(what(), "needs a non-degenerate triangle or a finite position, unit directions (an orthonormal frame) and finite non-negative flux")) }
    }

    /// A point just off this source on the side it emits to, for deciding whether the light
    /// shines into a convex room.
    pub fn inward_point(&self, epsilon: f64) -> DVec3 {
        match self {
            LightSource::Point { position, .. } => *position,
            LightSource::Lambert { corners, .. } | LightSource::Sky { corners, .. } | LightSource::Sun { corners, .. } => {
                let (_, n) = area_normal(corners);
                (corners[0] + corners[1] + corners[2]) / 3.0 + n * epsilon
            }
        }
    }

    /// The corners of an emitting triangle (none for a point).
    pub fn corners(&self) -> Option<&[DVec3; 3]> {
        match self {
            LightSource::Point { .. } => None,
            LightSource::Lambert { corners, .. } | LightSource::Sky { corners, .. } | LightSource::Sun { corners, .. } => Some(corners),
        }
    }

    /// Emits one particle: a start point (moved `epsilon` off an emitting triangle), a unit
    /// direction and the flux it carries as value / density.
    pub fn emit(&self, rng: &mut Stream, epsilon: f64) -> Emission {
        match self {
            LightSource::Lambert { corners: [a, b, c], flux } => {
                let (_, n) = area_normal(&[*a, *b, *c]);
                let origin = triangle_point(*a, *b, *c, rng.uniform(), rng.uniform()) + n * epsilon;
                let direction = cosine_hemisphere(&Frame::from_normal(n), rng.uniform(), rng.uniform());
                Emission { origin, direction, flux: *flux }
            }
            LightSource::Point { position, frame, intensity, scale } => {
                let (local, weight) = intensity.sample(rng.uniform(), rng.uniform(), rng.uniform());
                Emission { origin: *position, direction: frame.to_world(local).normalize(), flux: scale.map(|s| s * weight) }
            }
            LightSource::Sky { corners: [a, b, c], radiance, scale } => {
                let (area, n) = area_normal(&[*a, *b, *c]);
                let origin = triangle_point(*a, *b, *c, rng.uniform(), rng.uniform()) + n * epsilon;
                let direction = cosine_hemisphere(&Frame::from_normal(n), rng.uniform(), rng.uniform());
                // L cos dA dω / (cos/π · 1/A) = π A L.
                let l = world_value(radiance, direction);
                Emission { origin, direction, flux: scale.map(|s| s * PI * area * l) }
            }
            LightSource::Sun { corners: [a, b, c], direction, irradiance } => {
                let (area, n) = area_normal(&[*a, *b, *c]);
                let origin = triangle_point(*a, *b, *c, rng.uniform(), rng.uniform()) + n * epsilon;
                let cos = direction.dot(n).max(0.0);
                Emission { origin, direction: *direction, flux: irradiance.map(|e| e * area * cos) }
            }
        }
    }
}

/// A world-frame table's value in world direction d (θ from +z, φ from +x counter-clockwise).
fn world_value(table: &DirectionTable, d: DVec3) -> f64 {
    table.value_local(d)
}
