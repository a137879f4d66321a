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
//! The diffracted impulse response of an edge (free field 1/r):
//!
//!   h(τ) = −ν/(4π) ∫ δ(τ − (m + l)/c) β(z) / (m l) dz,   ν = π / θ_w,
//!   β = Σ±± sin(ν(π ± θ_S ± θ_R)) / (cosh(νη) − cos(ν(π ± θ_S ± θ_R))),
//!   η = cosh⁻¹((m l + (z − z_S)(z − z_R)) / (r_S r_R)),
//!
//! m and l the distances from the source and the receiver to the edge point z, (r, θ, z) the
//! cylindrical coordinates about the edge with θ measured from one face through the air. It is
//! integrated as Torres, Svensson and Kleiner do ("Computation of edge diffraction for more
//! accurate room acoustics auralization", JASA 109(2), 2001): per time sample, over the part of
//! the edge whose path falls in that sample, each side of the apex (the point of the shortest
//! path) apart. Near a shadow or reflection boundary β has a sharp peak at the apex; an adaptive
//! Gauss–Kronrod rule resolves it, and cosh(νη) − cos(νφ) is evaluated as
//! 2 sinh²(νη/2) + 2 sin²(νφ/2) so that the peak keeps its precision.
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

// The quadrature tables are QUADPACK's, digit for digit.
#![allow(clippy::excessive_precision)]

use std::f64::consts::PI;

use glam::DVec3;
use num_complex::Complex64;

use super::edges::Wedge;
use super::image_sources::ImageTree;
use super::{directivity_gain, Arrival, ArrivalKind, Context, PairArrivals};
use crate::geometry::Ray;

/// Frequencies per band at which |H|² is averaged.
pub const FREQUENCIES_PER_BAND: usize = 24;

/// Source and receiver about one wedge, in its cylindrical coordinates.
#[derive(Clone, Copy, Debug)]
pub struct WedgeGeometry {
    pub nu: f64,
    pub r_s: f64,
    pub theta_s: f64,
    pub z_s: f64,
    pub r_r: f64,
    pub theta_r: f64,
    pub z_r: f64,
}

impl WedgeGeometry {
    pub fn new(open_angle_rad: f64, (r_s, theta_s, z_s): (f64, f64, f64), (r_r, theta_r, z_r): (f64, f64, f64)) -> WedgeGeometry {
        WedgeGeometry { nu: PI / open_angle_rad, r_s, theta_s, z_s, r_r, theta_r, z_r }
    }

    /// Path length via edge point z.
    #[inline]
    pub fn path(&self, z: f64) -> f64 {
        (self.r_s * self.r_s + (z - self.z_s).powi(2)).sqrt() + (self.r_r * self.r_r + (z - self.z_r).powi(2)).sqrt()
    }

    /// The edge point of the shortest path (on the infinite edge).
    pub fn apex(&self) -> f64 {
        self.z_s + (self.z_r - self.z_s) * self.r_s / (self.r_s + self.r_r)
    }

    /// −ν/(4π) β / (m l) at edge point z.
    pub fn integrand(&self, z: f64) -> f64 {
        let (ds, dr) = (z - self.z_s, z - self.z_r);
        let m = (self.r_s * self.r_s + ds * ds).sqrt();
        let l = (self.r_r * self.r_r + dr * dr).sqrt();
        let x = (m * l + ds * dr) / (self.r_s * self.r_r);
        let eta = x.max(1.0).acosh();
        let sh = (0.5 * self.nu * eta).sinh();
        let mut beta = 0.0;
        for phi in [
            PI + self.theta_s + self.theta_r,
            PI + self.theta_s - self.theta_r,
            PI - self.theta_s + self.theta_r,
            PI - self.theta_s - self.theta_r,
        ] {
            let sn = (0.5 * self.nu * phi).sin();
            let den = 2.0 * (sh * sh + sn * sn);
            if den > 0.0 {
                beta += (self.nu * phi).sin() / den;
            }
        }
        -self.nu / (4.0 * PI) * beta / (m * l)
    }
}

