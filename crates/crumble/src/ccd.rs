//! Continuous collision: the sweep that catches what the discrete step
//! missed.
//!
//! After the solver has moved the bodies, each fast body (one that moved
//! more than half its smallest half extent this step) and each bullet is
//! swept along its displacement against what it could have passed through:
//! static and kinematic bodies always (found by the broad phase's
//! `query_fixed`, which skips the tree's dynamic proxies), and other
//! dynamic bodies too when it is a bullet.
//! The sweep is D. Eberly's dynamic OBB test (the 15 axes of the seed's
//! Appendix A, each giving an interval of overlap in time) for box–box, and
//! exact swept spheres for balls ([`crate::collision::toi`]). Where a hit
//! would have carried the body deeper into the obstacle than it may
//! overlap, the body is put back to just before the time of impact,
//! keeping the direction of its velocity but not the speed its forces gave
//! it over the distance it no longer travels (`Solver::put_back`), and the
//! contact solver takes over next step.
//!
//! Rotation during the step is ignored, as in Eberly's paper: the sweep
//! moves each box along a straight line with its end-of-step orientation.
//! A corner of a box turning at ω sweeps an extra arc of up to `ω · dt · r`
//! (r its distance from the centre of mass) that the sweep does not see;
//! the speculative margin, which grows with `|ω| r dt`, covers it for the
//! discrete step.

use crate::aabb::Aabb;
use crate::arena::Arena;
use crate::body::{Body, BodyType};
use crate::broad_phase::BroadPhase;
use crate::collider::Collider;
use crate::collision::sat::Obb;
use crate::collision::toi::{obb_time_of_impact, sphere_box_time_of_impact, sphere_sphere_time_of_impact};
use crate::math::{Pose, Vec3};
use crate::shape::Shape;
use crate::solver::Solver;
use crate::world::{Visits, WorldSettings};

/// Pose of a collider at the start of the step with its body's
/// end-of-step orientation, and the body's displacement over the step.
fn swept_collider(
    bodies: &Arena<Body>,
    colliders: &Arena<Collider>,
    solver: &Solver,
    collider: u32,
) -> Option<(Pose, Vec3)> {
    let c = colliders.at(collider)?;
    let b = bodies.at(c.body)?;
    if b.solver_index == u32::MAX {
        return Some((c.world_pose, Vec3::ZERO));
    }
    let (origin, dp) = solver.sweep(b.solver_index as usize, b.local_com);
    Some((origin.mul_pose(&c.local_pose), dp))
}

/// The continuous-collision stage: puts fast bodies and bullets among the
/// `awake` bodies back to just before a hit that the discrete step let
/// them pass, by shortening their displacement in the solver. Returns how
/// many it put back.
#[allow(clippy::too_many_arguments)]
pub(crate) fn continuous_collision(
    settings: &WorldSettings,
    awake: &[u32],
    bodies: &Arena<Body>,
    colliders: &Arena<Collider>,
    broad_phase: &BroadPhase,
    solver: &mut Solver,
    candidates_scratch: &mut Vec<u32>,
    visits: &mut Visits,
) -> usize {
    let mut hits = 0;
    if !settings.continuous {
        return hits;
    }
    visits.bodies += awake.len();
    for &bi in awake {
        let b = bodies.at(bi).expect("awake body");
        if b.body_type != BodyType::Dynamic {
            continue;
        }
        let si = b.solver_index as usize;
        let disp = solver.displacement(si);
        let dist = disp.length();
        if dist == 0.0 || (!b.bullet && dist <= 0.5 * b.min_extent) {
            continue;
        }
        let bullet = b.bullet;
        // Overlap the discrete contact may legitimately leave at the end
        // of a step, and how far before the impact the body is put.
        let allowed = 0.25 * b.min_extent;
        let backoff = (0.25 * b.min_extent).min(settings.speculative_distance);
        let mut first = 1.0f32;
        for ci in 0..b.colliders.len() {
            let collider = bodies.at(bi).expect("awake").colliders[ci];
            let Some((start, _)) = swept_collider(bodies, colliders, solver, collider) else { continue };
            let shape = colliders.at(collider).expect("attached").shape;
            let a0 = shape.aabb(&start);
            let swept = Aabb::new(a0.min.min(a0.min + disp), a0.max.max(a0.max + disp));
            let mut candidates = std::mem::take(candidates_scratch);
            candidates.clear();
            // A bullet is swept against every body; another fast body
            // against the static and kinematic ones only (below), which
            // its query finds without visiting the tree's dynamic proxies.
            let found = |other| {
                candidates.push(other);
                true
            };
            if bullet {
                broad_phase.query(&swept, found);
            } else {
                broad_phase.query_fixed(&swept, found);
            }
            for &other in &candidates {
                let Some(oc) = colliders.at(other) else { continue };
                if oc.body == bi {
                    continue;
                }
                let ob = bodies.at(oc.body).expect("parent");
                if ob.body_type == BodyType::Dynamic && !bullet {
                    continue;
                }
                let Some((other_start, other_disp)) = swept_collider(bodies, colliders, solver, other) else {
                    continue;
                };
                if let Some((t, n)) = sweep(&shape, &start, disp, &oc.shape, &other_start, other_disp) {
                    // Only a hit the body would have gone deep past counts:
                    // a sliding or resting contact closes by almost nothing.
                    let closing = (disp - other_disp).dot(n);
                    if (1.0 - t) * closing > allowed {
                        first = first.min(t);
                    }
                }
            }
            *candidates_scratch = candidates;
        }
        if first < 1.0 {
            let t = (first - backoff / dist).max(0.0);
            solver.put_back(si, disp * t);
            hits += 1;
        }
    }
    hits
}

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
