//! The waves' memory estimate (wave/settings.rs) against what the solver actually holds once
//! built ([`WaveSolver::allocated_bytes`]: its vectors' capacities), for flat walls and for a
//! described surface whose wells add Foster branches to every face of their material
//! (wave/wells.rs). The estimate is made before anything is voxelised; it must not be below the
//! allocation (else a run the check let through could exhaust memory), and it should not be far
//! above it (else runs that fit are refused).

use sonolux_core::wave::{build_solver, settings::bands_fitted, wall_branches, wall_fits, AbsorptionKind, SceneSize, WaveMaterials, WaveSettings, Wells};

mod common;

/// A 5 × 4 × 3 m room: floor (material 0), walls (1), ceiling (2), absorbing as furnished rooms'
/// surfaces do (random incidence), in octaves 125..1000 Hz; a grid of 0.1 m (343 Hz). The walls'
/// 2–3 % are lossy walls with branches since session 12 (before, the fit's tolerance in dB made
/// them rigid).
fn room() -> (sonolux_core::Mesh, WaveMaterials, WaveSettings) {
    let mesh = common::shoebox(5.0, 4.0, 3.0, [0, 2, 1, 1, 1, 1]);
    let absorption = vec![0.10, 0.15, 0.20, 0.25, 0.02, 0.03, 0.04, 0.05, 0.40, 0.60, 0.70, 0.75];
    let materials = WaveMaterials { band_centres_hz: vec![125.0, 250.0, 500.0, 1000.0], absorption, wells: Vec::new() };
    let settings = WaveSettings { threads: 2, absorption_kind: AbsorptionKind::RandomIncidence, ..common::wave_settings(0.1, 0.05) };
    (mesh, materials, settings)
}

/// A quadratic-residue diffuser, N = 7, designed for 500 Hz (Schroeder 1975; Cox and D'Antonio,
/// "Acoustic Absorbers and Diffusers", 2nd ed., §9.2: d_n = (n² mod N) λ₀ / (2N)), in 0.5 m patches.
fn qrd() -> Wells {
    let lambda0 = 343.0 / 500.0;
    Wells { depths_m: (0..7).map(|n| ((n * n) % 7) as f64 * lambda0 / 14.0).collect(), patch_m: 0.5 }
}

/// (estimate of the run's grid and boundary, bytes allocated) for `materials`.
fn estimate_and_allocation(mesh: &sonolux_core::Mesh, materials: &WaveMaterials, settings: &WaveSettings) -> (u64, u64, usize) {
    let (_, stats) = build_solver(mesh, materials, settings, 1).unwrap();
    let est = &stats.estimate;
    let branches = stats.fits.iter().map(|f| f.admittance.branches.len()).max().unwrap();
    (est.grid_bytes + est.boundary_bytes, stats.allocated_bytes, branches)
}

#[test]
fn the_estimate_bounds_what_the_solver_holds_with_flat_walls_and_with_wells() {
    let (mesh, flat, settings) = room();
    let fitted = bands_fitted(&flat.band_centres_hz, settings.max_frequency_hz);
    let (est_flat, held_flat, branches) = estimate_and_allocation(&mesh, &flat, &settings);
    println!("flat walls: estimate {est_flat} B, held {held_flat} B ({:.3}); fits' most branches {branches}, bands fitted {fitted}", est_flat as f64 / held_flat as f64);
    let mut profiled = flat.clone();
    profiled.wells = vec![Some(qrd()), None, None];
    let (est, held, _) = estimate_and_allocation(&mesh, &profiled, &settings);
    println!("QRD floor: estimate {est} B, held {held} B ({:.3}); the wells' part: estimate {} B, held {} B", est as f64 / held as f64, est - est_flat, held - held_flat);
    for (e, h) in [(est_flat, held_flat), (est, held)] {
        // Never below; above by what an upper bound per face costs: every face counted as a
        // node of its own, while a room's edges and corners share nodes.
        assert!(e >= h && (e as f64) < 1.3 * h as f64, "estimate {e} B against {h} B held");
    }
    // The wells' part: every floor face carries the branches of the deepest well (3 here) in
    // the estimate; what is held is 3 branches for the faces of the six wells deeper than 0
    // (6/7 of the floor) and any (node, well) entries that patches split: at least what is held,
    // at most 7/6 of it and the split entries (≤ 25 %). Without the wells the estimate would
    // not move at all.
    let (wells_est, wells_held) = (est - est_flat, held - held_flat);
    assert!(wells_held > 0 && wells_est >= wells_held && (wells_est as f64) < 1.25 * wells_held as f64, "the wells: estimate {wells_est} B against {wells_held} B held");
    // The estimate made from the scene before any solver is built is the one the run made.
    let counts = wall_branches(&profiled, &settings).unwrap();
    let scene = SceneSize::of(&mesh).with_fitted_branches(counts);
    let seen = settings.memory_estimate(&scene.clone().with_wells(&profiled.wells), 1, fitted);
    assert_eq!(seen.grid_bytes + seen.boundary_bytes, est);
    assert_eq!(settings.memory_estimate(&scene, 1, fitted).boundary_bytes, est_flat - seen.grid_bytes);
}

