//! Level of detail: sound ignores detail that is small against its wavelength.
//!
//! A finite panel reflects specularly only at frequencies where it covers the reflection's
//! Fresnel zone. Rindel's model ("Attenuation of sound reflections due to diffraction", Nordic
//! Acoustical Meeting 1986; as implemented in ODEON and documented for Arup's Strutt
//! "Reflection from a finite-sized surface") gives, for a panel with sides a and b, the energy
//! share of the specular reflection
//!
//!   K = K_a · K_b,   K_a = min(1, f / f_a),   f_a = c d* / (2 (a cos θ_a)²),
//!
//! with d* = d₁ d₂ / (d₁ + d₂) (d₁, d₂ the path lengths before and after the reflection) and θ_a
//! the angle of incidence seen in the plane that holds the normal and side a; the same for b.
//! Above both cut-offs nothing changes; between them the reflection falls by 3 dB an octave;
//! below both by 6 dB an octave. A large wall keeps K = 1 down to the lowest band, a 20 cm box
//! face reflects specularly only in the high bands, and grazing incidence (cos θ → 0) raises the
//! cut-off, as a thin strip seen edge-on stops reflecting.
//!
//! The energy that does not reflect specularly is not lost: it is scattered. For the particles
//! this is a scattering coefficient that grows as the panel shrinks against the wavelength,
//! s' = 1 − (1 − s) K ([`effective_scattering`]), so the model conserves energy and, per band,
//! turns small furniture into diffusers while light keeps the full mesh.

use glam::DVec3;

use super::planes::Panel;

/// Rindel's specular share K of one reflection on `panel` at `freq_hz`, for a path arriving
/// along the unit `incident` direction (towards the panel), `d1_m` from the (image) source and
/// `d2_m` on to the receiver.
pub fn specular_share(panel: &Panel, normal: DVec3, incident: DVec3, d1_m: f64, d2_m: f64, freq_hz: f64, speed_of_sound_m_s: f64) -> f64 {
    let d_star = d1_m * d2_m / (d1_m + d2_m);
    let axis_b = normal.cross(panel.axis_a);
    let along_n = incident.dot(normal).abs();
    let side = |size_m: f64, axis: DVec3| -> f64 {
        if !(size_m > 0.0) {
            return 0.0;
        }
        // cos θ in the plane of the normal and this side.
        let along = incident.dot(axis);
        let cos = along_n / (along_n * along_n + along * along).sqrt().max(1e-300);
        let cutoff_hz = speed_of_sound_m_s * d_star / (2.0 * (size_m * cos).powi(2));
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
        // 0.2 m face, d* = 2.5 m, near-normal incidence: f_a ≈ 343·2.5/(2·0.04·cos²) ≈ 11.5 kHz.
        let k125 = specular_share(&face, n, inc, 5.0, 5.0, 125.0, 343.0);
        let k4k = specular_share(&face, n, inc, 5.0, 5.0, 4000.0, 343.0);
        assert!(k125 < 1e-3 && k4k > 0.1 && k4k < 1.0, "{k125} {k4k}");
    }

    #[test]
    fn slopes_are_six_then_three_then_zero_db_per_octave() {
        // a = 4 m, b = 1 m at normal incidence, d* = 2 m: f_a = 21.4 Hz, f_b = 343 Hz.
        let p = panel(4.0, 1.0);
        let k = |f: f64| specular_share(&p, DVec3::Z, -DVec3::Z, 4.0, 4.0, f, 343.0);
        let db = |f: f64| 10.0 * (k(2.0 * f) / k(f)).log10();
        assert!((db(5.0) - 20.0 * 2f64.log10()).abs() < 1e-9); // below both cut-offs: 6 dB
        assert!((db(60.0) - 10.0 * 2f64.log10()).abs() < 1e-9); // between them: 3 dB
        assert!(db(1000.0).abs() < 1e-12); // above both
        assert!((k(343.0) - 1.0).abs() < 1e-12);
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
