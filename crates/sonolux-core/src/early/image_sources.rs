//! Specular image sources on a mesh (Allen and Berkley 1979 for the images; Borish, "Extension
//! of the image model to arbitrary polyhedra", JASA 75(6), 1984, for validity and visibility).
//!
//! One tree per source, shared by all receivers: node 0 is the source, a child is its parent
//! mirrored in another plane. A child is kept only if geometry allows some receiver to use it:
//! - the parent lies strictly off the child's plane (it has a side to reflect from);
//! - the child's plane has a corner on the parent's side of the parent's plane (a path leaving
//!   the parent's plane travels on that side);
//! - the image lies within c · t_max of the receivers' bounding box: every path through an
//!   image's descendants unfolds into a polyline from that image to the receiver, so it is at
//!   least as long, and the whole subtree can go.
//!
//! Per receiver, each node's path is built backwards: from the receiver towards the last image,
//! the BVH's closest hit must be a triangle of that image's plane (the reflection point lies on
//! the surface and nothing stands in between); from there towards the image before; and the
//! last leg to the source must be free.

use std::f64::consts::PI;

use glam::DVec3;

use super::planes::Planes;
use super::{directivity_gain, Arrival, ArrivalKind, Context, PairArrivals};
use crate::geometry::Ray;
use crate::sound::receivers::ball_mean_inverse_square;

/// Node 0's plane.
pub const NO_PLANE: u32 = u32::MAX;

#[derive(Clone, Debug)]
pub struct ImageNode {
    pub position: DVec3,
    /// The plane this image was mirrored in ([`NO_PLANE`] for the source).
    pub plane: u32,
    pub parent: u32,
    pub order: u32,
}

/// A source's image sources, parents before children.
#[derive(Clone, Debug)]
pub struct ImageTree {
    pub nodes: Vec<ImageNode>,
}

/// Distance from `p` to the box [lo, hi] (0 inside).
fn box_distance(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    (lo - p).max(p - hi).max(DVec3::ZERO).length()
}

impl ImageTree {
    /// All images up to `max_order` that could reach a receiver within `max_path_m`.
    pub fn build(planes: &Planes, source: DVec3, receivers: &[DVec3], max_order: u32, max_path_m: f64) -> ImageTree {
        Self::build_in_beams(planes, source, receivers, max_order, max_path_m, None)
    }

    /// [`ImageTree::build`], and with `beams` (each plane's aperture: [`Apertures::spheres`])
    /// a child is kept only if its plane's aperture meets the beam of its parent: the lines
    /// through the parent image and a point of the parent's plane aperture.
    ///
    /// Why that is conservative: [`specular_path`] builds a path backwards, from the receiver
    /// towards the child image I′ to a hit X on a triangle of the child's plane, then from X
    /// towards the parent image I to a hit Y on a triangle of the parent's plane. X, Y and I lie on
    /// one line, so X lies on a line through I and a point of the parent's aperture. Both
    /// apertures are bounded by spheres (each plane's vertex box, widened by the triangles'
    /// stand-off and the hits' slack), the lines through I and the parent's sphere fill a double
    /// cone of half-angle asin(r/d), and the child's sphere must meet it: otherwise no point of
    /// any receiver can have a path through the child (or any image below it). Borish's (1984)
    /// visibility condition, tested on bounding spheres like the beams of Funkhouser et al.
    /// (SIGGRAPH 1998); it drops no image [`specular_path`] would accept, so the arrivals are
    /// the same (their image indices shift: they are internal).
    pub(crate) fn build_in_beams(planes: &Planes, source: DVec3, receivers: &[DVec3], max_order: u32, max_path_m: f64, beams: Option<&[(DVec3, f64)]>) -> ImageTree {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for r in receivers {
            lo = lo.min(*r);
            hi = hi.max(*r);
        }
        let mut nodes = vec![ImageNode { position: source, plane: NO_PLANE, parent: 0, order: 0 }];
        // Breadth first, so that nodes are in order of reflection count.
        let mut start = 0;
        for order in 1..=max_order {
            let end = nodes.len();
            for i in start..end {
                let parent = nodes[i].clone();
                for (q, pl) in planes.planes.iter().enumerate() {
                    if q as u32 == parent.plane {
                        continue;
                    }
                    let side = pl.distance(parent.position);
                    if side.abs() < 1e-9 {
                        continue;
                    }
                    if parent.plane != NO_PLANE {
                        // The child's plane needs a corner on the side the parent's image reflects into.
                        let pp = &planes.planes[parent.plane as usize];
                        let grand = nodes[parent.parent as usize].position;
                        let s = pp.distance(grand).signum();
                        if !pl.vertices.iter().any(|v| pp.distance(*v) * s > 1e-9) {
                            continue;
                        }
                        if beams.is_some_and(|b| !in_beam(parent.position, b[parent.plane as usize], b[q])) {
                            continue;
                        }
                    }
                    let position = pl.mirror(parent.position);
                    if receivers.is_empty() || box_distance(position, lo, hi) > max_path_m {
                        continue;
                    }
                    nodes.push(ImageNode { position, plane: q as u32, parent: i as u32, order });
                }
            }
            start = end;
        }
        ImageTree { nodes }
    }

