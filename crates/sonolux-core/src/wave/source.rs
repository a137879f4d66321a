//! The source: an omnidirectional point source whose volume velocity is a Gaussian pulse, added
//! to the pressure update ("soft" source).
//!
//! For the pressure u, a point monopole of volume velocity q(t) enters the wave equation as
//! (1/c²)∂²u/∂t² − ∇²u = ρ q̇(t) δ(x − x_s); in free field u = ρ q̇(t − r/c)/(4πr). Integrated over
//! the source's cell (finite-volume form) and multiplied by c²Δt²/Δx³, each step adds
//! (c²Δt²ρ/Δx³) q̇(nΔt) to u^{n+1}, spread over the 8 nodes around the source with trilinear
//! weights (the adjoint of the receivers' interpolation, so that source and receiver swap).
//!
//! Injecting q̇ rather than q keeps the injected signal free of DC: a soft source fed a signal
//! with a DC part drives a growing, unphysical offset (Sheaffer, van Walstijn and Fazenda,
//! "Physical and numerical constraints in source modeling for finite difference simulation of
//! room acoustics", JASA 135(1), 2014). The pulse q(t) = q₀·exp(−(t − t₀)²/(2σ²)) with
//! σ = 1/(π f_max) puts the pressure spectrum's peak (∝ ω·exp(−ω²σ²/2)) at f_max/2; at f_max it
//! is 7 dB down, at 2 f_max 53 dB, at 3 f_max 136 dB, so the grid's badly dispersive upper
//! frequencies are barely excited, while f_max/16 is still within 14 dB of the peak.
//! t₀ = 6σ starts it from 1.5·10⁻⁸ of its peak. q₀ is chosen for a free-field pressure peak of
//! 1 Pa at 1 m.
//!
//! **Directional sources** are clusters of such monopoles, each fed its own volume acceleration
//! ([`SourceTerm`]): weighted monopoles matched to a directivity's low-order spherical harmonics
//! (Bilbao and Hamilton, "Directional sources in wave-based acoustic simulation", IEEE/ACM TASLP
//! 27(2), 2019). The terms and their signals are computed by the caller (the library fits them
//! to the source's pattern per band, docs/waves-sources.md); the core injects each as the monopole above,
//! with the pulse delayed by [`Sources::Terms`]' `pulse_delay_s` so that the signals' filters
//! have room before it.

use std::f64::consts::PI;

use glam::DVec3;

use super::grid::Grid;
use crate::error::CoreError;

/// The pulse every source emits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SourcePulse {
    pub sigma_s: f64,
    /// Time of the pulse's centre: the response's time 0 of emission.
    pub delay_s: f64,
    /// q₀, m³/s.
    pub peak_volume_velocity_m3_s: f64,
    pub air_density_kg_m3: f64,
}

impl SourcePulse {
    pub fn for_max_frequency(max_frequency_hz: f64, air_density_kg_m3: f64) -> SourcePulse {
        let sigma_s = 1.0 / (PI * max_frequency_hz);
        // Peak of q̇ is q₀ e^{−½}/σ; its free-field pressure at 1 m is ρ q̇/(4π).
        let peak_volume_velocity_m3_s = 4.0 * PI * sigma_s * 0.5f64.exp() / air_density_kg_m3;
        SourcePulse { sigma_s, delay_s: 6.0 * sigma_s, peak_volume_velocity_m3_s, air_density_kg_m3 }
    }

    /// q(t), m³/s.
    pub fn volume_velocity(&self, t: f64) -> f64 {
        let x = (t - self.delay_s) / self.sigma_s;
        self.peak_volume_velocity_m3_s * (-0.5 * x * x).exp()
    }

    /// q̇(t), m³/s².
    pub fn volume_acceleration(&self, t: f64) -> f64 {
        let x = (t - self.delay_s) / self.sigma_s;
        -self.peak_volume_velocity_m3_s * x / self.sigma_s * (-0.5 * x * x).exp()
    }

    /// The free-field pressure at 1 m, without the propagation delay: ρ q̇(t)/(4π).
    pub fn pressure_at_1m(&self, t: f64) -> f64 {
        self.air_density_kg_m3 * self.volume_acceleration(t) / (4.0 * PI)
    }
}

/// One monopole of a directional source's cluster: where it is and its volume acceleration q̇
/// (m³/s²) at every time step from 0 (zero after the last).
#[derive(Clone, Debug, PartialEq)]
pub struct SourceTerm {
    pub position_m: DVec3,
    pub volume_acceleration_m3_s2: Vec<f64>,
}

/// What a run emits: monopoles all emitting the pulse (omnidirectional sources, at once), or the
/// terms of a directional source with the pulse (their reference, what the responses are
/// normalised by) centred at `pulse_delay_s` (at least the pulse's own 6σ).
#[derive(Clone, Copy, Debug)]
pub enum Sources<'a> {
    Monopoles(&'a [DVec3]),
    Terms { terms: &'a [SourceTerm], pulse_delay_s: f64 },
}

impl Sources<'_> {
    /// The pulse of a run at `max_frequency_hz`, delayed as the sources say.
    pub fn pulse(&self, max_frequency_hz: f64, air_density_kg_m3: f64) -> SourcePulse {
        let pulse = SourcePulse::for_max_frequency(max_frequency_hz, air_density_kg_m3);
        match self {
            Sources::Monopoles(_) => pulse,
            Sources::Terms { pulse_delay_s, .. } => SourcePulse { delay_s: pulse.delay_s.max(*pulse_delay_s), ..pulse },
        }
    }
}

