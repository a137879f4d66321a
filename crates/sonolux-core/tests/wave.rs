//! The wave solver against exact answers: voxelisation against generalised winding numbers,
//! conservation of the scheme's discrete energy, stability at the Courant limit, the modes of a
//! rigid box, free-field propagation, determinism across thread counts, and refusals.
//! (Walls that absorb: `wave_walls.rs`.)

mod common;

use glam::{DVec3, Quat, Vec3};
use realfft::RealFftPlanner;
use sonolux_core::wave::scheme::{mode_omega_dt, phase_velocity_ratio};
use sonolux_core::wave::{build_solver, simulate_waves, AbsorptionKind, WaveMaterials, WaveSettings, COURANT_LIMIT, COURANT_MAX};
use sonolux_core::Mesh;

const C: f64 = 343.0;

/// Settings whose grid spacing is `h` on `threads` threads.
fn settings(h: f64, duration_s: f64, threads: usize) -> WaveSettings {
    WaveSettings { threads, ..common::wave_settings(h, duration_s) }
}

/// `n` materials that absorb nothing, in octaves 125..1000 Hz.
fn rigid(n: usize) -> WaveMaterials {
    WaveMaterials { band_centres_hz: vec![125.0, 250.0, 500.0, 1000.0], absorption: vec![0.0; 4 * n], wells: Vec::new() }
}

/// A deterministic pseudo-random sequence in [−1, 1) (xorshift).
fn noise(seed: u64, n: usize) -> Vec<f32> {
    let mut x = seed | 1;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 40) as f32 / (1u64 << 23) as f32 - 1.0
        })
        .collect()
}

/// Noise over the air nodes with its mean removed: a net volume (or its rate) would be the box's
/// zero-frequency mode, a static pressure (or one growing linearly) that carries no energy
/// but swamps the f32 fields' precision.
fn air_noise(grid: &sonolux_core::wave::Grid, seed: u64) -> Vec<f32> {
    let mut x = noise(seed, grid.cells());
    let air: Vec<usize> = (0..x.len()).filter(|&i| grid.is_air(i)).collect();
    let mean = air.iter().map(|&i| x[i] as f64).sum::<f64>() / air.len() as f64;
    for &i in &air {
        x[i] -= mean as f32;
    }
    x
}

#[test]
fn a_box_of_whole_cells_voxelises_to_exactly_its_cells() {
    let mesh = common::shoebox(0.7, 1.1, 1.7, [0, 1, 2, 3, 4, 5]);
    let (solver, stats) = build_solver(&mesh, &rigid(6), &settings(0.05, 0.01, 1), 0).unwrap();
    assert_eq!(stats.air_cells, 14 * 22 * 34);
    // Every air node on the box's surface layer has its outward faces, and no face is unexplained.
    assert_eq!(stats.boundary.faces, 2 * (22 * 34 + 14 * 34 + 14 * 22));
    assert_eq!(stats.voxels.faces_without_crossing, 0);
    assert!((stats.boundary.area_m2 - 2.0 * (0.7 * 1.1 + 0.7 * 1.7 + 1.1 * 1.7)).abs() < 1e-5);
    assert_eq!(solver.grid().dims, [16, 24, 36]);
}

/// Air nodes against the generalised winding number of the same mesh (Jacobson et al. 2013):
/// a node is air when the winding number rounds to the room's. Nodes within 1 µm of a surface,
/// where either answer is as good, are left out.
fn check_against_winding_numbers(mesh: &Mesh, h: f64) -> usize {
    let n_mat = mesh.material.iter().max().map_or(1, |&m| m as usize + 1);
    let (solver, _) = build_solver(mesh, &rigid(n_mat), &settings(h, 0.01, 0), 0).unwrap();
    let grid = solver.grid();
    let w_air = sonolux_core::wave::voxel::air_winding(mesh) as f64;
    let points: Vec<Vec3> = (0..grid.cells()).map(|i| grid.position(i).as_vec3()).collect();
    let w = mesh.winding_numbers(&points);
    let disagree: Vec<usize> = (0..grid.cells()).filter(|&i| grid.is_air(i) != ((w[i] - w_air).abs() < 0.5)).collect();
    let near: Vec<f64> = mesh.distance_to_surface(&disagree.iter().map(|&i| points[i]).collect::<Vec<_>>());
    let real: Vec<usize> = disagree.iter().zip(&near).filter(|(_, &d)| d > 1e-6).map(|(&i, _)| i).collect();
    assert!(real.is_empty(), "{} nodes disagree, e.g. at {:?}", real.len(), real.first().map(|&i| grid.position(i)));
    grid.air_cells()
}

