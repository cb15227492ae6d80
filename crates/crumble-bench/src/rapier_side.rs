//! The Rapier copy of a crumble scene.
//!
//! Mapping of the settings (see `docs/performance.md`, "The harness"):
//! - dt 1/60 on both sides.
//! - crumble's 4 substeps ↔ Rapier's `num_solver_iterations = 4`: Rapier
//!   divides the step by `num_solver_iterations` and runs, per substep, one
//!   biased PGS pass (`num_internal_pgs_iterations = 1`) and one unbiased
//!   stabilisation pass (`num_internal_stabilization_iterations = 1`). crumble
//!   runs, per substep, one biased pass and at least `relax_iterations = 8`
//!   relax passes (more for a deep stack, and while not converged). Both are
//!   the engines' defaults.
//! - Friction combines as the geometric mean and restitution as the max of
//!   the two materials, as crumble does. Rapier has no rolling resistance.
//! - The ground is a static cuboid 2 km wide whose top face is y = 0.
//! - Sleep: `can_sleep(false)` on every body unless the scene allows sleep;
//!   bodies created asleep in crumble are created asleep in Rapier.
//! - Bullets (crumble's swept bodies) get Rapier's CCD.

use crumble::{BodyHandle, BodyType, Shape, World};
use rapier3d::math::{Pose, Rotation};
use rapier3d::prelude::{
    CoefficientCombineRule, ColliderBuilder, PhysicsWorld, RigidBodyBuilder, RigidBodyHandle, Vector,
};

use crate::scenes::{SceneDef, DT};

pub struct RapierScene {
    pub world: PhysicsWorld,
    /// The Rapier body of each tracked crumble body, in the same order.
    pub tracked: Vec<RigidBodyHandle>,
}

fn v(x: crumble::Vec3) -> Vector {
    Vector::new(x.x, x.y, x.z)
}

/// Copies every body and collider of `src` into a new Rapier world.
pub fn mirror(def: &SceneDef, src: &World, tracked: &[BodyHandle]) -> RapierScene {
    let mut world = PhysicsWorld::new();
    world.gravity = v(def.gravity);
    let p = &mut world.integration_parameters;
    p.dt = DT;
    p.num_solver_iterations = src.settings().substeps as usize;
    p.num_internal_pgs_iterations = 1;
    p.num_internal_stabilization_iterations = 1;

    let mut map = std::collections::HashMap::new();
    for (h, b) in src.bodies() {
        let pose = b.pose();
        let builder = match b.body_type() {
            BodyType::Static => RigidBodyBuilder::fixed(),
            BodyType::Kinematic => RigidBodyBuilder::kinematic_velocity_based(),
            BodyType::Dynamic => RigidBodyBuilder::dynamic(),
        };
        let builder = builder
            .translation(v(pose.position))
            .rotation(v(pose.rotation.to_scaled_axis()))
            .linvel(v(b.linear_velocity()))
            .angvel(v(b.angular_velocity()))
            .can_sleep(def.sleep)
            .sleeping(b.is_sleeping())
            .ccd_enabled(b.is_bullet());
        let rb = world.insert_body(builder);
        map.insert(h, rb);
        for ch in src.body_colliders(h) {
            let c = src.collider(ch).expect("live collider");
            let local = c.local_pose();
            let (shape, position) = match c.shape() {
                Shape::Cuboid(cub) => {
                    let he = cub.half_extents();
                    (ColliderBuilder::cuboid(he.x, he.y, he.z), v(local.position))
                }
                Shape::Ball(ball) => (ColliderBuilder::ball(ball.radius()), v(local.position)),
                Shape::HalfSpace(hs) => {
                    // Only the ground (normal +y) is used by the scenes.
                    assert!(hs.normal().y > 0.999, "only a y-up ground is mirrored");
                    (ColliderBuilder::cuboid(1000.0, 1.0, 1000.0), Vector::new(0.0, hs.offset() - 1.0, 0.0))
                }
            };
            let m = c.material();
            let collider = shape
                .position(Pose::from_parts(position, to_rot(local.rotation)))
                .density(m.density)
                .friction(m.friction)
                .restitution(m.restitution)
                .friction_combine_rule(CoefficientCombineRule::GeometricMean)
                .restitution_combine_rule(CoefficientCombineRule::Max);
            world.insert_collider(collider, Some(rb));
        }
    }
    let tracked = tracked.iter().map(|h| map[h]).collect();
    RapierScene { world, tracked }
}

fn to_rot(q: crumble::Quat) -> Rotation {
    Rotation::from_xyzw(q.x, q.y, q.z, q.w)
}

/// Contact points Rapier's solver worked on in the last step, from its
/// counters (enabled for that step by the harness).
///
/// Not the points of every manifold with an awake body: Rapier hands its
/// solver only the manifolds of pairs that its narrow phase has updated
/// since they were created, and it updates a pair only when one of its
/// bodies moves. In `smash` all 10,051 bodies are awake and their
/// manifolds hold 119k points from the first step, but the solver gets
/// only the pairs the box's hit has set moving: 1,405 points at step 11,
/// 11,744 at step 111.
pub fn contact_points(world: &PhysicsWorld) -> usize {
    world.physics_pipeline.counters.solver.ncontacts
}

/// Position of a body, as a crumble vector.
pub fn position(world: &PhysicsWorld, h: RigidBodyHandle) -> crumble::Vec3 {
    let t = world.bodies[h].translation();
    crumble::Vec3::new(t.x, t.y, t.z)
}
