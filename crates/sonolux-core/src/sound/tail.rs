//! The largest per-ray late contributions of a bake, per receiver and band: the data of the
//! progressive bake's heavy-tail diagnostic (python/sonolux/sound/tail.py, docs/progressive.md,
//! "The late decay of rare long-lived rays").
//!
//! A ray's contribution to entry (receiver r, band b) is the sum of the energies it deposits
//! into receiver r's sphere in band b at or after `from_s[r · bands + b]` (before the
//! fixed-point rounding: the expectation the counts round). The mean of those contributions
//! over the rays is the late energy the decay's end rests on; whether that mean can be trusted
//! is a question about the contributions' upper tail, which the generalized Pareto fit of
//! Pareto smoothed importance sampling answers from the largest M = 3√S of S draws (Vehtari,
//! Simpson, Gelman, Yao and Gabry, JMLR 25, 2024, §3 and Appendix H). So each entry keeps its
//! `keep` largest contributions, with the ray that made each.
//!
//! Same bits whatever the threads and ray ranges: a ray's sum is its own deposits added in its
//! own order; an entry keeps the first `keep` of its contributions in one total order (value
//! descending, then source, then ray ascending), and the first `keep` of a union are the first
//! `keep` of the first `keep` of each part. Off the bake's path unless asked for: the tracer
//! tests one `Option` a deposit and a ray.

/// What a bake asks for: per entry (receiver-major, `bands` a receiver), the time in s from
/// which deposits count (infinite: the entry is not watched), and how many contributions an
/// entry keeps.
#[derive(Clone, Debug, PartialEq)]
pub struct TailSettings {
    pub from_s: Vec<f64>,
    pub keep: usize,
}

/// One kept contribution: its value (J/m², the deposits' energy before rounding) and its ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contribution {
    pub value: f64,
    pub source: u32,
    pub ray: u64,
}

/// The kept contributions of every entry, and per entry the number of rays that contributed
/// at all (more than zero).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tail {
    pub kept: Vec<Vec<Contribution>>,
    pub contributing: Vec<u64>,
    keep: usize,
}

/// The order an entry keeps: larger values first, then the lower (source, ray).
fn first(a: &Contribution, b: &Contribution) -> std::cmp::Ordering {
    b.value.total_cmp(&a.value).then(a.source.cmp(&b.source)).then(a.ray.cmp(&b.ray))
}

impl Tail {
    pub fn new(entries: usize, keep: usize) -> Tail {
        Tail { kept: vec![Vec::new(); entries], contributing: vec![0; entries], keep }
    }

    /// Adds one ray's contribution to entry `i`.
    fn offer(&mut self, i: usize, c: Contribution) {
        self.contributing[i] += 1;
        let list = &mut self.kept[i];
        list.push(c);
        // Amortised: let the list grow to twice `keep`, then cut it back to the first `keep`.
        if list.len() >= 2 * self.keep.max(1) {
            list.select_nth_unstable_by(self.keep - 1, first);
            list.truncate(self.keep);
        }
    }

    /// The first `keep` of each entry, in order (the answer; call after the last ray).
    pub fn finish(&mut self) {
        for list in &mut self.kept {
            list.sort_unstable_by(first);
            list.truncate(self.keep);
        }
    }

    /// Adds another worker's (or range's) tail: the same bits as one tail of all their rays.
    pub fn merge(&mut self, other: &Tail) {
        for (i, list) in other.kept.iter().enumerate() {
            self.kept[i].extend_from_slice(list);
            self.contributing[i] += other.contributing[i];
        }
        self.finish();
    }
}

/// A worker's tail and the ray it is tracing: its late sums per entry, and which receivers
/// the ray reached (so that only those are read at its end).
#[derive(Debug)]
pub struct RayTail {
    from_s: Vec<f64>,
    bands: usize,
    sums: Vec<f64>,
    touched: Vec<u32>,
    pub tail: Tail,
}

impl RayTail {
    pub fn new(settings: &TailSettings, bands: usize) -> RayTail {
        let n = settings.from_s.len();
        RayTail { from_s: settings.from_s.clone(), bands, sums: vec![0.0; n], touched: Vec::new(), tail: Tail::new(n, settings.keep) }
    }