/// Kronrod 15-point nodes and weights, and the embedded 7-point Gauss weights (QUADPACK).
const XGK: [f64; 8] = [
    0.991455371120812639206854697526329,
    0.949107912342758524526189684047851,
    0.864864423359769072789712788640926,
    0.741531185599394439863864773280788,
    0.586087235467691130294144845693013,
    0.405845151377397166906606412076961,
    0.207784955007898467600689403773245,
    0.0,
];
const WGK: [f64; 8] = [
    0.022935322010529224963732008058970,
    0.063092092629978553290700663189204,
    0.104790010322250183839876322541518,
    0.140653259715525918745189590510238,
    0.169004726639267902826583426598550,
    0.190350578064785409913256402421014,
    0.204432940075298892414161999234649,
    0.209482141084727828012999174891714,
];
const WG: [f64; 4] = [0.129484966168869693270611432679082, 0.279705391489276667901467771423780, 0.381830050505118944950369775488975, 0.417959183673469387755102040816327];

/// ∫ f over [a, b] by adaptive Gauss–Kronrod 7–15, to `tol` absolute.
pub fn integrate(f: &impl Fn(f64) -> f64, a: f64, b: f64, tol: f64, depth: u32) -> f64 {
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    let fc = f(c);
    let (mut k, mut g) = (WGK[7] * fc, WG[3] * fc);
    for j in 0..7 {
        let x = h * XGK[j];
        let s = f(c - x) + f(c + x);
        k += WGK[j] * s;
        if j % 2 == 1 {
            g += WG[j / 2] * s;
        }
    }
    let (k, g) = (k * h, g * h);
    // A relative floor: below it the estimate is as good as double precision allows, and a
    // non-finite estimate is not refined (neither would ever meet an absolute tolerance).
    if depth == 0 || !(k - g).is_finite() || (k - g).abs() <= tol.max(1e-13 * k.abs()) {
        return k;
    }
    integrate(f, a, c, 0.5 * tol, depth - 1) + integrate(f, c, b, 0.5 * tol, depth - 1)
}

