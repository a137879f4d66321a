//! What a sound bake is told besides the scene ([`SoundSettings`]), checked once at the edge
//! against the materials and receivers, and the limits it is checked against (threads, the
//! field's bytes a cell).

use super::{field, nee, Acoustics, Estimator, Layout};
use crate::error::CoreError;

/// Most worker threads a run may ask for (0 asks for one per core). More would only cost memory:
/// each worker keeps its own scratch and statistics.
pub const MAX_THREADS: usize = 1024;

/// Bytes a bake holds per cell of its field (one receiver, time bin, direction and band) at its
/// peak: the u64 accumulator, plus the f32 energy and the u64 counts a caller may copy out in the
/// public order ([`SoundResult::write_public`]); the accumulator's padding to
/// [`field::band_stride`] counts a (receiver, time, direction) adds [`field_bytes_per_cell`]'s rest.
pub const FIELD_BYTES_PER_CELL: u64 = 8 + 4 + 8;

/// Bytes a bake of `n_bands` bands holds per cell of its field at its peak: [`FIELD_BYTES_PER_CELL`]
/// with the accumulator's 8 bytes a count scaled by its padding (7 bands: 8 · 8/7 + 12 ≈ 21.1).
pub fn field_bytes_per_cell(n_bands: usize) -> f64 {
    let nb = n_bands.max(1);
    (FIELD_BYTES_PER_CELL - 8) as f64 + 8.0 * field::band_stride(nb) as f64 / nb as f64
}

/// Everything a sound bake needs besides the scene.
#[derive(Clone, Debug)]
pub struct SoundSettings {
    /// Rays per source in the whole bake, and the range of them this run traces.
    pub rays: u64,
    pub first_ray: u64,
    pub end_ray: u64,
    pub seed: u64,
    /// The index, in the whole bake, of this run's first receiver: a bake may trace its
    /// receivers in tiles, and each deposit's rounding is keyed by the receiver's index in the
    /// whole bake, so every tile gives its receivers the bits of the whole bake. 0 for a run of
    /// every receiver.
    pub first_receiver: u64,
    /// Trace this source alone (its index in the sources given), or every source (None). The
    /// other sources still set the fixed-point quantum and the sources' keys stay their indices,
    /// so the field of each source traced alone is, bit for bit, its share of a bake that
    /// traces them one by one (a field per source, docs/fieldfile.md).
    pub only_source: Option<usize>,
    /// Worker threads, 0 = all cores, at most [`MAX_THREADS`]. Does not change the result.
    pub threads: usize,
    pub estimator: Estimator,
    pub speed_of_sound_m_s: f64,
    /// Energy attenuation of the air per metre, per band (1/m).
    pub air_attenuation_per_m: Vec<f64>,
    pub energy_drop_db: f64,
    pub max_time_s: f64,
    pub sample_rate_hz: f64,
    /// Length of the part binned at one sample, and the width of the bins after it.
    pub early_s: f64,
    pub late_bin_s: f64,
    pub n_azimuth: usize,
    pub n_elevation: usize,
    /// The largest field, in bytes ([`field_bytes_per_cell`] a cell), the caller accepts: a bake
    /// that would need more is refused before anything is allocated.
    pub max_field_bytes: u64,
}

