//! What a tree costs a query: the closest-hit walk of `traverse::closest` retraced with
//! counters (node tests, packet tests), to judge a build by the work its queries do
//! (docs/bvh.md, "Wide nodes by cost"). The same node test (the walk's own, on the portable
//! lanes, which round alike), the same nearest-first order (entry distance, then the lower
//! slot) and the same pruning, so the same visits and the same answer; the triangles of a
//! packet by the scalar watertight test, which the packet test equals to the bit.

use glam::Vec3;

use super::super::lanes::Portable;
use super::super::traverse::{TravRay, WideNode};
use super::super::{Bvh, Node8, LEAF, PACKET_INDEX};
use crate::geometry::{intersect_triangle, Hit, Ray, BOX_EXIT_WIDEN};

/// Work done by one closest-hit query.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkCounts {
    /// 8-wide node tests.
    pub nodes: u32,
    /// 8-triangle packet tests.
    pub packets: u32,
    /// Node tests on the way from the root to the leaf that holds the answer (0 for a miss):
    /// the rest of `nodes` were tests of boxes the answer was not in.
    pub to_answer: u32,
}

impl Bvh {
    /// [`Bvh::closest_hit_from`] with the work it took, on a tree with full-precision nodes
    /// (`None` on a compressed tree): a probe of the tree's quality, not a fast query.
    pub fn closest_hit_counted(&self, origin: Vec3, dir: Vec3) -> Option<(Option<Hit>, WalkCounts)> {
        if self.is_compressed() {
            return None;
        }
        let l = Portable;
        let trav = TravRay::from_origin_dir(l, origin, dir, 0.0);
        let ray = Ray::new(origin, dir);
        let mut counts = WalkCounts::default();
        let (mut t_best, mut triangle) = (f32::INFINITY, u32::MAX);
        // Entries: child, entry distance, node tests on the way to it.
        let mut stack: Vec<(u32, f32, u32)> = Vec::new();
        let (mut current, mut depth) = (0u32, 0u32);
        loop {
            if current & LEAF == 0 {
                let node: &Node8 = &self.nodes[current as usize];
                counts.nodes += 1;
                depth += 1;
                let (mask, enter) = node.hit_children(l, &trav, t_best);
                let mut hit: Vec<usize> = (0..8).filter(|s| mask >> s & 1 != 0).collect();
                // Nearest entry first, the lower slot first on ties.
                hit.sort_by(|&a, &b| enter[a].total_cmp(&enter[b]).then(a.cmp(&b)));
                if let Some((&first, rest)) = hit.split_first() {
                    stack.extend(rest.iter().rev().map(|&s| (node.child[s], enter[s], depth)));
                    current = node.child[first];
                    continue;
                }
            } else {
                let first = (current & PACKET_INDEX) as usize;
                for p in &self.packets[first..first + ((current & !LEAF) >> 29) as usize + 1] {
                    counts.packets += 1;
                    for lane in 0..8 {
                        let v = |k: usize| Vec3::new(p.corners[3 * k][lane], p.corners[3 * k + 1][lane], p.corners[3 * k + 2][lane]);
                        if let Some(t) = intersect_triangle(&ray, v(0), v(1), v(2), 0.0, t_best) {
                            (t_best, triangle, counts.to_answer) = (t, p.ids[lane], depth);
                        }
                    }
                }
            }
            loop {
                match stack.pop() {
                    None => return Some(((triangle != u32::MAX).then_some(Hit { t: t_best, triangle }), counts)),
                    // (Widened as the walk's own pop: traverse::closest.)
                    Some((child, t, d)) if t <= t_best * BOX_EXIT_WIDEN => {
                        (current, depth) = (child, d);
                        break;
                    }
                    Some(_) => {}
                }
            }
        }
    }
}