/// The edge point on [from, to] (where the path length is monotone) at which it equals `target`.
fn invert_path(g: &WedgeGeometry, from: f64, to: f64, target: f64) -> f64 {
    let (mut lo, mut hi) = (from, to);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if g.path(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
        if (hi - lo).abs() < 1e-13 * (1.0 + mid.abs()) {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// The diffracted impulse response of the edge part [z1, z2], binned at `sample_rate_hz`: the
/// onset time (the shortest path over the part, / c) and the integral of h over each bin
/// [onset + n/fs, onset + (n + 1)/fs).
pub fn binned_response(g: &WedgeGeometry, z1: f64, z2: f64, speed_m_s: f64, sample_rate_hz: f64) -> (f64, Vec<f64>) {
    let z_min = g.apex().clamp(z1, z2);
    let l0 = g.path(z_min);
    let step = speed_m_s / sample_rate_hz;
    let l_end = g.path(z1).max(g.path(z2));
    let n_bins = ((l_end - l0) / step).ceil().max(1.0) as usize;
    let mut bins = vec![0.0; n_bins];
    let scale = g.nu / (4.0 * PI) / (g.r_s * g.r_r).max(1e-12);
    let f = |z: f64| g.integrand(z);
    for (end, sign) in [(z2, 1.0), (z1, -1.0)] {
        if (end - z_min) * sign <= 0.0 {
            continue;
        }
        let l_side = g.path(end);
        let mut z_prev = z_min;
        for (n, bin) in bins.iter_mut().enumerate() {
            let target = l0 + (n + 1) as f64 * step;
            let z_next = if target >= l_side { end } else { invert_path(g, z_prev, end, target) };
            let (a, b) = if sign > 0.0 { (z_prev, z_next) } else { (z_next, z_prev) };
            let tol = 1e-10 * scale * (b - a).max(1e-6);
            *bin += integrate(&f, a, b, tol, 30);
            z_prev = z_next;
            if z_next == end {
                break;
            }
        }
    }
    (l0 / speed_m_s, bins)
}

/// H(f) of a binned response at each of `freqs_hz`: Σ bin · e^(−j2πf t_n) over the bins'
/// centres, divided by sinc(f / fs) (a bin is the response smoothed by a one-sample box).
pub fn spectrum(onset_s: f64, bins: &[f64], sample_rate_hz: f64, freqs_hz: &[f64]) -> Vec<Complex64> {
    freqs_hz
        .iter()
        .map(|&f| {
            let w = Complex64::from_polar(1.0, -2.0 * PI * f / sample_rate_hz);
            let mut phase = Complex64::from_polar(1.0, -2.0 * PI * f * (onset_s + 0.5 / sample_rate_hz));
            let mut sum = Complex64::new(0.0, 0.0);
            for &b in bins {
                sum += phase * b;
                phase *= w;
            }
            let x = PI * f / sample_rate_hz;
            sum / (x.sin() / x)
        })
        .collect()
}

/// The frequencies of each band at which energies are averaged: midpoints of equal parts.
pub fn band_frequencies(ctx_edges: &[(f64, f64)]) -> Vec<f64> {
    let n = FREQUENCIES_PER_BAND;
    ctx_edges.iter().flat_map(|&(lo, hi)| (0..n).map(move |k| lo + (k as f64 + 0.5) * (hi - lo) / n as f64)).collect()
}

/// The internal sample rate of the binned responses: 16 samples a period of the highest band's
/// top edge, at least 48 kHz.
pub fn internal_rate_hz(band_edges: &[(f64, f64)]) -> f64 {
    band_edges.iter().map(|e| e.1).fold(0.0, f64::max).mul_add(16.0, 0.0).max(48_000.0)
}

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
            let g = WedgeGeometry::new(w.open_angle_rad, cs, cr);
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
            let (mut onset, mut apex_z) = (f64::INFINITY, 0.0);
            for &(z1, z2) in &runs {
                let (t0, bins) = binned_response(&g, z1, z2, c, fs);
                for (acc, x) in h.iter_mut().zip(spectrum(t0, &bins, fs, &freqs)) {
                    *acc += x;
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
                    let m = ctx.mesh.material[tri as usize] as usize * nb;
                    for b in 0..nb {
                        amp2[b] *= (1.0 - ctx.acoustics.absorption[m + b]) * (1.0 - ctx.acoustics.scattering[m + b]);
                    }
                }
            }
            for b in 0..nb {
                amp2[b] *= (-set.air_attenuation_per_m[b] * apex_path).exp();
            }
            // Band energies and cross terms with the geometric arrivals this edge bounds.
            let group: Vec<usize> = (0..n_specular)
                .filter(|&i| {
                    let a = &out.arrivals[i];
                    a.image == e || w.planes.iter().any(|&p| tree.nodes[a.image as usize].parent == e && tree.nodes[a.image as usize].plane == p && a.image != 0)
                })
                .collect();
            let n = FREQUENCIES_PER_BAND;
            let mut energy = vec![0.0; nb];
            let mut cross = vec![vec![0.0; nb]; group.len()];
            for b in 0..nb {
                let hb = &h[b * n..(b + 1) * n];
                energy[b] = amp2[b] * hb.iter().map(|x| x.norm_sqr()).sum::<f64>() / n as f64;
                for (gi, &i) in group.iter().enumerate() {
                    let eg = out.energy[i * nb + b];
                    let tg = out.arrivals[i].time_s;
                    let mut sum = 0.0;
                    for (k, x) in hb.iter().enumerate() {
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

/// The triangle on which a first-order image's path to edge point `q` reflects.
fn reflection_triangle(ctx: &Context, tree: &ImageTree, node: u32, q: DVec3) -> Option<u32> {
    let img = &tree.nodes[node as usize];
    let dir = img.position - q;
    let len = dir.length();
    ctx.bvh.closest_hit(&Ray::new(q.as_vec3(), dir.as_vec3()), (ctx.epsilon_m / len) as f32, 1.0).map(|h| h.triangle)
}