/// The nodes the sources feed and their weights (sorted by node, shared nodes summed), and the
/// factor c²Δt²ρ/Δx³. Terms of a directional source: each term's nodes and signal.
#[derive(Clone, Debug)]
pub(crate) struct Injector {
    nodes: Vec<(usize, f64)>,
    scale: f64,
    pulse: SourcePulse,
    dt: f64,
    terms: Vec<FedNodes>,
}

/// A term's nodes with their trilinear weights, and its signal.
type FedNodes = (Vec<(usize, f64)>, Vec<f64>);

impl Injector {
    pub fn new(grid: &Grid, positions: &[DVec3], pulse: SourcePulse, c: f64, dt: f64) -> Result<Injector, CoreError> {
        if positions.is_empty() {
            return Err(CoreError::invalid("sources", "a wave simulation needs at least one source"));
        }
        let mut nodes: Vec<(usize, f64)> = Vec::new();
        for (i, p) in positions.iter().enumerate() {
            nodes.extend(weights_in_air(grid, *p, "source", i)?);
        }
        sum_shared_nodes(&mut nodes);
        let h = grid.spacing_m;
        Ok(Injector { nodes, scale: c * c * dt * dt * pulse.air_density_kg_m3 / (h * h * h), pulse, dt, terms: Vec::new() })
    }

    /// The injector of `sources` (see [`Sources`]).
    pub fn of(grid: &Grid, sources: &Sources, pulse: SourcePulse, c: f64, dt: f64) -> Result<Injector, CoreError> {
        let terms = match sources {
            Sources::Monopoles(positions) => return Injector::new(grid, positions, pulse, c, dt),
            Sources::Terms { terms, .. } => terms,
        };
        if terms.is_empty() {
            return Err(CoreError::invalid("source_terms", "a directional source needs at least one term"));
        }
        let mut out = Vec::with_capacity(terms.len());
        for (i, t) in terms.iter().enumerate() {
            if let Some(k) = t.volume_acceleration_m3_s2.iter().position(|v| !v.is_finite()) {
                return Err(CoreError::invalid("source_terms", format!("term {i}'s signal is not finite at step {k}")));
            }
            out.push((weights_in_air(grid, t.position_m, "source term", i)?, t.volume_acceleration_m3_s2.clone()));
        }
        let h = grid.spacing_m;
        Ok(Injector { nodes: Vec::new(), scale: c * c * dt * dt * pulse.air_density_kg_m3 / (h * h * h), pulse, dt, terms: out })
    }

    /// What step n adds to u^{n+1}.
    pub fn at_step(&self, n: u64, out: &mut Vec<(usize, f32)>) {
        out.clear();
        if !self.terms.is_empty() {
            // Every term's share of each node, summed in the terms' order (fixed: same bits on
            // any thread count), then sorted by node with shared nodes summed.
            let mut sum: Vec<(usize, f64)> = Vec::new();
            for (nodes, signal) in &self.terms {
                let q = self.scale * signal.get(n as usize).copied().unwrap_or(0.0);
                sum.extend(nodes.iter().map(|&(i, w)| (i, w * q)));
            }
            sum_shared_nodes(&mut sum);
            out.extend(sum.into_iter().map(|(i, v)| (i, v as f32)));
            return;
        }
        let q = self.scale * self.pulse.volume_acceleration(n as f64 * self.dt);
        out.extend(self.nodes.iter().map(|&(i, w)| (i, (w * q) as f32)));
    }
}

/// Sorts (node, value) pairs by node (stably: equal nodes keep their order, so the sums are the
/// same bits on any thread count) and sums the values of a node that appears more than once.
fn sum_shared_nodes(pairs: &mut Vec<(usize, f64)>) {
    pairs.sort_by_key(|p| p.0);
    pairs.dedup_by(|b, a| {
        if a.0 == b.0 {
            a.1 += b.1;
            true
        } else {
            false
        }
    });
}

/// Trilinear weights of the air nodes around a source or receiver, or an error naming it.
pub(crate) fn weights_in_air(grid: &Grid, p: DVec3, what: &str, i: usize) -> Result<Vec<(usize, f64)>, CoreError> {
    if !p.is_finite() {
        return Err(CoreError::invalid(format!("{what}s"), format!("{what} {i} has a non-finite position {p:?}")));
    }
    grid.air_weights(p).ok_or_else(|| {
        CoreError::invalid(
            format!("{what}s"),
            format!(
                "{what} {i} at ({:.3}, {:.3}, {:.3}) m is not in the room's air as voxelised at {:.3} m (outside the walls or inside an obstacle)",
                p.x, p.y, p.z, grid.spacing_m
            ),
        )
    })
}
