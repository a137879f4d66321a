//! Physics checks of luminaires, skies, glazing and the work plane against closed forms in the
//! manner of CIE 171:2006 ("Test cases to assess the accuracy of lighting computer programs"):
//! a point source over a plane (E = I cos θ / d²), the sky through an opening, the integrating
//! sphere (inter-reflected illuminance ρΦ / (A(1 − ρ))), and what glazing lets through.
//! Every tolerance is stated beside its test, with the noise it has to cover.

use std::f64::consts::{PI, TAU};
use std::sync::Arc;

use glam::{DVec3, Vec3};
use sonolux_core::light::{trace_light_sources, DirectionTable, LightResult, LightSettings, LightSource, Lighting, Optics, Patches, WorkPlane};
use sonolux_core::sampling::Frame;
use sonolux_core::{Bvh, Mesh};

mod common;

fn run(mesh: &Mesh, optics: &Optics, lighting: Lighting, size: f64, particles: u64) -> LightResult {
    let bvh = Bvh::build(mesh).unwrap();
    let patches = Patches::new((0..mesh.triangles.len()).map(|t| mesh.corners(t).map(|v| v.as_dvec3())), size, 4096);
    let settings = LightSettings { particles, first_ray: 0, end_ray: particles, seed: 11, threads: 2, max_bounces: 100_000 };
    trace_light_sources(mesh, &bvh, optics, lighting, patches, &settings, |_| true).unwrap()
}

fn black(n: usize) -> Optics {
    Optics { rho: vec![[0.0; 3]; n], specular: vec![0.0; n], roughness: vec![0.5; n] }
}

/// A black square floor [-s, s]² at z = 0, facing up.
fn floor(s: f32) -> Mesh {
    let v = vec![Vec3::new(-s, -s, 0.0), Vec3::new(s, -s, 0.0), Vec3::new(s, s, 0.0), Vec3::new(-s, s, 0.0)];
    Mesh::new(v, vec![[0, 1, 2], [0, 2, 3]], vec![0, 0]).unwrap()
}

/// A luminaire's intensity table (cd) in its own frame: I(γ) = 800 (0.3 + cos²γ)(1 + 0.2 cos 2C),
/// tabulated every 2.5° of γ over the lower hemisphere and every 15° of C, as an IES file would.
fn luminaire() -> DirectionTable {
    let theta: Vec<f64> = (0..=36).map(|i| (i as f64 * 2.5).to_radians()).collect();
    let phi: Vec<f64> = (0..=24).map(|j| (j as f64 * 15.0).to_radians()).collect();
    let values = phi.iter().flat_map(|c| theta.iter().map(move |g| intensity(*g, *c))).collect();
    DirectionTable::new(theta, phi, values).unwrap()
}

fn intensity(gamma: f64, c: f64) -> f64 {
    800.0 * (0.3 + gamma.cos().powi(2)) * (1.0 + 0.2 * (2.0 * c).cos())
}

