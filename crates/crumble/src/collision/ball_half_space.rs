//! Contact between a Ball (shape A) and a HalfSpace (shape B).

use super::ball_ball::within_margin;
use super::{ContactPoint, Manifold};
use crate::math::Pose;
use crate::shape::{Ball, HalfSpace};

/// Contact manifold between a ball and a half-space; the normal points from
/// the ball toward the half-space, i.e. it is the plane's outward normal
/// negated.
///
/// At most one point, reported when the distance from the ball's surface to
/// the plane is below `margin`. The point lies half-way between the ball's
/// lowest point (along the plane normal) and the centre's projection on the
/// plane.
///
/// Feature id: both shapes have a single feature here, so the id is `0`.
pub fn manifold(a: &Ball, pose_a: &Pose, b: &HalfSpace, pose_b: &Pose, margin: f32) -> Manifold {
    let (n, d) = b.world_plane(pose_b);
    let centre = pose_a.position;
    // Signed height of the centre above the plane.
    let height = n.dot(centre) - d;
    let separation = height - a.radius();
    if !within_margin(separation, margin) {
        return Manifold::EMPTY;
    }
    // Ball surface: centre - r n; plane: centre - height n; midpoint between.
    let point = centre - n * (0.5 * (a.radius() + height));
    let mut m = Manifold::with_normal(-n);
    m.push(ContactPoint { point, separation, id: 0 });
    m
}
