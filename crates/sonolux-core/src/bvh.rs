//! Bounding-volume hierarchy over a mesh's triangles, built with the binned surface-area
//! heuristic, with closest-hit and any-hit queries. Both tracers and the camera share one.
//!
//! Layout: a flat array of 32-byte nodes in depth-first order (a node's left child follows it),
//! and the triangles' corners copied into leaf order so that a leaf reads one contiguous run.

use glam::Vec3;
use rayon::prelude::*;

use crate::error::CoreError;
use crate::geometry::{intersect_triangle, Aabb, Hit, Ray};
use crate::mesh::Mesh;

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Leaf: first triangle (in leaf order). Interior: index of the right child.
    first_or_right: u32,
    /// Leaf: number of triangles (> 0). Interior: 0.
    count: u32,
}

/// The acceleration structure. Queries take `&self` and are safe to share between threads.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Triangle corners in leaf order.
    corners: Vec<[Vec3; 3]>,
    /// Mesh index of each triangle in leaf order.
    ids: Vec<u32>,
}

const BINS: usize = 16;
const MAX_LEAF: usize = 8;
/// Cost of one traversal step relative to one triangle test, for the SAH.
const TRAVERSAL_COST: f32 = 1.0;
const STACK: usize = 64;

struct Build<'a> {
    centroids: Vec<Vec3>,
    boxes: Vec<Aabb>,
    order: Vec<u32>,
    nodes: Vec<Node>,
    _mesh: &'a Mesh,
}

impl Bvh {
    /// Builds the hierarchy over the mesh's non-degenerate triangles.
    pub fn build(mesh: &Mesh) -> Result<Bvh, CoreError> {
        let order: Vec<u32> = (0..mesh.triangles.len() as u32).filter(|&i| !mesh.degenerate[i as usize]).collect();
        if order.is_empty() {
            return Err(CoreError::Geometry("no triangles with a non-zero area".into()));
        }
        let n = mesh.triangles.len();
        let mut boxes = vec![Aabb::EMPTY; n];
        let mut centroids = vec![Vec3::ZERO; n];
        for &i in &order {
            let [a, b, c] = mesh.corners(i as usize);
            let mut bb = Aabb::EMPTY;
            bb.grow(a);
            bb.grow(b);
            bb.grow(c);
            boxes[i as usize] = bb;
            centroids[i as usize] = bb.center();
        }
        let count = order.len();
        let mut b = Build { centroids, boxes, order, nodes: Vec::with_capacity(2 * count / MAX_LEAF + 1), _mesh: mesh };
        b.split(0, count, 0);
        let corners = b.order.iter().map(|&i| mesh.corners(i as usize)).collect();
        Ok(Bvh { nodes: b.nodes, corners, ids: b.order })
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    pub fn bounds(&self) -> Aabb {
        self.nodes[0].bounds
    }

    /// The nearest triangle hit with t in (t_min, t_max).
    pub fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut t_best = t_max;
        self.traverse(ray, t_min, &mut t_best, |tri, t| {
            best = Some(Hit { t, triangle: tri });
            false
        });
        best
    }

