//! First-order edge diffraction by the Biot–Tolstoy–Medwin secondary-source model.
//!
//! Why BTM and not the UTD: the BTM expression of Svensson, Fred and Vanderkooy ("An analytic
//! secondary source model of edge diffraction impulse responses", JASA 106(5), 1999) is exact
//! for a rigid wedge of any open angle and finite length, valid at any frequency and distance
//! (the UTD of Kouyoumjian and Pathak is a high-frequency asymptote that fails close to edges
//! and at low frequencies, which are exactly where diffraction matters indoors), it is an
//! impulse response, so it gives every band at once and a sample-exact onset, and its finite
//! edges let visibility cut an edge into pieces with the right end effects.
//!
//! The edge integral itself, binned in time with bounded work near zone boundaries, is
//! [`super::btm`].
//!
//! Per band the energy is the mean of |H(f)|² over the band (the DFT of the binned response,
//! divided by the bins' sinc), as a source of white power spectrum would give. Across a shadow
//! boundary the geometric sound jumps and the diffracted sound jumps by the opposite amount;
//! only their coherent sum is continuous. So each diffracted arrival also carries its cross
//! terms with the geometric arrivals its edge bounds (the emitter's own arrival and its images
//! in the edge's two faces): 2 Re⟨G D*⟩ per band. Away from boundaries they average to nearly
//! zero; at a boundary they make the sum of the arrivals' energies continuous. When the sum is
//! negative (the lit side of a boundary, where D subtracts), the deficit is taken from the
//! largest geometric arrival of the group, so no arrival has a negative energy.

use std::f64::consts::PI;

use glam::DVec3;
use num_complex::Complex64;

pub use super::btm::{band_frequencies, binned_response, internal_rate_hz, spectrum, stand_in_spectrum, BinnedResponse, WedgeGeometry, FREQUENCIES_PER_BAND};
use super::edges::Wedge;
use super::image_sources::ImageTree;
use super::{directivity_gain, Arrival, ArrivalKind, Context, PairArrivals};
use crate::geometry::Ray;

/// Whether the segment from `p` to `q` is free.
fn free(ctx: &Context, p: DVec3, q: DVec3) -> bool {
    let d = q - p;
    let len = d.length();
    let e = ctx.epsilon_m / len;
    !ctx.bvh.occluded(&Ray::new(p.as_vec3(), d.as_vec3()), e as f32, (1.0 - e) as f32)
}

/// Whether edge point `q` hears emitter `node` of `tree`: directly for the source, through a
/// valid reflection in the image's plane (then free on to the source) for a first-order image.
/// Returns the point where the path leaves the source (for its directivity) when it does.
fn emitter_sees(ctx: &Context, tree: &ImageTree, node: u32, q: DVec3) -> Option<DVec3> {
    let src = tree.nodes[0].position;
    if node == 0 {
        return free(ctx, q, src).then_some(q);
    }
    let img = &tree.nodes[node as usize];
    let plane = &ctx.planes.planes[img.plane as usize];
    let (dq, di) = (plane.distance(q), plane.distance(img.position));
    if !(dq * di < 0.0) {
        return None;
    }
    let dir = img.position - q;
    let t = dq / (dq - di);
    let len = dir.length();
    let hit = ctx.bvh.closest_hit(&Ray::new(q.as_vec3(), dir.as_vec3()), (ctx.epsilon_m / len) as f32, (t + 4.0 * ctx.epsilon_m / len) as f32)?;
    if ctx.planes.plane_of_triangle[hit.triangle as usize] != img.plane {
        return None;
    }
    let p = q + dir * t;
    free(ctx, p, src).then_some(p)
}

