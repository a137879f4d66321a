//! From pressure and velocity responses to energy per band, time bin and arrival direction, in
//! the sound tracer's layout ([`crate::sound::Layout`]), with the air's absorption.
//!
//! Bands. Zero-phase filters applied by FFT, power-complementary: around each edge between two
//! bands (the geometric mean of their centres) the lower band's magnitude falls as
//! cos(π(x + 1)/4) while the upper one's rises as sin(π(x + 1)/4), x running from −1 to 1 across
//! a quarter of the narrower band's width (in log frequency) on each side. The squared
//! magnitudes sum to one, so the band energies of a signal add up to its energy between the
//! outer edges, and no energy is lost or counted twice at the crossovers.
//!
//! Air. The air absorbs a band's energy as exp(−m·c·t) after a flight of duration t (m per
//! metre, as ISO 9613-1 gives it per band: the numbers the tracer receives). The solver's grid
//! carries no air loss, so each band's energy in the impulse response is multiplied by
//! exp(−m·c·t), t the time since emission: exact for every path, since all energy arriving at
//! time t has flown c·t (diffraction and scattering included). Applying it to band energies,
//! not inside the scheme, keeps the scheme lossless in its interior and the air's absorption
//! exactly the tracer's, band by band.
//!
//! Direction. Energy flows along the intensity I = p·v; sound arrives from −I. Each sample's
//! band energy goes to the direction bin of −I_b (the band's intensity, averaged over one period
//! of the band's centre to remove its oscillation between pressure and velocity), as the
//! spatial decomposition method assigns each sample of a response to one direction (Tervo,
//! Pätynen, Kuusinen and Lokki, "Spatial decomposition method for room impulse responses", JAES
//! 61(1/2), 2013; the intensity as the estimate of direction is that of DirAC, Pulkki, JAES
//! 55(6), 2007).
//!
//! Impulse responses first. The responses are to the source's pulse, whose spectrum falls by
//! 7 dB across the top octave below f_max and rises as f at the bottom: band energies taken
//! straight from them would weigh each band's frequencies by that spectrum. So each response is
//! divided, frequency by frequency, by the spectrum of the pulse's free-field pressure at 1 m:
//! what remains is the impulse response h, with h = δ(t − r/c)/r in free field, and time 0 at
//! emission. Frequencies where the pulse is more than 120 dB below its peak are left out (far
//! above f_max, where the grid is not valid anyway).
//!
//! Energy. A band's energy is Σ h_b², divided by 4π times Σ δ_b² (the band's filter applied to a
//! unit impulse): the field per joule of source energy in every band, the tracer's convention
//! (a free field gives 1/(4πr²)).

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};

use super::admittance::band_edges;
use super::direct::{subtract_direct, subtract_terms, PreparedTerms};
use super::WaveResult;
use crate::error::CoreError;
use crate::sound::Layout;

/// Power-complementary band filters for signals of one length and sample rate.
pub struct BandFilters {
    /// Per band, the magnitude at each FFT bin.
    gains: Vec<Vec<f64>>,
    fft_len: usize,
    r2c: Arc<dyn RealToComplex<f64>>,
    c2r: Arc<dyn ComplexToReal<f64>>,
}

