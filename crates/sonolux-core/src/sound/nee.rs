//! Next-event estimation that scales with the number of receivers ("sampled rain").
//!
//! The rain estimator ([`super::Estimator::Rain`]) connects every diffuse reflection to every
//! receiver: its cost per reflection grows with the receivers, and on a grid it is unusable.
//! Here each diffuse reflection connects to `M` receivers drawn with replacement from a proposal
//! density p(r) that follows the connection's own geometric factor, and each connection is
//! weighted by 1 / (M p(r)): the expectation is the rain estimator's, receiver by receiver,
//! band by band (Shirley, Wang and Zimmerman, "Monte Carlo techniques for direct lighting
//! calculations", ACM TOG 15(1), 1996, §3: a light chosen with probability p and weighted by
//! 1/p; with M independent draws the mean of M such estimates).
//!
//! The proposal is drawn from a binary tree over the receivers' centres, walked from the root:
//! at each node the child is chosen in proportion to an importance that bounds what the receivers
//! below it can receive from the reflection point x with normal n (Conty Estevez and Kulla,
//! "Importance sampling of many lights with adaptive tree splitting", Proc. ACM CGIT 1(2), 2018,
//! §4: number of emitters × a bound of the cosine over the node's bounding cone / squared
//! distance). A receiver sphere gets, from a Lambert source at x, cos θ × the ball mean of
//! 1/(4π d²) ([`ball_mean_inverse_square`]); at a leaf this exact factor is the importance, so
//! between two sibling receivers the choice follows their connections exactly. The probability
//! of a receiver is the product of the choices along its path, computed on the way down: no
//! normalisation over all receivers, O(log N) work a draw.
//!
//! Unbiasedness needs p(r) > 0 wherever the rain estimator deposits: an internal node's
//! importance is zero only when its bounding sphere lies wholly behind the reflecting surface
//! (cos ≤ 0 for every receiver below), and is otherwise positive. Visibility is not in the
//! proposal (a blocked connection deposits nothing, as in rain).
//!
//! Visibility sharing: a receiver drawn k times among the M is connected once, with weight
//! k / (M p): one occlusion test and one deposit for the k draws, exactly. Distinct receivers
//! need distinct segments from x, and one ray cannot answer for another's segment; an exact shared
//! test would be a shaft test of the volume spanned by x and both spheres (Haines and Wallace,
//! "Shaft culling for efficient ray-traced radiosity", 1994), not done here.
//!
//! When the bake has no more receivers than M, every receiver is connected once (exactly the
//! rain estimator, which is then cheaper and has no sampling noise).
//!
//! Random numbers: the draws of a reflection are keyed by (seed, source, ray, event) through
//! [`keyed_uniform`] with a receiver key no receiver has, so they do not touch the ray's stream
//! (the ray's path is the rain estimator's path) and are the same whatever the threads or ranges.
//! A bake traced in receiver tiles (a memory budget smaller than its field) gives each tile the
//! whole bake's receivers ([`super::Extras::bake_receivers`]): the draws are made among all of
//! them, as in the untiled bake, and a tile deposits only the connections to its own receivers,
//! with their keys in the whole bake: the tiles together are the untiled bake, bit for bit.

use glam::DVec3;

use super::field::{Accumulator, Deposits};
use super::receivers::ball_mean_inverse_square;
use super::stats::SoundStats;
use super::Scene;
use crate::geometry::{offset_origin, Ray};
use crate::rng::keyed_uniform;

/// Most receivers one diffuse reflection may connect to (the draws live on the stack).
pub const MAX_CONNECTIONS: u32 = 256;

/// The hybrid's early diffuse connections, for the sphere ("paper") estimator: ODEON's early
/// scattering (Naylor, "ODEON — another hybrid room acoustical model", Applied Acoustics 38,
/// 1993; Rindel and Christensen, "Room acoustic simulation and auralization — how close can we
/// get to the real room?", WESPAC 8, 2003): the diffusely reflected part of every reflection is
/// sent straight to the receivers that see the reflection point, Lambert-weighted and
/// visibility-tested, for the arrivals before `until_s` (the transition time, when the image
/// sources hand over), and the cheap sphere estimator takes the rest.
///
/// Each path is counted once: the leg from a diffuse reflection at x straight to receiver r is
/// counted either by this connection (when it arrives before `until_s`) or by the sphere that
/// the ray's next segment crosses after a diffuse bounce at x (when it arrives at `until_s` or
/// later), never both. Both estimate the same quantity (the Lambert source at x seen over the
/// receiver's ball) and both time it at (path to x + |r − x|) / c, so the split is by the
/// arrival time alone, decided the same way on both sides. Segments after a specular bounce
/// (a specular chain from x) stay with the spheres, as in the rain estimator.
///
/// With more receivers than `connections`, each reflection connects to `connections` drawn
/// receivers ([`connect`], weighted 1 / (M p)); with no more, to every one (rain).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EarlyConnections {
    /// Arrivals before this time (s) come from the connections, later ones from the spheres.
    pub until_s: f64,
    /// M, the receivers a reflection connects to when the bake has more (1 to [`MAX_CONNECTIONS`]).
    pub connections: u32,
}

