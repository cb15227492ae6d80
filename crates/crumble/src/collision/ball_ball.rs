//! Contact between a Ball (shape A) and a Ball (shape B).

use super::{ContactPoint, Manifold};
use crate::math::{Pose, Vec3};
use crate::shape::Ball;

/// Unit direction of `v` and its length, computed without overflow or
/// underflow: `v` is first divided by its largest component, so the vector
/// that gets squared has a length in `[1, sqrt 3]`. Returns `None` for the
/// zero vector.
#[inline]
pub(crate) fn direction_and_length(v: Vec3) -> Option<(Vec3, f32)> {
    let scale = v.abs().max_element();
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    let u = v / scale;
    let len_u = u.length();
    Some((u / len_u, scale * len_u))
}

/// True when a point at `separation` is reported for `margin`: strictly
/// closer than the margin (so with `margin = 0` only overlap counts, and a NaN
/// margin reports nothing).
#[inline]
pub(crate) fn within_margin(separation: f32, margin: f32) -> bool {
    separation < margin
}

/// Contact manifold between two balls; the normal points from A toward B.
///
/// At most one point, reported when the surface distance is below `margin`.
/// The point lies half-way between the two surface points nearest each other
/// (`centre_a + r_a n` and `centre_b - r_b n`).
///
/// When the centres coincide there is no preferred direction; the normal is
/// then `+Y`, always, so that the result is deterministic. (This is the one
/// case where swapping the balls does not negate the normal.)
///
/// Feature id: a ball has a single feature, so the id is always `0`.
pub fn manifold(a: &Ball, pose_a: &Pose, b: &Ball, pose_b: &Pose, margin: f32) -> Manifold {
    let ca = pose_a.position;
    let cb = pose_b.position;
    let (normal, distance) = direction_and_length(cb - ca).unwrap_or((Vec3::Y, 0.0));
    // Written so that swapping A and B gives exactly the negated normal and
    // bit-identical points: `contact_manifold` does not flip this pair, it
    // calls it in both orders.
    let separation = distance - (a.radius() + b.radius());
    if !within_margin(separation, margin) {
        return Manifold::EMPTY;
    }
    // Half-way between ca + r_a n and cb - r_b n.
    let point = (ca + cb) * 0.5 + normal * ((a.radius() - b.radius()) * 0.5);
    let mut m = Manifold::with_normal(normal);
    m.push(ContactPoint { point, separation, id: 0 });
    m
}