    /// The child of `node` mirrored in `plane`, if the tree has it.
    pub fn child(&self, node: u32, plane: u32) -> Option<u32> {
        // Children of a node are contiguous and in plane order; trees are small enough that a
        // scan of the next order's range is cheap next to the BVH queries around it.
        self.nodes.iter().position(|n| n.parent == node && n.plane == plane && n.order > 0).map(|i| i as u32)
    }
}

/// Whether the sphere `child` (centre, radius) meets the double cone of lines through `apex` and
/// the sphere `aperture` ([`ImageTree::build_in_beams`]); true whenever the apex lies in either
/// sphere. The angles get a margin of 1e-9 rad for rounding.
fn in_beam(apex: DVec3, aperture: (DVec3, f64), child: (DVec3, f64)) -> bool {
    let (to_a, to_c) = (aperture.0 - apex, child.0 - apex);
    let (da, dc) = (to_a.length(), to_c.length());
    if !(da > aperture.1 && dc > child.1) {
        return true;
    }
    let reach = (aperture.1 / da).asin() + (child.1 / dc).asin() + 1e-9;
    let angle = (to_a.dot(to_c) / (da * dc)).clamp(-1.0, 1.0).acos();
    // The lines run both ways through the apex.
    angle <= reach || std::f64::consts::PI - angle <= reach
}

/// A valid path of one image to one receiver.
pub(crate) struct SpecularPath {
    /// Reflection points from the source side to the receiver side.
    pub points: Vec<DVec3>,
    /// Triangle hit at each reflection, same order.
    pub triangles: Vec<u32>,
    pub length_m: f64,
}

/// Checks node `node`'s path to `receiver` against the BVH: None if invalid or blocked.
pub(crate) fn specular_path(ctx: &Context, tree: &ImageTree, node: u32, receiver: DVec3) -> Option<SpecularPath> {
    let eps = ctx.epsilon_m;
    let mut points = Vec::new();
    let mut triangles = Vec::new();
    let mut from = receiver;
    let mut k = node;
    let mut first_leg = true;
    while k != 0 {
        let img = &tree.nodes[k as usize];
        let plane = &ctx.planes.planes[img.plane as usize];
        let (d_from, d_img) = (plane.distance(from), plane.distance(img.position));
        // The receiver side of a reflection is the side opposite the image.
        if !(d_from * d_img < 0.0) {
            return None;
        }
        let dir = img.position - from;
        let t_plane = d_from / (d_from - d_img);
        let point = from + dir * t_plane;
        let len = dir.length();
        let t_min = if first_leg { 0.0 } else { eps / len };
        let ray = Ray::new(from.as_vec3(), dir.as_vec3());
        let hit = ctx.bvh.closest_hit(&ray, t_min as f32, (t_plane + 4.0 * eps / len) as f32)?;
        if ctx.planes.plane_of_triangle[hit.triangle as usize] != img.plane {
            return None;
        }
        points.push(point);
        triangles.push(hit.triangle);
        from = point;
        k = img.parent;
        first_leg = false;
    }
    // The last leg, to the source itself, must be free.
    let source = tree.nodes[0].position;
    let dir = source - from;
    let len = dir.length();
    let t_min = if first_leg { 0.0 } else { eps / len };
    if len > 0.0 && ctx.bvh.occluded(&Ray::new(from.as_vec3(), dir.as_vec3()), t_min as f32, (1.0 - eps / len) as f32) {
        return None;
    }
    points.reverse();
    triangles.reverse();
    let length_m = (tree.nodes[node as usize].position - receiver).length();
    Some(SpecularPath { points, triangles, length_m })
}

