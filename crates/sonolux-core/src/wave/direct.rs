//! The sources' free-field direct sound, taken out of a receiver's pressure and velocity
//! ([`super::bands::reflected_energies`] says why).
//!
//! The direct sound of a monopole of volume velocity q in free field (Pierce, "Acoustics",
//! 1981, §4.3): p = ρ·q̇(τ)/(4πr), radial velocity v = q̇(τ)/(4πrc) + q(τ)/(4πr²) (from
//! ρ∂v/∂t = −∂p/∂r), τ = t − r/c. A receiver closer to a source than 10⁻⁶ m is left as is.
//!
//! A directional source's terms ([`super::SourceTerm`]) are monopoles each fed its own volume
//! acceleration a, sampled at n·Δt: q is a's running integral (trapezoids), and both are read at
//! τ = t − r/c by the four-point cubic of Catmull and Rom (error of order (ωΔt)⁴, 10⁻³ at the
//! grid's f_max, where linear interpolation would leave 1.6% of the direct sound).
//!
//! Cost. τ's fractional part is the same at every sample of one term and receiver, so the cubic's
//! four weights are computed once and the interpolation is a four-tap filter of the signal
//! shifted by whole samples; and nothing arrives before r/c, so each term starts at its arrival.
//! What is left is a few multiply-adds per sample, in a loop the compiler vectorises (four lanes
//! where the CPU has AVX2; multiplies and adds only, no fused multiply-add, so the same bits on
//! any machine). Session 9's loop (the cubic evaluated at τ at every sample from time 0) took
//! 12.6 ns a term and sample; this one 1.1 ns (this file's `cost_against_before`, 131 terms).

use glam::DVec3;

use super::source::SourcePulse;
use super::SourceTerm;

const FOUR_PI: f64 = 4.0 * std::f64::consts::PI;

/// The terms of a directional source made ready for [`subtract_terms`] once per run: each term's
/// volume acceleration a and volume velocity q (its running integral), padded so that
/// `a[m]` is the signal at sample m − 1 for m in 0..n + 3 (0 before the first sample, the last
/// value past the last, as the cubic reads them), n the responses' length.
pub(crate) struct PreparedTerms {
    positions_m: Vec<DVec3>,
    accelerations: Vec<Vec<f64>>,
    velocities: Vec<Vec<f64>>,
    dt: f64,
    air_density_kg_m3: f64,
}

impl PreparedTerms {
    /// `terms` for responses of `n_samples` at `dt` (s) in air of `air_density_kg_m3`.
    pub(crate) fn new(terms: &[SourceTerm], n_samples: usize, dt: f64, air_density_kg_m3: f64) -> PreparedTerms {
        let padded = |s: &[f64]| -> Vec<f64> {
            let last = s.last().copied().unwrap_or(0.0);
            (0..n_samples + 3).map(|m| if m == 0 { 0.0 } else { s.get(m - 1).copied().unwrap_or(last) }).collect()
        };
        PreparedTerms {
            positions_m: terms.iter().map(|t| t.position_m).collect(),
            accelerations: terms.iter().map(|t| padded(&t.volume_acceleration_m3_s2)).collect(),
            velocities: terms.iter().map(|t| padded(&running_integral(&t.volume_acceleration_m3_s2, dt))).collect(),
            dt,
            air_density_kg_m3,
        }
    }
}

/// Takes the free-field direct sound of monopoles at `sources` emitting `pulse` out of one
/// receiver's pressure and velocity (`channels`: p, v_x, v_y, v_z at n·`dt`) at `at`.
pub(crate) fn subtract_direct(channels: &mut [Vec<f64>], pulse: &SourcePulse, dt: f64, sources: &[DVec3], at: DVec3, c: f64) {
    for s in sources {
        let d = at - *s;
        let r = d.length();
        if r < 1e-6 {
            continue;
        }
        let n = d / r;
        for i in 0..channels[0].len() {
            let tau = i as f64 * dt - r / c;
            let p = pulse.pressure_at_1m(tau) / r;
            let v = pulse.volume_acceleration(tau) / (FOUR_PI * r * c) + pulse.volume_velocity(tau) / (FOUR_PI * r * r);
            channels[0][i] -= p;
            channels[1][i] -= v * n.x;
            channels[2][i] -= v * n.y;
            channels[3][i] -= v * n.z;
        }
    }
}