impl BandFilters {
    /// Filters for signals of `n_samples` at `sample_rate_hz` into the bands centred at `centres_hz`.
    pub fn new(centres_hz: &[f64], sample_rate_hz: f64, n_samples: usize) -> Result<BandFilters, CoreError> {
        if centres_hz.is_empty() || centres_hz.iter().any(|f| !(*f > 0.0)) || centres_hz.windows(2).any(|w| !(w[1] > w[0])) {
            return Err(CoreError::invalid("band_centres_hz", format!("{centres_hz:?} must be positive and increasing")));
        }
        // Room for the filters' ringing on both sides of the signal.
        let fft_len = (2 * n_samples.max(16)).next_power_of_two();
        let edges = band_edges(centres_hz);
        let octaves = |b: usize| (edges[b].1 / edges[b].0).log2();
        let nb = centres_hz.len();
        let bins = fft_len / 2 + 1;
        let gains = (0..nb)
            .map(|b| {
                let w_lo = 0.25 * if b == 0 { octaves(0) } else { octaves(b).min(octaves(b - 1)) };
                let w_hi = 0.25 * if b + 1 == nb { octaves(b) } else { octaves(b).min(octaves(b + 1)) };
                (0..bins)
                    .map(|k| {
                        let f = k as f64 * sample_rate_hz / fft_len as f64;
                        if f <= 0.0 {
                            return 0.0;
                        }
                        let rise = transition((f / edges[b].0).log2() / w_lo).1;
                        let fall = transition((f / edges[b].1).log2() / w_hi).0;
                        rise * fall
                    })
                    .collect()
            })
            .collect();
        let mut planner = RealFftPlanner::<f64>::new();
        Ok(BandFilters { gains, fft_len, r2c: planner.plan_fft_forward(fft_len), c2r: planner.plan_fft_inverse(fft_len) })
    }

    pub fn n_bands(&self) -> usize {
        self.gains.len()
    }

    /// The spectrum of a signal (zero-padded).
    pub fn spectrum(&self, signal: &[f64]) -> Vec<realfft::num_complex::Complex<f64>> {
        let mut x = vec![0.0; self.fft_len];
        x[..signal.len()].copy_from_slice(signal);
        let mut s = self.r2c.make_output_vec();
        self.r2c.process(&mut x, &mut s).expect("buffer sizes come from the plan");
        s
    }

    /// Band `b` of a signal whose spectrum is `s`, `n` samples long.
    pub fn band_of(&self, s: &[realfft::num_complex::Complex<f64>], b: usize, n: usize) -> Vec<f64> {
        let mut y: Vec<_> = s.iter().zip(&self.gains[b]).map(|(x, g)| x * (g / self.fft_len as f64)).collect();
        // The inverse of a real signal's spectrum: DC and Nyquist bins are real.
        y[0].im = 0.0;
        let last = y.len() - 1;
        y[last].im = 0.0;
        let mut out = self.c2r.make_output_vec();
        self.c2r.process(&mut y, &mut out).expect("buffer sizes come from the plan");
        out.truncate(n);
        out
    }

    /// 1/S of the spectrum S of the source's pulse, 0 where S is more than 120 dB below its peak.
    pub fn inverse_of(&self, pulse: &[f64]) -> Vec<realfft::num_complex::Complex<f64>> {
        let s = self.spectrum(pulse);
        let peak = s.iter().map(|x| x.norm()).fold(0.0, f64::max);
        s.iter().map(|x| if x.norm() > 1e-6 * peak { 1.0 / x } else { 0.0.into() }).collect()
    }

    /// The spectrum of a response divided by the pulse's (`inverse` from [`Self::inverse_of`]):
    /// the impulse response's spectrum.
    pub fn deconvolved(&self, response: &[f64], inverse: &[realfft::num_complex::Complex<f64>]) -> Vec<realfft::num_complex::Complex<f64>> {
        let mut s = self.spectrum(response);
        for (x, i) in s.iter_mut().zip(inverse) {
            *x *= i;
        }
        s
    }

    /// Σ δ_b²: the energy band `b` lets through of a unit impulse (Parseval, over the whole
    /// filter: a zero-phase filter rings on both sides of the impulse).
    pub fn impulse_energy(&self, b: usize) -> f64 {
        let g = &self.gains[b];
        let last = g.len() - 1;
        let inner: f64 = g[1..last].iter().map(|x| x * x).sum();
        (g[0] * g[0] + 2.0 * inner + g[last] * g[last]) / self.fft_len as f64
    }

    /// Every band of a signal: `[band][time]`.
    pub fn split(&self, signal: &[f64]) -> Vec<Vec<f64>> {
        let s = self.spectrum(signal);
        (0..self.n_bands()).map(|b| self.band_of(&s, b, signal.len())).collect()
    }
}