/// The energy per band that a valid path brings, written into `out`: the source's power and
/// directivity towards the first leg, spreading over the unfolded length, each reflection's
/// (1 − α)(1 − s) (α at the reflection's angle of incidence with locally reacting walls) and
/// (with level of detail) Rindel's specular share, and the air.
pub(crate) fn path_energy(ctx: &Context, s: usize, path: &SpecularPath, source: DVec3, receiver: DVec3, out: &mut [f64]) {
    let set = ctx.settings;
    let nb = out.len();
    let src = &ctx.sources[s];
    let first = path.points.first().copied().unwrap_or(receiver);
    let emit = (first - source).normalize_or_zero();
    let l = path.length_m;
    let spread = if set.receiver_radius_m > 0.0 { ball_mean_inverse_square(l, set.receiver_radius_m) } else { 1.0 / (4.0 * PI * l * l) };
    let g = src.power_w * directivity_gain(&src.directivity, emit) * spread;
    out.fill(g);
    crate::sound::air::attenuate(&set.air_attenuation_per_m[..nb], l, out);
    if let Some(hook) = ctx.gains {
        let mut extra = vec![1.0; nb];
        hook(s, emit, &mut extra);
        for b in 0..nb {
            out[b] *= extra[b];
        }
    }
    let n = path.points.len();
    let mut shares = vec![1.0; nb];
    let mut absorption = vec![0.0; nb];
    let mut by_angle = vec![0.0; nb];
    for (k, (&p, &tri)) in path.points.iter().zip(&path.triangles).enumerate() {
        let m = ctx.mesh.material[tri as usize] as usize * nb;
        // The absorption at this reflection's angle of incidence, as the tracer applies it
        // (sound/reflectance.rs): the leg arriving from the previous point meets the plane.
        let arriving = (p - if k == 0 { source } else { path.points[k - 1] }).normalize_or_zero();
        let cos_incidence = arriving.dot(ctx.planes.planes[ctx.planes.plane_of_triangle[tri as usize] as usize].normal).abs();
        let mut scat = &ctx.acoustics.scattering[m..m + nb];
        let profiled = ctx.settings.by_angle.as_ref().filter(|t| t.profiled(m / nb));
        let alpha = match profiled {
            // A described surface's α and s at this angle (sound/scattering.rs), as the tracer's.
            Some(table) => {
                table.scattering(m / nb, cos_incidence, &mut by_angle);
                scat = &by_angle;
                table.absorption(m / nb, cos_incidence, &mut absorption);
                &absorption[..]
            }
            None => ctx.walls.absorption(&ctx.acoustics.absorption, m, cos_incidence, &mut absorption),
        };
        for b in 0..nb {
            out[b] *= (1.0 - alpha[b]) * (1.0 - scat[b]);
        }
        if let Some(lod) = ctx.lod {
            // The legs before and after this reflection along the path, as the particle on
            // this path sees them (lod.rs): after the last reflection, the leg runs past the
            // receiver to the next surface.
            let prev = if k == 0 { source } else { path.points[k - 1] };
            let d1 = (p - prev).length();
            let d2 = if k + 1 < n { (path.points[k + 1] - p).length() } else { leg_to_surface(ctx, p, receiver - p) };
            lod.specular_shares(tri as usize, (p - prev) / d1, d1, d2, &mut shares);
            for b in 0..nb {
                out[b] *= shares[b];
            }
        }
    }
}

/// Length of the leg that leaves `from` (a reflection point) along `dir` until it meets a
/// surface; infinite when it leaves the scene.
fn leg_to_surface(ctx: &Context, from: DVec3, dir: DVec3) -> f64 {
    let len = dir.length();
    if !(len > 0.0) {
        return f64::INFINITY;
    }
    let ray = Ray::new(from.as_vec3(), dir.as_vec3());
    ctx.bvh.closest_hit(&ray, (ctx.epsilon_m / len) as f32, f32::INFINITY).map_or(f64::INFINITY, |h| h.t as f64 * len)
}

