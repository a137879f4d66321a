//! The wave solver's free field: a point source in a box large enough that the direct sound is
//! over before the first reflection arrives. Amplitude against 1/r, arrival time against r/c,
//! the intensity's direction against the source's, and the energies per band and direction
//! against the tracer's free-field convention, 1/(4πr²)·exp(−m·r).

mod common;

use glam::DVec3;
use sonolux_core::sound::Layout;
use sonolux_core::wave::bands::direction_energies;
use sonolux_core::wave::{simulate_waves, WaveMaterials, WaveResult};

const C: f64 = 343.0;
const H: f64 = 0.1;

/// Ten receivers 1 to 2.5 m from the source, in directions within 45° of the horizontal (nearer
/// the poles, azimuth sectors meet and the tracer's bins blur), and at least 4.5° in azimuth from
/// the edges of 8 sectors.
fn receivers(src: DVec3) -> Vec<DVec3> {
    (0..10)
        .map(|i| {
            let z = 0.7 * (1.0 - (i as f64 + 0.5) / 5.0);
            let phi = (27.0 + 108.0 * i as f64).to_radians();
            let d = DVec3::new((1.0 - z * z).sqrt() * phi.cos(), (1.0 - z * z).sqrt() * phi.sin(), z);
            src + d * (1.0 + 1.5 * i as f64 / 9.0)
        })
        .collect()
}

/// A run in a rigid cube of `side` m, grid spacing `h`, with the source at its centre (give or take a few cm).
fn run(side: f64, h: f64, rcv_offset: impl Fn(DVec3) -> Vec<DVec3>) -> (DVec3, Vec<DVec3>, WaveResult) {
    let src = DVec3::splat(0.5 * side) + DVec3::new(0.013, -0.013, 0.031);
    let rcv = rcv_offset(src);
    let mesh = common::shoebox(side as f32, side as f32, side as f32, [0; 6]);
    let materials = WaveMaterials { band_centres_hz: vec![125.0, 250.0], absorption: vec![0.0, 0.0], wells: Vec::new() };
    let s = common::wave_settings(h, 0.0045 * side);
    let r = simulate_waves(&mesh, &materials, &[src], &rcv, &s, |_| true).unwrap();
    (src, rcv, r)
}

/// Free-field pressure, arrival and intensity at 10 receivers.
#[test]
fn a_point_source_falls_off_as_1_over_r_arrives_at_r_over_c_and_flows_away_from_itself() {
    // Off the nodes on purpose: the source and every receiver are spread over 8 nodes.
    let (src, rcv, r) = run(10.0, H, receivers);
    let (fs, n) = (r.sample_rate_hz, r.n_samples);
    let (sigma, delay) = (r.pulse.sigma_s, r.pulse.delay_s);
    let (mut worst_amp, mut worst_time, mut worst_angle) = (0.0f64, 0.0f64, 0.0f64);
    for (i, &x) in rcv.iter().enumerate() {
        let dist = (x - src).length();
        let centre = delay + dist / C;
        let window = ((centre - 5.0 * sigma) * fs) as usize..((centre + 5.0 * sigma) * fs).ceil() as usize;
        let p = &r.pressure_pa[i * n..(i + 1) * n];
        // Amplitude: the window's RMS against ρ q̇(t − r/c)/(4πr).
        let expected: Vec<f64> = window.clone().map(|k| r.pulse.pressure_at_1m(k as f64 / fs - dist / C) / dist).collect();
        let rms = |x: &mut dyn Iterator<Item = f64>| x.map(|v| v * v).sum::<f64>().sqrt();
        let amp = rms(&mut window.clone().map(|k| p[k] as f64)) / rms(&mut expected.iter().cloned()) - 1.0;
        // Arrival: the zero crossing at the centre of the odd pulse, interpolated between samples.
        let k = window.clone().find(|&k| p[k] > 0.0 && p[k + 1] <= 0.0 && (k as f64 / fs - centre).abs() < sigma).unwrap();
        let t = (k as f64 + p[k] as f64 / (p[k] - p[k + 1]) as f64) / fs;
        let late_samples = (t - centre) * fs;
        // Direction: the time-integrated intensity p·v over the window.
        let mut flow = DVec3::ZERO;
        for k in window.clone() {
            let v = DVec3::new(r.velocity_m_s[(3 * i) * n + k] as f64, r.velocity_m_s[(3 * i + 1) * n + k] as f64, r.velocity_m_s[(3 * i + 2) * n + k] as f64);
            flow += v * p[k] as f64;
        }
        let angle = flow.angle_between(x - src).to_degrees();
        println!("r = {dist:.2} m: amplitude {:+.2}%, arrival {late_samples:+.3} samples, direction {angle:.2}°", 100.0 * amp);
        worst_amp = worst_amp.max(amp.abs());
        worst_time = worst_time.max(late_samples.abs());
        worst_angle = worst_angle.max(angle);
    }
    println!("worst: amplitude {:.2}%, arrival {worst_time:.3} samples, direction {worst_angle:.2}°", 100.0 * worst_amp);
    // Arrival within one sample and direction within 5°, as the issue asks. Amplitude: the pulse
    // peaks at f_max/2 (20 points per wavelength), where trilinear interpolation at source and
    // receiver loses at most (kΔx)²/8 ≈ 1.2% per axis each; 1/r within 5% holds that with room.
    assert!(worst_time < 1.0, "{worst_time}");
    assert!(worst_angle < 5.0, "{worst_angle}");
    assert!(worst_amp < 0.05, "{worst_amp}");
}

