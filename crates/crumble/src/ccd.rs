//! Continuous collision: the sweep that catches what the discrete step
//! missed.
//!
//! After the solver has moved the bodies, each fast body (one that moved
//! more than half its smallest half extent this step) and each bullet is
//! swept along its displacement against what it could have passed through:
//! static bodies always, and other dynamic bodies too when it is a bullet.
//! The sweep is D. Eberly's dynamic OBB test (the 15 axes of the seed's
//! Appendix A, each giving an interval of overlap in time) for box–box, and
//! exact swept spheres for balls ([`crate::collision::toi`]). Where a hit
//! would have carried the body deeper into the obstacle than it may
//! overlap, the body is put back to just before the time of impact,
//! keeping its velocity, and the contact solver takes over next step.
//!
//! Rotation during the step is ignored, as in Eberly's paper: the sweep
//! moves each box along a straight line with its end-of-step orientation.
//! A corner of a box turning at ω sweeps an extra arc of up to `ω · dt · r`
//! (r its distance from the centre of mass) that the sweep does not see;
//! the speculative margin, which grows with `|ω| r dt`, covers it for the
//! discrete step.

use crate::collision::sat::Obb;
use crate::collision::toi::{obb_time_of_impact, sphere_box_time_of_impact, sphere_sphere_time_of_impact};
use crate::math::{Pose, Vec3};
use crate::shape::Shape;

/// First contact of collider A (pose `pa` at the start, displacement `da`
/// over the step) with collider B (`pb`, `db`), as `(fraction of the step,
/// normal from A to B)`, or `None` when they do not meet or already overlap
/// at the start (the discrete contact handles those).
pub(crate) fn sweep(sa: &Shape, pa: &Pose, da: Vec3, sb: &Shape, pb: &Pose, db: Vec3) -> Option<(f32, Vec3)> {
    let hit = match (sa, sb) {
        (Shape::Cuboid(a), Shape::Cuboid(b)) => {
            obb_time_of_impact(&Obb::from_cuboid(a, pa), da, &Obb::from_cuboid(b, pb), db, 1.0)
                .map(|h| (h.time, h.normal))
        }
        (Shape::Ball(s), Shape::Cuboid(c)) => {
            sphere_box_time_of_impact(pa.position, s.radius(), da - db, c, pb, 1.0).map(|h| (h.time, h.normal))
        }
        (Shape::Cuboid(c), Shape::Ball(s)) => {
            sphere_box_time_of_impact(pb.position, s.radius(), db - da, c, pa, 1.0).map(|h| (h.time, -h.normal))
        }
        (Shape::Ball(a), Shape::Ball(b)) => {
            sphere_sphere_time_of_impact(pa.position, a.radius(), da, pb.position, b.radius(), db, 1.0)
                .map(|h| (h.time, h.normal))
        }
        (_, Shape::HalfSpace(h)) => {
            // Distance of A's lowest point above the plane, and how fast it
            // closes: first contact at gap / closing.
            let (n, d) = h.world_plane(pb);
            let reach = match sa {
                Shape::Cuboid(c) => {
                    let m = pa.basis();
                    let e = c.half_extents();
                    n.dot(m.x_axis).abs() * e.x + n.dot(m.y_axis).abs() * e.y + n.dot(m.z_axis).abs() * e.z
                }
                Shape::Ball(b) => b.radius(),
                Shape::HalfSpace(_) => return None,
            };
            let gap = n.dot(pa.position) - reach - d;
            let closing = -n.dot(da);
            (gap > 0.0 && closing > gap).then(|| (gap / closing, -n))
        }
        (Shape::HalfSpace(_), _) => sweep(sb, pb, db, sa, pa, da).map(|(t, n)| (t, -n)),
    }?;
    (hit.0 > 0.0).then_some(hit)
}
