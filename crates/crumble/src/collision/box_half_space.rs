//! Contact between a Cuboid (shape A) and a HalfSpace (shape B).

use super::ball_ball::within_margin;
use super::{ContactPoint, Manifold};
use crate::math::Pose;
use crate::shape::{Cuboid, HalfSpace};

/// Contact manifold between a box and a half-space; the normal points from
/// the box toward the half-space, i.e. it is the plane's outward normal
/// negated.
///
/// Candidate corners come from one face of the box: the face whose outward
/// normal is most anti-parallel to the plane normal (the face the box "sits
/// on"). Its four corners are kept when their signed distance to the plane is
/// below `margin`. This gives 4 points for a box lying flat, 2 for a box on
/// an edge and 1 for a box on a corner, and the same corners are chosen step
/// after step: the deepest corner of the box belongs to every candidate face,
/// and when the choice of face flips (a box tipping over an edge) the corners
/// of the shared edge keep their ids.
///
/// Each point lies half-way between its corner and the corner's projection on
/// the plane; its separation is the corner's signed height above the plane.
///
/// Feature id: the corner index `0..8` as in [`Cuboid::local_corners`] (bit
/// `k` set when the corner is on the `+` side of local axis `k`). It stays the
/// same while the same corner touches. Points are pushed in increasing id
/// order.
pub fn manifold(a: &Cuboid, pose_a: &Pose, b: &HalfSpace, pose_b: &Pose, margin: f32) -> Manifold {
    let (n, d) = b.world_plane(pose_b);
    // Plane normal in the box frame.
    let local_n = pose_a.inverse_transform_vector(n);

    // The face most anti-parallel to n is on axis argmax |local_n_k|, on the
    // side opposite to local_n. Ties go to the lower axis.
    let mut axis = 0;
    for k in 1..3 {
        if local_n[k].abs() > local_n[axis].abs() {
            axis = k;
        }
    }
    // Corners on the face have bit `axis` set when the face is on the + side,
    // which is when local_n points toward -axis.
    let want_bit = local_n[axis] < 0.0;

    let corners = a.local_corners();
    let mut m = Manifold::with_normal(-n);
    for (i, corner) in corners.iter().enumerate() {
        if ((i >> axis) & 1 != 0) != want_bit {
            continue;
        }
        let p = pose_a.transform_point(*corner);
        let separation = n.dot(p) - d;
        if within_margin(separation, margin) {
            m.push(ContactPoint { point: p - n * (0.5 * separation), separation, id: i as u32 });
        }
    }
    m
}
