//! Contact between a Cuboid (shape A) and a Cuboid (shape B).

use super::Manifold;
use crate::math::Pose;
use crate::shape::Cuboid;

/// Contact manifold, normal from A toward B. STUB: filled in by the collision work.
pub fn manifold(
    _a: &Cuboid,
    _pose_a: &Pose,
    _b: &Cuboid,
    _pose_b: &Pose,
    _margin: f32,
) -> Manifold {
    Manifold::EMPTY
}