#[test]
fn point_source_over_a_plane_gives_i_cos_over_d_squared() {
    // A luminaire 2 m above a black floor, aimed down (C = 0 along +x, C = 90° along +y); a
    // work plane at 0.5 m with 0.5 m cells. Each cell's mean illuminance must match the mean
    // of E = I(γ, C) cos γ / d² over the cell (a 20 × 20 midpoint rule of the table as
    // interpolated) within 1 % at 20 cells from γ = 0 to about 60°. At 4·10⁷ particles the
    // least-lit of these cells takes 1.2·10⁵ hits: a noise of 0.3 %.
    let mesh = floor(20.0);
    let table = Arc::new(luminaire());
    let frame = Frame { t: DVec3::X, b: DVec3::Y, n: DVec3::NEG_Z };
    let height = 2.0;
    let source = LightSource::Point { position: DVec3::new(0.0, 0.0, height), frame, intensity: table.clone(), scale: [1.0; 3] };
    let plane = WorkPlane { height_m: 0.5, origin_m: [0.0, 0.0], spacing_m: 0.5, lo: [-6, -6], count: [13, 13] };
    let lighting = Lighting { sources: std::slice::from_ref(&source), transmittance: &[], work_plane: Some(&plane) };
    let res = run(&mesh, &black(1), lighting, 1.0, 40_000_000);
    let d = height - plane.height_m;
    let cells: Vec<(i64, i64)> = (0..5).flat_map(|i| (0..4).map(move |j| (i, j))).collect();
    for &(i, j) in &cells {
        let m = 20;
        let mut exact = 0.0;
        for a in 0..m {
            for b in 0..m {
                let x = (i as f64 - 0.5 + (a as f64 + 0.5) / m as f64) * plane.spacing_m;
                let y = (j as f64 - 0.5 + (b as f64 + 0.5) / m as f64) * plane.spacing_m;
                let r2 = x * x + y * y + d * d;
                let cos = d / r2.sqrt();
                exact += table.value(cos.acos(), y.atan2(x)) * cos / r2;
            }
        }
        exact /= (m * m) as f64;
        let index = ((j - plane.lo[1]) as usize) * plane.count[0] + (i - plane.lo[0]) as usize;
        let got = res.plane_flux[index][1] / (plane.spacing_m * plane.spacing_m);
        assert!((got / exact - 1.0).abs() < 0.01, "cell ({i}, {j}): {got:.3} lx vs {exact:.3} lx");
    }
    // The emitted flux is the table's integral ∫ I dω (exact for the interpolated table, here
    // against a fine quadrature of the closed form): within the 0.1 % noise of the weights.
    let mut flux = 0.0;
    let (nt, np) = (400, 400);
    for a in 0..nt {
        let g = (a as f64 + 0.5) / nt as f64 * PI / 2.0;
        for b in 0..np {
            flux += intensity(g, (b as f64 + 0.5) / np as f64 * TAU) * g.sin() * (PI / 2.0 / nt as f64) * (TAU / np as f64);
        }
    }
    assert!((res.stats.emitted[0] / flux - 1.0).abs() < 2e-3, "{} vs {flux}", res.stats.emitted[0]);
}

/// The CIE standard overcast sky, L(θ) = Lz (1 + 2 cos θ) / 3 (Moon & Spencer 1942; CIE S 011),
/// tabulated by travel direction: light from the sky at zenith angle θ travels with polar angle
/// π − θ from +z. Below the horizon (travel upwards) nothing.
fn overcast(lz: f64) -> DirectionTable {
    let theta: Vec<f64> = (0..=180).map(|i| (i as f64).to_radians()).collect();
    let values = theta.iter().map(|t| if *t >= PI / 2.0 { lz * (1.0 - 2.0 * t.cos()) / 3.0 } else { 0.0 }).collect();
    DirectionTable::new(theta, vec![0.0], values).unwrap()
}

/// A horizontal regular n-gon of radius r at height z, its triangles facing down.
fn opening(n: usize, r: f64, z: f64) -> Vec<[DVec3; 3]> {
    (0..n)
        .map(|k| {
            let p = |k: usize| { let a = TAU * k as f64 / n as f64; DVec3::new(r * a.cos(), r * a.sin(), z) };
            [DVec3::new(0.0, 0.0, z), p(k + 1), p(k)]
        })
        .collect()
}

