//! The Rapier copy of a crumble scene.
//!
//! Mapping of the settings (see `docs/performance.md`, "The harness"):
//! - dt 1/60 on both sides.
//! - crumble's substeps (6 by default) ↔ Rapier's own default
//!   `num_solver_iterations = 4`: Rapier
//!   divides the step by `num_solver_iterations` and runs, per substep, one
//!   biased PGS pass (`num_internal_pgs_iterations = 1`) and one unbiased
//!   stabilisation pass (`num_internal_stabilization_iterations = 1`). crumble
//!   runs, per substep, one biased pass and at least `relax_iterations = 3`
//!   relax passes (more for a deep stack, and while not converged). Both are
//!   the engines' defaults; `--rapier-substeps N` gives Rapier N, and
//!   `--matched` gives crumble Rapier's substeps and passes.
//! - Friction combines as the geometric mean and restitution as the max of
//!   the two materials, as crumble does. Rapier has no rolling resistance.
//! - The ground is a static cuboid 2 km wide whose top face is y = 0.
//! - Sleep: `can_sleep(false)` on every body unless the scene allows sleep.
//!   Bodies created asleep in crumble are put to sleep by Rapier itself,
//!   untimed ([`mirror`]): Rapier's `.sleeping(true)` does not hold (the
//!   first step's touching pairs wake the sleeping side, and the pair
//!   hints made while both slept leave them without solver contacts for
//!   six steps, so that a wall created asleep under gravity free-falls
//!   51 mm into the ground).
//! - Bullets (crumble's swept bodies) get Rapier's CCD.
//! - Joints: each crumble joint becomes Rapier's impulse joint of the same
//!   kind (`ImpulseJointSet`, solved in the same PGS passes as the
//!   contacts): spherical, fixed, rope; a distance joint is a rope whose
//!   length is limited to `[L, L]`, rigid (crumble does not expose a
//!   spring's constants); a hinge is refused (crumble does not expose its
//!   axis). The local anchors are crumble's, and contacts between the two
//!   bodies are disabled (`contacts_enabled(false)`) unless crumble's
//!   `collide_connected` is set. The world side of a joint is a fixed body
//!   at the origin, so that its local anchor is crumble's world point.
//!   With [`Joints::Multibody`] (`--rapier-multibody`) the spherical and
//!   fixed joints are multibody joints instead (reduced coordinates: the
//!   chain cannot come apart); a joint that would close a loop, a rope and
//!   a distance joint stay impulse joints.

use crumble::{BodyHandle, BodyType, JointKind, Shape, World};
use rapier3d::math::{Pose, Rotation};
use rapier3d::prelude::{
    CoefficientCombineRule, ColliderBuilder, FixedJointBuilder, GenericJoint, JointAxis, PhysicsWorld,
    RigidBodyBuilder, RigidBodyHandle, RopeJointBuilder, SphericalJointBuilder, Vector,
};

use crate::scenes::{Pendulum, SceneDef, DT};

/// Which of Rapier's joints mirror crumble's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Joints {
    /// `ImpulseJointSet`: constraints solved with the contacts (Rapier's
    /// usual joints).
    Impulse,
    /// `MultibodyJointSet` for the spherical and fixed joints.
    Multibody,
}

impl Joints {
    pub fn name(self) -> &'static str {
        match self {
            Joints::Impulse => "impulse",
            Joints::Multibody => "multibody",
        }
    }
}

/// A joint whose two anchors must coincide (spherical, fixed): its bodies
/// and its anchors in each body's frame.
#[derive(Clone, Copy, Debug)]
pub struct PointJoint {
    pub body1: RigidBodyHandle,
    pub body2: RigidBodyHandle,
    pub anchor1: Vector,
    pub anchor2: Vector,
}

pub struct RapierScene {
    pub world: PhysicsWorld,
    /// The Rapier body of each tracked crumble body, in the same order.
    pub tracked: Vec<RigidBodyHandle>,
    /// Every mirrored joint whose anchors must coincide.
    pub point_joints: Vec<PointJoint>,
    /// The wrecking ball's body, in the scenes that have one.
    pub ball: Option<RigidBodyHandle>,
    /// How Rapier put the bodies created asleep to sleep, in the scenes
    /// that have some.
    pub slept: Option<Slept>,
}

/// The untimed steps in which Rapier put the bodies crumble created asleep
/// to sleep ([`mirror`]).
#[derive(Clone, Copy, Debug)]
pub struct Slept {
    /// Bodies created asleep.
    pub bodies: usize,
    /// Steps at zero gravity until Rapier's sleep test slept them all.
    pub steps: usize,
    /// The largest distance any of them moved meanwhile, m.
    pub moved: f32,
}

/// The most untimed steps Rapier may take to put the bodies created asleep
/// to sleep (10 s; its sleep test takes half a second of rest, 31 steps).
pub const MAX_SLEEP_STEPS: usize = 600;

fn v(x: crumble::Vec3) -> Vector {
    Vector::new(x.x, x.y, x.z)
}

