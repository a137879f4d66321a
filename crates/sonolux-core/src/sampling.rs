//! Samplers: directions for emitting and bouncing rays, and points on emitting surfaces.
//! Each maps two uniform numbers in [0, 1) to a sample and states the density it draws from;
//! the tests check each against that density with a chi-square test.

use std::f64::consts::PI;

use glam::DVec3;

/// An orthonormal frame (t, b, n) around a unit normal n (Duff et al., JCGT 2017, branch-free).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: DVec3,
    pub b: DVec3,
    pub n: DVec3,
}

impl Frame {
    pub fn from_normal(n: DVec3) -> Frame {
        let sign = 1.0f64.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Frame {
            t: DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            b: DVec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    /// Local (x, y, z) to world.
    #[inline]
    pub fn to_world(&self, v: DVec3) -> DVec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// Uniform over the unit sphere; density 1 / (4π).
#[inline]
pub fn uniform_sphere(u1: f64, u2: f64) -> DVec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform over the cone of half-angle acos(cos_max) around the frame's normal;
/// density 1 / (2π (1 − cos_max)).
#[inline]
pub fn uniform_cone(frame: &Frame, cos_max: f64, u1: f64, u2: f64) -> DVec3 {
    let z = 1.0 - u1 * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    frame.to_world(DVec3::new(r * phi.cos(), r * phi.sin(), z))
}

/// Cosine-weighted over the hemisphere of the frame's normal (Lambert); density cos θ / π.
#[inline]
pub fn cosine_hemisphere(frame: &Frame, u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let z = (1.0 - u1).max(0.0).sqrt();
    frame.to_world(DVec3::new(r * phi.cos(), r * phi.sin(), z))
}

/// Uniform over the area of triangle (a, b, c); density 1 / area.
#[inline]
pub fn triangle_point(a: DVec3, b: DVec3, c: DVec3, u1: f64, u2: f64) -> DVec3 {
    let s = u1.sqrt();
    let (wa, wb) = (1.0 - s, u2 * s);
    a * wa + b * wb + c * (1.0 - wa - wb)
}

/// Chooses an index with probability proportional to its weight (e.g. a triangle by its area,
/// a light by its power), by binary search in the cumulative sums.
#[derive(Clone, Debug)]
pub struct Discrete {
    cdf: Vec<f64>,
}

impl Discrete {
    /// None when there is no positive weight (or a weight is negative or not finite).
    pub fn new(weights: &[f64]) -> Option<Discrete> {
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return None;
        }
        let mut acc = 0.0;
        let mut cdf: Vec<f64> = weights.iter().map(|w| { acc += w; acc }).collect();
        if acc <= 0.0 {
            return None;
        }
        cdf.iter_mut().for_each(|c| *c /= acc);
        Some(Discrete { cdf })
    }

    pub fn probability(&self, i: usize) -> f64 {
        self.cdf[i] - if i == 0 { 0.0 } else { self.cdf[i - 1] }
    }

    #[inline]
    pub fn sample(&self, u: f64) -> usize {
        let i = self.cdf.partition_point(|&c| c <= u);
        // u < 1 always; rounding in the sums may leave the last entry just below it.
        i.min(self.cdf.len() - 1)
    }
}

#[cfg(test)]
mod tests;
