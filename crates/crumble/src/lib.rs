//! # crumble
//!
//! A rigid-body physics engine for boxes, spheres and a ground plane, built
//! around oriented-box (OBB) colliders. It grew out of the "Breaking a Brick
//! Wall" project report and its use of D. Eberly's separating-axis test, and
//! aims at walls that stand still at real gravity and break convincingly.
//!
//! The crate is split so that each part reads on its own:
//!
//! - [`math`]: poses (position + unit quaternion) on top of `glam`.
//! - [`shape`]: cuboids, balls and half-spaces, with their mass properties
//!   and bounding boxes.
//! - [`broad_phase`]: an incremental dynamic AABB tree that reports the pairs
//!   of colliders whose fattened boxes begin or stop overlapping.
//! - [`collision`]: the narrow phase: one function per shape pair producing a
//!   contact [`collision::Manifold`], plus the seed report's 15-axis test
//!   ([`collision::sat`]).
//!
//! The engine does no file I/O, no rendering and no printing.

pub mod aabb;
mod arena;
pub mod body;
pub mod broad_phase;
mod ccd;
pub mod collider;
pub mod collision;
pub mod contact;
mod edge_list;
mod island;
pub mod math;
mod partition;
pub mod scenes;
pub mod shape;
pub mod solver;
pub mod world;

pub use aabb::Aabb;
pub use body::{Body, BodyBuilder, BodyHandle, BodyType};
pub use collider::{Collider, ColliderBuilder, ColliderHandle, Material, MaterialError};
pub use contact::{ContactEvent, ContactEventKind};
pub use glam;
pub use math::{Pose, Quat, Vec3};
pub use shape::{Ball, Cuboid, HalfSpace, MassProperties, Shape, ShapeError};
pub use world::{Profile, World, WorldError, WorldSettings};

/// Manifolds the contact solver works on at once, side by side in SIMD
/// lanes: 8 (one AVX register, or two 128-bit halves without AVX), or 4
/// with the `lanes4` feature (one 128-bit register). The
/// width never changes the results, only the speed: which is faster
/// depends on the processor and the scene (`docs/performance.md`,
/// "Session 22").
pub const SOLVER_LANES: usize = solver::LANES;

/// The instructions the contact solver's passes run with on this
/// processor, chosen when the first pass runs: `"avx512"` on x86-64
/// processors with AVX-512 F, VL, DQ and BW (the same lanes, with twice
/// the vector registers), else `"avx"` or `"sse2"`; `"neon"` on AArch64,
/// `"portable"` elsewhere. Like [`SOLVER_LANES`], this never changes the
/// results, only the speed (`docs/performance.md`, "Session 24").
pub fn solver_code_path() -> &'static str {
    solver::code_path()
}
