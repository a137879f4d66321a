//! sonolux-core: the engine of sonolux, free of Python.
//!
//! It owns what is the craft of the project: triangle geometry and its checks ([`mesh`]),
//! the watertight ray–triangle test ([`geometry`]), the bounding-volume hierarchy that both tracers
//! share ([`bvh`]) and its shortcut for closed convex rooms ([`convex`]), the samplers that emit
//! rays and choose bounces ([`sampling`]) and the random streams that make every ray replayable
//! from (seed, source, ray) alone ([`rng`]), and the partitioned convolver that
//! auralization runs on ([`convolver`]), the wave solver for the low bands ([`wave`]), the locally
//! reacting wall that the waves and (when asked) the rays share ([`wall`]), and the
//! exact early sound of image sources and edge diffraction ([`early`]).
//!
//! Conventions, the same in every module and in the Python package:
//! - lengths in metres, z up; azimuth 0° is +x and grows counter-clockwise seen from above;
//! - geometry is stored in `f32` (a 100 m room keeps sub-0.01 mm resolution); anything that
//!   accumulates (path length, time, energy) is `f64`.

// Band loops index several arrays at once, and `!(x > 0.0)` is how NaN is rejected on purpose.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod bvh;
pub mod convex;
pub mod convolver;
pub mod early;
pub mod error;
pub mod geometry;
pub mod light;
pub mod mesh;
pub mod parallel;
pub mod rng;
pub mod sampling;
pub mod sound;
pub mod wall;
pub mod wave;

pub use bvh::Bvh;
pub use error::CoreError;
pub use geometry::{Aabb, Hit, Ray};
pub use mesh::{Mesh, MeshReport};

/// The version of the engine, shared with the Python package.
pub use glam as glam_export;

/// The version of the engine, shared with the Python package.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