#[test]
fn deeper_wells_and_higher_frequencies_cost_more_branches_and_the_bisection_sees_them() {
    let (mesh, mut materials, settings) = room();
    materials.wells = vec![Some(qrd()), None, None];
    let flat = SceneSize::of(&mesh);
    let profiled = flat.clone().with_wells(&materials.wells);
    let centres = &materials.band_centres_hz;
    let at = |scene: &SceneSize, f: f64| {
        let s = WaveSettings { max_frequency_hz: f, ..settings.clone() };
        s.memory_estimate(scene, 1, bands_fitted(centres, f)).boundary_bytes
    };
    // Material 0 is the floor: 5 × 4 m = 20 m² of staircase area. Its deepest well (0.196 m)
    // keeps ⌊(4 d f / c + 1)/2⌋ + 3 branches: 3 at 150 and 343 Hz (its first resonance, 437 Hz,
    // lies above), 4 at 700 Hz.
    for (f, kept) in [(150.0, 3u64), (343.0, 3), (700.0, 4)] {
        let h: f64 = 343.0 / (10.0 * f);
        let faces = (20.0 / (h * h)).ceil() as u64;
        assert_eq!(at(&profiled, f) - at(&flat, f), faces * kept * 16, "{f} Hz");
    }
    // The largest frequency that fits a budget is lower with the wells than without.
    let budget = 2 * at(&profiled, 343.0) + 20_000_000;
    let fit = |scene: &SceneSize| settings.max_frequency_within(scene, 1, centres, budget).unwrap();
    assert!(fit(&profiled) < fit(&flat), "{} vs {}", fit(&profiled), fit(&flat));
}

/// Rigid walls (α 0 in every band: the fit gives no conductance and no branches) hold a rigid
/// node's 8 bytes and the shell's 4 a face, not a lossy node's; the estimate counts them so
/// (session 12) and stays at or above what is held, and the estimate made before the run from
/// `wall_fits` is the run's own.
#[test]
fn rigid_walls_are_counted_at_their_bytes_and_never_below_what_is_held() {
    let (mesh, mut materials, settings) = room();
    materials.absorption[4..8].copy_from_slice(&[0.0; 4]);
    let (est, held, _) = estimate_and_allocation(&mesh, &materials, &settings);
    let fitted = bands_fitted(&materials.band_centres_hz, settings.max_frequency_hz);
    let fits = wall_fits(&materials, &settings).unwrap();
    assert!(fits[1].admittance.is_rigid() && !fits[0].admittance.is_rigid());
    let seen = settings.memory_estimate(&SceneSize::of(&mesh).with_fits(&fits), 1, fitted);
    let all_lossy = settings.memory_estimate(&SceneSize::of(&mesh).with_fitted_branches(wall_branches(&materials, &settings).unwrap()), 1, fitted);
    let lossy_total = all_lossy.grid_bytes + all_lossy.boundary_bytes;
    println!("rigid walls: estimate {est} B, held {held} B ({:.3}); counting them as lossy {lossy_total} B ({:.3})", est as f64 / held as f64, lossy_total as f64 / held as f64);
    assert_eq!(seen.grid_bytes + seen.boundary_bytes, est);
    assert!(est >= held && est < lossy_total, "estimate {est} B, held {held} B, all lossy {lossy_total} B");
    assert!((est as f64) < 1.15 * held as f64, "estimate {est} B against {held} B held");
}