/// Each plane's bounding box and how far a reflection point found by the BVH may lie outside
/// it along a path ([`Apertures`]), for the quick test that a ball cannot see an image.
pub(crate) struct Apertures {
    boxes: Vec<(DVec3, DVec3)>,
    /// Per plane: the most its triangles stand off the plane (the grouping's offset tolerance,
    /// the normal tolerance times the box's diagonal) plus the hit's slack of 4 ε.
    slack_m: Vec<f64>,
}

impl Apertures {
    pub(crate) fn new(ctx: &Context) -> Apertures {
        let boxes: Vec<(DVec3, DVec3)> = ctx.planes.planes.iter().map(|p| p.vertices.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)))).collect();
        let slack_m = boxes.iter().map(|(lo, hi)| ctx.settings.plane_tolerance_m.max(1e-9) + super::planes::NORMAL_TOLERANCE * (*hi - *lo).length() + 4.0 * ctx.epsilon_m).collect();
        Apertures { boxes, slack_m }
    }

    /// Each plane's aperture bounded by a sphere: its box's centre, half its diagonal plus the
    /// slack and a relative margin of 1e-9 (for [`ImageTree::build_in_beams`]).
    pub(crate) fn spheres(&self) -> Vec<(DVec3, f64)> {
        self.boxes.iter().zip(&self.slack_m).map(|((lo, hi), slack)| (0.5 * (*lo + *hi), (0.5 * (*hi - *lo).length() + slack) * (1.0 + 1e-9) + 1e-9)).collect()
    }
}

/// The specular arrivals (direct sound included) of source `s` at receiver `r`.
pub(crate) fn arrivals(ctx: &Context, tree: &ImageTree, twins: &Twins, apertures: &Apertures, s: usize, r: usize, receiver: DVec3) -> PairArrivals {
    let nb = ctx.acoustics.n_bands;
    let set = ctx.settings;
    let max_path_m = set.max_time_s * set.speed_of_sound_m_s;
    let mut out = PairArrivals::new(nb);
    let mut energy = vec![0.0; nb];
    let source = tree.nodes[0].position;
    let radius = set.receiver_radius_m;
    for (i, node) in tree.nodes.iter().enumerate() {
        let length = (node.position - receiver).length();
        if length > max_path_m || !(length > 0.0) || !twins.first[i] {
            continue;
        }
        out.checked += 1;
        let same = Same { twins, first: i as u32 };
        // The quick test first: no point of the ball (so not its centre) can have a path.
        if same.out_of_reach(ctx, tree, apertures, receiver, radius) {
            continue;
        }
        let centre = same.path(ctx, tree, receiver);
        let (path, share) = if radius > 0.0 { seen_over_ball(ctx, tree, same, receiver, radius, centre) } else { (centre, 1.0) };
        let Some(path) = path else { continue };
        path_energy(ctx, s, &path, source, receiver, &mut energy);
        if share < 1.0 {
            for e in energy.iter_mut() {
                *e *= share;
            }
        }
        let from_direction = (node.position - receiver) / length;
        let a = Arrival {
            source: s as u32,
            receiver: r as u32,
            time_s: length / set.speed_of_sound_m_s,
            from_direction,
            kind: ArrivalKind::Specular { order: node.order },
            image: i as u32,
        };
        out.push(a, &energy);
    }
    out
}

/// Probes of the unit ball for [`seen_over_ball`]: its six poles, then `BALL_POINTS` points of
/// equal volume (a Fibonacci spiral of directions, radii at the cube roots of stratified
/// fractions), fixed so that every run tests the same points.
const BALL_POINTS: usize = 64;

fn ball_probe(k: usize) -> DVec3 {
    const POLES: [DVec3; 6] = [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z];
    if k < 6 {
        return POLES[k];
    }
    let i = (k - 6) as f64 + 0.5;
    let n = BALL_POINTS as f64;
    let z = 1.0 - 2.0 * i / n;
    let phi = i * PI * (3.0 - 5f64.sqrt());
    let rho = (1.0 - z * z).max(0.0).sqrt();
    // The radius of the i-th of n shells of equal volume, visited in a shuffled order (7 is
    // prime to 64) so that neighbouring directions do not share a radius.
    let shell = ((k - 6) * 7 % BALL_POINTS) as f64 + 0.5;
    (shell / n).cbrt() * DVec3::new(rho * phi.cos(), rho * phi.sin(), z)
}