/// Rapier's own default `num_solver_iterations` (its substeps): what the
/// harness gives Rapier unless `--rapier-substeps` says otherwise, whatever
/// crumble's substeps are.
pub fn default_substeps() -> usize {
    rapier3d::dynamics::IntegrationParameters::default().num_solver_iterations
}

/// Copies every body, collider and joint of `src` into a new Rapier world;
/// `joints` says which of Rapier's joints, `substeps` is its
/// `num_solver_iterations` (the harness's default: Rapier's own,
/// [`default_substeps`]).
///
/// Bodies that crumble created asleep cannot be created asleep in Rapier
/// (see the module's notes). They go in first, awake, with the static
/// bodies, and Rapier steps them at zero gravity until its own sleep test
/// has put every one of them to sleep, at most [`MAX_SLEEP_STEPS`] steps
/// (an error otherwise); then the scene's gravity is set and the other
/// bodies and the joints go in. None of these steps is timed. A scene
/// without bodies created asleep is copied in one pass, in crumble's
/// order.
pub fn mirror(
    def: &SceneDef,
    src: &World,
    tracked: &[BodyHandle],
    pendulum: Option<&Pendulum>,
    joints: Joints,
    substeps: usize,
) -> Result<RapierScene, String> {
    let mut world = PhysicsWorld::new();
    let p = &mut world.integration_parameters;
    p.dt = DT;
    p.num_solver_iterations = substeps;
    p.num_internal_pgs_iterations = 1;
    p.num_internal_stabilization_iterations = 1;

    let asleep: Vec<BodyHandle> =
        src.bodies().filter(|(_, b)| b.is_dynamic() && b.is_sleeping()).map(|(h, _)| h).collect();
    if !asleep.is_empty() && !def.sleep {
        return Err(format!("{}: bodies created asleep in a scene without sleep", def.name));
    }
    let first = |b: &crumble::Body| b.body_type() == BodyType::Static || (b.is_dynamic() && b.is_sleeping());
    let mut map = std::collections::HashMap::new();
    let mut slept = None;
    if !asleep.is_empty() {
        world.gravity = Vector::ZERO;
        for (h, b) in src.bodies().filter(|(_, b)| first(b)) {
            map.insert(h, insert_body(&mut world, def, src, h, b));
        }
        let start: Vec<Vector> = asleep.iter().map(|h| world.bodies[map[h]].translation()).collect();
        let mut steps = 0;
        while asleep.iter().any(|h| !world.bodies[map[h]].is_sleeping()) {
            if steps == MAX_SLEEP_STEPS {
                let awake = asleep.iter().filter(|h| !world.bodies[map[h]].is_sleeping()).count();
                return Err(format!(
                    "{}: Rapier's sleep test left {awake} of the {} bodies created asleep awake after \
{MAX_SLEEP_STEPS} steps at zero gravity",
                    def.name,
                    asleep.len()
                ));
            }
            world.step();
            steps += 1;
        }
        let moved = asleep
            .iter()
            .zip(&start)
            .map(|(h, &p0)| (world.bodies[map[h]].translation() - p0).length())
            .fold(0.0, f32::max);
        slept = Some(Slept { bodies: asleep.len(), steps, moved });
    }
    world.gravity = v(def.gravity);
    for (h, b) in src.bodies() {
        map.entry(h).or_insert_with(|| insert_body(&mut world, def, src, h, b));
    }
    let point_joints = mirror_joints(&mut world, src, &map, joints);
    let tracked = tracked.iter().map(|h| map[h]).collect();
    let ball = pendulum.map(|p| map[&p.ball]);
    Ok(RapierScene { world, tracked, point_joints, ball, slept })
}

/// Inserts crumble's body `h` (`b`) and its colliders into `world`, awake
/// (see [`mirror`] for the bodies created asleep).
fn insert_body(
    world: &mut PhysicsWorld,
    def: &SceneDef,
    src: &World,
    h: BodyHandle,
    b: &crumble::Body,
) -> RigidBodyHandle {
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
        .ccd_enabled(b.is_bullet());
    let rb = world.insert_body(builder);
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
    rb
}

