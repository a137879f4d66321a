//! What the integration tests share: rooms.

use glam::Vec3;
use sonolux_core::Mesh;

/// A box [0,l]×[0,w]×[0,h] wound so that every normal (b − a) × (c − a) faces into it; the
/// material ids of its faces in the order floor, ceiling, south (y=0), north, west (x=0), east.
pub fn shoebox(l: f32, w: f32, h: f32, materials: [u32; 6]) -> Mesh {
    let v: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new(if i & 1 == 1 { l } else { 0.0 }, if i & 2 == 2 { w } else { 0.0 }, if i & 4 == 4 { h } else { 0.0 }))
        .collect();
    let quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
    let (mut t, mut m) = (Vec::new(), Vec::new());
    for (q, mat) in quads.into_iter().zip(materials) {
        t.push([q[0], q[1], q[2]]);
        t.push([q[0], q[2], q[3]]);
        m.extend([mat, mat]);
    }
    Mesh::new(v, t, m).unwrap()
}