impl EarlyConnections {
    /// Checks the window and the connections; the message names the setting.
    pub fn check(&self) -> Result<(), String> {
        if !(self.until_s >= 0.0 && self.until_s.is_finite()) {
            return Err(format!("early connections: until_s = {} is not a finite time ≥ 0", self.until_s));
        }
        if !(1..=MAX_CONNECTIONS).contains(&self.connections) {
            return Err(format!("early connections: {} receivers a reflection; from 1 to {MAX_CONNECTIONS}", self.connections));
        }
        Ok(())
    }
}

/// The receiver key of the draws' random numbers: no receiver of a bake has this index.
const DRAW_KEY: u64 = u64::MAX - 1;

#[derive(Clone, Copy, Debug)]
struct Node {
    /// Centre and radius of a sphere holding every receiver sphere below the node.
    centre: DVec3,
    radius: f64,
    count: u32,
    /// Children (`left`, `left + 1` are not assumed: both stored), or the receiver of a leaf.
    left: u32,
    right: u32,
    leaf: bool,
}

/// A binary tree over the receivers' centres (median splits on the longest axis).
#[derive(Clone, Debug)]
pub struct ReceiverTree {
    nodes: Vec<Node>,
}

impl ReceiverTree {
    pub fn new(centres: &[DVec3], radius_m: f64) -> ReceiverTree {
        let mut tree = ReceiverTree { nodes: Vec::with_capacity(2 * centres.len()) };
        let mut order: Vec<u32> = (0..centres.len() as u32).collect();
        if !centres.is_empty() {
            tree.build(centres, radius_m, &mut order);
        }
        tree
    }

    /// Builds the node over `ids` and returns its index.
    fn build(&mut self, centres: &[DVec3], radius_m: f64, ids: &mut [u32]) -> u32 {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &i in ids.iter() {
            lo = lo.min(centres[i as usize]);
            hi = hi.max(centres[i as usize]);
        }
        let centre = 0.5 * (lo + hi);
        let radius = 0.5 * (hi - lo).length() + radius_m;
        let me = self.nodes.len() as u32;
        self.nodes.push(Node { centre, radius, count: ids.len() as u32, left: 0, right: 0, leaf: ids.len() == 1 });
        if ids.len() == 1 {
            self.nodes[me as usize].left = ids[0];
            return me;
        }
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z { 0 } else if extent.y >= extent.z { 1 } else { 2 };
        let mid = ids.len() / 2;
        // Ties broken by index: the tree does not depend on the sort's algorithm.
        ids.select_nth_unstable_by(mid, |a, b| centres[*a as usize][axis].total_cmp(&centres[*b as usize][axis]).then(a.cmp(b)));
        let (a, b) = ids.split_at_mut(mid);
        let left = self.build(centres, radius_m, a);
        let right = self.build(centres, radius_m, b);
        self.nodes[me as usize].left = left;
        self.nodes[me as usize].right = right;
        me
    }

    /// The importance of a node seen from `x` with unit normal `n` (see the module's doc).
    #[inline]
    fn importance(&self, node: &Node, x: DVec3, n: DVec3, receiver_radius: f64, centres: &[DVec3]) -> f64 {
        if node.leaf {
            // The exact factor, on the scale of the bound below (4π d² × the ball mean → 1).
            return 4.0 * std::f64::consts::PI * geometric_factor(centres[node.left as usize] - x, n, receiver_radius);
        }
        let to = node.centre - x;
        let d2 = to.length_squared();
        let r2 = node.radius * node.radius;
        if d2 <= r2 {
            // x inside the bounding sphere: any direction may lead to a receiver.
            return node.count as f64 / r2;
        }
        let d = d2.sqrt();
        // The largest cosine to any point of the bounding sphere: the angle to its centre less
        // the sphere's angular radius (a cone holding it).
        let cos_c = (n.dot(to) / d).clamp(-1.0, 1.0);
        let sin_c = (1.0 - cos_c * cos_c).max(0.0).sqrt();
        let sin_u = node.radius / d;
        let cos_u = (1.0 - sin_u * sin_u).max(0.0).sqrt();
        // cos(θc − θu) where θc > θu, else 1.
        let cos_max = if cos_c >= cos_u { 1.0 } else { cos_c * cos_u + sin_c * sin_u };
        if !(cos_max > 0.0) {
            return 0.0;
        }
        node.count as f64 * cos_max / d2
    }

