//! The sound tracer's settings: any number of bands (31 third-octave bands included), each
//! setting checked once with an error that names it (never a panic), and the field handed out
//! in the public order [receiver][direction][band][time].

use glam::DVec3;
use sonolux_core::sound::{trace_sound, Acoustics, Directivity, Estimator, Receivers, SoundResult, SoundSettings, SoundSource};
use sonolux_core::{Bvh, CoreError, Mesh};

mod common;

fn room() -> Mesh {
    common::shoebox(5.0, 4.0, 3.0, [0, 1, 2, 2, 2, 2])
}

/// Three materials whose absorption in band b is `alpha[b % alpha.len()]` scaled per material,
/// with the same scattering in every band.
fn acoustics(bands: usize, alpha: &[f64]) -> Acoustics {
    let mut absorption = Vec::new();
    let mut scattering = Vec::new();
    for (m, scale) in [1.0, 0.5, 0.8].iter().enumerate() {
        for b in 0..bands {
            absorption.push(alpha[b % alpha.len()] * scale);
            scattering.push(0.2 + 0.2 * m as f64);
        }
    }
    Acoustics { n_bands: bands, absorption, scattering }
}

fn settings(bands: usize, air: &[f64], estimator: Estimator) -> SoundSettings {
    SoundSettings {
        rays: 3_000,
        first_ray: 0,
        first_receiver: 0,
        only_source: None,
        end_ray: 3_000,
        seed: 11,
        threads: 2,
        estimator,
        speed_of_sound_m_s: 343.0,
        air_attenuation_per_m: (0..bands).map(|b| air[b % air.len()]).collect(),
        energy_drop_db: 60.0,
        max_time_s: 0.4,
        sample_rate_hz: 8_000.0,
        early_s: 0.02,
        late_bin_s: 0.005,
        n_azimuth: 4,
        n_elevation: 1,
        max_field_bytes: 1 << 30,
    }
}

fn receivers() -> Receivers {
    Receivers::new(vec![DVec3::new(1.5, 1.0, 1.5), DVec3::new(3.5, 3.0, 1.2)], 0.4)
}

fn sources() -> Vec<SoundSource> {
    vec![SoundSource { position: DVec3::new(2.5, 2.0, 1.5), power_w: 1.0, directivity: Directivity::Omni }]
}

fn trace(ac: &Acoustics, set: &SoundSettings) -> Result<SoundResult, CoreError> {
    let mesh = room();
    let bvh = Bvh::build(&mesh).unwrap();
    trace_sound(&mesh, &bvh, ac, &sources(), &receivers(), set, |_| true)
}

/// Bands do not interact: with the same scattering in every band, a band's counts depend only on
/// its own absorption and air, so band b of a 31-band bake is band b % 3 of a 3-band bake, bit for
/// bit (the rays, their bounces and the rounding draws are the same), and every band's energy
/// balance closes.
#[test]
fn thirty_one_bands_trace_as_their_three_distinct_bands() {
    let alpha = [0.08, 0.25, 0.6];
    let air = [0.0, 0.002, 0.01];
    for est in [Estimator::Paper, Estimator::Rain] {
        let wide = trace(&acoustics(31, &alpha), &settings(31, &air, est)).unwrap();
        let narrow = trace(&acoustics(3, &alpha), &settings(3, &air, est)).unwrap();
        let (lw, ln) = (&wide.layout, &narrow.layout);
        assert_eq!(lw.n_bands, 31);
        assert_eq!(lw.n_time(), ln.n_time());
        let mut nonzero = 0;
        for r in 0..lw.n_receivers {
            for t in 0..lw.n_time() {
                for d in 0..lw.n_directions() {
                    for b in 0..31 {
                        let w = wide.field.get(lw.index(r, t, d) + b);
                        assert_eq!(w, narrow.field.get(ln.index(r, t, d) + b % 3), "{est:?} r{r} t{t} d{d} b{b}");
                        nonzero += usize::from(w > 0);
                    }
                }
            }
        }
        assert!(nonzero > 1000, "{est:?}: the field holds energy ({nonzero} cells)");
        let emitted = wide.stats.energy("emitted").unwrap();
        let out: Vec<f64> = ["absorbed_surfaces", "absorbed_air", "escaped", "remaining"]
            .iter()
            .map(|k| wide.stats.energy(k).unwrap())
            .fold(vec![0.0; 31], |acc, v| acc.iter().zip(&v).map(|(a, b)| a + b).collect());
        let reweighted = wide.stats.energy("reweighted").unwrap();
        for b in 0..31 {
            // Fixed-point tallies: the balance closes to rounding (2⁻⁸⁰ J a count).
            assert!((emitted[b] + reweighted[b] - out[b]).abs() < 1e-9, "{est:?} band {b}");
        }
    }
}

#[test]
fn the_public_order_is_receiver_direction_band_time_for_any_thread_count() {
    let res = trace(&acoustics(5, &[0.1, 0.3]), &settings(5, &[0.0], Estimator::Paper)).unwrap();
    let l = &res.layout;
    let (nd, nb, nt) = (l.n_directions(), l.n_bands, l.n_time());
    let counts = res.counts(1);
    assert_eq!(counts, res.counts(3));
    for r in 0..l.n_receivers {
        for d in 0..nd {
            for b in 0..nb {
                for t in 0..nt {
                    assert_eq!(counts[((r * nd + d) * nb + b) * nt + t], res.field.get(l.index(r, t, d) + b));
                }
            }
        }
    }
    let energy = res.energy(2);
    let q = res.field.quantum;
    assert!(energy.iter().zip(&counts).all(|(e, c)| *e == (*c as f64 * q) as f32));
}

/// Each bad setting is refused with an error that names it, before anything is traced or
/// allocated.
#[test]
fn bad_settings_are_errors_that_name_the_setting() {
    let ac = acoustics(6, &[0.1]);
    let base = settings(6, &[0.0], Estimator::Paper);
    let cases: Vec<(&str, Acoustics, SoundSettings)> = vec![
        ("threads", ac.clone(), SoundSettings { threads: 100_000, ..base.clone() }),
        ("max_time_s", ac.clone(), SoundSettings { max_time_s: 1e12, ..base.clone() }),
        ("max_time_s", ac.clone(), SoundSettings { max_time_s: 1e300, ..base.clone() }),
        ("max_time_s", ac.clone(), SoundSettings { max_field_bytes: 1000, ..base.clone() }),
        ("early_s", ac.clone(), SoundSettings { early_s: f64::NAN, ..base.clone() }),
        ("sample_rate_hz", ac.clone(), SoundSettings { sample_rate_hz: 0.0, ..base.clone() }),
        ("bands", Acoustics { n_bands: 0, absorption: vec![], scattering: vec![] }, SoundSettings { air_attenuation_per_m: vec![], ..base.clone() }),
        ("air_attenuation_per_m", ac.clone(), SoundSettings { air_attenuation_per_m: vec![0.0; 5], ..base.clone() }),
        ("materials", Acoustics { scattering: vec![0.1; 17], ..ac.clone() }, base.clone()),
        ("materials", acoustics(6, &[1.5]), base.clone()),
        ("first_ray..end_ray", ac.clone(), SoundSettings { first_ray: 5, end_ray: 5, ..base.clone() }),
        ("directions", ac.clone(), SoundSettings { n_azimuth: 0, ..base.clone() }),
    ];
    for (what, ac, set) in cases {
        match trace(&ac, &set) {
            Err(CoreError::InvalidInput { what: got, problem }) => assert_eq!(got, what, "{problem}"),
            other => panic!("{what}: expected an error, got {other:?}"),
        }
    }
}