/// Band energies per direction: the direct sound's energy lands in the source's direction bin,
/// and equals 1/(4πr²)·exp(−m r) per band.
#[test]
fn the_direct_sound_lands_in_its_direction_bin_with_the_tracers_free_field_energy() {
    // 12 m: the band filters ring for ten ms and more at 125 Hz, and the first reflection must
    // come later than that (20 ms after the direct sound). Δx = 8 cm puts the 250 Hz octave's
    // upper edge (354 Hz) below the maximum frequency (429 Hz).
    let (src, rcv, r) = run(12.0, 0.08, receivers);
    let bands = [125.0, 250.0];
    // Strong air (a tenth of its energy per 2 m and more), so that a missing or wrong factor shows.
    let air = [0.03, 0.06];
    let layout = Layout {
        n_receivers: rcv.len(),
        n_azimuth: 8,
        n_elevation: 2,
        n_bands: 2,
        sample_rate_hz: r.sample_rate_hz,
        early_bins: r.n_samples,
        late_bin_s: 0.01,
        late_bins: 0,
    };
    let field = direction_energies(&r, &bands, &air, C, &layout).unwrap();
    let mut worst_energy = 0.0f64;
    let mut worst_outside = 0.0f64;
    for (i, &x) in rcv.iter().enumerate() {
        let dist = (x - src).length();
        // 12 ms after the direct sound; the first reflection comes 20 ms after it.
        let end = ((dist + 4.2) / C * r.sample_rate_hz) as usize;
        let from = layout.direction_bin((src - x).normalize());
        for b in 0..2 {
            let (mut inside, mut total) = (0.0, 0.0);
            for t in 0..end {
                for d in 0..layout.n_directions() {
                    let e = field[layout.index(i, t, d) + b];
                    total += e;
                    if d == from {
                        inside += e;
                    }
                }
            }
            let want = (-air[b] * dist).exp() / (4.0 * std::f64::consts::PI * dist * dist);
            let err = total / want - 1.0;
            println!("r = {dist:.2} m, {} Hz: energy {:+.2}% of 1/(4πr²)·e^(−mr), {:.2}% outside its direction bin", bands[b], 100.0 * err, 100.0 * (1.0 - inside / total));
            worst_energy = worst_energy.max(err.abs());
            worst_outside = worst_outside.max(1.0 - inside / total);
        }
    }
    // Trilinear interpolation at the source and at the receiver each attenuate a wave by up to
    // cos(kΔx/2) per axis at a cell's centre: 3.4% in amplitude at the 250 Hz octave's upper
    // edge here, 0.7% at its centre; over a band, both ends, a few percent of energy, and the
    // band filters ring a little beyond the window. 8% of energy (0.35 dB); 5% outside the bin.
    assert!(worst_energy < 0.08, "{worst_energy}");
    assert!(worst_outside < 0.05, "{worst_outside}");
}