    /// Draws one receiver with `u` uniform in [0, 1); returns it and its probability, or None
    /// when no receiver is in front of the surface.
    pub fn sample(&self, x: DVec3, n: DVec3, receiver_radius: f64, centres: &[DVec3], mut u: f64) -> Option<(u32, f64)> {
        let mut node = self.nodes.first()?;
        let mut p = 1.0;
        while !node.leaf {
            let (l, r) = (&self.nodes[node.left as usize], &self.nodes[node.right as usize]);
            let il = self.importance(l, x, n, receiver_radius, centres);
            let ir = self.importance(r, x, n, receiver_radius, centres);
            let total = il + ir;
            if !(total > 0.0) {
                return None;
            }
            let pl = il / total;
            // One uniform serves the whole descent: rescaled into the chosen part each step.
            if u < pl {
                u /= pl;
                p *= pl;
                node = l;
            } else {
                u = ((u - pl) / (1.0 - pl)).min(1.0 - f64::EPSILON);
                p *= 1.0 - pl;
                node = r;
            }
        }
        let leaf_ok = geometric_factor(centres[node.left as usize] - x, n, receiver_radius) > 0.0;
        (leaf_ok && p > 0.0).then_some((node.left, p))
    }

    /// The probability that [`ReceiverTree::sample`] draws `receiver` (for tests).
    pub fn probability(&self, x: DVec3, n: DVec3, receiver_radius: f64, centres: &[DVec3], receiver: u32) -> f64 {
        // Walk every path: small trees only.
        #[allow(clippy::too_many_arguments)]
        fn walk(t: &ReceiverTree, i: u32, p: f64, x: DVec3, n: DVec3, rr: f64, c: &[DVec3], target: u32) -> f64 {
            let node = &t.nodes[i as usize];
            if node.leaf {
                return if node.left == target && geometric_factor(c[node.left as usize] - x, n, rr) > 0.0 { p } else { 0.0 };
            }
            let il = t.importance(&t.nodes[node.left as usize], x, n, rr, c);
            let ir = t.importance(&t.nodes[node.right as usize], x, n, rr, c);
            if !(il + ir > 0.0) {
                return 0.0;
            }
            walk(t, node.left, p * il / (il + ir), x, n, rr, c, target) + walk(t, node.right, p * ir / (il + ir), x, n, rr, c, target)
        }
        if self.nodes.is_empty() {
            return 0.0;
        }
        walk(self, 0, 1.0, x, n, receiver_radius, centres, receiver)
    }
}

/// What a receiver sphere gets of a Lambert source at the origin of `to` with normal `n`,
/// up to the source's energy and constants: cos θ × the ball mean of 1/(4π d²); 0 behind.
#[inline]
fn geometric_factor(to: DVec3, n: DVec3, receiver_radius: f64) -> f64 {
    let d = to.length();
    let cos = n.dot(to) / d;
    if !(cos > 0.0) {
        return 0.0;
    }
    cos * ball_mean_inverse_square(d, receiver_radius)
}

