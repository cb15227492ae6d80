//! Joints: constraints that hold two bodies (or a body and the world)
//! together at anchor points, solved in the same passes as the contacts
//! (`solver/joints.rs`).
//!
//! Five kinds, built with [`JointBuilder`] in the idiom of Rapier's
//! builders and inserted with [`World::insert_joint`](crate::World::insert_joint):
//!
//! | kind | holds | rows |
//! |---|---|---|
//! | [`spherical`](JointBuilder::spherical) | one point of each body together (ball and socket) | 3 |
//! | [`revolute`](JointBuilder::revolute) | the point, and the bodies turning only about an axis, optionally within limits | 5 (+ limits) |
//! | [`fixed`](JointBuilder::fixed) | the whole relative pose (a weld) | 6 |
//! | [`distance`](JointBuilder::distance) | two points at a fixed distance, or on a spring | 1 |
//! | [`rope`](JointBuilder::rope) | two points no further apart than a length, slack below it | 1 (one-sided) |
//!
//! Every joint is rigid unless it is given a spring: its rows are solved
//! exactly along the joint trees of each island (`solver/joints.rs`), and
//! the drift that the velocity rows leave is removed by the same
//! split-impulse position correction as the contacts'. A joint can break:
//! at the end of each step its impulse summed over the substeps is turned
//! into a force and a torque, and a joint above its
//! [`break_force`](JointBuilder::break_force) or
//! [`break_torque`](JointBuilder::break_torque) is removed and reported
//! ([`JointEvent::Broken`]). The thresholds mean the same force at any
//! step and substep count. `docs/joints.md` is the user's manual.

use crate::arena::RawHandle;
use crate::body::BodyHandle;
use crate::math::{Quat, Vec3};

/// A Copy handle to a joint in a [`World`](crate::World); stale once the
/// joint is removed or broken.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JointHandle(pub(crate) RawHandle);

impl JointHandle {
    /// The slot index (stable while the joint lives; reused after removal).
    pub fn index(self) -> u32 {
        self.0.index
    }
}

/// One side of a joint: a body, or the world (a fixed point in space).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointBody {
    /// The world: anchors on this side are world points.
    World,
    /// A body.
    Body(BodyHandle),
}

impl From<BodyHandle> for JointBody {
    fn from(b: BodyHandle) -> Self {
        JointBody::Body(b)
    }
}

/// The kind of a joint (see the module table).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// Ball and socket: the anchors coincide, any rotation.
    Spherical,
    /// Hinge: the anchors coincide, rotation only about the axis.
    Revolute,
    /// Weld: the relative pose at insertion is kept.
    Fixed,
    /// The anchors stay `length` apart (rigid), or a spring pulls them to
    /// that distance.
    Distance,
    /// The anchors stay at most `length` apart.
    Rope,
}

/// Where a joint's anchors are given.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Anchors {
    /// The origin of body `b` (of `a` when `b` is the world).
    Default,
    /// One world point for both bodies.
    World(Vec3),
    /// A world point for each body.
    WorldEach(Vec3, Vec3),
    /// A point in each body's frame (relative to its origin; a world
    /// point for the world side).
    Local(Vec3, Vec3),
}

/// Describes a joint to insert with [`World::insert_joint`](crate::World::insert_joint).
///
/// Defaults: the anchor at the origin of body `b` (of `a` when `b` is
/// the world; for [`distance`](Self::distance) and [`rope`](Self::rope):
/// each body's origin), no limits, no spring, unbreakable (`break_force` and
/// `break_torque` infinite), the two bodies do not collide with each
/// other (`collide_connected(false)`), user data 0.
///
/// ```
/// use crumble::{BodyBuilder, ColliderBuilder, JointBuilder, JointBody, Shape, Vec3, World};
/// let mut world = World::default();
/// let ball = world.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 1.0, 0.0))).unwrap();
/// world.insert_collider(ColliderBuilder::new(Shape::ball(0.1).unwrap()), ball).unwrap();
/// // A pendulum: the ball hangs 1 m below a fixed point in the world.
/// let joint = JointBuilder::spherical(JointBody::World, ball).anchor(Vec3::new(0.0, 2.0, 0.0));
/// let h = world.insert_joint(joint).unwrap();
/// world.step(1.0 / 60.0).unwrap();
/// assert!(world.joint(h).unwrap().separation() < 1e-4);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointBuilder {
    pub(crate) kind: JointKind,
    pub(crate) a: JointBody,
    pub(crate) b: JointBody,
    anchors: Anchors,
    pub(crate) axis: Vec3,
    pub(crate) options: JointOptions,
}

/// What a joint is built with besides its bodies, anchors and axis: kept
/// by the joint as its builder gave it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct JointOptions {
    pub(crate) limits: Option<(f32, f32)>,
    pub(crate) length: f32,
    pub(crate) spring: Option<(f32, f32)>,
    pub(crate) break_force: f32,
    pub(crate) break_torque: f32,
    pub(crate) collide_connected: bool,
    pub(crate) user_data: u64,
}