/// Which part of the receiver's ball sees an image, as the particles measure it: a particle
/// deposits energy × chord / volume in the ball, so it estimates the mean over the ball of the
/// image's 1/d² wherever the image's path is valid. The centre alone decides when it agrees with
/// the ball's six poles (the usual case, one path check more per pole); otherwise the share is
/// the 1/d²-weighted fraction of `BALL_POINTS` probes whose path is valid. Returns the path to
/// use for the reflections' materials (the centre's, or a valid probe's) and that share.
/// Without this, a receiver whose ball straddles a panel's edge got the whole image where the
/// particles see part of it (+5 … +8 % early energy near a table edge, docs/early-sound.md).
/// The caller has already found that some point of the ball may see the image
/// ([`Same::out_of_reach`]).
fn seen_over_ball(ctx: &Context, tree: &ImageTree, same: Same, receiver: DVec3, radius: f64, centre: Option<SpecularPath>) -> (Option<SpecularPath>, f64) {
    let valid = centre.is_some();
    if (0..6).all(|k| same.path(ctx, tree, receiver + ball_probe(k) * radius).is_some() == valid) {
        return (centre, if valid { 1.0 } else { 0.0 });
    }
    let image = tree.nodes[same.first as usize].position;
    let (mut seen, mut all) = (0.0, 0.0);
    let mut path = centre;
    for k in 6..6 + BALL_POINTS {
        let x = receiver + ball_probe(k) * radius;
        let w = 1.0 / (x - image).length_squared();
        all += w;
        if let Some(p) = same.path(ctx, tree, x) {
            seen += w;
            path.get_or_insert(p);
        }
    }
    if seen > 0.0 {
        (path, seen / all)
    } else {
        (None, 0.0)
    }
}

/// For each node of a tree, the next node of the same order at the same image position
/// (`u32::MAX`: none), and whether it is the first of them. Two walls meeting at a right angle
/// mirror a source to one image in either order; which order's path is valid changes across the
/// plane through their common edge, so a receiver's ball can hold both: the image is one
/// arrival, heard from wherever either order's path is valid. Found once a tree, for all its
/// receivers.
pub(crate) struct Twins {
    next: Vec<u32>,
    first: Vec<bool>,
}

impl Twins {
    pub(crate) fn of(tree: &ImageTree) -> Twins {
        let scale = tree.nodes.iter().fold(1.0f64, |m, n| m.max(n.position.abs().max_element()));
        let tol = 1e-9 * scale;
        // Sorted by (order, rounded position, index): twins are neighbours, in index order.
        let mut keys: Vec<(u32, [i64; 3], u32)> = tree.nodes.iter().enumerate().map(|(i, n)| (n.order, (n.position / tol).round().as_i64vec3().to_array(), i as u32)).collect();
        keys.sort_unstable();
        let mut next = vec![u32::MAX; tree.nodes.len()];
        let mut first = vec![true; tree.nodes.len()];
        for w in keys.windows(2) {
            if (w[0].0, w[0].1) == (w[1].0, w[1].1) {
                next[w[0].2 as usize] = w[1].2;
                first[w[1].2 as usize] = false;
            }
        }
        Twins { next, first }
    }
}

/// The nodes that are one image (see [`Twins`]), from `first` along `next`.
#[derive(Clone, Copy)]
struct Same<'a> {
    twins: &'a Twins,
    first: u32,
}