#[test]
fn overcast_sky_through_a_round_opening_matches_its_closed_form() {
    // Under a round opening of angular radius α (seen from a point on its axis), the CIE
    // overcast sky gives E = (Lz / 3)(π sin²α + (4π / 3)(1 − cos³α)), from ∫ cos θ dω =
    // π sin²α and ∫ cos² θ dω = (2π / 3)(1 − cos³α) over the cone; the unobstructed
    // horizontal illuminance (α = 90°) is 7π Lz / 9, and the daylight factor E / (7π Lz / 9).
    // A cell of 0.4 m under an opening of 1 m radius 1 m above the plane: its mean is the
    // area integral ∫ L(θ) h² / r⁴ dA over the disc, averaged over the cell by quadrature
    // (equal to the closed form on the axis, checked first); the 360-gon's area differs from
    // the disc's by 5·10⁻⁵. 10⁷ particles put 3·10⁵ paths through the cell (0.2 % noise);
    // tolerance 1 %.
    let lz = 3000.0;
    let table = Arc::new(overcast(lz));
    let sources: Vec<LightSource> = opening(360, 1.0, 1.5)
        .into_iter()
        .map(|corners| LightSource::Sky { corners, radiance: table.clone(), scale: [1.0; 3] })
        .collect();
    // The total that enters: the opening's area times the unobstructed horizontal illuminance.
    let area: f64 = sources.iter().map(|s| { let c = s.corners().unwrap(); 0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length() }).sum();
    let e_h = 7.0 * PI * lz / 9.0;
    let plane = WorkPlane { height_m: 0.5, origin_m: [0.0, 0.0], spacing_m: 0.4, lo: [0, 0], count: [1, 1] };
    let lighting = Lighting { sources: &sources, transmittance: &[], work_plane: Some(&plane) };
    let res = run(&floor(10.0), &black(1), lighting, 1.0, 10_000_000);
    assert!((res.stats.emitted[0] / (area * e_h) - 1.0).abs() < 2e-3, "{} vs {}", res.stats.emitted[0], area * e_h);
    let alpha = (1.0f64 / 1.0).atan();
    let e_axis = lz / 3.0 * (PI * alpha.sin().powi(2) + 4.0 * PI / 3.0 * (1.0 - alpha.cos().powi(3)));
    // E at (x, y) on the plane, h below the disc: ∫∫ L(θ) cos²θ / r² dA in polar coordinates
    // about the disc's centre, cos θ = h / r.
    let h = 1.0;
    let e_at = |x: f64, y: f64| {
        let (nr, na) = (200, 200);
        let mut e = 0.0;
        for a in 0..nr {
            let rho = (a as f64 + 0.5) / nr as f64;
            for b in 0..na {
                let phi = (b as f64 + 0.5) / na as f64 * TAU;
                let (dx, dy) = (rho * phi.cos() - x, rho * phi.sin() - y);
                let r2 = dx * dx + dy * dy + h * h;
                let cos = h / r2.sqrt();
                e += lz * (1.0 + 2.0 * cos) / 3.0 * cos * cos / r2 * rho * (1.0 / nr as f64) * (TAU / na as f64);
            }
        }
        e
    };
    assert!((e_at(0.0, 0.0) / e_axis - 1.0).abs() < 1e-4, "quadrature {} vs closed form {e_axis}", e_at(0.0, 0.0));
    let m = 6;
    let cell_mean = (0..m * m).map(|k| e_at(((k % m) as f64 + 0.5) / m as f64 * 0.4 - 0.2, ((k / m) as f64 + 0.5) / m as f64 * 0.4 - 0.2)).sum::<f64>() / (m * m) as f64;
    let got = res.plane_flux[0][0] / 0.16;
    assert!((got / cell_mean - 1.0).abs() < 0.01, "{got} lx vs {cell_mean} lx (daylight factor on the axis {:.4})", e_axis / e_h);
}