/// Next-event estimation at a diffuse reflection through `m` drawn receivers: the diffusely
/// scattered part s·E leaves `point` as a Lambert source; receiver r, drawn k times, receives
/// k / (m p(r)) × what the rain estimator sends it (4 cos θ × the ball mean of 1/(4π d²) × air).
/// `key` is (source, ray, event): the draws' and the roundings' key. Only connections arriving
/// before `until_s` deposit ([`EarlyConnections`]; infinite for the nee estimator).
#[allow(clippy::too_many_arguments)]
pub(crate) fn connect(scene: &Scene, m: u32, point: DVec3, normal: DVec3, path: f64, e: &[f64], scat: &[f64], share: f64, acc: &Accumulator, buf: &mut Deposits, st: &mut SoundStats, key: [u64; 3], scratch: (&mut [f64], &mut [f64]), until_s: f64) {
    let (deposit, gain) = scratch;
    let Some(tree) = scene.receiver_tree else { return };
    let set = scene.settings;
    // The tree's receivers: the whole bake's, of which this run traces `offset..offset + own`.
    let centres = scene.tree_centres;
    let (offset, own) = (scene.tree_offset, scene.receivers.centres.len());
    let radius = scene.receivers.radius_m;
    let n_receivers = centres.len();
    // Draw the m receivers, or take each once when there are no more than m.
    let mut picks = [(0u32, 0f64); MAX_CONNECTIONS as usize];
    let mut n_picks = 0usize;
    if n_receivers <= m as usize {
        for (r, pick) in picks.iter_mut().enumerate().take(n_receivers) {
            *pick = (r as u32, 1.0);
        }
        n_picks = n_receivers;
    } else {
        st.draws += u64::from(m);
        for j in 0..m as u64 {
            let u = keyed_uniform(set.seed, key[0], key[1], DRAW_KEY, key[2] * MAX_CONNECTIONS as u64 + j);
            if let Some((r, p)) = tree.sample(point, normal, radius, centres, u) {
                picks[n_picks] = (r, 1.0 / (m as f64 * p));
                n_picks += 1;
            }
        }
        // The same receiver drawn twice is connected once with the summed weight.
        picks[..n_picks].sort_unstable_by_key(|p| p.0);
        let mut w = 0usize;
        for i in 0..n_picks {
            if w > 0 && picks[w - 1].0 == picks[i].0 {
                picks[w - 1].1 += picks[i].1;
            } else {
                picks[w] = picks[i];
                w += 1;
            }
        }
        n_picks = w;
    }
    for &(r, weight) in &picks[..n_picks] {
        // A receiver of another tile: that tile's run deposits it (the same draws there).
        let Some(r) = (r as usize).checked_sub(offset).filter(|&r| r < own) else { continue };
        connect_one(scene, r, weight, point, normal, path, e, scat, share, acc, buf, st, key, (&mut *deposit, &mut *gain), until_s);
    }
}

/// Next-event estimation at a reflection: the diffusely scattered part s·E leaves the point as
/// a Lambert source, so a receiver at distance d and angle θ from the normal receives
/// s·E·cos θ / (π d²) per unit area, taken here as the mean over its sphere, 4 cos θ ×
/// [`ball_mean_inverse_square`], and attenuated by the air on the way.
/// `scratch` is the worker's (deposit, receiver gain), one value a band each; `key` is
/// (source, ray, event), the rounding's key with the receiver.
#[allow(clippy::too_many_arguments)]
pub(crate) fn rain(scene: &Scene, point: DVec3, normal: DVec3, path: f64, e: &[f64], scat: &[f64], share: f64, acc: &Accumulator, buf: &mut Deposits, st: &mut SoundStats, key: [u64; 3], scratch: (&mut [f64], &mut [f64])) {
    let (deposit, gain) = scratch;
    for r in 0..scene.receivers.centres.len() {
        connect_one(scene, r, 1.0, point, normal, path, e, scat, share, acc, buf, st, key, (&mut *deposit, &mut *gain), f64::INFINITY);
    }
}

