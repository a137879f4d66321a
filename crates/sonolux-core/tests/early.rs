//! Image sources on meshes against closed forms and an independent path check.

use std::f64::consts::PI;

use glam::{DVec3, Vec3};
use sonolux_core::early::{early_arrivals, ArrivalKind, EarlyResult, EarlySettings};
use sonolux_core::sound::{Acoustics, Directivity, SoundSource};
use sonolux_core::{Bvh, Mesh};

mod common;

const C: f64 = 343.0;
const FS: f64 = 48_000.0;

/// Per face (floor, ceiling, south, north, west, east) and band: distinct absorption and
/// scattering, so that a wrong wall or band shows.
fn shoebox_acoustics(bands: usize) -> Acoustics {
    let (mut a, mut s) = (Vec::new(), Vec::new());
    for face in 0..6 {
        for b in 0..bands {
            a.push(0.05 + 0.07 * face as f64 + 0.02 * b as f64);
            s.push(0.02 * face as f64 + 0.05 * b as f64);
        }
    }
    Acoustics { n_bands: bands, absorption: a, scattering: s }
}

fn omni(p: DVec3) -> SoundSource {
    SoundSource { position: p, power_w: 1.0, directivity: Directivity::Omni }
}

fn settings(bands: usize, max_order: u32, max_time_s: f64, threads: usize) -> EarlySettings {
    let mut s = EarlySettings::octaves(bands);
    s.max_order = max_order;
    s.max_time_s = max_time_s;
    s.speed_of_sound_m_s = C;
    s.air_attenuation_per_m = (0..bands).map(|b| 0.001 * b as f64).collect();
    s.threads = threads;
    s
}