#[test]
fn a_rotated_room_voxelises_as_its_winding_number_says() {
    let room = common::shoebox(3.0, 2.2, 2.5, [0, 1, 2, 3, 4, 5]);
    let q = Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.5, 0.8);
    let mesh = common::transformed(&room, |v| q * v + Vec3::new(0.1, -0.2, 0.3));
    let air = check_against_winding_numbers(&mesh, 0.1);
    // The air volume is the room's within a layer of half a cell over its surface.
    let volume = air as f64 * 1e-3;
    assert!((volume - 16.5).abs() < 0.5 * 0.1 * 2.0 * (3.0 * 2.2 + 3.0 * 2.5 + 2.2 * 2.5), "{volume}");
}

#[test]
fn furniture_is_solid_even_where_it_pierces_a_wall() {
    let room = common::shoebox(4.0, 3.0, 2.5, [0, 1, 2, 2, 2, 2]);
    let table = common::cuboid(Vec3::new(1.0, 1.0, 0.7), Vec3::new(2.2, 1.8, 0.76), [6; 6], false);
    let cabinet = common::cuboid(Vec3::new(3.3, 0.2, 0.0), Vec3::new(4.0, 0.9, 1.9), [7; 6], false);
    // A pillar that goes through the floor and the ceiling.
    let pillar = common::cuboid(Vec3::new(0.43, 2.13, -0.5), Vec3::new(0.77, 2.51, 3.0), [6; 6], false);
    let q = Quat::from_rotation_z(0.37);
    let mesh = common::transformed(&common::merge(&[room, table, cabinet, pillar]), |v| q * v);
    check_against_winding_numbers(&mesh, 0.07);
    // The faces next to the table top carry its material.
    let (solver, _) = build_solver(&mesh, &rigid(8), &settings(0.07, 0.01, 0), 0).unwrap();
    let grid = solver.grid();
    let above = grid.nearest_node((q * Vec3::new(1.6, 1.4, 0.8)).as_dvec3()).unwrap();
    assert!(grid.is_air(above));
}

#[test]
fn a_closed_rigid_box_conserves_the_discrete_energy() {
    // Random fields excite every mode, up to the grid's Nyquist: the hardest case.
    let mesh = common::shoebox(0.7, 1.1, 1.7, [0; 6]);
    let (mut solver, _) = build_solver(&mesh, &rigid(1), &settings(0.05, 1.0, 2), 0).unwrap();
    let (u1, u0) = (air_noise(solver.grid(), 1), air_noise(solver.grid(), 2));
    solver.set_state(&u1, &u0).unwrap();
    let e0 = solver.energy();
    let mut worst = 0.0f64;
    for step in 1..=5000 {
        solver.step(&[]);
        if step % 50 == 0 {
            worst = worst.max((solver.energy() / e0 - 1.0).abs());
        }
    }
    // f32 fields round each update by ~6e-8 relative; over 5000 steps of ~13,000 nodes the energy
    // random-walks by about 6e-8·√5000 ≈ 4e-6 at most. A wrong boundary term would leak or
    // pump percents.
    println!("relative energy drift over 5000 steps: {worst:.2e}");
    assert!(worst < 1e-5, "{worst}");
}

