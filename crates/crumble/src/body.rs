//! Rigid bodies: handles, builders and the per-body state the world keeps.

use crate::arena::RawHandle;
use crate::math::{Mat3, Pose, Quat, Vec3};

/// A Copy handle to a body in a [`World`](crate::World). A handle to a body
/// that has been removed is detected (it has a stale generation) and every
/// API taking it answers `None` or an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BodyHandle(pub(crate) RawHandle);

impl BodyHandle {
    /// The slot index (stable while the body lives; reused after removal).
    pub fn index(self) -> u32 {
        self.0.index
    }
}

/// How a body moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BodyType {
    /// Never moves; infinite mass. The ground, fixed obstacles.
    Static,
    /// Moved by forces, gravity and contacts.
    Dynamic,
    /// Moved only by its velocity, set by the user; pushes dynamic bodies
    /// but is not pushed back.
    Kinematic,
}

/// Describes a body to create with [`World::insert_body`](crate::World::insert_body).
///
/// Defaults: at the origin, no rotation, at rest, no damping, gravity scale 1,
/// allowed to sleep, created awake, not a bullet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyBuilder {
    pub(crate) body_type: BodyType,
    pub(crate) pose: Pose,
    pub(crate) linear_velocity: Vec3,
    pub(crate) angular_velocity: Vec3,
    pub(crate) linear_damping: f32,
    pub(crate) angular_damping: f32,
    pub(crate) gravity_scale: f32,
    pub(crate) can_sleep: bool,
    pub(crate) sleeping: bool,
    pub(crate) bullet: bool,
    pub(crate) user_data: u64,
}

impl BodyBuilder {
    fn new(body_type: BodyType) -> Self {
        Self {
            body_type,
            pose: Pose::IDENTITY,
            linear_velocity: Vec3::ZERO,
            angular_velocity: Vec3::ZERO,
            linear_damping: 0.0,
            angular_damping: 0.0,
            gravity_scale: 1.0,
            can_sleep: true,
            sleeping: false,
            bullet: false,
            user_data: 0,
        }
    }

    /// A body moved by forces and contacts.
    pub fn dynamic() -> Self {
        Self::new(BodyType::Dynamic)
    }

    /// A body that never moves.
    pub fn fixed() -> Self {
        Self::new(BodyType::Static)
    }

    /// A body moved only by the velocity the user gives it.
    pub fn kinematic() -> Self {
        Self::new(BodyType::Kinematic)
    }

    /// Position of the body's origin, metres (default: the origin).
    pub fn position(mut self, p: Vec3) -> Self {
        self.pose.position = p;
        self
    }

    /// Orientation (default: identity). Normalised when the body is inserted.
    pub fn rotation(mut self, q: Quat) -> Self {
        self.pose.rotation = q;
        self
    }

    /// Position and orientation at once.
    pub fn pose(mut self, pose: Pose) -> Self {
        self.pose = pose;
        self
    }

    /// Initial linear velocity of the centre of mass, m/s (default zero).
    pub fn linear_velocity(mut self, v: Vec3) -> Self {
        self.linear_velocity = v;
        self
    }

    /// Initial angular velocity in world space, rad/s (default zero).
    pub fn angular_velocity(mut self, w: Vec3) -> Self {
        self.angular_velocity = w;
        self
    }

    /// Linear damping rate, 1/s (default 0): `v ← v / (1 + h·c)` each substep.
    pub fn linear_damping(mut self, c: f32) -> Self {
        self.linear_damping = c;
        self
    }

    /// Angular damping rate, 1/s (default 0).
    pub fn angular_damping(mut self, c: f32) -> Self {
        self.angular_damping = c;
        self
    }

    /// Multiplier on the world's gravity for this body (default 1).
    pub fn gravity_scale(mut self, s: f32) -> Self {
        self.gravity_scale = s;
        self
    }

    /// Whether the body may fall asleep when at rest (default true).
    pub fn can_sleep(mut self, yes: bool) -> Self {
        self.can_sleep = yes;
        self
    }

    /// Create the body asleep (default false). It wakes when touched by a
    /// moving body or through the API.
    pub fn sleeping(mut self, yes: bool) -> Self {
        self.sleeping = yes;
        self
    }

    /// Mark the body as a fast projectile (default false): it is swept
    /// against dynamic bodies too, not only static ones.
    pub fn bullet(mut self, yes: bool) -> Self {
        self.bullet = yes;
        self
    }

    /// A number of the user's, kept with the body (default 0).
    pub fn user_data(mut self, d: u64) -> Self {
        self.user_data = d;
        self
    }
}