/// The shoebox's images in closed form (Allen and Berkley 1979): per axis an image at
/// 2 n L + (1 − 2q) x, reflected |n − q| times on the wall at 0 and |n| times at L.
/// Returns (time, energy per band) of every image within `max_time_s`, sorted by time.
fn closed_form(dims: [f64; 3], src: DVec3, rcv: DVec3, ac: &Acoustics, air: &[f64], max_time_s: f64) -> Vec<(f64, Vec<f64>)> {
    let nb = ac.n_bands;
    // Face order of common::shoebox: z=0, z=h, y=0, y=w, x=0, x=l → per axis (low, high) faces.
    let faces = [(4, 5), (2, 3), (0, 1)];
    let keep = |f: usize, b: usize| (1.0 - ac.absorption[f * nb + b]) * (1.0 - ac.scattering[f * nb + b]);
    let reach = (max_time_s * C / (2.0 * dims.iter().cloned().fold(f64::INFINITY, f64::min))).ceil() as i64 + 1;
    let mut out = Vec::new();
    for nx in -reach..=reach {
        for ny in -reach..=reach {
            for nz in -reach..=reach {
                for q in 0..8 {
                    let n = [nx, ny, nz];
                    let mut img = DVec3::ZERO;
                    let mut e: Vec<f64> = vec![1.0; nb];
                    for ax in 0..3 {
                        let qa = (q >> ax) & 1;
                        img[ax] = 2.0 * n[ax] as f64 * dims[ax] + (1 - 2 * qa) as f64 * src[ax];
                        let (lo, hi) = ((n[ax] - qa as i64).unsigned_abs() as i32, n[ax].unsigned_abs() as i32);
                        for (b, eb) in e.iter_mut().enumerate() {
                            *eb *= keep(faces[ax].0, b).powi(lo) * keep(faces[ax].1, b).powi(hi);
                        }
                    }
                    let d = (img - rcv).length();
                    if d / C > max_time_s {
                        continue;
                    }
                    for b in 0..nb {
                        e[b] *= (-air[b] * d).exp() / (4.0 * PI * d * d);
                    }
                    out.push((d / C, e));
                }
            }
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

fn run(mesh: &Mesh, ac: &Acoustics, src: &[SoundSource], rcv: &[DVec3], set: &EarlySettings) -> EarlyResult {
    let bvh = Bvh::build(mesh).unwrap();
    early_arrivals(mesh, &bvh, ac, src, rcv, set, None).unwrap()
}

#[test]
fn shoebox_arrivals_equal_the_closed_form_image_enumeration() {
    // Each wall cut into two triangles; generic positions so that no two images tie.
    // The walls sit where f32 puts them; the closed form uses the same positions.
    let dims = [7.3f32 as f64, 5.1f32 as f64, 3.2f32 as f64];
    let mesh = common::shoebox(dims[0] as f32, dims[1] as f32, dims[2] as f32, [0, 1, 2, 3, 4, 5]);
    let ac = shoebox_acoustics(3);
    let (src, rcv) = (DVec3::new(1.73, 1.21, 1.37), DVec3::new(5.11, 3.67, 1.62));
    let set = settings(3, 12, 0.045, 2);
    let expected = closed_form(dims, src, rcv, &ac, &set.air_attenuation_per_m, set.max_time_s);
    let res = run(&mesh, &ac, &[omni(src)], &[rcv], &set);
    assert!(expected.len() >= 50, "only {} images within the time", expected.len());
    // Every image within the time, not only the first 50: time to 1e-9 s (far below a sample),
    // energy to 0.1 dB (the computations differ only by rounding, so 1e-9 relative is reached).
    assert_eq!(res.arrivals.len(), expected.len(), "arrival count");
    for (i, (a, (t, e))) in res.arrivals.iter().zip(&expected).enumerate() {
        assert!((a.time_s - t).abs() < 1e-9, "arrival {i}: {} s, closed form {t} s", a.time_s);
        assert_eq!((a.time_s * FS).round(), (t * FS).round(), "arrival {i}: sample");
        for (b, eb) in e.iter().enumerate().take(3) {
            let db = 10.0 * (res.energy_of(i)[b] / eb).log10();
            assert!(db.abs() < 0.1 && db.abs() < 1e-7, "arrival {i} band {b}: {db} dB");
        }
        // The direction points at the image.
        assert!((a.from_direction.length() - 1.0).abs() < 1e-12);
    }
    assert_eq!(res.arrivals[0].kind, ArrivalKind::Specular { order: 0 });
}

#[test]
fn triangulation_does_not_change_the_arrivals() {
    // Each wall of the box cut into many triangles: the planes merge, the arrivals stay.
    let dims = [6.1f32, 4.3, 2.9];
    let coarse = common::shoebox(dims[0], dims[1], dims[2], [0, 1, 2, 3, 4, 5]);
    let fine = subdivide(&subdivide(&subdivide(&coarse)));
    let ac = shoebox_acoustics(2);
    let src = [omni(DVec3::new(1.3, 2.9, 1.1))];
    let rcv = [DVec3::new(4.7, 0.9, 1.7), DVec3::new(2.2, 2.2, 2.2)];
    let set = settings(2, 4, 0.05, 1);
    let a = run(&coarse, &ac, &src, &rcv, &set);
    let b = run(&fine, &ac, &src, &rcv, &set);
    assert_eq!(a.stats.planes, 6);
    assert_eq!(b.stats.planes, 6);
    assert_eq!(a.arrivals.len(), b.arrivals.len());
    for (x, y) in a.arrivals.iter().zip(&b.arrivals) {
        assert_eq!((x.receiver, x.kind), (y.receiver, y.kind));
        assert!((x.time_s - y.time_s).abs() < 1e-12);
    }
}

/// Each triangle split in four at its edge midpoints.
fn subdivide(m: &Mesh) -> Mesh {
    let (mut v, mut t, mut mat) = (m.vertices.clone(), Vec::new(), Vec::new());
    for (i, tri) in m.triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|k| m.vertices[k as usize]);
        let base = v.len() as u32;
        v.extend([(a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5]);
        let (ab, bc, ca) = (base, base + 1, base + 2);
        t.extend([[tri[0], ab, ca], [ab, tri[1], bc], [ca, bc, tri[2]], [ab, bc, ca]]);
        mat.extend([m.material[i]; 4]);
    }
    Mesh::new(v, t, mat).unwrap()
}

#[test]
fn same_bits_on_one_and_two_threads() {
    let mesh = l_room();
    let ac = Acoustics { n_bands: 2, absorption: vec![0.1, 0.2, 0.3, 0.4, 0.05, 0.1], scattering: vec![0.0, 0.1, 0.2, 0.3, 0.1, 0.1] };
    let src = [omni(DVec3::new(2.0, 1.5, 1.2)), omni(DVec3::new(6.5, 2.5, 1.7))];
    let rcv: Vec<DVec3> = (0..7).map(|i| DVec3::new(1.0 + 0.4 * i as f64, 6.5 - 0.7 * i as f64, 1.5)).collect();
    let mut set = settings(2, 3, 0.06, 1);
    set.diffraction = true;
    set.level_of_detail = true;
    let one = run(&mesh, &ac, &src, &rcv, &set);
    set.threads = 2;
    let two = run(&mesh, &ac, &src, &rcv, &set);
    assert!(one.stats.diffracted_arrivals > 0 && one.stats.specular_arrivals > 0);
    assert_eq!(one.arrivals, two.arrivals);
    assert_eq!(one.energy.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), two.energy.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
}

/// The L-shaped floor plan (counter-clockwise seen from above).
const L_PLAN: [(f64, f64); 6] = [(0.0, 0.0), (8.0, 0.0), (8.0, 4.0), (4.0, 4.0), (4.0, 8.0), (0.0, 8.0)];
const L_HEIGHT: f64 = 3.0;

/// The L plan extruded to 3 m, normals facing into the room; material 0 floor, 1 ceiling,
/// 2 walls.
fn l_room() -> Mesh {
    let n = L_PLAN.len();
    let mut v: Vec<Vec3> = Vec::new();
    for z in [0.0, L_HEIGHT] {
        v.extend(L_PLAN.iter().map(|&(x, y)| Vec3::new(x as f32, y as f32, z as f32)));
    }
    let (mut t, mut m) = (Vec::new(), Vec::new());
    // Floor and ceiling: a fan from the reflex corner (4, 4), from which the plan is star-shaped.
    let hub = 3u32;
    for i in 0..n as u32 {
        let j = (i + 1) % n as u32;
        if i == hub || j == hub {
            continue;
        }
        t.push([hub, i, j]);
        m.push(0);
        t.push([hub + n as u32, j + n as u32, i + n as u32]);
        m.push(1);
    }
    for i in 0..n as u32 {
        let j = (i + 1) % n as u32;
        // Counter-clockwise plan: the inside is on the left, so (i, j+n, j) faces in.
        t.push([i, j + n as u32, j]);
        t.push([i, i + n as u32, j + n as u32]);
        m.extend([2, 2]);
    }
    Mesh::new(v, t, m).unwrap()
}

/// Whether the point lies inside the L room (closed), by its plan and height.
fn inside_l(p: DVec3) -> bool {
    let tol = 1e-9;
    let in_plan = (p.x >= -tol && p.x <= 8.0 + tol && p.y >= -tol && p.y <= 4.0 + tol) || (p.x >= -tol && p.x <= 4.0 + tol && p.y >= -tol && p.y <= 8.0 + tol);
    in_plan && p.z >= -tol && p.z <= L_HEIGHT + tol
}

/// An independent check of an image path in the L room: mirror the receiver's line back through
/// the planes by the planes' equations alone and require every reflection point to lie on the
/// room's boundary and every leg to stay inside the room (sampled every 5 mm): no BVH involved.
fn l_room_path_is_valid(planes: &[(DVec3, f64)], src: DVec3, rcv: DVec3) -> Option<f64> {
    let mut images = vec![src];
    for &(n, d) in planes {
        let p = *images.last().unwrap();
        images.push(p - 2.0 * (n.dot(p) - d) * n);
    }
    let mut from = rcv;
    let mut legs = Vec::new();
    for k in (0..planes.len()).rev() {
        let (n, d) = planes[k];
        let img = images[k + 1];
        let (df, di) = (n.dot(from) - d, n.dot(img) - d);
        if df * di >= 0.0 || df.is_nan() || di.is_nan() {
            return None;
        }
        let p = from + (img - from) * (df / (df - di));
        // The reflection point must lie on the room's boundary, not on a plane's extension
        // through the room: a step off the plane is inside on one side, outside on the other.
        if inside_l(p + 1e-6 * n) == inside_l(p - 1e-6 * n) {
            return None;
        }
        legs.push((from, p));
        from = p;
    }
    legs.push((from, src));
    for (a, b) in legs {
        let steps = ((b - a).length() / 0.005).ceil() as usize;
        for s in 0..=steps {
            if !inside_l(a + (b - a) * (s as f64 / steps as f64)) {
                return None;
            }
        }
    }
    Some((images.last().unwrap() - rcv).length())
}

#[test]
fn l_room_has_exactly_the_visible_image_paths() {
    let mesh = l_room();
    let ac = Acoustics { n_bands: 1, absorption: vec![0.1, 0.1, 0.1], scattering: vec![0.0; 3] };
    // Source in the east leg, receivers around the corner in the north leg and in view.
    let src = DVec3::new(6.7, 1.3, 1.2);
    let rcv = [DVec3::new(1.6, 6.9, 1.5), DVec3::new(2.1, 2.3, 1.4), DVec3::new(3.3, 5.2, 2.1)];
    let max_order = 3;
    let set = settings(1, max_order, 0.1, 2);
    let res = run(&mesh, &ac, &[omni(src)], &rcv, &set);
    // The room's planes: floor, ceiling, and the six walls of the plan.
    let mut planes: Vec<(DVec3, f64)> = vec![(DVec3::Z, 0.0), (DVec3::Z, L_HEIGHT)];
    for i in 0..6 {
        let (a, b) = (L_PLAN[i], L_PLAN[(i + 1) % 6]);
        let n = DVec3::new(b.1 - a.1, a.0 - b.0, 0.0).normalize();
        planes.push((n, n.x * a.0 + n.y * a.1));
    }
    for (r, &p) in rcv.iter().enumerate() {
        // Every plane sequence without repeats in a row, up to the order.
        let mut expected: Vec<f64> = Vec::new();
        let mut seqs: Vec<Vec<usize>> = vec![vec![]];
        for _ in 0..max_order {
            let next: Vec<Vec<usize>> = seqs
                .iter()
                .filter(|s| s.len() == seqs.last().unwrap().len())
                .flat_map(|s| (0..planes.len()).filter(move |&q| s.last() != Some(&q)).map(move |q| [s.clone(), vec![q]].concat()))
                .collect();
            seqs.extend(next);
        }
        for s in &seqs {
            let chosen: Vec<(DVec3, f64)> = s.iter().map(|&q| planes[q]).collect();
            if let Some(len) = l_room_path_is_valid(&chosen, src, p) {
                if len / C <= set.max_time_s {
                    expected.push(len / C);
                }
            }
        }
        expected.sort_by(f64::total_cmp);
        let got: Vec<f64> = res.arrivals.iter().filter(|a| a.receiver == r as u32).map(|a| a.time_s).collect();
        assert_eq!(got.len(), expected.len(), "receiver {r}: {got:?} against {expected:?}");
        for (g, e) in got.iter().zip(&expected) {
            assert!((g - e).abs() < 1e-9, "receiver {r}: {g} against {e}");
        }
    }
    // The receiver around the corner does not hear the source directly.
    assert!(!res.arrivals.iter().any(|a| a.receiver == 0 && a.kind == ArrivalKind::Specular { order: 0 }));
    assert!(res.arrivals.iter().any(|a| a.receiver == 1 && a.kind == ArrivalKind::Specular { order: 0 }));
}

#[test]
fn level_of_detail_leaves_a_rooms_corners_alone_and_thins_a_small_free_plate() {
    // A shoebox's walls meet only at interior right angles, where the image sources are exact:
    // level of detail must not change any arrival, even at 63 Hz on a 3 m wall.
    let mesh = common::shoebox(7.0, 5.0, 3.0, [0, 1, 2, 3, 4, 5]);
    let ac = shoebox_acoustics(3);
    let (src, rcv) = (DVec3::new(1.73, 1.21, 1.37), DVec3::new(5.11, 3.67, 1.62));
    let mut set = settings(3, 3, 0.05, 1);
    set.band_centres_hz = vec![63.0, 500.0, 4000.0];
    let plain = run(&mesh, &ac, &[omni(src)], &[rcv], &set);
    set.level_of_detail = true;
    let lod = run(&mesh, &ac, &[omni(src)], &[rcv], &set);
    assert_eq!(plain.energy, lod.energy);
    // A 0.4 m plate hung in the room has free edges: its reflection keeps Rindel's K, well below
    // 1 at 63 Hz and larger at 4 kHz; the room's own reflections are unchanged.
    let (mut vertices, mut triangles, mut material) = (mesh.vertices.clone(), mesh.triangles.clone(), mesh.material.clone());
    let base = vertices.len() as u32;
    for (x, y) in [(3.3, 2.3), (3.7, 2.3), (3.7, 2.7), (3.3, 2.7)] {
        vertices.push(Vec3::new(x, y, 2.5));
    }
    triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    material.extend([0, 0]);
    let plate = Mesh::new(vertices, triangles, material).unwrap();
    let (s2, r2) = (DVec3::new(2.9, 2.1, 1.2), DVec3::new(4.1, 2.9, 1.3));
    set.level_of_detail = false;
    let plain = run(&plate, &ac, &[omni(s2)], &[r2], &set);
    set.level_of_detail = true;
    let lod = run(&plate, &ac, &[omni(s2)], &[r2], &set);
    assert_eq!(plain.arrivals.len(), lod.arrivals.len());
    let mut changed = 0;
    for i in 0..plain.arrivals.len() {
        let (p, l) = (plain.energy_of(i), lod.energy_of(i));
        if p != l {
            changed += 1;
            assert!(l[0] < 0.05 * p[0] && l[0] / p[0] < l[2] / p[2] && l[2] <= p[2], "{p:?} {l:?}");
        }
    }
    assert!(changed > 0, "no reflection on the plate");
}
