//! Real rooms for the integration tests that need them (the BVH's agreement with brute force,
//! the mesh bakes' same bits): the example L-room read from its OBJ file, the furnished
//! meeting room, a shoebox, and the meshes that only Python generators write — the L-room's
//! 100k-triangle variant (`examples/l-room/make_l_room.py`, ported in `l_room_gen.rs`) and
//! the two 327k-triangle meshes of `benchmarks/bvh.py` (an icosphere and a room holding a
//! bumpy one), built here the same way. Each room comes with its air: where a ray of the
//! tracer can start.
//!
//! Shared by several test crates, each of which uses a part (hence `dead_code`).
#![allow(dead_code)]

pub mod l_room_gen;

use glam::{DVec3, Vec3};
use sonolux_core::rng::Stream;
use sonolux_core::Mesh;

/// An axis-aligned box, lower and upper corner.
pub type Boxed = (Vec3, Vec3);

/// A mesh with the region its rays start in.
pub struct Room {
    pub name: &'static str,
    pub mesh: Mesh,
    /// Points are drawn uniformly in this box and kept where `air` says.
    pub sample_box: Boxed,
    /// Boxes that are not air (furniture, a room's notch, an obstacle's bounds).
    pub solids: Vec<Boxed>,
    /// When set, air is only inside this ball (centre, radius): the icosphere's inside.
    pub inside_ball: Option<(Vec3, f32)>,
    /// The side of a triangle a ray leaves it on, in the tracer: +1 the side its normal
    /// (b − a) × (c − a) faces (rooms face into the room, furniture out of each piece),
    /// −1 the other (the benchmark's icosphere faces out, its rays run inside it).
    pub air_side: f64,
}

impl Room {
    /// Whether `p` is air: in the sample box, in no solid, inside the ball if there is one.
    pub fn in_air(&self, p: Vec3) -> bool {
        let inside = |(lo, hi): &Boxed| p.cmpgt(*lo).all() && p.cmplt(*hi).all();
        inside(&self.sample_box)
            && !self.solids.iter().any(inside)
            && self.inside_ball.is_none_or(|(c, r)| (p - c).length() < r)
    }

    /// A uniform point of the air, drawn from `s`.
    pub fn air_point(&self, s: &mut Stream) -> Vec3 {
        let (lo, hi) = self.sample_box;
        loop {
            let p = lo + (hi - lo) * Vec3::new(s.uniform_f32(), s.uniform_f32(), s.uniform_f32());
            if self.in_air(p) {
                return p;
            }
        }
    }
}

/// A mesh from an OBJ file's `v` and `f` lines (triangles; `f` entries may carry `/vt/vn`),
/// one material id a `usemtl` or `g` group in the order they first appear.
pub fn read_obj(path: &str) -> Mesh {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let (mut v, mut t, mut m) = (Vec::new(), Vec::new(), Vec::new());
    let mut groups: Vec<String> = Vec::new();
    let mut material = 0u32;
    for line in text.lines() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => v.push(Vec3::from_array(std::array::from_fn(|_| w.next().unwrap().parse().unwrap()))),
            Some("f") => {
                t.push(std::array::from_fn(|_| w.next().unwrap().split('/').next().unwrap().parse::<u32>().unwrap() - 1));
                m.push(material);
            }
            Some("usemtl" | "g") => {
                let name = w.next().unwrap_or("").to_string();
                material = groups.iter().position(|g| *g == name).unwrap_or_else(|| {
                    groups.push(name);
                    groups.len() - 1
                }) as u32;
            }
            _ => {}
        }
    }
    Mesh::new(v, t, m).unwrap()
}

fn example(path: &str) -> String {
    format!("{}/../../examples/{path}", env!("CARGO_MANIFEST_DIR"))
}

/// The bounding boxes of the mesh's pieces (sets of triangles joined by shared vertices) other
/// than the one that spans the whole mesh (the room's shell): its furniture.
pub fn pieces(mesh: &Mesh) -> Vec<Boxed> {
    let mut parent: Vec<usize> = (0..mesh.vertices.len()).collect();
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for t in &mesh.triangles {
        for k in 1..3 {
            let (a, b) = (root(&mut parent, t[0] as usize), root(&mut parent, t[k] as usize));
            parent[a.max(b)] = a.min(b);
        }
    }
    let mut boxes = std::collections::BTreeMap::<usize, Boxed>::new();
    for t in &mesh.triangles {
        let r = root(&mut parent, t[0] as usize);
        let b = boxes.entry(r).or_insert((Vec3::INFINITY, Vec3::NEG_INFINITY));
        for &i in t {
            b.0 = b.0.min(mesh.vertices[i as usize]);
            b.1 = b.1.max(mesh.vertices[i as usize]);
        }
    }
    let all = mesh.bounds();
    boxes.into_values().filter(|b| !(b.0 == all.min && b.1 == all.max)).collect()
}

/// The L-room's footprint lacks the box x ∈ [7, 12], y ∈ [5, 9] (make_l_room.py's notch).
fn l_room_notch() -> Boxed {
    (Vec3::new(7.0, 5.0, -1.0), Vec3::new(12.0, 9.0, 4.2))
}

fn l_room_air(name: &'static str, mesh: Mesh) -> Room {
    let b = mesh.bounds();
    let mut solids = pieces(&mesh);
    solids.push(l_room_notch());
    Room { name, mesh, sample_box: (b.min, b.max), solids, inside_ball: None, air_side: 1.0 }
}

/// examples/l-room/l-room.obj (652 triangles: walls, floor and ceiling of 28, tables, chairs
/// and a cabinet), a material a group.
pub fn l_room() -> Room {
    l_room_air("l-room", read_obj(&example("l-room/l-room.obj")))
}