/// One next-event connection of the rain and nee estimators: the diffusely reflected energy at
/// `point` sent to receiver `r` (Lambert's cosine, the sphere's mean 1/(4πd²), air, the
/// receiver's pattern) with an extra `weight` (1 for rain; 1/(M p) for a sampled receiver),
/// if the receiver is in front of the surface and sees the point, and it arrives before
/// `until_s` (infinite for rain and nee; the window of [`super::nee::EarlyConnections`]).
#[allow(clippy::too_many_arguments)]
fn connect_one(scene: &Scene, r: usize, weight: f64, point: DVec3, normal: DVec3, path: f64, e: &[f64], scat: &[f64], share: f64, acc: &Accumulator, buf: &mut Deposits, st: &mut SoundStats, key: [u64; 3], scratch: (&mut [f64], &mut [f64]), until_s: f64) {
    let (deposit, gain) = scratch;
    let set = scene.settings;
    let lay = &scene.layout;
    let nb = e.len();
    let c = scene.receivers.centres[r];
    let to = c - point;
    let d = to.length();
    let cos = normal.dot(to) / d;
    if !(cos > 0.0) {
        return;
    }
    let time_s = (path + d) / set.speed_of_sound_m_s;
    if !(time_s < until_s) {
        return;
    }
    let Some(tb) = lay.time_bin(time_s) else { return };
    if !scene.convex {
        let from = offset_origin(point, normal, point + normal);
        let ray = Ray::new(from.as_vec3(), (c - from).as_vec3());
        st.shadow_rays += 1;
        if scene.bvh.occluded(&ray, 0.0, 1.0) {
            return;
        }
    }
    // weight × share: the same bits as share alone for rain's weight 1.
    let g = weight * share * 4.0 * cos * ball_mean_inverse_square(d, scene.receivers.radius_m);
    for b in 0..nb {
        deposit[b] = e[b] * scat[b] * g;
    }
    // The air over the leg (sound/air.rs: the kernel's factors; × 1 exactly without air).
    if scene.air {
        scene.air_lanes.attenuate(d, &mut deposit[..nb]);
    }
    scene.receivers.weigh(r, -to / d, &mut deposit[..nb], gain);
    let u = keyed_uniform(set.seed, key[0], key[1], set.first_receiver + r as u64, key[2]);
    acc.deposit(buf, lay.cell(r, tb, lay.direction_bin(-to / d)), &deposit[..nb], u);
    st.deposits += 1;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;

    fn grid() -> Vec<DVec3> {
        (0..37).map(|i| DVec3::new(0.5 + (i % 7) as f64 * 1.1, 0.4 + (i / 7) as f64 * 0.9, 1.2 + 0.1 * (i % 3) as f64)).collect()
    }

    #[test]
    fn probabilities_sum_to_one_over_the_receivers_in_front() {
        let c = grid();
        let t = ReceiverTree::new(&c, 0.3);
        for (x, n) in [(DVec3::new(3.0, 2.0, 0.0), DVec3::Z), (DVec3::new(0.0, 2.0, 1.5), DVec3::X), (DVec3::new(4.0, 3.0, 1.25), -DVec3::Y)] {
            let total: f64 = (0..c.len() as u32).map(|r| t.probability(x, n, 0.3, &c, r)).sum();
            // 1 when every receiver is in front; below 1 when a node's bounding sphere straddles
            // the surface but its receivers are all behind (a draw that finds none: no deposit).
            let all_in_front = c.iter().all(|cr| geometric_factor(*cr - x, n, 0.3) > 0.0);
            assert!(if all_in_front { (total - 1.0).abs() < 1e-12 } else { total > 0.0 && total <= 1.0 + 1e-12 }, "{total}");
            // Every receiver in front has a positive probability (needed for unbiasedness).
            for (r, cr) in c.iter().enumerate() {
                if geometric_factor(*cr - x, n, 0.3) > 0.0 {
                    assert!(t.probability(x, n, 0.3, &c, r as u32) > 0.0);
                }
            }
        }
    }

    #[test]
    fn draws_follow_the_stated_probabilities() {
        // Chi-square of 200,000 draws against the probabilities the tree reports.
        let c = grid();
        let t = ReceiverTree::new(&c, 0.3);
        let (x, n) = (DVec3::new(2.0, 1.0, 1.25), DVec3::new(0.6, 0.8, 0.0));
        // A wall through the grid: some receivers behind, and draws that find none.
        let mut counts = vec![0f64; c.len() + 1];
        let mut s = Stream::new(3, 0, 0);
        let draws = 200_000;
        for _ in 0..draws {
            match t.sample(x, n, 0.3, &c, s.uniform()) {
                Some((r, p)) => {
                    assert!((p - t.probability(x, n, 0.3, &c, r)).abs() < 1e-9 * p);
                    counts[r as usize] += 1.0;
                }
                None => counts[c.len()] += 1.0,
            }
        }
        let mut probs: Vec<f64> = (0..c.len() as u32).map(|r| t.probability(x, n, 0.3, &c, r)).collect();
        probs.push(1.0 - probs.iter().sum::<f64>());
        let (mut chi2, mut dof) = (0.0f64, -1.0f64);
        for (k, p) in probs.iter().enumerate() {
            if *p > 0.0 {
                let e = draws as f64 * p;
                chi2 += (counts[k] - e).powi(2) / e;
                dof += 1.0;
            } else {
                assert_eq!(counts[k], 0.0, "a receiver of probability 0 was drawn");
            }
        }
        // P(χ² > dof + 6 √(2 dof)) < 1e-4 for these degrees of freedom (15–37).
        assert!(dof >= 10.0 && chi2 < dof + 6.0 * (2.0 * dof).sqrt(), "chi2 = {chi2}, dof = {dof}");
    }

    #[test]
    fn receivers_behind_the_surface_are_never_drawn() {
        let c = grid();
        let t = ReceiverTree::new(&c, 0.3);
        // A wall at x = 3 facing -x: only receivers with x < 3 are in front.
        let (x, n) = (DVec3::new(3.0, 2.0, 1.2), -DVec3::X);
        let mut s = Stream::new(9, 0, 0);
        for _ in 0..20_000 {
            if let Some((r, _)) = t.sample(x, n, 0.3, &c, s.uniform()) {
                assert!(c[r as usize].x < 3.0);
            }
        }
    }
}
