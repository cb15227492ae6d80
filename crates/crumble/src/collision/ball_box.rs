//! Contact between a Ball (shape A) and a Cuboid (shape B).

use super::ball_ball::direction_and_length;
use super::ball_ball::within_margin;
use super::{ContactPoint, FeatureId, Manifold};
use crate::math::{Pose, Vec3};
use crate::shape::{Ball, Cuboid};

/// Feature id of the box region given, per local axis, whether the ball's
/// centre lies below (`-1`), within (`0`) or beyond (`+1`) the box's slab on
/// that axis: `id = (s_x + 1) + 3 (s_y + 1) + 9 (s_z + 1)`.
#[inline]
fn region_id(s: [i32; 3]) -> FeatureId {
    ((s[0] + 1) + 3 * (s[1] + 1) + 9 * (s[2] + 1)) as FeatureId
}

/// Contact manifold between a ball and a box; the normal points from the
/// ball toward the box.
///
/// The ball's centre is taken into the box frame and clamped to the box to
/// find the closest point on it.
///
/// - Centre outside the box: the normal is the direction from the centre to
///   that closest point, and the separation is the distance minus the radius.
/// - Centre inside the box (or exactly on its surface): the ball is pushed
///   out through the nearest face. The normal is that face's outward normal
///   negated, and the separation is `-(distance to the face + radius)`.
///
/// At most one point, reported when the separation is below `margin`; it lies
/// half-way between the ball's surface point along the normal and the box's
/// surface point (the closest point, or the centre projected on the nearest
/// face).
///
/// Feature id: the Voronoi region of the box that holds the centre, written
/// as one base-3 digit per local axis (see below), in `0..27`:
/// `id = (s_x + 1) + 3 (s_y + 1) + 9 (s_z + 1)` where `s_k` is `-1` when the
/// centre is below the box on axis `k`, `+1` when beyond it and `0` when
/// within the slab. One non-zero digit is a face, two an edge, three a
/// vertex. A centre inside the box is reported with the id of the face it is
/// pushed out through, so the id does not change as the centre crosses that
/// face. The value `13` (all digits zero) is never produced.
pub fn manifold(a: &Ball, pose_a: &Pose, b: &Cuboid, pose_b: &Pose, margin: f32) -> Manifold {
    let h = b.half_extents();
    let radius = a.radius();
    let centre = pose_a.position;
    let local = pose_b.inverse_transform_point(centre);
    if !local.is_finite() {
        // Only absurd (overflowing) coordinates get here; no contact.
        return Manifold::EMPTY;
    }
    let closest = local.clamp(-h, h);

    let mut region = [0i32; 3];
    for k in 0..3 {
        if local[k] > h[k] {
            region[k] = 1;
        } else if local[k] < -h[k] {
            region[k] = -1;
        }
    }

    // Local normal (ball toward box), signed distance from the centre to the
    // box surface along it, and the box's surface point, all in the box frame.
    let (local_normal, distance, surface_local) = if region != [0; 3] {
        // Outside: `closest - local` is non-zero on every axis where the
        // centre is out (the difference of two distinct floats never rounds
        // to zero), so this only fails when the offset overflows.
        match direction_and_length(closest - local) {
            Some((dir, len)) => (dir, len, closest),
            None => return Manifold::EMPTY,
        }
    } else {
        // Inside or exactly on the surface: leave through the nearest
        // face. Ties go to the lower axis, then to the positive side, so
        // the choice is deterministic (a centred ball leaves through +X).
        let mut best_axis = 0;
        let mut best_sign = 1.0f32;
        let mut best_depth = f32::INFINITY;
        for k in 0..3 {
            for sign in [1.0f32, -1.0] {
                let depth = h[k] - sign * local[k];
                if depth < best_depth {
                    best_depth = depth;
                    best_axis = k;
                    best_sign = sign;
                }
            }
        }
        // Inside means every depth is >= 0; the max only guards rounding.
        let depth = best_depth.max(0.0);
        let mut outward = Vec3::ZERO;
        outward[best_axis] = best_sign;
        region = [0; 3];
        region[best_axis] = best_sign as i32;
        let mut surface = local;
        surface[best_axis] = best_sign * h[best_axis];
        (-outward, -depth, surface)
    };

    let separation = distance - radius;
    if !within_margin(separation, margin) {
        return Manifold::EMPTY;
    }
    let normal = pose_b.transform_vector(local_normal);
    let surface_ball = centre + normal * radius;
    let surface_box = pose_b.transform_point(surface_local);
    let mut m = Manifold::with_normal(normal);
    m.push(ContactPoint { point: (surface_ball + surface_box) * 0.5, separation, id: region_id(region) });
    m
}