/// The two power-complementary gains (falling, rising) at x ∈ [−1, 1] across an edge.
fn transition(x: f64) -> (f64, f64) {
    let phase = std::f64::consts::FRAC_PI_4 * (x.clamp(-1.0, 1.0) + 1.0);
    (phase.cos(), phase.sin())
}

/// Energy per band, time bin and arrival direction at every receiver of `result`, in `layout`
/// (`[time][receiver][direction][band]`, J/m² per joule of source energy in each band), with the
/// air's energy attenuation `air_attenuation_per_m` per band. `layout` must have the result's
/// receivers and at most `band_centres_hz`'s bands: a layout of k bands holds the first k only
/// (the wave bands of a hybrid, which need not pay for the bands above the crossover; each band
/// is filtered and binned alone, so its numbers do not depend on k). Bands beyond the grid's
/// maximum frequency come back with what little the grid carries there, and should not be asked.
pub fn direction_energies(
    result: &WaveResult,
    band_centres_hz: &[f64],
    air_attenuation_per_m: &[f64],
    speed_of_sound_m_s: f64,
    layout: &Layout,
) -> Result<Vec<f64>, CoreError> {
    reflected_energies(result, band_centres_hz, air_attenuation_per_m, speed_of_sound_m_s, layout, None)
}

/// Where the sources and receivers of a run are, for [`reflected_energies`]: the monopoles
/// emitting the run's pulse (`sources_m`), or the terms of a directional source (`terms`, each
/// a monopole with its own signal; `sources_m` is then ignored).
#[derive(Clone, Copy, Debug)]
pub struct DirectPaths<'a> {
    pub sources_m: &'a [DVec3],
    pub receivers_m: &'a [DVec3],
    pub terms: &'a [super::SourceTerm],
}

