//! Receivers: spheres at the cell centres of the grid (or at any listed points), with a uniform
//! grid over them so that a ray segment finds the spheres it crosses by walking the cells it
//! passes through (3D-DDA), whatever the number of receivers.
//!
//! A receiver may carry a **pattern** ([`ReceiverPattern`]): every deposit into it (sphere
//! crossings, diffuse rain, the exact direct sound, and through the binding the image sources'
//! arrivals) is weighted by the pattern's energy gain towards the direction the sound arrives
//! from. Several receivers at one point with different patterns are the channels of one
//! microphone position (an omni and a figure-of-eight for ISO 3382-1's JLF, a SOFA array's
//! capsules).

use glam::DVec3;

pub use super::receiver_pattern::{first_order_mean, ReceiverPattern};

mod lattice;
use lattice::{floor_plan_lattice, Lattice};

/// The receiver spheres and the cell grid that finds them.
#[derive(Clone, Debug)]
pub struct Receivers {
    pub centres: Vec<DVec3>,
    pub radius_m: f64,
    /// One pattern a receiver, or empty: every receiver omnidirectional.
    patterns: Vec<ReceiverPattern>,
    /// The grid's box (the tracer rejects segments beside it first), and the size of its cells.
    pub(crate) lo: DVec3,
    pub(crate) hi: DVec3,
    cell: DVec3,
    dims: [usize; 3],
    /// Receivers whose sphere overlaps each cell: `cells[i]..cells[i+1]` indexes `items`.
    cells: Vec<u32>,
    items: Vec<u32>,
    /// The receivers' floor-plan lattice, when they lie on one ([`floor_plan_lattice`]).
    lattice: Option<Lattice>,
}

/// A sphere crossed by a segment.
#[derive(Clone, Copy, Debug)]
pub struct Crossing {
    pub receiver: u32,
    /// Length of the chord inside the sphere, clipped to the segment.
    pub chord: f64,
    /// Distance along the segment of the point nearest the centre (may lie outside the segment).
    pub t_nearest: f64,
    /// Squared distance between the line and the centre.
    pub miss2: f64,
}