#[test]
fn at_the_largest_courant_number_a_box_stays_bounded_for_long() {
    let mesh = common::shoebox(0.3, 0.35, 0.4, [0; 6]);
    let mut s = settings(0.05, 1.0, 1);
    s.courant = COURANT_MAX;
    let (mut solver, _) = build_solver(&mesh, &rigid(1), &s, 0).unwrap();
    let (u1, u0) = (air_noise(solver.grid(), 3), air_noise(solver.grid(), 4));
    solver.set_state(&u1, &u0).unwrap();
    let e0 = solver.energy();
    let peak0 = solver.pressure().iter().fold(0f32, |a, &b| a.max(b.abs()));
    let mut peak = 0f32;
    for _ in 0..200_000 {
        solver.step(&[]);
        peak = peak.max(solver.pressure().iter().fold(0f32, |a, &b| a.max(b.abs())));
    }
    let drift = (solver.energy() / e0 - 1.0).abs();
    println!("200k steps: energy drift {drift:.2e}, peak {peak} vs initial {peak0}");
    assert!(drift < 1e-4 && peak < 20.0 * peak0, "{drift} {peak}");
}

/// The rigid box's first 20 modes, from the pressure response of a corner source at the
/// opposite corner.
#[test]
fn a_rigid_box_rings_at_its_first_20_modes() {
    let (nx, ny, nz, h) = (14usize, 22usize, 34usize, 0.05);
    let l = [nx as f64 * h, ny as f64 * h, nz as f64 * h];
    let mesh = common::shoebox(l[0] as f32, l[1] as f32, l[2] as f32, [0; 6]);
    let s = settings(h, 2.0, 0);
    let src = DVec3::splat(0.5 * h);
    let rcv = DVec3::new(l[0], l[1], l[2]) - 0.5 * h;
    let r = simulate_waves(&mesh, &rigid(1), &[src], &[rcv], &s, |_| true).unwrap();
    let fs = r.sample_rate_hz;
    let a2 = (s.courant * s.courant) as f32 as f64;
    // Modes: analytic (c/2)·√Σ(m_i/L_i)², and the scheme's own from its eigenvalues.
    let mut modes: Vec<(f64, f64, [usize; 3])> = Vec::new();
    for m in 0..8 {
        for n in 0..8 {
            for k in 0..8 {
                if m + n + k == 0 {
                    continue;
                }
                let idx = [m, n, k];
                let analytic = 0.5 * C * (0..3).map(|i| (idx[i] as f64 / l[i]).powi(2)).sum::<f64>().sqrt();
                let n_cells = [nx, ny, nz];
                let mu: f64 = (0..3).map(|i| 4.0 * (std::f64::consts::PI * idx[i] as f64 / (2.0 * n_cells[i] as f64)).sin().powi(2)).sum();
                let discrete = mode_omega_dt(mu, a2) * fs / std::f64::consts::TAU;
                modes.push((analytic, discrete, idx));
            }
        }
    }
    modes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let spectrum = Spectrum::of(&r.pressure_pa, fs);
    let mut worst_corrected = 0.0f64;
    let mut worst_raw = 0.0f64;
    for i in 0..20 {
        let (analytic, discrete, idx) = modes[i];
        let gap = |j: usize| (modes[j].1 - discrete).abs();
        let half_window = 0.5 * if i == 0 { gap(1) } else { gap(i - 1).min(gap(i + 1)) };
        let measured = spectrum.peak_near(discrete, half_window);
        // The scheme's dispersion correction: analytic/discrete of this mode.
        let corrected = measured * analytic / discrete;
        let err = (corrected / analytic - 1.0).abs();
        worst_corrected = worst_corrected.max(err);
        worst_raw = worst_raw.max((measured / analytic - 1.0).abs());
        println!("mode {idx:?}: analytic {analytic:.3} Hz, scheme {discrete:.3}, measured {measured:.3}, corrected error {:.4}%", 100.0 * err);
    }
    println!("worst error: corrected {:.4}%, uncorrected {:.3}%", 100.0 * worst_corrected, 100.0 * worst_raw);
    // With walls on cell faces, the box's discrete modes are exact eigenvectors of the scheme:
    // what remains is the peak estimate of a 2 s record (Hann window, parabolic interpolation
    // of the log spectrum: well under a hundredth of the 0.5 Hz resolution). The issue asks 1%;
    // we hold 0.05%, which a misplaced wall (one cell in 14 is 7%) or a wrong λ would break.
    assert!(worst_corrected < 5e-4, "{worst_corrected}");
}

