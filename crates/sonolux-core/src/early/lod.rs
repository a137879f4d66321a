//! Level of detail: sound ignores detail that is small against its wavelength.
//!
//! A finite panel reflects specularly only at frequencies where it covers the reflection's
//! Fresnel zone. Rindel's model ("Attenuation of sound reflections due to diffraction", Nordic
//! Acoustical Meeting 1986; the reflector design rule also given by Cox and D'Antonio,
//! "Acoustic Absorbers and Diffusers") gives, for a panel with sides a and b, the energy share of
//! the specular reflection
//!
//!   K = K_a · K_b,   K_a = min(1, f / f_a),   f_a = c a* / (2 (a cos θ_a)²),
//!
//! with the characteristic distance a* = 2 d₁ d₂ / (d₁ + d₂) and θ_a the angle of incidence seen
//! in the plane that holds the normal and side a; the same for b. Above both cut-offs nothing
//! changes; between them the reflection falls by 3 dB an octave; below both by 6 dB an octave.
//! A large wall keeps K = 1 down to the lowest band, a 20 cm box face reflects specularly only in
//! the high bands, and grazing incidence (cos θ → 0) raises the cut-off.
//!
//! **Which d₁ and d₂** (reflection-based scattering, C. L. Christensen and J. H. Rindel, "A new
//! scattering method that combines roughness and diffraction effects", Forum Acusticum 2005, the
//! method of ODEON): a ray tracer does not know where the receiver is, so d₁ is the leg before
//! the reflection (from the source or the previous reflection point) and d₂ the leg after it
//! along the specular direction (to the next surface the reflected ray meets). The image sources
//! use exactly these legs too (for the last reflection of a path, the distance along the path's
//! last leg to the surface beyond the receiver), so both parts of a hybrid compute the same K
//! for the same reflection: [`LevelOfDetail::specular_shares`] is the one function both call.
//!
//! **Combined with the surface's own scattering s** as two independent causes of non-specular
//! reflection (Christensen and Rindel 2005): s' = 1 − (1 − s) K ([`effective_scattering`]). The
//! energy that diffraction takes from the specular part is scattered, not lost, so the model
//! conserves energy and, per band, turns small furniture into diffusers while light keeps the
//! full mesh.
//!
//! **Which panel**: the connected piece of the reflecting plane the reflection point lies on
//! ([`Panel`]: triangles of one plane that share corners), seen as the rectangle with its second
//! moments of area. (ODEON estimates a and b from each surface's area and outline; a piece of a
//! mesh plane is our counterpart of an ODEON surface.)
//!
//! **Only panels with a diffracting edge**: Rindel's K is the loss of a reflector at its free
//! edges. A panel bounded only by concave joins (a room's walls meeting at its corners) has no
//! such edge: for an interior wedge of open angle π/n the image sources are the exact solution
//! (no edge wave; see `edges.rs`), so such a panel keeps K = 1 at every frequency. A panel
//! touches a diffracting edge when one of its triangles is a face of a wedge of
//! [`super::edges::wedges`] (a convex edge, open angle above π, or a free edge of a sheet).

use glam::DVec3;

use super::edges::wedges;
use super::planes::{Panel, Planes};
use crate::mesh::Mesh;

/// Rindel's characteristic distance a* = 2 d₁ d₂ / (d₁ + d₂); a leg that never ends (the ray
/// leaves an open scene) gives its limit 2 d₁.
pub fn characteristic_distance_m(d1_m: f64, d2_m: f64) -> f64 {
    match (d1_m.is_finite(), d2_m.is_finite()) {
        (true, true) => 2.0 * d1_m * d2_m / (d1_m + d2_m).max(1e-300),
        (true, false) => 2.0 * d1_m,
        (false, true) => 2.0 * d2_m,
        (false, false) => f64::INFINITY,
    }
}