#[test]
fn glazing_passes_its_transmittance_and_flux_is_conserved() {
    // A downward luminaire above a horizontal pane (τ = 0.6, ρ = 0.08) that covers the whole
    // floor plan of a closed black box; the work plane below reads 0.6 × what it reads with no
    // pane, and the light reflected off the pane is absorbed by the black box. Same seed, same
    // emission: the two runs differ only at the pane; tolerance 1.5 % on 2·10⁶ particles (the
    // ratio's noise is about 0.4 % since only 40 % of paths differ).
    let room = common::shoebox(4.0, 4.0, 3.0, [0; 6]);
    // Inset 1 mm from the walls, so that no path passes through the pane where it meets a wall
    // (the 0.1 % gap changes the ratio by less than 0.1 %).
    let pane = common::cuboid(Vec3::new(0.001, 0.001, 1.5), Vec3::new(3.999, 3.999, 1.5), [1, 0, 0, 0, 0, 0], true);
    let pane = Mesh::new(pane.vertices, pane.triangles[..2].to_vec(), vec![1, 1]).unwrap();
    let mesh = common::merge(&[room.clone(), pane]);
    let source = LightSource::Point { position: DVec3::new(2.0, 2.0, 2.8), frame: Frame::from_normal(DVec3::NEG_Z), intensity: Arc::new(luminaire()), scale: [1.0; 3] };
    let plane = WorkPlane { height_m: 0.8, origin_m: [2.0, 2.0], spacing_m: 1.0, lo: [-1, -1], count: [3, 3] };
    let mut optics = black(2);
    optics.rho[1] = [0.08; 3];
    let tau = [[0.0; 3], [0.6; 3]];
    let with = run(&mesh, &optics, Lighting { sources: std::slice::from_ref(&source), transmittance: &tau, work_plane: Some(&plane) }, 0.5, 2_000_000);
    let without = run(&room, &black(1), Lighting { sources: std::slice::from_ref(&source), transmittance: &[], work_plane: Some(&plane) }, 0.5, 2_000_000);
    let sum = |r: &LightResult| r.plane_flux.iter().map(|f| f[0]).sum::<f64>();
    let ratio = sum(&with) / sum(&without);
    assert!((ratio - 0.6).abs() < 0.6 * 0.015, "work plane behind the pane: {ratio}");
    let s = &with.stats;
    for c in 0..3 {
        let (lhs, rhs) = (s.emitted[c] + s.roulette[c], s.absorbed[c] + s.escaped[c]);
        assert!(((lhs - rhs) / s.emitted[c]).abs() < 1e-9, "channel {c}: {lhs} vs {rhs}");
    }
    assert_eq!(s.escaped_particles, 0, "the box is closed");
}

/// An icosphere of radius r: the icosahedron subdivided `levels` times, vertices pushed to the
/// sphere, faces wound to face the centre.
fn icosphere(r: f32, levels: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [[-1.0, t, 0.0], [1.0, t, 0.0], [-1.0, -t, 0.0], [1.0, -t, 0.0], [0.0, -1.0, t], [0.0, 1.0, t], [0.0, -1.0, -t], [0.0, 1.0, -t], [t, 0.0, -1.0], [t, 0.0, 1.0], [-t, 0.0, -1.0], [-t, 0.0, 1.0]]
        .iter()
        .map(|p| Vec3::from_array(*p).normalize())
        .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut cache = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
            v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
            v.len() as u32 - 1
        });
        f = f.iter().flat_map(|&[a, b, c]| { let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v)); [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]] }).collect();
    }
    // The icosahedron's faces are wound outwards; a room's face the centre.
    let tris = f.into_iter().map(|[a, b, c]| [a, c, b]).collect::<Vec<_>>();
    let n = tris.len();
    Mesh::new(v.into_iter().map(|p| p * r).collect(), tris, vec![0; n]).unwrap()
}

/// Solid angle of triangle (a, b, c) seen from the origin (Van Oosterom & Strackee 1983).
fn solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

