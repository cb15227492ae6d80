//! # crumble
//!
//! A rigid-body physics engine for boxes, spheres and a ground plane, built
//! around oriented-box (OBB) colliders. It grew out of the "Breaking a Brick
//! Wall" project report and its use of D. Eberly's separating-axis test, and
//! aims at walls that stand still at real gravity and break convincingly.
//!
//! ## Quick start
//!
//! The package is `crumble-physics`; its library is `crumble`. A box and a
//! ball dropped on the ground, stepped for two seconds (the same example
//! opens the crate's README.md, and `tests/readme.rs` checks that the two
//! match):
//!
//! ```
//! use crumble::{BodyBuilder, ColliderBuilder, Quat, Vec3, World};
//!
//! fn main() -> Result<(), Box<dyn std::error::Error>> {
//!     // Real gravity (9.81 m/s², y up) and the default settings.
//!     let mut world = World::default();
//!
//!     // The ground: the half-space below y = 0, on a fixed body.
//!     let ground = world.insert_body(BodyBuilder::fixed())?;
//!     world.insert_collider(ColliderBuilder::ground(0.0)?, ground)?;
//!
//!     // A 0.5 m box dropped from 1 m, and a ball of radius 0.1 m dropped onto it from 2 m.
//!     let block = world.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 1.0, 0.0)))?;
//!     world.insert_collider(ColliderBuilder::cuboid(0.25, 0.25, 0.25)?, block)?;
//!     let ball = world.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 2.0, 0.0)))?;
//!     world.insert_collider(ColliderBuilder::ball(0.1)?, ball)?;
//!
//!     // Two seconds at 60 steps a second.
//!     for _ in 0..120 {
//!         world.step(1.0 / 60.0)?;
//!     }
//!
//!     // The box rests upright on the ground and the ball on the box, each
//!     // within 1 mm of the height where it touches, and both are asleep.
//!     let block = world.body(block).ok_or("the box is gone")?;
//!     let ball = world.body(ball).ok_or("the ball is gone")?;
//!     let pose = block.pose();
//!     assert!((pose.position.y - 0.25).abs() < 1e-3, "box at {}", pose.position);
//!     assert!(pose.rotation.angle_between(Quat::IDENTITY) < 1e-3, "box turned to {}", pose.rotation);
//!     assert!((ball.position().y - 0.6).abs() < 1e-3, "ball at {}", ball.position());
//!     assert!(block.is_sleeping() && ball.is_sleeping());
//!     Ok(())
//! }
//! ```
//!
//! ## The crate's files
//!
//! The crate's files read as the pipeline a step runs ([`World::step`];
//! `docs/pipeline.md` walks through it stage by stage):
//!
//! - Foundations: [`math`] (poses: position + unit quaternion, on `glam`),
//!   [`aabb`] (axis-aligned boxes), [`shape`] (cuboids, balls, half-spaces,
//!   their mass properties and boxes), [`mass`] (a body's mass and inertia
//!   from its colliders, and the range simulated), [`body`] and [`collider`] (what the
//!   user inserts, with builders and handles), `arena` (generational slots
//!   behind the handles).
//! - [`world`]: the [`World`] that owns it all, its settings
//!   ([`WorldSettings`]), errors ([`WorldError`]) and per-step
//!   [`Profile`]; `world/step.rs` is the step, a table of contents of the
//!   stages below.
//! - [`broad_phase`]: an incremental dynamic AABB tree that reports the pairs
//!   of colliders whose fattened boxes begin or stop overlapping; the
//!   world's proxies for it are made in `world/proxies.rs`.
//! - `narrow_phase`: each active contact's manifold, recycled or computed
//!   by [`collision`]: one function per shape pair producing a
//!   [`collision::Manifold`], plus the seed report's 15-axis test
//!   ([`collision::sat`]). [`contact`] holds the contacts the pairs become,
//!   linked per body by `edge_list` (as the broad phase links its pairs).
//! - `awake` and `island`: the awake set, islands (union–find), sleep and
//!   waking, and the stack depth that sets relax passes.
//! - [`solver`]: the solver stage, `solver/step.rs` (what it keeps from
//!   step to step, the substep loop) and `solver/setup.rs` (its set-up
//!   phases), on the constraint groups and units of `partition`.
//! - [`bond`]: mortar between touching faces, which the contact solver
//!   solves in the pair's contact's place until it breaks; the world's
//!   bonds are in `world/bonds.rs`.
//! - `ccd`: continuous collision, sweeps of fast bodies and bullets.
//! - `energy`: the bound on each island's energy after the solver and
//!   continuous collision.
//! - [`fracture`]: boxes of a breakable material that split in two along
//!   one of their axis planes when the step's impulses overload it; the
//!   stage that judges and splits them is `world/fracture.rs`.
//! - `threads`: the step's pools and the loops it shares out over them.
//! - [`scenes`]: generators of walls, pyramids and stacks shared by the
//!   tests, benchmarks and tools.
//!
//! The engine does no file I/O, no rendering and no printing.

pub mod aabb;
mod arena;
mod awake;
pub mod body;
pub mod bond;
pub mod broad_phase;
mod ccd;
pub mod collider;
pub mod collision;
pub mod contact;
mod edge_list;
mod energy;
pub mod fracture;
mod island;
pub mod joint;
pub mod mass;
pub mod math;
mod narrow_phase;
mod partition;
pub mod scenes;
pub mod shape;
pub mod snapshot;
pub mod solver;
mod threads;
pub mod world;

pub use aabb::Aabb;
pub use body::{Body, BodyBuilder, BodyHandle, BodyType};
pub use bond::{Bond, BondEvent, BondHandle, BondMode, BondSpec};
pub use collider::{Collider, ColliderBuilder, ColliderHandle, Material, MaterialError, Strength};
pub use contact::{ContactEvent, ContactEventKind};
pub use fracture::{FractureEvent, FractureMode};
pub use glam;
pub use joint::{Joint, JointBody, JointBuilder, JointEvent, JointHandle, JointKind};
pub use math::{Pose, Quat, Vec3};
pub use shape::{Ball, Cuboid, HalfSpace, MassProperties, Shape, ShapeError};
pub use snapshot::{SnapshotError, SNAPSHOT_VERSION};
pub use world::{Profile, SolverExperiments, SolverStages, World, WorldError, WorldSettings};

/// Manifolds the contact solver works on at once, side by side in SIMD
/// lanes: 8 (one AVX register, or two 128-bit halves without AVX), or 4
/// with the `lanes4` feature (one 128-bit register). The width never
/// changes the results, only the speed: which is faster depends on the
/// processor and the scene (`docs/solver.md`, "Same bits: batches, lanes
/// and the reference").
pub const SOLVER_LANES: usize = solver::LANES;

/// The instructions the contact solver's passes run with on this
/// processor, chosen when the first pass runs: `"avx512"` on x86-64
/// processors with AVX-512 F, VL, DQ and BW (the same lanes, with twice
/// the vector registers), else `"avx"` or `"sse2"`; `"neon"` on AArch64,
/// `"portable"` elsewhere. Like [`SOLVER_LANES`], this never changes the
/// results, only the speed (`docs/solver.md`, "Memory layout").
pub fn solver_code_path() -> &'static str {
    solver::code_path()
}