/// [`direction_energies`] of the room's part of the field alone: with `direct`, each source's
/// free-field direct sound (below) is taken out of every receiver's pressure and velocity first.
///
/// Why: a receiver is a sphere whose energy is the mean over its volume, which the caller takes
/// over a few points. The direct sound's 1/r² is singular at the source, so no few-point rule
/// averages it when the source is in or near the sphere (a point on the source reads the grid's
/// near field, +10 dB over the sphere's mean in the paper room); and on the grid the point
/// source's own near field is not the continuous one within a few cells. The room's part is
/// smooth there (its sources, the images, are outside the room), so the points average it well;
/// the direct sound's sphere mean is known in closed form and the caller adds it.
///
/// The direct sound of each source or term is the free-field monopole's ([`super::direct`]).
pub fn reflected_energies(
    result: &WaveResult,
    band_centres_hz: &[f64],
    air_attenuation_per_m: &[f64],
    speed_of_sound_m_s: f64,
    layout: &Layout,
    direct: Option<DirectPaths>,
) -> Result<Vec<f64>, CoreError> {
    if let Some(d) = direct {
        if d.receivers_m.len() != result.n_receivers {
            return Err(CoreError::invalid("receivers", format!("{} positions for {} receivers", d.receivers_m.len(), result.n_receivers)));
        }
    }
    let nb = band_centres_hz.len();
    if !(1..=nb).contains(&layout.n_bands) || layout.n_receivers != result.n_receivers {
        return Err(CoreError::invalid("layout", format!("needs {} receivers × 1 to {nb} bands", result.n_receivers)));
    }
    // The bands binned: the layout's first `kept` of the filters' `nb`.
    let kept = layout.n_bands;
    if air_attenuation_per_m.len() != nb || air_attenuation_per_m.iter().any(|m| !(*m >= 0.0)) {
        return Err(CoreError::invalid("air_attenuation", format!("needs {nb} values ≥ 0")));
    }
    let ns = result.n_samples;
    let fs = result.sample_rate_hz;
    let dt = 1.0 / fs;
    let filters = BandFilters::new(band_centres_hz, fs, ns)?;
    let inverse = filters.inverse_of(&result.source_pressure_1m_pa);
    let unit: Vec<f64> = (0..nb).map(|b| filters.impulse_energy(b)).collect();
    let per_receiver = layout.n_time() * layout.n_directions() * kept;
    let mut out = vec![0.0; layout.len()];
    // Each term's signal and volume velocity q (its running integral), padded: once, not per
    // receiver.
    let prepared = direct.map(|d| PreparedTerms::new(d.terms, ns, dt, result.pulse.air_density_kg_m3));
    let chunk = 4 * rayon::current_num_threads();
    for first in (0..result.n_receivers).step_by(chunk.max(1)) {
        let last = (first + chunk).min(result.n_receivers);
        let fields: Vec<Vec<f64>> = (first..last)
            .into_par_iter()
            .map(|r| {
                let mut field = vec![0.0; per_receiver];
                let mut channels: Vec<Vec<f64>> = (0..4).map(|c| result.pressure_or_velocity(r, c).iter().map(|&x| x as f64).collect()).collect();
                if let (Some(d), Some(terms)) = (direct, &prepared) {
                    if d.terms.is_empty() {
                        subtract_direct(&mut channels, &result.pulse, dt, d.sources_m, d.receivers_m[r], speed_of_sound_m_s);
                    } else {
                        subtract_terms(&mut channels, terms, d.receivers_m[r], speed_of_sound_m_s);
                    }
                }
                let spectra: Vec<_> = channels.iter().map(|c| filters.deconvolved(c, &inverse)).collect();
                let len = filters.fft_len;
                for b in 0..kept {
                    // The whole circular buffer: samples past len − ns/2 are the zero-phase
                    // filter's ringing before time 0, given to the first bin.
                    let [h, vx, vy, vz] = [0, 1, 2, 3].map(|c| filters.band_of(&spectra[c], b, len));
                    let window = (fs / band_centres_hz[b]).round().max(1.0) as usize;
                    let intensity = smoothed_intensity(&h, &[vx, vy, vz], window);
                    let norm = if unit[b] > 0.0 { 1.0 / (4.0 * std::f64::consts::PI * unit[b]) } else { 0.0 };
                    for n in (0..ns).chain(len - ns / 2..len) {
                        let t = if n < ns { n as f64 * dt } else { 0.0 };
                        let Some(bin) = layout.time_bin(t) else { continue };
                        let e = h[n] * h[n] * norm * (-air_attenuation_per_m[b] * speed_of_sound_m_s * t).exp();
                        let from = -intensity[n];
                        let dir = layout.direction_bin(if from.length_squared() > 0.0 { from.normalize() } else { DVec3::X });
                        field[(bin * layout.n_directions() + dir) * kept + b] += e;
                    }
                }
                field
            })
            .collect();
        for (r, field) in (first..last).zip(fields) {
            for t in 0..layout.n_time() {
                for d in 0..layout.n_directions() {
                    let src = &field[(t * layout.n_directions() + d) * kept..][..kept];
                    out[layout.index(r, t, d)..][..kept].copy_from_slice(src);
                }
            }
        }
    }
    Ok(out)
}

/// p·v averaged over a centred window of `window` samples (prefix sums, in order).
fn smoothed_intensity(p: &[f64], v: &[Vec<f64>], window: usize) -> Vec<DVec3> {
    let n = p.len();
    let mut prefix = vec![DVec3::ZERO; n + 1];
    for i in 0..n {
        prefix[i + 1] = prefix[i] + DVec3::new(v[0][i], v[1][i], v[2][i]) * p[i];
    }
    let half = window / 2;
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half + 1).min(n));
            (prefix[b] - prefix[a]) / (b - a) as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_are_power_complementary() {
        let f = BandFilters::new(&[125.0, 250.0, 500.0], 8000.0, 1000).unwrap();
        for k in 0..f.gains[0].len() {
            let hz = k as f64 * 8000.0 / f.fft_len as f64;
            let total: f64 = f.gains.iter().map(|g| g[k] * g[k]).sum();
            if hz > 125.0 / 2f64.sqrt() * 2f64.powf(0.25) && hz < 500.0 * 2f64.sqrt() / 2f64.powf(0.25) {
                assert!((total - 1.0).abs() < 1e-12, "{hz} Hz: {total}");
            }
            assert!(total <= 1.0 + 1e-12);
        }
    }
}