impl Receivers {
    pub fn new(centres: Vec<DVec3>, radius_m: f64) -> Receivers {
        // Non-finite centres or radius are refused by `trace_sound` with an error naming them;
        // until then they get an empty search grid instead of a panic here.
        if !(radius_m > 0.0 && radius_m.is_finite()) || centres.iter().any(|c| !c.is_finite()) {
            let (lo, hi, cell, dims) = (DVec3::ZERO, DVec3::ONE, DVec3::ONE, [1, 1, 1]);
            return Receivers { centres, radius_m, patterns: Vec::new(), lo, hi, cell, dims, cells: vec![0, 0], items: Vec::new(), lattice: None };
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for c in &centres {
            lo = lo.min(*c - radius_m);
            hi = hi.max(*c + radius_m);
        }
        if centres.is_empty() {
            lo = DVec3::ZERO;
            hi = DVec3::ONE;
        }
        let lattice = floor_plan_lattice(&centres, radius_m);
        let (lo, cell, dims) = match lattice {
            // The paper's grid: one cell per receiver, each sphere inside its own cell.
            Some(lattice) => lattice,
            None => {
                let extent = (hi - lo).max(DVec3::splat(1e-9));
                // About one receiver a cell, never cells smaller than a sphere.
                let volume = extent.x * extent.y * extent.z;
                let cell = (volume / centres.len().max(1) as f64).cbrt().max(2.0 * radius_m);
                let dims = [
                    ((extent.x / cell).ceil() as usize).clamp(1, 1024),
                    ((extent.y / cell).ceil() as usize).clamp(1, 1024),
                    ((extent.z / cell).ceil() as usize).clamp(1, 1024),
                ];
                let cell = (extent.x / dims[0] as f64).max(extent.y / dims[1] as f64).max(extent.z / dims[2] as f64);
                (lo, DVec3::splat(cell), dims)
            }
        };
        let n_cells = dims[0] * dims[1] * dims[2];
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n_cells];
        for (k, c) in centres.iter().enumerate() {
            let a = ((*c - radius_m - lo) / cell).floor().max(DVec3::ZERO);
            let b = ((*c + radius_m - lo) / cell).floor();
            for z in a.z as usize..=(b.z as usize).min(dims[2] - 1) {
                for y in a.y as usize..=(b.y as usize).min(dims[1] - 1) {
                    for x in a.x as usize..=(b.x as usize).min(dims[0] - 1) {
                        lists[(z * dims[1] + y) * dims[0] + x].push(k as u32);
                    }
                }
            }
        }
        let mut cells = Vec::with_capacity(n_cells + 1);
        let mut items = Vec::new();
        cells.push(0);
        for l in lists {
            items.extend(l);
            cells.push(items.len() as u32);
        }
        let hi = lo + DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) * cell;
        let lattice = lattice.and_then(|(lo, cell, dims)| Lattice::new(&centres, lo, cell, dims, radius_m));
        Receivers { centres, radius_m, patterns: Vec::new(), lo, hi, cell, dims, cells, items, lattice }
    }

    /// Gives every receiver its pattern (one a receiver, in order); an all-omni list is
    /// stored as none, so that omnidirectional bakes take the fast path.
    pub fn with_patterns(mut self, patterns: Vec<ReceiverPattern>) -> Result<Receivers, String> {
        if patterns.len() != self.centres.len() {
            return Err(format!("{} patterns for {} receivers: one a receiver", patterns.len(), self.centres.len()));
        }
        self.patterns = if patterns.iter().all(ReceiverPattern::is_omni) { Vec::new() } else { patterns };
        Ok(self)
    }

    /// The patterns (empty: all omnidirectional).
    pub fn patterns(&self) -> &[ReceiverPattern] {
        &self.patterns
    }

    /// The largest gain of any receiver's pattern, at least 1.
    pub fn peak_gain(&self) -> f64 {
        self.patterns.iter().map(ReceiverPattern::peak).fold(1.0, f64::max)
    }

    /// Checks every pattern against a bake of `n_bands` bands.
    pub fn check_patterns(&self, n_bands: usize) -> Result<(), String> {
        for (r, p) in self.patterns.iter().enumerate() {
            p.check(n_bands).map_err(|problem| format!("receiver {r}: {problem}"))?;
        }
        Ok(())
    }

    /// Weighs a deposit into receiver `r` of sound arriving from unit direction `from` by the
    /// receiver's pattern (nothing to do for an omnidirectional one). `scratch` holds a band.
    #[inline]
    pub fn weigh(&self, r: usize, from: DVec3, energy: &mut [f64], scratch: &mut [f64]) {
        if let Some(p) = self.patterns.get(r) {
            p.weigh(from, energy, scratch);
        }
    }

    /// Weighs a deposit of sound arriving from all directions alike (the source inside the sphere).
    pub fn weigh_mean(&self, r: usize, energy: &mut [f64]) {
        if let Some(p) = self.patterns.get(r) {
            p.weigh_mean(energy);
        }
    }

    /// Receivers per cell of the search grid, at most (1 on a floor-plan lattice).
    pub fn max_per_cell(&self) -> usize {
        self.cells.windows(2).map(|w| (w[1] - w[0]) as usize).max().unwrap_or(0)
    }

    pub fn len(&self) -> usize {
        self.centres.len()
    }

    pub fn is_empty(&self) -> bool {
        self.centres.is_empty()
    }

    /// Calls `f` once for every sphere that the segment origin + t·dir, t in [0, length],
    /// crosses (dir is a unit vector). `stamp` is scratch of one u64 per receiver and
    /// `segment_id` must differ between calls: together they keep a sphere that spans several
    /// cells from being counted twice. Inlined into the tracer: most segments end at the
    /// rejection by their ends or at a sphere test or two; the cell walk is a call.
    #[inline(always)]
    pub fn crossings(&self, origin: DVec3, dir: DVec3, length: f64, stamp: &mut [u64], segment_id: u64, mut f: impl FnMut(Crossing)) {
        if self.centres.is_empty() {
            return;
        }
        // Most segments pass beside the box (a floor plan's receivers fill a thin slab at head
        // height): reject those by their ends before any division.
        let end = origin + dir * length;
        if (origin.cmplt(self.lo) & end.cmplt(self.lo)).any() || (origin.cmpgt(self.hi) & end.cmpgt(self.hi)).any() {
            return;
        }
        // A few receivers: test each sphere. Setting up the cell walk (six divisions, three
        // floors) costs more than a handful of sphere tests, and the walk would find the same
        // spheres (each is listed in every cell its box overlaps). The order of the calls differs,
        // which changes no bits: deposits are integers added in any order, their rounding keyed
        // by receiver and segment.
        if self.centres.len() <= DIRECT_TEST_MAX {
            for (k, c) in self.centres.iter().enumerate() {
                if let Some(crossing) = self.chord(k as u32, *c, origin, dir, length) {
                    f(crossing);
                }
            }
            return;
        }
        if let Some(lattice) = &self.lattice {
            self.walk_lattice(lattice, origin, dir, length, f);
            return;
        }
        self.walk(origin, dir, length, stamp, segment_id, f);
    }

    /// [`Receivers::crossings`] through the cells of the grid.
    #[inline(never)]
    fn walk(&self, origin: DVec3, dir: DVec3, length: f64, stamp: &mut [u64], segment_id: u64, mut f: impl FnMut(Crossing)) {
        // Clip the segment to the grid's box.
        let hi = self.hi;
        let inv = dir.map(|d| if d == 0.0 { 1e300f64.copysign(d) } else { 1.0 / d });
        let t0 = (self.lo - origin) * inv;
        let t1 = (hi - origin) * inv;
        let (near, far) = (t0.min(t1), t0.max(t1));
        let t_enter = near.max_element().max(0.0);
        let t_exit = far.min_element().min(length);
        if t_enter > t_exit {
            return;
        }
        // Walk the cells (Amanatides and Woo 1987). Products with the reciprocals instead of
        // divisions: the walk only decides which cells' spheres are tested, each by its exact
        // chord, so its rounding moves no bits (a sphere lies inside its cells, never only in
        // a corner that a rounding could skip).
        let p = (origin + dir * t_enter - self.lo) * self.cell.recip();
        let mut idx = [0i64; 3];
        let mut step = [0i64; 3];
        let mut t_next = [f64::INFINITY; 3];
        let mut t_delta = [f64::INFINITY; 3];
        for a in 0..3 {
            // Truncation, not `floor` (a libm call without SSE4.1): they differ only below 0,
            // where the clamp makes both 0.
            idx[a] = (p[a] as i64).clamp(0, self.dims[a] as i64 - 1);
            if dir[a] > 0.0 {
                step[a] = 1;
                t_delta[a] = self.cell[a] * inv[a];
                t_next[a] = t_enter + ((idx[a] + 1) as f64 - p[a]) * t_delta[a];
            } else if dir[a] < 0.0 {
                step[a] = -1;
                t_delta[a] = -self.cell[a] * inv[a];
                t_next[a] = t_enter + (p[a] - idx[a] as f64) * t_delta[a];
            }
        }
        loop {
            let c = ((idx[2] as usize * self.dims[1]) + idx[1] as usize) * self.dims[0] + idx[0] as usize;
            for &k in &self.items[self.cells[c] as usize..self.cells[c + 1] as usize] {
                if stamp[k as usize] == segment_id {
                    continue;
                }
                stamp[k as usize] = segment_id;
                if let Some(crossing) = self.chord(k, self.centres[k as usize], origin, dir, length) {
                    f(crossing);
                }
            }
            // Step to the next cell along the axis whose boundary comes first.
            let a = if t_next[0] < t_next[1] { if t_next[0] < t_next[2] { 0 } else { 2 } } else if t_next[1] < t_next[2] { 1 } else { 2 };
            if t_next[a] > t_exit {
                return;
            }
            idx[a] += step[a];
            if idx[a] < 0 || idx[a] >= self.dims[a] as i64 {
                return;
            }
            t_next[a] += t_delta[a];
        }
    }
}