/// A Hann-windowed, zero-padded magnitude spectrum.
struct Spectrum {
    mag_db: Vec<f64>,
    bin_hz: f64,
}

impl Spectrum {
    fn of(x: &[f32], fs: f64) -> Spectrum {
        let n = x.len();
        let len = (8 * n).next_power_of_two();
        let mut buf = vec![0.0; len];
        for i in 0..n {
            let w = 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n as f64).cos();
            buf[i] = x[i] as f64 * w;
        }
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(len);
        let mut out = fft.make_output_vec();
        fft.process(&mut buf, &mut out).unwrap();
        Spectrum { mag_db: out.iter().map(|c| 20.0 * c.norm().max(1e-300).log10()).collect(), bin_hz: fs / len as f64 }
    }

    /// The interpolated frequency of the highest peak within ±`half_window` of `f`.
    fn peak_near(&self, f: f64, half_window: f64) -> f64 {
        let lo = ((f - half_window) / self.bin_hz).ceil() as usize;
        let hi = ((f + half_window) / self.bin_hz).floor() as usize;
        let k = (lo..=hi).max_by(|&a, &b| self.mag_db[a].total_cmp(&self.mag_db[b])).unwrap();
        let (a, b, c) = (self.mag_db[k - 1], self.mag_db[k], self.mag_db[k + 1]);
        let delta = 0.5 * (a - c) / (a - 2.0 * b + c);
        (k as f64 + delta) * self.bin_hz
    }
}

#[test]
fn phase_velocity_is_exact_along_diagonals_and_1_percent_slow_along_axes_at_10_points() {
    let d = 1.0 / 3f64.sqrt();
    assert!((phase_velocity_ratio([d, d, d], 10.0, COURANT_LIMIT) - 1.0).abs() < 1e-12);
    let axial = phase_velocity_ratio([1.0, 0.0, 0.0], 10.0, COURANT_LIMIT);
    assert!((axial - 0.98896).abs() < 1e-4, "{axial}");
}

/// A furnished room with absorbing walls, two sources and three receivers: the same bits on one
/// thread and on two.
#[test]
fn one_and_two_threads_give_the_same_bits() {
    let room = common::shoebox(2.0, 1.5, 1.2, [0, 1, 2, 2, 2, 2]);
    let table = common::cuboid(Vec3::new(0.5, 0.4, 0.5), Vec3::new(1.2, 0.9, 0.55), [3; 6], false);
    let mesh = common::merge(&[room, table]);
    let materials = WaveMaterials {
        band_centres_hz: vec![125.0, 250.0, 500.0],
        absorption: vec![0.02, 0.03, 0.04, 0.5, 0.7, 0.9, 0.1, 0.2, 0.3, 0.2, 0.2, 0.2],
        wells: Vec::new(),
    };
    let sources = [DVec3::new(0.3, 0.3, 1.0), DVec3::new(1.7, 1.2, 0.3)];
    let receivers = [DVec3::new(1.0, 0.7, 0.9), DVec3::new(1.9, 0.1, 0.1), DVec3::new(0.77, 0.61, 0.2)];
    let run = |threads| {
        let mut s = settings(0.05, 0.05, threads);
        s.absorption_kind = AbsorptionKind::RandomIncidence;
        simulate_waves(&mesh, &materials, &sources, &receivers, &s, |_| true).unwrap()
    };
    let (a, b) = (run(1), run(2));
    assert!(a.pressure_pa.iter().any(|&p| p != 0.0));
    assert_eq!(a.pressure_pa.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), b.pressure_pa.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
    assert_eq!(a.velocity_m_s.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), b.velocity_m_s.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
}