/// Adds the diffracted arrivals of source `s` at receiver `r`: around every wedge, from the
/// source and from its first-order images, with their cross terms (see the module docs).
pub(crate) fn add_arrivals(ctx: &Context, tree: &ImageTree, wedges: &[Wedge], s: usize, r: usize, receiver: DVec3, out: &mut PairArrivals) {
    let set = ctx.settings;
    let nb = out.n_bands;
    let c = set.speed_of_sound_m_s;
    let band_edges: Vec<(f64, f64)> = (0..nb).map(|b| set.band_edges_hz(b)).collect();
    let freqs = band_frequencies(&band_edges);
    let fs = internal_rate_hz(&band_edges);
    let max_path = set.max_time_s * c;
    let src = &ctx.sources[s];
    let n_specular = out.arrivals.len();
    let emitters: Vec<u32> = (0..tree.nodes.len() as u32).filter(|&i| tree.nodes[i as usize].order <= 1.min(set.max_order)).collect();
    for &e in &emitters {
        let node = &tree.nodes[e as usize];
        for (w_index, w) in wedges.iter().enumerate() {
            if node.plane != u32::MAX && w.planes.contains(&node.plane) {
                continue; // an edge of the image's own plane: its boundary is the source's diffraction
            }
            let (cs, cr) = (w.cylindrical(node.position), w.cylindrical(receiver));
            let inside = |(rr, th, _): (f64, f64, f64)| rr > 1e-9 && th > 1e-9 && th < w.open_angle_rad - 1e-9;
            if !inside(cs) || !inside(cr) {
                continue;
            }
            let mut g = WedgeGeometry::new(w.open_angle_rad, cs, cr);
            // The geometric arrivals this edge bounds: the emitter's own and its images in the
            // edge's faces; their presence settles a receiver that lies on a zone boundary.
            let group: Vec<usize> = (0..n_specular)
                .filter(|&i| {
                    let a = &out.arrivals[i];
                    a.image == e || w.planes.iter().any(|&p| tree.nodes[a.image as usize].parent == e && tree.nodes[a.image as usize].plane == p && a.image != 0)
                })
                .collect();
            let heard = |plane: u32| group.iter().any(|&i| out.arrivals[i].image != e && tree.nodes[out.arrivals[i].image as usize].plane == plane);
            let direct = group.iter().any(|&i| out.arrivals[i].image == e);
            g.settle_on_side(ctx.epsilon_m / cr.0, direct, [heard(w.planes[0]), heard(w.planes[1])]);
            if g.path(g.apex().clamp(0.0, w.length_m())) > max_path {
                continue;
            }
            // Visible parts of the edge: pieces that both ends see.
            let len = w.length_m();
            let pieces = (len / set.diffraction_piece_m).ceil().max(1.0) as usize;
            let offset = w.bisector() * ctx.epsilon_m * 10.0;
            let mut runs: Vec<(f64, f64)> = Vec::new();
            let mut leave_dir = None;
            for k in 0..pieces {
                let (z1, z2) = (len * k as f64 / pieces as f64, len * (k + 1) as f64 / pieces as f64);
                let q = w.start + w.along * (0.5 * (z1 + z2)) + offset;
                if !free(ctx, q, receiver) {
                    continue;
                }
                let Some(p) = emitter_sees(ctx, tree, e, q) else { continue };
                leave_dir.get_or_insert(p);
                match runs.last_mut() {
                    Some(last) if last.1 == z1 => last.1 = z2,
                    _ => runs.push((z1, z2)),
                }
            }
            out.checked += 1;
            if runs.is_empty() {
                continue;
            }
            // The response of the visible parts, and its onset point.
            let mut h = vec![Complex64::new(0.0, 0.0); freqs.len()];
            let mut stand_in = vec![vec![Complex64::new(0.0, 0.0); freqs.len()]; 3];
            let (mut onset, mut apex_z) = (f64::INFINITY, 0.0);
            for &(z1, z2) in &runs {
                let response = binned_response(&g, z1, z2, c, fs);
                out.integrand_calls += response.integrand_calls;
                let t0 = response.onset_s;
                for (acc, x) in h.iter_mut().zip(spectrum(&response, fs, &freqs)) {
                    *acc += x;
                }
                for (wave, acc) in stand_in.iter_mut().enumerate() {
                    for (a, x) in acc.iter_mut().zip(stand_in_spectrum(&response, wave, &freqs)) {
                        *a += x;
                    }
                }
                if t0 < onset {
                    onset = t0;
                    apex_z = g.apex().clamp(z1, z2);
                }
            }
            let apex = w.start + w.along * apex_z;
            let apex_path = onset * c;
            // The emitter's strength towards the edge: power, directivity, the image's reflection.
            let first = leave_dir.unwrap_or(apex);
            let emit = (first - tree.nodes[0].position).normalize_or_zero();
            let mut amp2 = vec![src.power_w * directivity_gain(&src.directivity, emit) / (4.0 * PI); nb];
            if let Some(hook) = ctx.gains {
                let mut extra = vec![1.0; nb];
                hook(s, emit, &mut extra);
                for b in 0..nb {
                    amp2[b] *= extra[b];
                }
            }
            if e != 0 {
                if let Some(tri) = reflection_triangle(ctx, tree, e, apex + offset) {
                    let material = ctx.mesh.material[tri as usize] as usize;
                    let m = material * nb;
                    let (mut alpha, mut scat) = (ctx.acoustics.absorption[m..m + nb].to_vec(), ctx.acoustics.scattering[m..m + nb].to_vec());
                    if let Some(table) = ctx.settings.by_angle.as_ref().filter(|t| t.profiled(material)) {
                        // A described surface's α and s at this leg's own angle of incidence
                        // (sound/scattering.rs), as an image source's reflection takes them: the
                        // image-to-edge line meets the plane at the angle the leg from the
                        // emitter does (mirror symmetry).
                        let normal = ctx.planes.planes[ctx.planes.plane_of_triangle[tri as usize] as usize].normal;
                        let cos_incidence = (apex - tree.nodes[e as usize].position).normalize_or_zero().dot(normal).abs();
                        table.absorption(material, cos_incidence, &mut alpha);
                        table.scattering(material, cos_incidence, &mut scat);
                    }
                    for b in 0..nb {
                        amp2[b] *= (1.0 - alpha[b]) * (1.0 - scat[b]);
                    }
                }
            }
            crate::sound::air::attenuate(&set.air_attenuation_per_m[..nb], apex_path, &mut amp2[..nb]);
            // Band energies and cross terms with the geometric arrivals this edge bounds.
            let n = FREQUENCIES_PER_BAND;
            let mut energy = vec![0.0; nb];
            let mut cross = vec![vec![0.0; nb]; group.len()];
            // Each geometric wave crosses the whole diffracted wave less the closed-form parts
            // that stand in for the other waves of the group near their boundaries (see
            // `crossed_waves`).
            let crossed: Vec<Vec<Complex64>> = group
                .iter()
                .map(|&i| {
                    let own = crossed_waves(out.arrivals[i].image == e, tree.nodes[out.arrivals[i].image as usize].plane, w.planes);
                    (0..freqs.len()).map(|k| h[k] - (0..3).filter(|&v| !own[v]).map(|v| stand_in[v][k]).sum::<Complex64>()).collect()
                })
                .collect();
            for b in 0..nb {
                let hb = &h[b * n..(b + 1) * n];
                energy[b] = amp2[b] * hb.iter().map(|x| x.norm_sqr()).sum::<f64>() / n as f64;
                for (gi, &i) in group.iter().enumerate() {
                    let eg = out.energy[i * nb + b];
                    let tg = out.arrivals[i].time_s;
                    let mut sum = 0.0;
                    for (k, x) in crossed[gi][b * n..(b + 1) * n].iter().enumerate() {
                        let geo = Complex64::from_polar(eg.sqrt(), -2.0 * PI * freqs[b * n + k] * tg);
                        sum += 2.0 * (geo * (x * amp2[b].sqrt()).conj()).re;
                    }
                    cross[gi][b] = sum / n as f64;
                }
            }
            for b in 0..nb {
                let mut total = energy[b] + cross.iter().map(|x| x[b]).sum::<f64>();
                if total < 0.0 {
                    if let Some(&i) = group.iter().max_by(|&&x, &&y| out.energy[x * nb + b].total_cmp(&out.energy[y * nb + b])) {
                        let slot = &mut out.energy_mut(i)[b];
                        *slot = (*slot + total).max(0.0);
                    }
                    total = 0.0;
                }
                energy[b] = total;
            }
            let a = Arrival {
                source: s as u32,
                receiver: r as u32,
                time_s: onset,
                from_direction: (apex - receiver).normalize_or_zero(),
                kind: ArrivalKind::Diffracted { order: node.order, wedge: w_index as u32 },
                image: e,
            };
            out.push(a, &energy);
        }
    }
}