    /// Whether any triangle is hit with t in (t_min, t_max): the visibility test.
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        let mut found = false;
        let mut t = t_max;
        self.traverse(ray, t_min, &mut t, |_, _| {
            found = true;
            true
        });
        found
    }

    /// Closest hits of many rays on the current rayon pool; one result per ray, in order.
    pub fn closest_hits(&self, rays: &[Ray], t_max: f32) -> Vec<Option<Hit>> {
        rays.par_iter().with_min_len(256).map(|r| self.closest_hit(r, 0.0, t_max)).collect()
    }

    /// Stack traversal, nearer child first. `on_hit(triangle, t)` is called for each hit closer
    /// than `*t_max` (which then shrinks to t); it returns true to stop at once (any-hit).
    #[inline]
    fn traverse(&self, ray: &Ray, t_min: f32, t_max: &mut f32, mut on_hit: impl FnMut(u32, f32) -> bool) {
        if self.nodes[0].bounds.hit(ray, t_min, *t_max).is_none() {
            return;
        }
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        let mut index = 0usize;
        loop {
            let node = &self.nodes[index];
            if node.count > 0 {
                // Leaf: test its triangles.
                let start = node.first_or_right as usize;
                for k in start..start + node.count as usize {
                    let [a, b, c] = self.corners[k];
                    if let Some(t) = intersect_triangle(ray, a, b, c, t_min, *t_max) {
                        *t_max = t;
                        if on_hit(self.ids[k], t) {
                            return;
                        }
                    }
                }
            } else {
                // Interior: visit the children the ray meets, the nearer one first.
                let (left, right) = (index + 1, node.first_or_right as usize);
                let hl = self.nodes[left].bounds.hit(ray, t_min, *t_max);
                let hr = self.nodes[right].bounds.hit(ray, t_min, *t_max);
                match (hl, hr) {
                    (Some(tl), Some(tr)) => {
                        let (near, far) = if tl <= tr { (left, right) } else { (right, left) };
                        stack[sp] = far as u32;
                        sp += 1;
                        index = near;
                        continue;
                    }
                    (Some(_), None) => {
                        index = left;
                        continue;
                    }
                    (None, Some(_)) => {
                        index = right;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            if sp == 0 {
                return;
            }
            sp -= 1;
            index = stack[sp] as usize;
        }
    }
}

impl Build<'_> {
    /// Builds the subtree over order[start..end] and returns its node index.
    fn split(&mut self, start: usize, end: usize, depth: usize) -> usize {
        let index = self.nodes.len();
        let mut bounds = Aabb::EMPTY;
        let mut cbounds = Aabb::EMPTY;
        for &i in &self.order[start..end] {
            bounds = bounds.union(&self.boxes[i as usize]);
            cbounds.grow(self.centroids[i as usize]);
        }
        self.nodes.push(Node { bounds, first_or_right: start as u32, count: (end - start) as u32 });
        let n = end - start;
        if n <= 2 || depth + 1 >= STACK {
            return index;
        }

        // Find the cheapest of the binned splits along each axis.
        let extent = cbounds.extent();
        let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, bin boundary)
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                continue;
            }
            let scale = BINS as f32 / extent[axis];
            let bin_of = |c: Vec3| (((c[axis] - cbounds.min[axis]) * scale) as usize).min(BINS - 1);
            let mut bin_box = [Aabb::EMPTY; BINS];
            let mut bin_n = [0usize; BINS];
            for &i in &self.order[start..end] {
                let b = bin_of(self.centroids[i as usize]);
                bin_box[b] = bin_box[b].union(&self.boxes[i as usize]);
                bin_n[b] += 1;
            }
            // Sweep from the right to get the area and count right of each boundary.
            let mut right_area = [0f32; BINS];
            let mut right_n = [0usize; BINS];
            let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
            for b in (1..BINS).rev() {
                acc = acc.union(&bin_box[b]);
                cnt += bin_n[b];
                right_area[b] = acc.half_area();
                right_n[b] = cnt;
            }
            let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
            for b in 1..BINS {
                acc = acc.union(&bin_box[b - 1]);
                cnt += bin_n[b - 1];
                if cnt == 0 || right_n[b] == 0 {
                    continue;
                }
                let cost = cnt as f32 * acc.half_area() + right_n[b] as f32 * right_area[b];
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, b));
                }
            }
        }

        let leaf_cost = n as f32;
        let split = match best {
            Some((cost, axis, boundary)) => {
                let sah = TRAVERSAL_COST + cost / bounds.half_area().max(f32::MIN_POSITIVE);
                if sah >= leaf_cost && n <= MAX_LEAF {
                    return index;
                }
                let scale = BINS as f32 / extent[axis];
                let (lo, cs) = (cbounds.min[axis], &self.centroids);
                let mid = partition(&mut self.order[start..end], |i| {
                    (((cs[i as usize][axis] - lo) * scale) as usize).min(BINS - 1) < boundary
                });
                start + mid
            }
            None if n <= MAX_LEAF => return index,
            // All centroids coincide: split the list in half.
            None => start + n / 2,
        };
        let mid = split;
        self.split(start, mid, depth + 1);
        let right = self.split(mid, end, depth + 1);
        self.nodes[index] = Node { bounds, first_or_right: right as u32, count: 0 };
        index
    }
}

/// Moves the items for which `left` holds to the front; returns how many there are.
fn partition(items: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut k = 0;
    for j in 0..items.len() {
        if left(items[j]) {
            items.swap(k, j);
            k += 1;
        }
    }
    k
}
