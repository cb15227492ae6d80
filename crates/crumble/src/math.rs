//! Small math helpers on top of `glam` (f32).

pub use glam::{Mat3, Quat, Vec3, Vec4};

/// A rigid transform: a rotation (unit quaternion) followed by a translation.
///
/// `transform_point(p) = rotation * p + position`.
///
/// Build one with [`Pose::new`], [`Pose::from_translation`] or
/// [`Pose::IDENTITY`]; the two fields can then be read and set directly.
#[derive(Clone, Copy, PartialEq)]
#[repr(C)]
pub struct Pose {
    /// Orientation, a unit quaternion.
    pub rotation: Quat,
    /// Position of the body's origin (its centre of mass) in world space, metres.
    pub position: Vec3,
    /// Always 0. The compiler loads `position` into a SIMD register as 16
    /// bytes and lets the fourth lane ride along through the products:
    /// left as padding, those four bytes would be whatever the stack held
    /// when the pose was built, now and then a subnormal, and then every
    /// product on that lane takes a microcode assist (contact recycling,
    /// which composes poses, slows down severalfold; see `contact.rs`'s
    /// cache for the same trap).
    tail: f32,
}

impl std::fmt::Debug for Pose {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pose").field("position", &self.position).field("rotation", &self.rotation).finish()
    }
}

impl Default for Pose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Pose {
    /// The pose at the origin with no rotation.
    pub const IDENTITY: Pose = Pose::new(Vec3::ZERO, Quat::IDENTITY);

    /// A pose from a position and a rotation (the rotation is used as given).
    pub const fn new(position: Vec3, rotation: Quat) -> Self {
        Self { rotation, position, tail: 0.0 }
    }

    /// A pose with the given position and no rotation.
    pub const fn from_translation(position: Vec3) -> Self {
        Self::new(position, Quat::IDENTITY)
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
        Pose::new(rotation * -self.position, rotation)
    }

    /// The composition `self ∘ other` (apply `other` first).
    pub fn mul_pose(&self, other: &Pose) -> Pose {
        Pose::new(self.transform_point(other.position), self.rotation * other.rotation)
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

impl crate::snapshot::codec::Persist for Pose {
    fn save(&self, w: &mut crate::snapshot::codec::Writer) {
        self.rotation.save(w);
        self.position.save(w);
    }
    fn load(r: &mut crate::snapshot::codec::Reader) -> Result<Self, crate::snapshot::SnapshotError> {
        let rotation = Quat::load(r)?;
        Ok(Pose::new(Vec3::load(r)?, rotation))
    }
    fn layout(out: &mut String) {
        out.push_str("Pose{rotation:Quat,position:Vec3}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: as padding, a pose's four bytes after `position` are
    /// copied along with whatever the stack held; the compiler loads
    /// `position` as 16 bytes and multiplies all four lanes, and when those
    /// bytes read as a subnormal every product takes a microcode assist
    /// (contact recycling slows down severalfold). Every way of making a
    /// pose must leave a zero there.
    #[test]
    fn a_pose_is_never_followed_by_subnormal_bytes() {
        assert_eq!(std::mem::offset_of!(Pose, tail), std::mem::offset_of!(Pose, position) + 12, "`tail` right after");
        assert_eq!(std::mem::size_of::<Pose>(), 32, "nothing after `tail`");
        let a = Pose::new(Vec3::new(1.0, -2.0, 0.5), Quat::from_rotation_y(0.3));
        let b = Pose::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let mut moved = a;
        moved.position += Vec3::X;
        for p in [a, b, Pose::IDENTITY, Pose::default(), a.inverse(), a.mul_pose(&b), moved] {
            assert_eq!(p.tail.to_bits(), 0, "{p:?} is followed by {:e}", p.tail);
        }
    }
}
