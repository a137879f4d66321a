//! Where light is stored: every triangle is cut into k × k equal sub-triangles (a regular
//! subdivision, k from its size and the patch size asked for), and each holds the flux that
//! arrives on it. Irradiance is flux / area; a diffuse patch's radiance is ρ · E / π.

use glam::DVec3;

/// The patch layout of a mesh: triangle t owns patches `offsets[t]..offsets[t + 1]`, k_t² of them.
#[derive(Clone, Debug, PartialEq)]
pub struct Patches {
    pub resolution: Vec<u32>,
    pub offsets: Vec<u64>,
    pub area: Vec<f64>,
}

impl Patches {
    /// Cuts each triangle so that patches are about `size` across: k = ⌈√(2·area) / size⌉.
    pub fn new(corners: impl Iterator<Item = [DVec3; 3]>, size: f64, max_per_edge: u32) -> Patches {
        let mut resolution = Vec::new();
        let mut offsets = vec![0u64];
        let mut area = Vec::new();
        for [a, b, c] in corners {
            let tri_area = 0.5 * (b - a).cross(c - a).length();
            let k = ((2.0 * tri_area).sqrt() / size).ceil().clamp(1.0, max_per_edge as f64) as u32;
            resolution.push(k);
            let n = (k as u64) * (k as u64);
            offsets.push(offsets.last().unwrap() + n);
            area.extend(std::iter::repeat_n(tri_area / n as f64, n as usize));
        }
        Patches { resolution, offsets, area }
    }

    pub fn len(&self) -> usize {
        self.area.len()
    }

    pub fn is_empty(&self) -> bool {
        self.area.is_empty()
    }

    /// The patch of triangle `tri` that holds the point with barycentric coordinates (s, t)
    /// along (v1 − v0, v2 − v0).
    #[inline]
    pub fn index(&self, tri: usize, s: f64, t: f64) -> usize {
        self.offsets[tri] as usize + sub_triangle(self.resolution[tri] as usize, s, t)
    }
}

/// Index of the sub-triangle holding barycentric (s, t) in a k × k regular subdivision. Row i
/// (s from i/k to (i+1)/k) holds 2(k − i) − 1 sub-triangles, alternately pointing up and down.
#[inline]
pub fn sub_triangle(k: usize, s: f64, t: f64) -> usize {
    let (fs, ft) = (s.clamp(0.0, 1.0) * k as f64, t.clamp(0.0, 1.0) * k as f64);
    let i = (fs as usize).min(k - 1);
    let j = (ft as usize).min(k - 1 - i);
    let upper = (fs - i as f64) + (ft - j as f64) > 1.0 && i + j < k - 1;
    let before = i * (2 * k - i);
    before + 2 * j + usize::from(upper)
}

/// Barycentric (s, t) of point p in triangle (a, b, c): p ≈ a + s (b − a) + t (c − a).
#[inline]
pub fn barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (f64, f64) {
    let (e1, e2, d) = (b - a, c - a, p - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = d11 * d22 - d12 * d12;
    ((d22 * d1 - d12 * d2) / det, (d11 * d2 - d12 * d1) / det)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_sub_triangle_is_reached_once_and_indices_stay_in_range() {
        for k in 1..7usize {
            let mut seen = vec![0usize; k * k];
            // Centroids of the sub-triangles of the subdivision.
            for i in 0..k {
                for j in 0..k - i {
                    let lower = ((i as f64 + 1.0 / 3.0) / k as f64, (j as f64 + 1.0 / 3.0) / k as f64);
                    seen[sub_triangle(k, lower.0, lower.1)] += 1;
                    if i + j < k - 1 {
                        let upper = ((i as f64 + 2.0 / 3.0) / k as f64, (j as f64 + 2.0 / 3.0) / k as f64);
                        seen[sub_triangle(k, upper.0, upper.1)] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "k = {k}: {seen:?}");
        }
    }

    #[test]
    fn patch_areas_add_up_to_the_triangle() {
        let tri = [DVec3::ZERO, DVec3::new(3.0, 0.0, 0.0), DVec3::new(0.0, 2.0, 0.0)];
        let p = Patches::new([tri].into_iter(), 0.5, 64);
        let k = p.resolution[0];
        assert_eq!(k, ((2.0f64 * 3.0).sqrt() / 0.5).ceil() as u32);
        assert!((p.area.iter().sum::<f64>() - 3.0).abs() < 1e-12);
    }
}