/// A body as the world keeps it. Read it through [`World::body`](crate::World::body).
#[derive(Clone, Debug)]
pub struct Body {
    pub(crate) body_type: BodyType,
    /// Pose of the body origin.
    pub(crate) pose: Pose,
    /// Centre of mass in the body frame.
    pub(crate) local_com: Vec3,
    pub(crate) linear_velocity: Vec3,
    pub(crate) angular_velocity: Vec3,
    pub(crate) force: Vec3,
    pub(crate) torque: Vec3,
    pub(crate) mass: f32,
    pub(crate) inv_mass: f32,
    /// Inertia about the centre of mass, body frame.
    pub(crate) local_inertia: Mat3,
    pub(crate) local_inv_inertia: Mat3,
    pub(crate) linear_damping: f32,
    pub(crate) angular_damping: f32,
    pub(crate) gravity_scale: f32,
    pub(crate) can_sleep: bool,
    pub(crate) sleeping: bool,
    pub(crate) sleep_time: f32,
    pub(crate) bullet: bool,
    pub(crate) user_data: u64,
    /// Colliders attached to this body (collider slot indices).
    pub(crate) colliders: Vec<u32>,
    /// Largest distance from the centre of mass to any collider surface
    /// point; turns angular speed into surface speed for sleep and margins.
    pub(crate) max_extent: f32,
    /// Smallest half extent of its colliders (scales tolerances).
    pub(crate) min_extent: f32,
    /// Index in this step's solver arrays, or `u32::MAX`.
    pub(crate) solver_index: u32,
    /// Set when the body's state went non-finite and it was stopped.
    pub(crate) faulted: bool,
}

impl Body {
    pub(crate) fn from_builder(b: &BodyBuilder) -> Self {
        Body {
            body_type: b.body_type,
            pose: Pose::new(b.pose.position, b.pose.rotation.normalize()),
            local_com: Vec3::ZERO,
            linear_velocity: if b.body_type == BodyType::Static { Vec3::ZERO } else { b.linear_velocity },
            angular_velocity: if b.body_type == BodyType::Static { Vec3::ZERO } else { b.angular_velocity },
            force: Vec3::ZERO,
            torque: Vec3::ZERO,
            mass: 0.0,
            inv_mass: 0.0,
            local_inertia: Mat3::ZERO,
            local_inv_inertia: Mat3::ZERO,
            linear_damping: b.linear_damping,
            angular_damping: b.angular_damping,
            gravity_scale: b.gravity_scale,
            can_sleep: b.can_sleep,
            sleeping: b.sleeping && b.body_type == BodyType::Dynamic,
            sleep_time: 0.0,
            bullet: b.bullet,
            user_data: b.user_data,
            colliders: Vec::new(),
            max_extent: 0.0,
            min_extent: f32::INFINITY,
            solver_index: u32::MAX,
            faulted: false,
        }
    }

    /// How the body moves.
    pub fn body_type(&self) -> BodyType {
        self.body_type
    }

    /// True for dynamic bodies.
    pub fn is_dynamic(&self) -> bool {
        self.body_type == BodyType::Dynamic
    }

    /// Pose of the body's origin.
    pub fn pose(&self) -> Pose {
        self.pose
    }

    /// Position of the body's origin.
    pub fn position(&self) -> Vec3 {
        self.pose.position
    }

    /// Orientation.
    pub fn rotation(&self) -> Quat {
        self.pose.rotation
    }

    /// World position of the centre of mass.
    pub fn center_of_mass(&self) -> Vec3 {
        self.pose.transform_point(self.local_com)
    }

    /// Linear velocity of the centre of mass, m/s.
    pub fn linear_velocity(&self) -> Vec3 {
        self.linear_velocity
    }

    /// Angular velocity, world frame, rad/s.
    pub fn angular_velocity(&self) -> Vec3 {
        self.angular_velocity
    }

    /// Mass in kg (0 for static and kinematic bodies).
    pub fn mass(&self) -> f32 {
        self.mass
    }

    /// Inertia tensor about the centre of mass, in world space.
    pub fn world_inertia(&self) -> Mat3 {
        let r = self.pose.basis();
        r * self.local_inertia * r.transpose()
    }

    /// Angular momentum about the centre of mass, world frame.
    pub fn angular_momentum(&self) -> Vec3 {
        self.world_inertia() * self.angular_velocity
    }

    /// True while the body sleeps.
    pub fn is_sleeping(&self) -> bool {
        self.sleeping
    }

    /// True when the body was marked a bullet.
    pub fn is_bullet(&self) -> bool {
        self.bullet
    }

    /// The user's number given at creation.
    pub fn user_data(&self) -> u64 {
        self.user_data
    }

    /// True when the body's state went non-finite in the last step that
    /// moved it and the world put it back and stopped it (see
    /// [`World::faulted_bodies`](crate::World::faulted_bodies)); the next
    /// step that moves it soundly clears it.
    pub fn is_faulted(&self) -> bool {
        self.faulted
    }

    /// Velocity of a world point attached to the body.
    pub fn velocity_at_point(&self, p: Vec3) -> Vec3 {
        self.linear_velocity + self.angular_velocity.cross(p - self.center_of_mass())
    }

    /// Handles of the colliders attached (slot indices).
    pub(crate) fn world_inv_inertia(&self) -> Mat3 {
        let r = self.pose.basis();
        r * self.local_inv_inertia * r.transpose()
    }
}