/// [`subtract_direct`] for the terms of a directional source (module doc): p = ρ·a(τ)/(4πr),
/// v = a(τ)/(4πrc) + q(τ)/(4πr²).
pub(crate) fn subtract_terms(channels: &mut [Vec<f64>], terms: &PreparedTerms, at: DVec3, c: f64) {
    let n = channels[0].len();
    let [p, vx, vy, vz] = channels else { panic!("four channels: p, v_x, v_y, v_z") };
    for ((position, a), q) in terms.positions_m.iter().zip(&terms.accelerations).zip(&terms.velocities) {
        let d = at - *position;
        let r = d.length();
        // The first sample at or after the arrival, k; τ/Δt = (i − k) + f from there on.
        let delay = r / c / terms.dt;
        let first = delay.ceil();
        if r < 1e-6 || !(first < n as f64) {
            continue;
        }
        let read = Read {
            weights: catmull_rom(first - delay),
            pressure: terms.air_density_kg_m3 / (FOUR_PI * r),
            by_a: 1.0 / (FOUR_PI * r * c),
            by_q: 1.0 / (FOUR_PI * r * r),
            u: d / r,
        };
        let k = first as usize;
        let out = [&mut p[k..], &mut vx[k..], &mut vy[k..], &mut vz[k..]];
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = pulp::x86::V3::try_new() {
            v3.vectorize(|| subtract_read(&read, a, q, out));
            continue;
        }
        subtract_read(&read, a, q, out);
    }
}

/// How one term is read at one receiver: the cubic's weights, and the factors of p and v.
struct Read {
    weights: [f64; 4],
    pressure: f64,
    by_a: f64,
    by_q: f64,
    u: DVec3,
}

/// One term's direct sound taken out of the four channels `out` from its arrival on, its padded
/// signal `a` and volume velocity `q` read from there.
/// Inlined into [`subtract_terms`]' AVX2 path (pulp's `vectorize`), where the compiler uses
/// four lanes; multiplies and adds only, so the same bits as the portable path.
#[inline(always)]
fn subtract_read(read: &Read, a: &[f64], q: &[f64], out: [&mut [f64]; 4]) {
    let [p, vx, vy, vz] = out;
    let m = p.len();
    let w = read.weights;
    let (a0, a1, a2, a3) = (&a[..m], &a[1..m + 1], &a[2..m + 2], &a[3..m + 3]);
    let (q0, q1, q2, q3) = (&q[..m], &q[1..m + 1], &q[2..m + 2], &q[3..m + 3]);
    let (vx, vy, vz) = (&mut vx[..m], &mut vy[..m], &mut vz[..m]);
    for i in 0..m {
        let ai = w[0] * a0[i] + w[1] * a1[i] + w[2] * a2[i] + w[3] * a3[i];
        let qi = w[0] * q0[i] + w[1] * q1[i] + w[2] * q2[i] + w[3] * q3[i];
        let v = read.by_a * ai + read.by_q * qi;
        p[i] -= read.pressure * ai;
        vx[i] -= v * read.u.x;
        vy[i] -= v * read.u.y;
        vz[i] -= v * read.u.z;
    }
}

/// The weights of the four samples around a point f ∈ [0, 1) past the second, in the cubic of
/// Catmull and Rom: p₁ + f(p₂ − p₀)/2 + f²(2p₀ − 5p₁ + 4p₂ − p₃)/2 + f³(3(p₁ − p₂) + p₃ − p₀)/2.
fn catmull_rom(f: f64) -> [f64; 4] {
    let (f2, f3) = (f * f, f * f * f);
    [0.5 * (-f + 2.0 * f2 - f3), 1.0 + 0.5 * (-5.0 * f2 + 3.0 * f3), 0.5 * (f + 4.0 * f2 - 3.0 * f3), 0.5 * (f3 - f2)]
}