/// Which of the edge's three geometric waves (the emitter's own, its images in the reference
/// and in the other face) a group member is: its own or its image in `plane`.
///
/// Why the cross terms leave out the other waves' stand-ins: at the boundary of wave r the
/// diffracted wave jumps by r's amplitude (a half of it either way, carried by the closed-form
/// near-apex part of r's β term), which keeps |G_r + D|² continuous when G_r crosses the whole
/// of D. A second wave G_d crossing that jump would jump by 2 Re(G_d G_r*): in the exact field
/// that is cancelled by the interference of the two geometric waves, which an energy model of
/// arrivals does not carry. So G_d crosses D less r's stand-in, which is continuous across r's
/// boundary; what is lost is half the interference of G_d and G_r near that boundary, the same
/// kind of term the energy model drops everywhere else.
fn crossed_waves(own: bool, plane: u32, planes: [u32; 2]) -> [bool; 3] {
    if own {
        [true, false, false]
    } else {
        [false, plane == planes[0], plane == planes[1]]
    }
}

/// The triangle on which a first-order image's path to edge point `q` reflects.
fn reflection_triangle(ctx: &Context, tree: &ImageTree, node: u32, q: DVec3) -> Option<u32> {
    let img = &tree.nodes[node as usize];
    let dir = img.position - q;
    let len = dir.length();
    ctx.bvh.closest_hit(&Ray::new(q.as_vec3(), dir.as_vec3()), (ctx.epsilon_m / len) as f32, 1.0).map(|h| h.triangle)
}