impl JointBuilder {
    fn new(kind: JointKind, a: JointBody, b: JointBody) -> Self {
        JointBuilder {
            kind,
            a,
            b,
            anchors: Anchors::Default,
            axis: Vec3::Z,
            options: JointOptions {
                limits: None,
                length: 0.0,
                spring: None,
                break_force: f32::INFINITY,
                break_torque: f32::INFINITY,
                collide_connected: false,
                user_data: 0,
            },
        }
    }

    /// A ball-and-socket joint between `a` and `b`: the anchor points
    /// coincide, and the bodies turn freely about it.
    pub fn spherical(a: impl Into<JointBody>, b: impl Into<JointBody>) -> Self {
        Self::new(JointKind::Spherical, a.into(), b.into())
    }

    /// A hinge between `a` and `b` about `axis` (a world direction at
    /// insertion, fixed in both bodies from then on).
    pub fn revolute(a: impl Into<JointBody>, b: impl Into<JointBody>, axis: Vec3) -> Self {
        JointBuilder { axis, ..Self::new(JointKind::Revolute, a.into(), b.into()) }
    }

    /// A weld: the bodies keep the relative pose they have at insertion.
    pub fn fixed(a: impl Into<JointBody>, b: impl Into<JointBody>) -> Self {
        Self::new(JointKind::Fixed, a.into(), b.into())
    }

    /// The anchors stay `length` metres apart: a rigid rod, or with
    /// [`spring`](Self::spring) a spring of that rest length.
    pub fn distance(a: impl Into<JointBody>, b: impl Into<JointBody>, length: f32) -> Self {
        let mut builder = Self::new(JointKind::Distance, a.into(), b.into());
        builder.options.length = length;
        builder
    }

    /// A rope: the anchors stay at most `max_length` metres apart, and
    /// move freely closer.
    pub fn rope(a: impl Into<JointBody>, b: impl Into<JointBody>, max_length: f32) -> Self {
        let mut builder = Self::new(JointKind::Rope, a.into(), b.into());
        builder.options.length = max_length;
        builder
    }

    /// One anchor for both bodies: a world point at insertion.
    pub fn anchor(mut self, p: Vec3) -> Self {
        self.anchors = Anchors::World(p);
        self
    }

    /// A world point for each body's anchor, at insertion (for a distance
    /// joint or a rope, its two ends).
    pub fn anchors(mut self, pa: Vec3, pb: Vec3) -> Self {
        self.anchors = Anchors::WorldEach(pa, pb);
        self
    }

    /// Each anchor in its body's frame, relative to the body's origin (a
    /// world point on the world's side).
    pub fn local_anchors(mut self, la: Vec3, lb: Vec3) -> Self {
        self.anchors = Anchors::Local(la, lb);
        self
    }

    /// Limits of a hinge's angle, radians, `-π ≤ lo ≤ hi ≤ π`: the angle
    /// of `b` relative to `a` about the axis, 0 at insertion, positive by
    /// the right-hand rule.
    pub fn limits(mut self, lo: f32, hi: f32) -> Self {
        self.options.limits = Some((lo, hi));
        self
    }

    /// Makes a distance joint a spring of `hertz` (its natural frequency
    /// for the two bodies' effective mass) and damping ratio `zeta` (1:
    /// critically damped). A frequency of 0 is no spring (rigid).
    pub fn spring(mut self, hertz: f32, zeta: f32) -> Self {
        self.options.spring = Some((hertz, zeta));
        self
    }

    /// The force, N, above which the joint breaks: its impulse over a step
    /// divided by the step (default: never).
    pub fn break_force(mut self, newtons: f32) -> Self {
        self.options.break_force = newtons;
        self
    }

    /// The torque, N·m, above which the joint breaks (default: never).
    pub fn break_torque(mut self, newton_metres: f32) -> Self {
        self.options.break_torque = newton_metres;
        self
    }

    /// Whether the two bodies collide with each other (default false: a
    /// chain's links overlap at their joints).
    pub fn collide_connected(mut self, yes: bool) -> Self {
        self.options.collide_connected = yes;
        self
    }

    /// A number of the user's, reported back in the joint's events.
    pub fn user_data(mut self, data: u64) -> Self {
        self.options.user_data = data;
        self
    }

    /// The anchors in each body's frame, given the two sides' poses at
    /// insertion (`None`: the world, whose frame is the identity).
    pub(crate) fn local_anchor_points(
        &self,
        pose_a: crate::math::Pose,
        pose_b: crate::math::Pose,
        b_is_world: bool,
    ) -> (Vec3, Vec3) {
        let local = |pose: crate::math::Pose, p: Vec3| pose.rotation.inverse() * (p - pose.position);
        match self.anchors {
            Anchors::Default => match self.kind {
                JointKind::Distance | JointKind::Rope => (Vec3::ZERO, Vec3::ZERO),
                _ => {
                    let p = if b_is_world { pose_a.position } else { pose_b.position };
                    (local(pose_a, p), local(pose_b, p))
                }
            },
            Anchors::World(p) => (local(pose_a, p), local(pose_b, p)),
            Anchors::WorldEach(pa, pb) => (local(pose_a, pa), local(pose_b, pb)),
            Anchors::Local(la, lb) => (la, lb),
        }
    }