/// Rindel's specular share K of one reflection on `panel` at `freq_hz`, for a ray arriving
/// along the unit `incident` direction (towards the panel) after a leg of `d1_m` and leaving
/// along the specular direction for a leg of `d2_m`.
pub fn specular_share(panel: &Panel, normal: DVec3, incident: DVec3, d1_m: f64, d2_m: f64, freq_hz: f64, speed_of_sound_m_s: f64) -> f64 {
    let a_star = characteristic_distance_m(d1_m, d2_m);
    let axis_b = normal.cross(panel.axis_a);
    let along_n = incident.dot(normal).abs();
    let side = |size_m: f64, axis: DVec3| -> f64 {
        if !(size_m > 0.0) {
            return 0.0;
        }
        // cos θ in the plane of the normal and this side.
        let along = incident.dot(axis);
        let cos = along_n / (along_n * along_n + along * along).sqrt().max(1e-300);
        let cutoff_hz = speed_of_sound_m_s * a_star / (2.0 * (size_m * cos).powi(2));
        (freq_hz / cutoff_hz).min(1.0)
    };
    side(panel.size_a_m, panel.axis_a) * side(panel.size_b_m, axis_b)
}

/// The scattering coefficient of a panel once the specular share K is taken into account:
/// what the surface scatters anyway (s) plus what diffraction at its size takes from the
/// specular part, s' = 1 − (1 − s) K.
pub fn effective_scattering(scattering: f64, specular_share: f64) -> f64 {
    1.0 - (1.0 - scattering) * specular_share.clamp(0.0, 1.0)
}

/// What the particles and the image sources need to apply level of detail: the mesh's panels,
/// the bands' centre frequencies and the speed of sound. Built once a bake.
#[derive(Clone, Debug)]
pub struct LevelOfDetail {
    pub planes: Planes,
    /// Per panel: whether it touches a diffracting edge (else K = 1).
    pub diffracting: Vec<bool>,
    pub band_centres_hz: Vec<f64>,
    pub speed_of_sound_m_s: f64,
}

impl LevelOfDetail {
    /// Panels of `mesh` (coplanar within `plane_tolerance_m`, connected through shared corners).
    pub fn new(mesh: &Mesh, band_centres_hz: Vec<f64>, speed_of_sound_m_s: f64, plane_tolerance_m: f64) -> LevelOfDetail {
        LevelOfDetail::with_planes(mesh, Planes::build(mesh, plane_tolerance_m), band_centres_hz, speed_of_sound_m_s)
    }

    /// As [`LevelOfDetail::new`], with the mesh's planes already built.
    pub fn with_planes(mesh: &Mesh, planes: Planes, band_centres_hz: Vec<f64>, speed_of_sound_m_s: f64) -> LevelOfDetail {
        let mut diffracting = vec![false; planes.panels.len()];
        for w in wedges(mesh, &planes) {
            for t in w.triangles {
                if let Some(p) = planes.panel_of_triangle.get(t as usize).filter(|p| **p != u32::MAX) {
                    diffracting[*p as usize] = true;
                }
            }
        }
        LevelOfDetail { planes, diffracting, band_centres_hz, speed_of_sound_m_s }
    }