/// Up to this many receivers, a segment tests every sphere instead of walking the grid's cells.
const DIRECT_TEST_MAX: usize = 8;

impl Receivers {
    /// The chord of the line origin + t·dir through sphere `k` (centre `centre`), clipped to
    /// [0, length], if it is not empty.
    #[inline(always)]
    fn chord(&self, k: u32, centre: DVec3, origin: DVec3, dir: DVec3, length: f64) -> Option<Crossing> {
        let r2 = self.radius_m * self.radius_m;
        let oc = centre - origin;
        let tc = oc.dot(dir);
        let d2 = oc.length_squared() - tc * tc;
        if d2 >= r2 {
            return None;
        }
        let half = (r2 - d2).sqrt();
        let (a, b) = ((tc - half).max(0.0), (tc + half).min(length));
        (b > a).then_some(Crossing { receiver: k, chord: b - a, t_nearest: tc, miss2: d2 })
    }
}

/// Mean of 1 / (4π |x − s|²) over a ball of radius r whose centre is at distance d from s.
///
/// This is what a sphere receiver measures of a point source's direct sound (the expectation of
/// the chord-length estimator), so the deterministic direct sound and diffuse-rain connections
/// agree with the spheres in expectation, including a source inside the sphere (d < r), where
/// it is finite: 3 / (4π r²) at d = 0. For d ≫ r it tends to 1 / (4π d²).
///
/// Integrating the shells of the ball: mean = 3 H / (8π r³ d), with
/// H = ((r² − d²)/2) ln((d + r)/|d − r|) + d r.
pub fn ball_mean_inverse_square(d: f64, r: f64) -> f64 {
    if d < 1e-9 * r {
        return 3.0 / (4.0 * std::f64::consts::PI * r * r);
    }
    let log = if (d - r).abs() < 1e-12 * r { 0.0 } else { ((d + r) / (d - r).abs()).ln() };
    let h = 0.5 * (r * r - d * d) * log + d * r;
    3.0 * h / (8.0 * std::f64::consts::PI * r * r * r * d)
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::super::pattern::Pattern;
    use super::*;

    #[test]
    fn a_measured_pattern_keeps_its_level_and_omni_receivers_take_the_fast_path() {
        // A measured gain of 2 in band 0 and 0.5 in band 1 everywhere: kept, not normalised
        // (a source's pattern would be scaled to mean 1); its mean over the sphere is exact
        // for a constant bilinear surface.
        let (nt, np, nb) = (5, 4, 2);
        let gains: Vec<f64> = (0..nt * np).flat_map(|_| [2.0, 0.5]).collect();
        let p = Pattern::measured(nt, np, nb, &gains, DVec3::X, DVec3::Z).unwrap();
        let r = ReceiverPattern::Table(Arc::new(p));
        let mut e = [1.0, 1.0];
        r.weigh(DVec3::new(0.3, -0.4, 0.5).normalize(), &mut e, &mut [0.0; 2]);
        assert!((e[0] - 2.0).abs() < 1e-12 && (e[1] - 0.5).abs() < 1e-12, "{e:?}");
        let mut m = [1.0, 1.0];
        r.weigh_mean(&mut m);
        assert!((m[0] - 2.0).abs() < 1e-12 && (m[1] - 0.5).abs() < 1e-12, "{m:?}");
        assert_eq!(r.peak(), 2.0);
        assert!(r.check(3).is_err());
        // Patterns per receiver; an all-omni list is stored as none.
        let centres = vec![DVec3::ZERO, DVec3::ONE];
        let rc = Receivers::new(centres.clone(), 0.1).with_patterns(vec![ReceiverPattern::Omni, ReceiverPattern::Omni]).unwrap();
        assert!(rc.patterns().is_empty());
        assert!(Receivers::new(centres.clone(), 0.1).with_patterns(vec![ReceiverPattern::Omni]).is_err());
        let rc = Receivers::new(centres, 0.1).with_patterns(vec![ReceiverPattern::Omni, r]).unwrap();
        assert_eq!(rc.peak_gain(), 2.0);
        let mut e = [1.0, 1.0];
        rc.weigh(0, DVec3::X, &mut e, &mut [0.0; 2]);
        assert_eq!(e, [1.0, 1.0]);
    }

    #[test]
    fn ball_mean_limits() {
        let r = 0.3;
        let at_centre = ball_mean_inverse_square(0.0, r);
        assert!((ball_mean_inverse_square(1e-6, r) / at_centre - 1.0).abs() < 1e-6);
        let d = 50.0;
        let far = ball_mean_inverse_square(d, r) * 4.0 * std::f64::consts::PI * d * d;
        assert!((far - 1.0).abs() < 1e-4, "{far}");
        // Continuous through the surface of the ball.
        let (a, b) = (ball_mean_inverse_square(r * (1.0 - 1e-7), r), ball_mean_inverse_square(r * (1.0 + 1e-7), r));
        assert!((a / b - 1.0).abs() < 1e-5);
    }

    #[test]
    fn ball_mean_matches_monte_carlo() {
        // Average of 1/(4π|x−s|²) over points x uniform in the ball, for s outside it (inside,
        // the integrand's variance is infinite and Monte Carlo cannot check it; the limits do).
        let mut s = crate::rng::Stream::new(11, 0, 0);
        for d in [0.6, 1.0, 2.5] {
            let r = 0.5;
            let n = 2_000_000;
            let mut sum = 0.0;
            for _ in 0..n {
                let dir = crate::sampling::uniform_sphere(s.uniform(), s.uniform());
                let x = dir * r * s.uniform().cbrt();
                sum += 1.0 / (4.0 * std::f64::consts::PI * (x - DVec3::new(d, 0.0, 0.0)).length_squared());
            }
            let mc = sum / n as f64;
            let exact = ball_mean_inverse_square(d, r);
            // 2 million samples of a bounded integrand: well under 1% error.
            assert!((mc / exact - 1.0).abs() < 0.01, "d = {d}: mc {mc} exact {exact}");
        }
    }

    #[test]
    fn grid_finds_the_same_spheres_as_testing_all() {
        // Spheres overlapping their neighbours (a generic grid), then a floor-plan lattice
        // (a cell per sphere) with one point missing, as a grid clipped by a wall.
        let overlapping: Vec<DVec3> = (0..60).map(|i| DVec3::new((i % 10) as f64, (i / 10) as f64 * 0.7, 1.5)).collect();
        let lattice: Vec<DVec3> = (0..60).filter(|&i| i != 23).map(|i| DVec3::new(0.5 + (i % 10) as f64, (i / 10) as f64 * 0.8, 1.5)).collect();
        let rc = Receivers::new(lattice.clone(), 0.35);
        assert_eq!(rc.max_per_cell(), 1);
        assert_eq!(rc.dims, [10, 6, 1]);
        assert!(Receivers::new(overlapping.clone(), 0.4).max_per_cell() > 1);
        // Two receivers at every lattice point (a receiver's channels): no lattice, every
        // sphere found (the lattice kept one receiver a point).
        let doubled: Vec<DVec3> = lattice.iter().flat_map(|c| [*c, *c]).collect();
        assert!(Receivers::new(doubled.clone(), 0.35).lattice.is_none());
        assert!(Receivers::new(lattice.clone(), 0.35).lattice.is_some());
        // 0.4: spheres that touch the cells' sides (listed in two cells, counted once).
        for (centres, radius) in [(overlapping, 0.4), (lattice.clone(), 0.35), (lattice, 0.4), (doubled, 0.35), (vec![DVec3::new(1.0, 2.0, 1.5)], 0.25)] {
            check_against_brute_force(&centres, radius);
        }
    }

    fn check_against_brute_force(centres: &[DVec3], radius: f64) {
        let r2 = radius * radius;
        let rc = Receivers::new(centres.to_vec(), radius);
        let mut stamp = vec![0u64; centres.len()];
        let mut s = crate::rng::Stream::new(5, 0, 0);
        for seg in 1..20_000u64 {
            let o = DVec3::new(s.uniform() * 12.0 - 1.0, s.uniform() * 6.0 - 1.0, s.uniform() * 3.0);
            let mut d = crate::sampling::uniform_sphere(s.uniform(), s.uniform());
            // Some straight up or down, along x or y, level at the spheres' height (the
            // lattice's degenerate directions).
            match seg % 7 {
                1 => d = DVec3::new(0.0, 0.0, d.z.signum()),
                2 => d = DVec3::new(d.x.signum(), 0.0, 0.0),
                3 => d = DVec3::new(0.0, d.y.signum(), 0.0),
                4 => d = DVec3::new(d.x, d.y, 0.0).normalize(),
                _ => {}
            }
            let o = if seg % 7 == 4 { DVec3::new(o.x, o.y, 1.5 + (s.uniform() - 0.5) * radius) } else { o };
            let len = s.uniform() * 8.0;
            let mut found = Vec::new();
            rc.crossings(o, d, len, &mut stamp, seg, |c| found.push((c.receiver, c.chord)));
            found.sort_by_key(|f| f.0);
            let mut expect = Vec::new();
            for (k, c) in centres.iter().enumerate() {
                let oc = *c - o;
                let tc = oc.dot(d);
                let d2 = oc.length_squared() - tc * tc;
                if d2 < r2 {
                    let h = (r2 - d2).sqrt();
                    let (a, b) = ((tc - h).max(0.0), (tc + h).min(len));
                    if b > a {
                        expect.push((k as u32, b - a));
                    }
                }
            }
            assert_eq!(found.len(), expect.len(), "segment {seg}");
            for (f, e) in found.iter().zip(&expect) {
                assert_eq!(f.0, e.0);
                assert!((f.1 - e.1).abs() < 1e-12);
            }
        }
    }
}