impl SoundSettings {
    /// Checks the settings against the materials' acoustics and the number of receivers: every
    /// value in range, the same band count (at least one) in the absorption, the scattering and
    /// the air, and a field no larger than `max_field_bytes`. Called once, by [`trace_sound`].
    pub fn validate(&self, acoustics: &Acoustics, n_receivers: usize) -> Result<(), CoreError> {
        let bad = |what: &str, problem: String| Err(CoreError::invalid(what, problem));
        let nb = acoustics.n_bands;
        if nb == 0 {
            return bad("bands", "at least one frequency band is needed".into());
        }
        if acoustics.absorption.len() % nb != 0 || acoustics.scattering.len() != acoustics.absorption.len() {
            return bad("materials", format!("absorption ({} values) and scattering ({} values) must both hold {nb} bands per material", acoustics.absorption.len(), acoustics.scattering.len()));
        }
        if acoustics.absorption.iter().chain(&acoustics.scattering).any(|a| !(0.0..=1.0).contains(a)) {
            return bad("materials", "absorption and scattering must lie in [0, 1]".into());
        }
        if self.air_attenuation_per_m.len() != nb || self.air_attenuation_per_m.iter().any(|m| !(*m >= 0.0 && m.is_finite())) {
            return bad("air_attenuation_per_m", format!("needs {nb} finite values ≥ 0, one per band (got {})", self.air_attenuation_per_m.len()));
        }
        if self.rays == 0 {
            return bad("rays", "must be at least 1".into());
        }
        if !(self.first_ray < self.end_ray && self.end_ray <= self.rays) {
            return bad("first_ray..end_ray", format!("{}..{} is not a non-empty part of 0..{}", self.first_ray, self.end_ray, self.rays));
        }
        if let Estimator::Nee { connections } = self.estimator {
            if !(1..=nee::MAX_CONNECTIONS).contains(&connections) {
                return bad("nee_receivers", format!("{connections} receivers a reflection: from 1 to {}", nee::MAX_CONNECTIONS));
            }
        }
        if self.threads > MAX_THREADS {
            return bad("threads", format!("{} is more than {MAX_THREADS} (0 uses every core)", self.threads));
        }
        for (name, v) in [("speed_of_sound_m_s", self.speed_of_sound_m_s), ("sample_rate_hz", self.sample_rate_hz), ("late_bin_s", self.late_bin_s), ("max_time_s", self.max_time_s), ("energy_drop_db", self.energy_drop_db)] {
            if !(v > 0.0 && v.is_finite()) {
                return bad(name, format!("{v} is not a positive finite number"));
            }
        }
        if !(self.early_s >= 0.0 && self.early_s.is_finite()) {
            return bad("early_s", format!("{} is not a finite time ≥ 0", self.early_s));
        }
        if self.n_azimuth == 0 || self.n_elevation == 0 {
            return bad("directions", format!("{} azimuth × {} elevation bands: at least one of each", self.n_azimuth, self.n_elevation));
        }
        // The field's size, estimated in floating point before any integer could overflow.
        let early_bins = (self.early_s * self.sample_rate_hz).round();
        let late_bins = ((self.max_time_s - early_bins / self.sample_rate_hz).max(0.0) / self.late_bin_s).ceil();
        let cells = n_receivers as f64 * self.n_azimuth as f64 * self.n_elevation as f64 * nb as f64 * (early_bins + late_bins);
        let per_cell = field_bytes_per_cell(nb);
        let bytes = cells * per_cell;
        if !(bytes <= self.max_field_bytes as f64) {
            return bad(
                "max_time_s",
                format!(
                    "the field would take {bytes:.3e} bytes ({n_receivers} receivers × {} directions × {nb} bands × {} time bins × {per_cell:.2} bytes), more than the limit of {:.3e}: shorten max_time_s or early_s, widen late_bin_s, or use fewer receivers or directions",
                    self.n_azimuth * self.n_elevation,
                    early_bins + late_bins,
                    self.max_field_bytes as f64
                ),
            );
        }
        Ok(())
    }

    /// The field's layout; call [`SoundSettings::validate`] first.
    pub fn layout(&self, n_receivers: usize, n_bands: usize) -> Layout {
        let early_bins = (self.early_s * self.sample_rate_hz).round() as usize;
        let early = early_bins as f64 / self.sample_rate_hz;
        let late_bins = ((self.max_time_s - early).max(0.0) / self.late_bin_s).ceil() as usize;
        Layout {
            n_receivers,
            n_azimuth: self.n_azimuth,
            n_elevation: self.n_elevation,
            n_bands,
            sample_rate_hz: self.sample_rate_hz,
            early_bins,
            late_bin_s: self.late_bin_s,
            late_bins,
        }
    }
}