#[test]
fn what_does_not_fit_is_refused_with_the_frequency_that_would() {
    let mesh = common::shoebox(24.0, 10.0, 8.0, [0; 6]);
    let mut s = settings(0.05, 2.0, 1);
    s.memory_limit_bytes = 100 << 20;
    let err = build_solver(&mesh, &rigid(1), &s, 10).unwrap_err().to_string();
    assert!(err.contains("largest max_frequency_hz that fits is"), "{err}");
    // The frequency it names fits, and 5% more does not.
    let scene = sonolux_core::wave::SceneSize::of(&mesh);
    let f = s.max_frequency_within(&scene, 10, &rigid(1).band_centres_hz, s.memory_limit_bytes).unwrap();
    let centres = rigid(1).band_centres_hz;
    let at = |f: f64| {
        let fitted = sonolux_core::wave::settings::bands_fitted(&centres, f);
        WaveSettings { max_frequency_hz: f, ..s.clone() }.memory_estimate(&scene, 10, fitted).total_bytes
    };
    assert!(at(f) <= s.memory_limit_bytes && at(1.05 * f) > s.memory_limit_bytes, "{f}");
}

#[test]
fn bad_inputs_are_errors_naming_what_is_wrong() {
    let mesh = common::shoebox(1.0, 1.0, 1.0, [0; 6]);
    let good = settings(0.1, 0.01, 1);
    let inside = [DVec3::splat(0.5)];
    let try_run = |s: &WaveSettings, m: &WaveMaterials, src: &[DVec3], rcv: &[DVec3]| simulate_waves(&mesh, m, src, rcv, s, |_| true).unwrap_err().to_string();
    let e = try_run(&WaveSettings { courant: 0.6, ..good.clone() }, &rigid(1), &inside, &inside);
    assert!(e.contains("courant"), "{e}");
    let e = try_run(&WaveSettings { max_frequency_hz: f64::NAN, ..good.clone() }, &rigid(1), &inside, &inside);
    assert!(e.contains("max_frequency_hz"), "{e}");
    let e = try_run(&good, &WaveMaterials { band_centres_hz: vec![125.0, 250.0, 500.0, 1000.0], absorption: vec![0.0, 1.5, 0.0, 0.0], wells: Vec::new() }, &inside, &inside);
    assert!(e.contains("absorption") && e.contains("1.5"), "{e}");
    let e = try_run(&good, &rigid(2), &inside, &inside);
    assert!(e.contains("materials"), "{e}");
    let e = try_run(&good, &rigid(1), &[DVec3::new(3.0, 0.5, 0.5)], &inside);
    assert!(e.contains("source 0") && e.contains("not in the room"), "{e}");
    let e = try_run(&good, &rigid(1), &inside, &[DVec3::splat(0.5), DVec3::new(0.5, f64::INFINITY, 0.5)]);
    assert!(e.contains("receiver 1"), "{e}");
    let e = try_run(&good, &rigid(1), &[], &inside);
    assert!(e.contains("at least one source"), "{e}");
}

#[test]
fn a_cancelled_run_returns_what_it_computed() {
    let mesh = common::shoebox(1.0, 1.0, 1.0, [0; 6]);
    let s = settings(0.05, 1.0, 1);
    let mut calls = 0;
    let r = simulate_waves(&mesh, &rigid(1), &[DVec3::splat(0.3)], &[DVec3::splat(0.6)], &s, |p| {
        calls += 1;
        assert!(p.done <= p.total);
        calls < 2
    })
    .unwrap();
    assert!(r.cancelled && r.n_samples < s.n_steps() as usize && r.n_samples > 0);
    assert_eq!(r.pressure_pa.len(), r.n_samples);
}