#[test]
fn integrating_sphere_inter_reflection_is_uniform_and_analytic() {
    // CIE 171:2006 §5.x-style integrating sphere: inside a sphere of reflectance ρ, whatever
    // the source, the inter-reflected illuminance is ρ Φ / (A (1 − ρ)) on every element (the
    // configuration factor between any two elements of a sphere is dA / A). An off-centre
    // luminaire with a strongly non-uniform table; the direct part of each facet is I × its
    // solid angle, subtracted exactly. The faceted sphere (1280 triangles) departs from a
    // sphere by < 0.3 % in configuration factors. Tolerance: the mean over all facets within
    // 1 % (its noise is about 0.05 %); every facet within 5 σ + 1 % of the analytic value, σ
    // being its illuminance / √(hits), the noise of the direct part included.
    let rho = 0.6;
    let mesh = icosphere(2.0, 3);
    let optics = Optics { rho: vec![[rho; 3]], specular: vec![0.0], roughness: vec![0.5] };
    let table = Arc::new(luminaire());
    let pos = DVec3::new(0.4, -0.3, 0.5);
    let frame = Frame::from_normal(DVec3::new(0.3, 0.2, -1.0).normalize());
    let source = LightSource::Point { position: pos, frame, intensity: table.clone(), scale: [1.0; 3] };
    let res = run(&mesh, &optics, Lighting { sources: std::slice::from_ref(&source), transmittance: &[], work_plane: None }, 100.0, 4_000_000);
    let phi = res.stats.emitted[0];
    let area: f64 = res.patches.area.iter().sum();
    let expected = rho * phi / (area * (1.0 - rho));
    let mut sum = 0.0;
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(t).map(|v| v.as_dvec3() - pos);
        // Direct: the table over the facet's solid angle, by 4 × 4 sub-triangle midpoints.
        let omega = solid_angle(a, b, c);
        let mut mean_i = 0.0;
        let k = 6;
        for i in 0..k {
            for j in 0..k - i {
                let (s, u) = ((i as f64 + 1.0 / 3.0) / k as f64, (j as f64 + 1.0 / 3.0) / k as f64);
                let d = (a + (b - a) * s + (c - a) * u).normalize();
                let local = DVec3::new(d.dot(frame.t), d.dot(frame.b), d.dot(frame.n));
                mean_i += table.value_local(local);
            }
        }
        mean_i /= (k * (k + 1) / 2) as f64;
        let direct = mean_i * omega / res.patches.area[t];
        let indirect = res.flux[t][0] / res.patches.area[t] - direct;
        let sigma = res.flux[t][0] / res.patches.area[t] / (res.hits[t] as f64).sqrt();
        assert!((indirect - expected).abs() < 5.0 * sigma + 0.01 * expected, "facet {t}: {indirect} vs {expected} (σ {sigma})");
        sum += indirect * res.patches.area[t];
    }
    let mean = sum / area;
    assert!((mean / expected - 1.0).abs() < 0.01, "mean {mean} vs {expected}");
}

#[test]
fn sources_are_the_same_bits_on_any_thread_count() {
    let mesh = common::shoebox(3.0, 3.0, 3.0, [0; 6]);
    let optics = Optics { rho: vec![[0.7, 0.5, 0.3]], specular: vec![0.2], roughness: vec![0.3] };
    let sky = Arc::new(overcast(1000.0));
    let sources = vec![
        LightSource::Point { position: DVec3::new(1.5, 1.5, 2.5), frame: Frame::from_normal(DVec3::NEG_Z), intensity: Arc::new(luminaire()), scale: [1.0, 0.9, 0.8] },
        LightSource::Sky { corners: [DVec3::new(1.0, 1.0, 2.99), DVec3::new(2.0, 2.0, 2.99), DVec3::new(2.0, 1.0, 2.99)], radiance: sky, scale: [1.0; 3] },
        LightSource::Sun { corners: [DVec3::new(1.0, 1.0, 2.99), DVec3::new(2.0, 2.0, 2.99), DVec3::new(2.0, 1.0, 2.99)], direction: DVec3::new(0.3, 0.1, -1.0).normalize(), irradiance: [5e4; 3] },
    ];
    let plane = WorkPlane { height_m: 0.8, origin_m: [1.5, 1.5], spacing_m: 0.5, lo: [-3, -3], count: [7, 7] };
    let bvh = Bvh::build(&mesh).unwrap();
    let go = |threads| {
        let patches = Patches::new((0..mesh.triangles.len()).map(|t| mesh.corners(t).map(|v| v.as_dvec3())), 0.5, 4096);
        let settings = LightSettings { particles: 50_000, first_ray: 0, end_ray: 50_000, seed: 3, threads, max_bounces: 1000 };
        let lighting = Lighting { sources: &sources, transmittance: &[], work_plane: Some(&plane) };
        trace_light_sources(&mesh, &bvh, &optics, lighting, patches, &settings, |_| true).unwrap()
    };
    let (a, b) = (go(1), go(2));
    assert_eq!(a.flux, b.flux);
    assert_eq!(a.plane_flux, b.plane_flux);
    assert!(a.plane_flux.iter().any(|f| f[0] > 0.0));
}
