//! Small math helpers on top of `glam` (f32).

pub use glam::{Mat3, Quat, Vec3, Vec4};

/// A rigid transform: a rotation (unit quaternion) followed by a translation.
///
/// `transform_point(p) = rotation * p + position`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Position of the body's origin (its centre of mass) in world space, metres.
    pub position: Vec3,
    /// Orientation, a unit quaternion.
    pub rotation: Quat,
}

impl Default for Pose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Pose {
    /// The pose at the origin with no rotation.
    pub const IDENTITY: Pose = Pose { position: Vec3::ZERO, rotation: Quat::IDENTITY };

    /// A pose from a position and a rotation (the rotation is used as given).
    pub fn new(position: Vec3, rotation: Quat) -> Self {
        Self { position, rotation }
    }

    /// A pose with the given position and no rotation.
    pub fn from_translation(position: Vec3) -> Self {
        Self { position, rotation: Quat::IDENTITY }
    }

    /// Maps a point from the local frame to world space.
    #[inline]
    pub fn transform_point(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.position
    }

    /// Maps a world-space point into the local frame.
    #[inline]
    pub fn inverse_transform_point(&self, p: Vec3) -> Vec3 {
        self.rotation.inverse() * (p - self.position)
    }

    /// Rotates a local direction into world space.
    #[inline]
    pub fn transform_vector(&self, v: Vec3) -> Vec3 {
        self.rotation * v
    }

    /// Rotates a world direction into the local frame.
    #[inline]
    pub fn inverse_transform_vector(&self, v: Vec3) -> Vec3 {
        self.rotation.inverse() * v
    }

    /// The inverse pose: maps world space into this pose's local frame.
    pub fn inverse(&self) -> Pose {
        let rotation = self.rotation.inverse();
        Pose { position: rotation * -self.position, rotation }
    }

    /// The composition `self ∘ other` (apply `other` first).
    pub fn mul_pose(&self, other: &Pose) -> Pose {
        Pose { position: self.transform_point(other.position), rotation: self.rotation * other.rotation }
    }

    /// The rotation as a matrix whose columns are the local axes in world space.
    #[inline]
    pub fn basis(&self) -> Mat3 {
        Mat3::from_quat(self.rotation)
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.position.is_finite() && self.rotation.is_finite()
    }
}
