//! The work plane: a virtual horizontal plane at `height_m`, cut into square cells, that
//! measures illuminance without being a surface. Every particle path segment that crosses the
//! plane downwards deposits its flux in the cell it crosses; flux / cell area is then the
//! irradiance on the plane's upper face (what a horizontal illuminance meter facing up reads),
//! exact in expectation. Particles are not stopped or changed by the plane.
//!
//! Cell (i, j) is centred at origin_m + spacing_m · (i, j) and spans ± spacing_m / 2; the grid
//! holds i in lo[0]..lo[0] + count[0], j likewise; cell (i, j) is stored at
//! (j − lo[1]) · count[0] + (i − lo[0]), rows along +x (the order of the sound receivers' grid).

use glam::DVec3;

use crate::error::CoreError;

#[derive(Clone, Debug)]
pub struct WorkPlane {
    pub height_m: f64,
    pub origin_m: [f64; 2],
    pub spacing_m: f64,
    pub lo: [i64; 2],
    pub count: [usize; 2],
}

impl WorkPlane {
    pub fn validate(&self) -> Result<(), CoreError> {
        if !(self.height_m.is_finite() && self.origin_m.iter().all(|v| v.is_finite()) && self.spacing_m.is_finite() && self.spacing_m > 0.0) {
            return Err(CoreError::invalid("work plane", "height, origin and a positive spacing must be finite"));
        }
        if self.count[0] == 0 || self.count[1] == 0 || self.count[0].saturating_mul(self.count[1]) > 50_000_000 {
            return Err(CoreError::invalid("work plane", format!("{} × {} cells: between 1 and 5·10⁷ allowed", self.count[0], self.count[1])));
        }
        Ok(())
    }

    pub fn len(&self) -> usize {
        self.count[0] * self.count[1]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The cell that the segment from `from` along unit `dir` for length `t` (infinite for an
    /// escaping particle) crosses downwards, if any.
    #[inline]
    pub fn crossing(&self, from: DVec3, dir: DVec3, t: f64) -> Option<usize> {
        if !(dir.z < 0.0 && from.z > self.height_m) {
            return None;
        }
        let s = (from.z - self.height_m) / -dir.z;
        if s > t {
            return None;
        }
        let p = from + dir * s;
        let fi = ((p.x - self.origin_m[0]) / self.spacing_m + 0.5).floor() as i64 - self.lo[0];
        let fj = ((p.y - self.origin_m[1]) / self.spacing_m + 0.5).floor() as i64 - self.lo[1];
        if fi < 0 || fj < 0 || fi >= self.count[0] as i64 || fj >= self.count[1] as i64 {
            return None;
        }
        Some(fj as usize * self.count[0] + fi as usize)
    }
}