    /// Rindel's K per band for a reflection on triangle `tri`, written into `out`: the ray
    /// arrived along the unit `incident` after a leg of `d1_m` and leaves specularly for a leg of
    /// `d2_m`. A degenerate triangle (no panel) and a panel without a diffracting edge keep
    /// K = 1.
    pub fn specular_shares(&self, tri: usize, incident: DVec3, d1_m: f64, d2_m: f64, out: &mut [f64]) {
        let (plane, panel) = (self.planes.plane_of_triangle[tri], self.planes.panel_of_triangle[tri]);
        if plane == u32::MAX || panel == u32::MAX || !self.diffracting[panel as usize] {
            out.fill(1.0);
            return;
        }
        let normal = self.planes.planes[plane as usize].normal;
        let panel = &self.planes.panels[panel as usize];
        for (k, f) in out.iter_mut().zip(&self.band_centres_hz) {
            *k = specular_share(panel, normal, incident, d1_m, d2_m, *f, self.speed_of_sound_m_s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn panel(a: f64, b: f64) -> Panel {
        Panel { axis_a: DVec3::X, size_a_m: a, size_b_m: b, area_m2: a * b }
    }

    #[test]
    fn a_large_wall_reflects_fully_and_a_small_face_only_at_high_frequency() {
        let n = DVec3::Z;
        let inc = DVec3::new(0.3, 0.2, -1.0).normalize();
        let wall = panel(10.0, 4.0);
        let face = panel(0.2, 0.2);
        for f in [63.0, 125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0] {
            assert_eq!(specular_share(&wall, n, inc, 5.0, 5.0, f, 343.0), 1.0, "{f} Hz");
        }
        // 0.2 m face, a* = 5 m, near-normal incidence: f_a ≈ 343·5/(2·0.04·cos²) ≈ 23 kHz, so
        // K ≈ 0.03 at 4 kHz and ≈ 0.5 at 16 kHz.
        let k = |f: f64| specular_share(&face, n, inc, 5.0, 5.0, f, 343.0);
        assert!(k(125.0) < 1e-3 && (k(4000.0) - 0.0307).abs() < 1e-3 && (k(16000.0) - 0.49).abs() < 0.01, "{} {}", k(4000.0), k(16000.0));
    }

    #[test]
    fn slopes_are_six_then_three_then_zero_db_per_octave() {
        // a = 4 m, b = 1 m at normal incidence, a* = 2 m: f_a = 21.4 Hz, f_b = 343 Hz.
        let p = panel(4.0, 1.0);
        let k = |f: f64| specular_share(&p, DVec3::Z, -DVec3::Z, 2.0, 2.0, f, 343.0);
        let db = |f: f64| 10.0 * (k(2.0 * f) / k(f)).log10();
        assert!((db(5.0) - 20.0 * 2f64.log10()).abs() < 1e-9); // below both cut-offs: 6 dB
        assert!((db(60.0) - 10.0 * 2f64.log10()).abs() < 1e-9); // between them: 3 dB
        assert!(db(1000.0).abs() < 1e-12); // above both
        assert!((k(343.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn rindels_example_and_an_endless_leg() {
        // Rindel's rule of thumb: a 1 m panel with source and receiver 5 m away (a* = 5 m)
        // reflects fully from c a* / (2 a²) ≈ 858 Hz.
        let p = panel(1.0, 100.0);
        let k = |f: f64, d2: f64| specular_share(&p, DVec3::Z, -DVec3::Z, 5.0, d2, f, 343.0);
        assert!((k(857.5, 5.0) - 1.0).abs() < 1e-12 && (k(428.75, 5.0) - 0.5).abs() < 1e-12);
        // An endless second leg: a* → 2 d₁.
        assert_eq!(characteristic_distance_m(5.0, f64::INFINITY), 10.0);
        assert!((k(1715.0, f64::INFINITY) - 1.0).abs() < 1e-12 && k(1000.0, f64::INFINITY) < 1.0);
    }

    #[test]
    fn grazing_incidence_raises_the_cutoff_and_scattering_conserves_energy() {
        let p = panel(1.0, 1.0);
        let normal_inc = specular_share(&p, DVec3::Z, -DVec3::Z, 3.0, 3.0, 200.0, 343.0);
        let grazing = specular_share(&p, DVec3::Z, DVec3::new(1.0, 0.0, -0.2).normalize(), 3.0, 3.0, 200.0, 343.0);
        assert!(grazing < normal_inc);
        for (s, k) in [(0.0, 0.3), (0.4, 1.0), (0.2, 0.0)] {
            let s2 = effective_scattering(s, k);
            // The specular share left is (1 − s)·K; what diffraction removes goes to scattering.
            assert!(s2 >= s && (1.0 - s2 - (1.0 - s) * k).abs() < 1e-15);
        }
    }
}