/// The 100k-triangle L-room (make_l_room.py's dense variant, ported): tessellated walls and a
/// bumpy sculpture of 81,920 triangles (whose bounding box is kept out of the air).
pub fn l_room_100k() -> Room {
    l_room_air("l-room-100k", l_room_gen::build(true))
}

/// The furnished meeting room (examples/furniture: furnished_room.toml's 7 × 5 × 2.8 m
/// shoebox and furniture.obj), the shoebox's triangles first.
pub fn furnished() -> Room {
    let furniture = read_obj(&example("furniture/furniture.obj"));
    let shell = shoebox_mesh(Vec3::new(7.0, 5.0, 2.8));
    let n = shell.vertices.len() as u32;
    let mut v = shell.vertices.clone();
    v.extend(&furniture.vertices);
    let mut t = shell.triangles.clone();
    t.extend(furniture.triangles.iter().map(|tri| tri.map(|i| i + n)));
    let mut m = vec![0; shell.triangles.len()];
    m.extend(furniture.material.iter().map(|k| k + 1));
    let mesh = Mesh::new(v, t, m).unwrap();
    let b = mesh.bounds();
    Room { name: "furnished", solids: pieces(&mesh), mesh, sample_box: (b.min, b.max), inside_ball: None, air_side: 1.0 }
}

/// A box [0, size], two triangles a face facing into it (benchmarks/bvh.py's `shoebox`).
pub fn shoebox_mesh(size: Vec3) -> Mesh {
    let corners: Vec<Vec3> = (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32) * size).collect();
    let quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6)];
    let t: Vec<[u32; 3]> = quads.iter().flat_map(|&(a, b, c, d)| [[a, b, c], [a, c, d]]).collect();
    let n = t.len();
    Mesh::new(corners, t, vec![0; n]).unwrap()
}

/// The paper-large shoebox (24 × 10 × 8 m) as a mesh, the benchmark's `shoebox` case.
pub fn shoebox() -> Room {
    let size = Vec3::new(24.0, 10.0, 8.0);
    Room { name: "shoebox", mesh: shoebox_mesh(size), sample_box: (Vec3::ZERO, size), solids: vec![], inside_ball: None, air_side: 1.0 }
}

/// A unit icosphere: the icosahedron, each triangle split into four `subdivisions` times,
/// the new vertices put back on the sphere (trimesh's `icosphere`; not its bits or order).
/// Faces wound outward. 20 · 4^subdivisions triangles.
pub fn icosphere(subdivisions: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        (-1.0, g, 0.0), (1.0, g, 0.0), (-1.0, -g, 0.0), (1.0, -g, 0.0),
        (0.0, -1.0, g), (0.0, 1.0, g), (0.0, -1.0, -g), (0.0, 1.0, -g),
        (g, 0.0, -1.0), (g, 0.0, 1.0), (-g, 0.0, -1.0), (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid = std::collections::HashMap::new();
        let mut half = |a: u32, b: u32, v: &mut Vec<DVec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((0.5 * (v[a as usize] + v[b as usize])).normalize());
                (v.len() - 1) as u32
            })
        };
        f = f
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (half(a, b, &mut v), half(b, c, &mut v), half(c, a, &mut v));
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    (v, f)
}

/// The benchmark's `icosphere`: 7 subdivisions (327,680 triangles), radius 1 m; rays start in
/// the ball of radius 0.9 m.
pub fn bench_icosphere() -> Room {
    let (v, t) = icosphere(7);
    let n = t.len();
    let mesh = Mesh::new(v.iter().map(|p| p.as_vec3()).collect(), t, vec![0; n]).unwrap();
    let ball = (Vec3::ZERO, 0.9);
    Room { name: "icosphere", mesh, sample_box: (Vec3::splat(-0.9), Vec3::splat(0.9)), solids: vec![], inside_ball: Some(ball), air_side: -1.0 }
}

/// The benchmark's `room+bumps`: the paper-large shoebox holding an icosphere of 7
/// subdivisions, radius 2.5 m at (9, 5, 4), displaced radially by smooth bumps and seeded noise
/// (benchmarks/bvh.py's `bumpy_sphere`: 1 + 0.08 sin 6x sin(5y + 1) sin(4z + 2) + noise of
/// σ = 0.01 clipped to ±0.03; the noise drawn here from the project's stream, Box–Muller):
/// 327,692 triangles from ~1e-4 m² to 120 m². Rays start in the room off the obstacle's box.
pub fn bench_room_and_bumps() -> Room {
    let size = Vec3::new(24.0, 10.0, 8.0);
    let room = shoebox_mesh(size);
    let (u, t) = icosphere(7);
    let centre = DVec3::new(9.0, 5.0, 4.0);
    let mut v = room.vertices.clone();
    v.extend(u.iter().enumerate().map(|(i, p)| {
        let mut s = Stream::new(71, 4, i as u64);
        let normal = (-2.0 * (1.0 - s.uniform()).ln()).sqrt() * (std::f64::consts::TAU * s.uniform()).cos();
        let bumps = 0.08 * (6.0 * p.x).sin() * (5.0 * p.y + 1.0).sin() * (4.0 * p.z + 2.0).sin();
        (*p * 2.5 * (1.0 + bumps + (0.01 * normal).clamp(-0.03, 0.03)) + centre).as_vec3()
    }));
    let mut tris = room.triangles.clone();
    tris.extend(t.iter().map(|tri| tri.map(|i| i + 8)));
    let n = tris.len();
    let mesh = Mesh::new(v, tris, vec![0; n]).unwrap();
    Room { name: "room+bumps", solids: pieces(&mesh), mesh, sample_box: (Vec3::ZERO, size), inside_ball: None, air_side: 1.0 }
}
