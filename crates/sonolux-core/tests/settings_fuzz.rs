//! Random settings never panic the sound tracer: every combination of in-range, edge and
//! absurd values (NaN, infinities, zero, huge counts, wrong band counts, sources and receivers
//! anywhere) ends in `Ok` or in a `CoreError` naming the input at fault, the contract that the
//! binding relies on to turn every core error into a Python `SonoluxError`.
//!
//! A property test with a fixed-seed generator of its own (so it needs no extra crate and runs
//! the same cases everywhere): 400 cases in `cargo test`, 20 000 with `--ignored`.

use std::panic::{catch_unwind, AssertUnwindSafe};

use glam::DVec3;
use sonolux_core::sound::{trace_sound, Acoustics, Directivity, Estimator, Receivers, SoundSettings, SoundSource};
use sonolux_core::Bvh;

mod common;

/// SplitMix64: a small, well-mixed generator for test cases.
struct Cases(u64, u64);

impl Cases {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn pick<T: Copy>(&mut self, from: &[T]) -> T {
        from[(self.next() % from.len() as u64) as usize]
    }

    /// A float from `typical`, or, once in `self.1` draws, an odd one (0: never).
    fn float(&mut self, typical: &[f64]) -> f64 {
        // Not huge finite values: a setting that is valid but huge (max_time_s = 1e9) is a long
        // run, not a panic; the Python edge bounds those (sonolux.limits).
        const ODD: [f64; 9] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -0.0, -1.0, 1e-300, f64::MIN_POSITIVE, 1.5];
        if self.1 > 0 && self.next() % self.1 == 0 {
            self.pick(&ODD)
        } else {
            self.pick(typical)
        }
    }

    fn point(&mut self) -> DVec3 {
        DVec3::new(self.float(&[0.5, 1.5, 2.5, 4.9, 6.0]), self.float(&[0.5, 2.0, 3.9]), self.float(&[0.2, 1.5, 2.9]))
    }
}

/// One random case; true when the tracer accepted it (and ran it).
fn one_case(cases: &mut Cases) -> bool {
    // Some cases are all sensible values, the others break one setting in 2, 5 or 20.
    cases.1 = cases.pick(&[0u64, 2, 5, 20]);
    let mesh = common::shoebox(5.0, 4.0, 3.0, [0, 1, 2, 2, 2, 2]);
    let bvh = Bvh::build(&mesh).unwrap();
    let odd = |c: &mut Cases| c.1 > 0 && c.next() % c.1 == 0;
    let n_bands = if odd(cases) { cases.pick(&[0usize, 31, 100]) } else { cases.pick(&[1usize, 3, 6]) };
    let n_values = if odd(cases) { cases.pick(&[0usize, 1, 5]) } else { 3 * n_bands };
    let acoustics = Acoustics {
        n_bands,
        absorption: (0..n_values).map(|_| cases.float(&[0.0, 0.1, 0.5, 1.0])).collect(),
        scattering: (0..n_values).map(|_| cases.float(&[0.0, 0.2, 1.0])).collect(),
    };
    let rays = if odd(cases) { 0 } else { cases.pick(&[1u64, 7, 50, 200]) };
    let (first_ray, end_ray) = if odd(cases) { (cases.pick(&[3u64, 200, u64::MAX]), cases.pick(&[0u64, 1, u64::MAX])) } else { (0, rays) };
    let air_len = if odd(cases) { cases.pick(&[0usize, 2, 40]) } else { n_bands };
    let settings = SoundSettings {
        rays,
        first_ray,
        first_receiver: 0,
        only_source: None,
        end_ray,
        seed: cases.next(),
        threads: if odd(cases) { cases.pick(&[1025usize, 100_000, usize::MAX]) } else { cases.pick(&[0usize, 1, 2, 3]) },
        estimator: cases.pick(&[Estimator::Paper, Estimator::Rain]),
        speed_of_sound_m_s: cases.float(&[343.0, 330.0, 1500.0]),
        air_attenuation_per_m: (0..air_len).map(|_| cases.float(&[0.0, 0.001, 0.1])).collect(),
        energy_drop_db: cases.float(&[60.0, 1.0, 300.0]),
        max_time_s: cases.float(&[0.05, 0.3]),
        sample_rate_hz: cases.float(&[8000.0, 16000.0]),
        early_s: cases.float(&[0.0, 0.01, 0.08]),
        late_bin_s: cases.float(&[0.001, 0.01]),
        n_azimuth: if odd(cases) { cases.pick(&[0usize, 100_000]) } else { cases.pick(&[1usize, 8, 36]) },
        n_elevation: if odd(cases) { cases.pick(&[0usize, 1000]) } else { cases.pick(&[1usize, 3]) },
        // Small, so that a case the checks accept stays small (the limit is the contract).
        max_field_bytes: if odd(cases) { cases.pick(&[0u64, 1 << 10]) } else { 1 << 24 },
    };
    let n_receivers = if odd(cases) { 0 } else { cases.pick(&[1usize, 3]) };
    let receivers = Receivers::new((0..n_receivers).map(|_| cases.point()).collect(), cases.float(&[0.25, 0.01, 3.0]));
    let n_sources = if odd(cases) { 0 } else { cases.pick(&[1usize, 2]) };
    let sources: Vec<SoundSource> = (0..n_sources)
        .map(|_| SoundSource {
            position: cases.point(),
            power_w: cases.float(&[1.0, 0.01, 1e3]),
            directivity: if cases.next() % 2 == 0 {
                Directivity::Omni
            } else {
                let axis = DVec3::new(cases.float(&[1.0, 0.0]), cases.float(&[0.0, 1.0]), cases.float(&[0.0, 1.0]));
                Directivity::Cone { axis: axis.normalize_or_zero(), cos_half_angle: cases.float(&[0.3, 0.9, -0.99]) }
            },
        })
        .collect();
    trace_sound(&mesh, &bvh, &acoustics, &sources, &receivers, &settings, |_| true).is_ok()
}

fn run(n: u64, seed: u64) {
    let mut cases = Cases(seed, 0);
    let mut accepted = 0;
    for case in 0..n {
        let state = cases.0;
        let outcome = catch_unwind(AssertUnwindSafe(|| one_case(&mut cases)));
        assert!(outcome.is_ok(), "case {case} (generator state {state:#x}) panicked");
        accepted += outcome.unwrap() as u64;
    }
    // Both sides are exercised: many cases trace, many are refused.
    assert!(accepted >= n / 10 && accepted <= n - n / 10, "{accepted} of {n} cases accepted");
}

#[test]
fn random_sound_settings_never_panic() {
    run(400, 0x5EED_0014);
}

#[test]
#[ignore = "long: make test-all"]
fn random_sound_settings_never_panic_long() {
    run(20_000, 0x5EED_1014);
}