/// The running integral of a signal sampled at n·`dt` (trapezoids), from 0 at its first sample.
fn running_integral(a: &[f64], dt: f64) -> Vec<f64> {
    let mut q = vec![0.0; a.len()];
    for n in 1..a.len() {
        q[n] = q[n - 1] + 0.5 * (a[n - 1] + a[n]) * dt;
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The direct sound of the terms as it was computed before the cost was cut: the cubic
    /// evaluated at τ at every sample, from time 0 (session 9's `subtract_terms`).
    fn reference(channels: &mut [Vec<f64>], terms: &[SourceTerm], dt: f64, rho: f64, at: DVec3, c: f64) {
        for term in terms {
            let q = running_integral(&term.volume_acceleration_m3_s2, dt);
            let d = at - term.position_m;
            let r = d.length();
            if r < 1e-6 {
                continue;
            }
            let a = &term.volume_acceleration_m3_s2;
            let at_time = |s: &[f64], t: f64| -> f64 {
                let x = t / dt;
                if x < 0.0 || s.is_empty() {
                    return 0.0;
                }
                let i = x.floor() as i64;
                let f = x - i as f64;
                let v = |k: i64| if k < 0 { 0.0 } else { s.get(k as usize).copied().unwrap_or(s[s.len() - 1]) };
                let (p0, p1, p2, p3) = (v(i - 1), v(i), v(i + 1), v(i + 2));
                p1 + 0.5 * f * (p2 - p0 + f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)))
            };
            let n = d / r;
            for i in 0..channels[0].len() {
                let tau = i as f64 * dt - r / c;
                let (ai, qi) = (at_time(a, tau), at_time(&q, tau));
                let p = rho * ai / (FOUR_PI * r);
                let v = ai / (FOUR_PI * r * c) + qi / (FOUR_PI * r * r);
                channels[0][i] -= p;
                channels[1][i] -= v * n.x;
                channels[2][i] -= v * n.y;
                channels[3][i] -= v * n.z;
            }
        }
    }

    /// A cluster of `count` terms one cell apart around `centre`, each fed a Gaussian pulse's
    /// derivative of its own sign, width and delay (and one term cut short, one empty).
    fn cluster(count: usize, centre: DVec3, spacing_m: f64, n: usize, dt: f64) -> Vec<SourceTerm> {
        (0..count)
            .map(|j| {
                let offset = DVec3::new((j % 5) as f64 - 2.0, ((j / 5) % 5) as f64 - 2.0, (j / 25) as f64 - 2.0);
                let (sigma, t0, sign) = ((6.0 + (j % 7) as f64) * dt, (60 + 3 * j) as f64 * dt, if j % 2 == 0 { 1.0 } else { -0.7 });
                let len = if j == 1 { n / 3 } else if j == 2 { 0 } else { n };
                let signal = (0..len).map(|i| {
                    let x = (i as f64 * dt - t0) / sigma;
                    sign * x * (-0.5 * x * x).exp() + if j == 3 { 1e-3 } else { 0.0 }
                });
                SourceTerm { position_m: centre + offset * spacing_m, volume_acceleration_m3_s2: signal.collect() }
            })
            .collect()
    }

    /// The responses' direct sound as before, to rounding, at receivers far, near (arriving
    /// within the first samples, so the padding is read), on a term (left out), and beyond the
    /// responses' end. Tolerance 1e-12 of the largest value: the same products summed in
    /// another order with the cubic's weights computed once (double precision, ≈ 1e-16 per
    /// operation over a few hundred terms).
    #[test]
    fn terms_subtracted_as_before_to_rounding() {
        let (n, dt, c, rho, h) = (3000, 1.0 / 8660.0, 343.0, 1.2, 0.0686);
        let centre = DVec3::new(1.0, 2.0, 1.5);
        let terms = cluster(131, centre, h, n, dt);
        let prepared = PreparedTerms::new(&terms, n, dt, rho);
        let receivers = [centre + DVec3::new(2.1, -0.73, 0.4), centre + DVec3::new(0.01, 0.02, 0.005), terms[7].position_m, centre + DVec3::new(0.0, 0.0, 200.0)];
        for at in receivers {
            let start: Vec<Vec<f64>> = (0..4).map(|k| (0..n).map(|i| ((i * 7 + k) % 13) as f64 * 1e-3).collect()).collect();
            let (mut old, mut new) = (start.clone(), start.clone());
            reference(&mut old, &terms, dt, rho, at, c);
            subtract_terms(&mut new, &prepared, at, c);
            for k in 0..4 {
                let peak = old[k].iter().zip(&start[k]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                let worst = old[k].iter().zip(&new[k]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                assert!(worst <= 1e-12 * peak.max(1e-300) || worst == 0.0, "receiver {at}, channel {k}: {worst:e} of {peak:e}");
            }
        }
    }

    /// The AVX2 path (four lanes) and the portable one give the same bits: multiplies and adds
    /// only, each rounded alike in any lane. Exact equality.
    #[test]
    fn four_lanes_give_the_portable_bits() {
        let (n, dt) = (1001, 1.0 / 8660.0);
        let terms = cluster(9, DVec3::ZERO, 0.0686, n, dt);
        let prepared = PreparedTerms::new(&terms, n, dt, 1.2);
        let read = Read { weights: catmull_rom(0.3718), pressure: 0.37, by_a: 1.1e-3, by_q: 0.21, u: DVec3::new(0.48, -0.6, 0.64) };
        let k = 17;
        let run = |vectorised: bool| {
            let mut ch: Vec<Vec<f64>> = (0..4).map(|j| (0..n).map(|i| ((i + j) % 5) as f64 * 1e-4).collect()).collect();
            for (a, q) in prepared.accelerations.iter().zip(&prepared.velocities) {
                let [p, vx, vy, vz] = &mut ch[..] else { unreachable!() };
                let out = [&mut p[k..], &mut vx[k..], &mut vy[k..], &mut vz[k..]];
                if vectorised {
                    #[cfg(target_arch = "x86_64")]
                    if let Some(v3) = pulp::x86::V3::try_new() {
                        v3.vectorize(|| subtract_read(&read, a, q, out));
                        continue;
                    }
                }
                subtract_read(&read, a, q, out);
            }
            ch
        };
        assert_eq!(run(true), run(false));
    }

    /// What the cut cost: session 9's loop against this one, per term and sample (prints; run
    /// with `--ignored --nocapture`; no assertion on time).
    #[test]
    #[ignore]
    fn cost_against_before() {
        let (n, dt, c, rho, h) = (8700, 1.0 / 8660.0, 343.0, 1.2, 0.0686);
        let centre = DVec3::new(1.0, 2.0, 1.5);
        for count in [29, 61, 131] {
            let terms = cluster(count, centre, h, n, dt);
            let receivers: Vec<DVec3> = (0..100).map(|j| centre + DVec3::new(0.5 + 0.07 * j as f64, 1.0 - 0.02 * j as f64, 0.3)).collect();
            let start: Vec<Vec<f64>> = (0..4).map(|_| vec![0.0; n]).collect();
            let t = std::time::Instant::now();
            for at in &receivers {
                let mut ch = start.clone();
                reference(&mut ch, &terms, dt, rho, *at, c);
            }
            let before = t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            let prepared = PreparedTerms::new(&terms, n, dt, rho);
            for at in &receivers {
                let mut ch = start.clone();
                subtract_terms(&mut ch, &prepared, *at, c);
            }
            let after = t.elapsed().as_secs_f64();
            println!("{count} terms, 100 points × {n} samples: before {before:.3} s, after {after:.3} s, {:.1}x; {:.2} ns / term·sample after", before / after, 1e9 * after / (count as f64 * 100.0 * n as f64));
        }
    }
}