    /// The points the anchors were given as (for the checks).
    pub(crate) fn anchor_values(&self) -> [Vec3; 2] {
        match self.anchors {
            Anchors::Default => [Vec3::ZERO; 2],
            Anchors::World(p) => [p, p],
            Anchors::WorldEach(a, b) | Anchors::Local(a, b) => [a, b],
        }
    }
}

/// A joint in the world: what it was built with, and what the last step
/// measured of it.
#[derive(Clone, Debug)]
pub struct Joint {
    pub(crate) kind: JointKind,
    /// Body slots, `NO_BODY` for the world, and the handles.
    pub(crate) a: u32,
    pub(crate) b: u32,
    pub(crate) handle_a: Option<BodyHandle>,
    pub(crate) handle_b: Option<BodyHandle>,
    /// Anchors in each body's frame (relative to its origin).
    pub(crate) local_a: Vec3,
    pub(crate) local_b: Vec3,
    /// Hinge axis in each body's frame, and a direction perpendicular to
    /// it in each (the same world direction at insertion), from which the
    /// hinge angle is measured.
    pub(crate) axis_a: Vec3,
    pub(crate) axis_b: Vec3,
    pub(crate) ref_a: Vec3,
    pub(crate) ref_b: Vec3,
    /// `q_a⁻¹ q_b` at insertion: the relative orientation a weld keeps.
    pub(crate) relative: Quat,
    pub(crate) options: JointOptions,
    /// The impulses of the last substep, world frame (warm start): on the
    /// point rows, the angular rows, and the one-sided or spring rows.
    pub(crate) linear_impulse: Vec3,
    pub(crate) angular_impulse: Vec3,
    pub(crate) extra_impulse: [f32; 2],
    /// What the last step measured (see the accessors).
    pub(crate) force: Vec3,
    pub(crate) torque: Vec3,
    pub(crate) separation: f32,
}

/// The `a` or `b` of a joint on the world's side.
pub(crate) const NO_BODY: u32 = u32::MAX;

impl Joint {
    /// The kind.
    pub fn kind(&self) -> JointKind {
        self.kind
    }

    /// The two bodies (`None` for the world).
    pub fn bodies(&self) -> (Option<BodyHandle>, Option<BodyHandle>) {
        (self.handle_a, self.handle_b)
    }

    /// The anchors in each body's frame, relative to its origin (a world
    /// point on the world's side).
    pub fn local_anchors(&self) -> (Vec3, Vec3) {
        (self.local_a, self.local_b)
    }

    /// The force the joint applied to body `b` over the last step (its
    /// impulse summed over the substeps, divided by the step), N, world
    /// frame; body `a` felt the opposite.
    pub fn force(&self) -> Vec3 {
        self.force
    }

    /// The torque the joint applied to body `b` over the last step, N·m,
    /// world frame (the point rows' moment not included: this is what
    /// the angular rows and limits carried).
    pub fn torque(&self) -> Vec3 {
        self.torque
    }

    /// How far the joint is from holding after the last step, metres: the
    /// distance between the anchors of a spherical, revolute or fixed
    /// joint; how far a rigid distance joint is from its length; how far a
    /// rope is stretched beyond its length (0 when slack); 0 for a spring.
    pub fn separation(&self) -> f32 {
        self.separation
    }

    /// A hinge's limits, radians, as built.
    pub fn limits(&self) -> Option<(f32, f32)> {
        self.options.limits
    }

    /// A distance joint's spring: its frequency, Hz, and damping ratio.
    pub fn spring(&self) -> Option<(f32, f32)> {
        self.options.spring
    }

    /// A hinge's axis in each body's frame (a world direction on the
    /// world's side).
    pub fn local_axes(&self) -> (Vec3, Vec3) {
        (self.axis_a, self.axis_b)
    }

    /// The orientation of body `b` relative to body `a`, `q_a⁻¹ q_b`, at
    /// insertion: what a weld keeps.
    pub fn relative_rotation(&self) -> Quat {
        self.relative
    }

    /// A distance joint's length or a rope's maximum length, metres.
    pub fn length(&self) -> f32 {
        self.options.length
    }

    /// The break thresholds, N and N·m (infinite: never).
    pub fn break_thresholds(&self) -> (f32, f32) {
        (self.options.break_force, self.options.break_torque)
    }

    /// Whether the two bodies collide with each other.
    pub fn collide_connected(&self) -> bool {
        self.options.collide_connected
    }

    /// The user's number given at creation.
    pub fn user_data(&self) -> u64 {
        self.options.user_data
    }
}

/// What happened to a joint in the last step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointEvent {
    /// The joint's force or torque over the step went above its threshold,
    /// and it was removed at the end of the step.
    Broken {
        /// The joint's handle (now stale).
        joint: JointHandle,
        /// Its bodies (`None` for the world).
        body_a: Option<BodyHandle>,
        body_b: Option<BodyHandle>,
        /// The force and torque over the step that broke it, N and N·m.
        force: f32,
        torque: f32,
        /// The joint's user data.
        user_data: u64,
    },
}