/// Adds `src`'s joints to `world` (see the module's notes); returns those
/// whose anchors must coincide.
fn mirror_joints(
    world: &mut PhysicsWorld,
    src: &World,
    map: &std::collections::HashMap<BodyHandle, RigidBodyHandle>,
    joints: Joints,
) -> Vec<PointJoint> {
    let mut ground = None;
    let mut out = Vec::new();
    for (_, j) in src.joints() {
        let mut side = |b: Option<BodyHandle>| match b {
            Some(b) => map[&b],
            None => *ground.get_or_insert_with(|| world.insert_body(RigidBodyBuilder::fixed())),
        };
        let (a, b) = j.bodies();
        let (body1, body2) = (side(a), side(b));
        let (la, lb) = j.local_anchors();
        let (anchor1, anchor2) = (v(la), v(lb));
        let contacts = j.collide_connected();
        // The joint's frames: its anchors, and the bodies' relative
        // rotation now (the scene has not been stepped: at insertion) in
        // the first body's frame. A fixed joint keeps that rotation; a
        // multibody joint starts from it (its coordinates are zero when
        // the two frames coincide: with identity frames Rapier would turn
        // every link to the world's axes, hanging the released chain
        // straight down).
        let (p1, p2) = (world.bodies[body1].position(), world.bodies[body2].position());
        let frame1 = Pose::from_parts(anchor1, p1.rotation.inverse() * p2.rotation);
        let frame2 = Pose::from_parts(anchor2, Rotation::IDENTITY);
        let data: GenericJoint = match j.kind() {
            JointKind::Spherical => {
                SphericalJointBuilder::new().local_frame1(frame1).local_frame2(frame2).contacts_enabled(contacts).into()
            }
            JointKind::Fixed => {
                FixedJointBuilder::new().local_frame1(frame1).local_frame2(frame2).contacts_enabled(contacts).into()
            }
            JointKind::Rope => RopeJointBuilder::new(j.length())
                .local_anchor1(anchor1)
                .local_anchor2(anchor2)
                .contacts_enabled(contacts)
                .into(),
            JointKind::Distance => {
                let mut data: GenericJoint = RopeJointBuilder::new(j.length())
                    .local_anchor1(anchor1)
                    .local_anchor2(anchor2)
                    .contacts_enabled(contacts)
                    .into();
                data.set_limits(JointAxis::LinX, [j.length(), j.length()]);
                data
            }
            JointKind::Revolute => {
                panic!("revolute joints are not mirrored: crumble does not expose a hinge's axis")
            }
        };
        let point = matches!(j.kind(), JointKind::Spherical | JointKind::Fixed);
        let tree = joints == Joints::Multibody && point;
        if !tree || world.insert_multibody_joint(body1, body2, data).is_none() {
            world.insert_impulse_joint(body1, body2, data);
        }
        if point {
            out.push(PointJoint { body1, body2, anchor1, anchor2 });
        }
    }
    out
}

/// The largest distance between the two anchors of any of `joints`, m.
pub fn max_separation(world: &PhysicsWorld, joints: &[PointJoint]) -> f32 {
    let point = |b: RigidBodyHandle, local: Vector| world.bodies[b].position().transform_point(local);
    joints.iter().map(|j| (point(j.body2, j.anchor2) - point(j.body1, j.anchor1)).length()).fold(0.0, f32::max)
}

fn to_rot(q: crumble::Quat) -> Rotation {
    Rotation::from_xyzw(q.x, q.y, q.z, q.w)
}

/// Contact points Rapier's solver worked on in the last step, from its
/// counters (enabled for that step by the harness). With Rapier's own
/// `.sleeping(true)` for the bodies created asleep (before [`mirror`] slept
/// them itself), `smash`'s solver got only the pairs the box's hit had
/// set moving (1,405 points at step 11) although the whole wall was
/// awake; with them slept by Rapier it gets every awake pair's (117,055 at
/// the end).
pub fn contact_points(world: &PhysicsWorld) -> usize {
    world.physics_pipeline.counters.solver.ncontacts
}

/// Position of a body, as a crumble vector.
pub fn position(world: &PhysicsWorld, h: RigidBodyHandle) -> crumble::Vec3 {
    let t = world.bodies[h].translation();
    crumble::Vec3::new(t.x, t.y, t.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::{build, find};

    /// Rapier runs its own default substeps (4, as `docs/performance.md`
    /// says), not crumble's.
    #[test]
    fn rapier_runs_its_own_default_substeps() {
        assert_eq!(default_substeps(), 4);
        let def = find("wall100").expect("scene");
        let built = build(def, 1, false).expect("build");
        let rs = mirror(def, &built.world, &built.tracked, None, Joints::Impulse, default_substeps()).expect("mirror");
        assert_eq!(rs.world.integration_parameters.num_solver_iterations, 4);
    }

    /// Rapier's joints hold crumble's anchors: apart by nothing before the
    /// first step. With multibody joints the chain also starts from its
    /// released pose: ten steps later the ball is where crumble's is
    /// (regression: with identity joint frames Rapier turned every link to
    /// the world's axes at once, hanging the chain straight down).
    #[test]
    fn joints_are_mirrored_at_their_anchors_and_pose() {
        let def = find("chain").expect("the chain scene");
        for joints in [Joints::Impulse, Joints::Multibody] {
            let built = build(def, 1, false).expect("chain");
            let pendulum = built.pendulum.expect("a wrecking ball");
            let mut rs = mirror(def, &built.world, &built.tracked, Some(&pendulum), joints, 4).expect("mirror");
            assert_eq!(rs.point_joints.len(), 21, "{joints:?}");
            let separation = max_separation(&rs.world, &rs.point_joints);
            assert!(separation < 1e-5, "{joints:?}: the anchors start {separation} m apart");
            if joints == Joints::Multibody {
                let mut world = built.world;
                for _ in 0..10 {
                    world.step(DT).expect("step");
                    rs.world.step();
                }
                let c = world.body(pendulum.ball).expect("ball").position();
                let r = position(&rs.world, rs.ball.expect("ball"));
                assert!((c - r).length() < 1e-3, "crumble's ball at {c}, Rapier's at {r}");
            }
        }
    }
}