    /// A deposit of the current ray into `receiver` at `time_s`, `energy` per band.
    #[inline]
    pub fn deposit(&mut self, receiver: u32, time_s: f64, energy: &[f64]) {
        let base = receiver as usize * self.bands;
        let mut any = false;
        for (b, &e) in energy.iter().enumerate() {
            if time_s >= self.from_s[base + b] && e > 0.0 {
                if self.sums[base + b] == 0.0 {
                    any = true;
                }
                self.sums[base + b] += e;
            }
        }
        if any && !self.touched.contains(&receiver) {
            self.touched.push(receiver);
        }
    }

    /// The current ray (`source`, `ray`) has ended: its sums become contributions.
    pub fn end_ray(&mut self, source: usize, ray: u64) {
        for &r in &self.touched {
            let base = r as usize * self.bands;
            for i in base..base + self.bands {
                let value = std::mem::take(&mut self.sums[i]);
                if value > 0.0 {
                    self.tail.offer(i, Contribution { value, source: source as u32, ray });
                }
            }
        }
        self.touched.clear();
    }
}

impl super::trace::Worker {
    /// The worker, watching the late contributions `tail` asks for (None: not at all).
    pub(super) fn watching(mut self, tail: Option<&TailSettings>, bands: usize) -> Self {
        self.scratch.tail = tail.map(|t| RayTail::new(t, bands));
        self
    }
}

/// The workers' tails as one: the same bits whatever the workers and their rays.
pub(super) fn merged(tails: impl Iterator<Item = RayTail>, entries: usize, keep: usize) -> Tail {
    let mut out = Tail::new(entries, keep);
    for t in tails {
        out.merge(&t.tail);
    }
    out.finish();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(value: f64, ray: u64) -> Contribution {
        Contribution { value, source: 0, ray }
    }

    #[test]
    fn a_tail_keeps_the_largest_in_one_order_however_its_rays_are_split() {
        // 1,000 contributions with ties, offered in one tail or in three, in another order.
        let values: Vec<Contribution> = (0..1000u64).map(|i| c(((i * 7919) % 113) as f64, i)).collect();
        let mut one = Tail::new(1, 40);
        for &v in &values {
            one.offer(0, v);
        }
        one.finish();
        let mut parts = [Tail::new(1, 40), Tail::new(1, 40), Tail::new(1, 40)];
        for &v in values.iter().rev() {
            parts[(v.ray % 3) as usize].offer(0, v);
        }
        let mut merged = Tail::new(1, 40);
        for p in &mut parts {
            p.finish();
            merged.merge(p);
        }
        assert_eq!(one, merged);
        assert_eq!(one.contributing[0], 1000);
        let mut sorted = values.clone();
        sorted.sort_by(first);
        assert_eq!(one.kept[0], sorted[..40].to_vec());
        assert!(one.kept[0].windows(2).all(|w| w[0].value >= w[1].value));
    }

    #[test]
    fn a_ray_contributes_its_late_deposits_only_once_it_ends() {
        let settings = TailSettings { from_s: vec![0.5, 1.0, f64::INFINITY, 0.0], keep: 4 };
        let mut t = RayTail::new(&settings, 2);
        t.deposit(0, 0.4, &[1.0, 1.0]); // too early for both bands of receiver 0
        t.deposit(0, 0.7, &[2.0, 3.0]); // band 0 only
        t.deposit(0, 1.2, &[0.5, 4.0]);
        t.deposit(1, 9.0, &[8.0, 1.0]); // receiver 1: band 0 never watched, band 1 from 0
        t.end_ray(0, 5);
        t.deposit(1, 0.1, &[1.0, 0.25]);
        t.end_ray(0, 6);
        t.tail.finish();
        assert_eq!(t.tail.kept[0], vec![c(2.5, 5)]);
        assert_eq!(t.tail.kept[1], vec![c(4.0, 5)]);
        assert!(t.tail.kept[2].is_empty());
        assert_eq!(t.tail.kept[3], vec![c(1.0, 5), c(0.25, 6)]);
        assert_eq!(t.tail.contributing, vec![1, 1, 0, 2]);
    }
}