/// Whether no point x of the ball about `receiver` (radius `radius`) can have a valid path
/// through image node `node`, by the apertures alone (no BVH query). The path is built as
/// [`specular_path`] builds it, backwards: from x towards the last image, it must cross that
/// image's plane from the side opposite the image, at a point of one of the plane's triangles
/// (so inside the plane's box), then from there towards the image before, and so on. The test
/// follows a region that holds every crossing a point of the ball can make: a ball of centre c
/// and radius ρ (first the receiver's). Towards image I across a plane at signed distances d_c
/// (centre) and d_I (image), a point x = c + δ, |δ| ≤ ρ, on the valid side crosses at
/// I + (x − I) a/(a + b_x), a = |d_I|, b_x = |d_x| (opposite sides); it moves from the
/// centre's crossing by at most ρ (1 + |c − I| / (a + b_c)) (a/(a + b_x) ≤ 1 and
/// |b_x − b_c| ≤ ρ). So the next region is the ball about the centre's crossing with that radius.
/// The image is out of reach when a region lies wholly on the image's side of its plane, or
/// holds no point of the plane's box widened by the triangles' stand-off seen along the path
/// (slack / cos θ, θ the largest incidence in the region). A conservative test: it skips only
/// images that [`specular_path`] would refuse from every point of the ball, so the arrivals are
/// the same as without it (Borish 1984's validity test applied to a region; the beam idea of
/// Funkhouser et al., SIGGRAPH 1998).
fn chain_out_of_reach(ctx: &Context, tree: &ImageTree, apertures: &Apertures, node: u32, receiver: DVec3, radius: f64) -> bool {
    let (mut c, mut rho) = (receiver, radius);
    let mut k = node;
    while k != 0 {
        let img = &tree.nodes[k as usize];
        let plane = &ctx.planes.planes[img.plane as usize];
        let (d_c, d_img) = (plane.distance(c), plane.distance(img.position));
        if d_c * d_img > 0.0 && d_c.abs() > rho * (1.0 + 1e-9) + 1e-9 {
            return true;
        }
        if !(d_c * d_img < 0.0) {
            return false;
        }
        let to = img.position - c;
        let crossing = c + to * (d_c / (d_c - d_img));
        // The smallest cosine of incidence over the region (|d_x − d_I| ≥ |d_c − d_I| − ρ,
        // |x − I| ≤ |c − I| + ρ): a crossing lies within stand-off / cos of its hit.
        let cos = (((d_c - d_img).abs() - rho) / (to.length() + rho)).max(1e-12);
        rho = rho * (1.0 + to.length() / (d_img.abs() + d_c.abs())) * (1.0 + 1e-9) + 1e-9;
        let (lo, hi) = apertures.boxes[img.plane as usize];
        let outside = (lo - crossing).max(crossing - hi).max(DVec3::ZERO).length();
        if outside > rho + apertures.slack_m[img.plane as usize] / cos {
            return true;
        }
        c = crossing;
        k = img.parent;
    }
    false
}

impl Same<'_> {
    /// Whether no point of the ball about `receiver` can have a path, for every one of these
    /// nodes ([`chain_out_of_reach`]).
    fn out_of_reach(&self, ctx: &Context, tree: &ImageTree, apertures: &Apertures, receiver: DVec3, radius: f64) -> bool {
        let mut j = self.first;
        while j != u32::MAX {
            if !chain_out_of_reach(ctx, tree, apertures, j, receiver, radius) {
                return false;
            }
            j = self.twins.next[j as usize];
        }
        true
    }

    /// The first valid path of these nodes to `receiver`.
    fn path(&self, ctx: &Context, tree: &ImageTree, receiver: DVec3) -> Option<SpecularPath> {
        let mut j = self.first;
        while j != u32::MAX {
            if let Some(p) = specular_path(ctx, tree, j, receiver) {
                return Some(p);
            }
            j = self.twins.next[j as usize];
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_beam_holds_every_line_through_the_apex_and_the_aperture() {
        let apex = DVec3::ZERO;
        let aperture = (DVec3::new(4.0, 0.0, 0.0), 1.0);
        // Random lines through the apex and a point of the aperture's sphere: every point on
        // them (either side of the apex) is in the beam of a tiny sphere about it.
        let mut s = crate::rng::Stream::new(5, 0, 0);
        for _ in 0..10_000 {
            let v = DVec3::new(s.uniform() - 0.5, s.uniform() - 0.5, s.uniform() - 0.5);
            let y = aperture.0 + v.normalize_or_zero() * aperture.1 * s.uniform().cbrt();
            let x = apex + (y - apex) * (6.0 * s.uniform() - 3.0);
            assert!(in_beam(apex, aperture, (x, 1e-6)), "{x:?}");
        }
        // Off the cone (half-angle asin(1/4) = 14.5°): at 40° from the axis, a small sphere is out.
        let off = DVec3::new(40f64.to_radians().cos(), 40f64.to_radians().sin(), 0.0) * 6.0;
        assert!(!in_beam(apex, aperture, (off, 0.1)));
        assert!(!in_beam(apex, aperture, (-off, 0.1)));
        // The apex inside either sphere: everything is reachable.
        assert!(in_beam(DVec3::new(4.5, 0.0, 0.0), aperture, (off, 0.1)));
        assert!(in_beam(off, aperture, (off, 0.1)));
    }
}
