//! The narrow phase: each active contact's manifold, recycled while its
//! pair has barely moved, else computed afresh by the shape pair's
//! function in `collision/`.
//!
//! Each contact is updated on its own (it reads its colliders and bodies
//! and writes only itself), so with enough of them the threads share them
//! out, with the same bits whoever computes which. A contact between
//! sleeping bodies is not active and keeps the manifold it had when they
//! fell asleep.

use rayon::prelude::*;

use crate::arena::Arena;
use crate::awake::AwakeSet;
use crate::body::Body;
use crate::collider::Collider;
use crate::collision::contact_manifold;
use crate::contact::{Contact, ContactSet};
use crate::shape::Shape;
use crate::solver::SharedItems;
use crate::threads::workers;
use crate::world::{WorldSettings, WORLD_BOUND};

/// How far a pair of these shapes may move before its manifold is
/// computed afresh instead of recycled (`Contact::recycle`): `[linear,
/// angular]`, fixed for the pair's life (a collider's shape never
/// changes), so computed when the pair is made.
///
/// A pair recycles while it has barely moved relative to itself
/// (see `ManifoldCache`): each point's two anchors (on
/// A and on B) have slid apart across the normal by at most 2%
/// of the smaller body's smallest half extent (0.65 mm for a
/// seed brick, 1 cm for a unit cube), and come nearer along it
/// by at most that much, and B has turned, seen from A, by no
/// more than moves a point of the smaller body's bounding ball
/// that far (5.3 mrad for a seed brick, 11.5 mrad for a unit
/// cube), so the normal, fixed in A, is as close. A corner of the
/// smaller body that was not in the manifold has then come at
/// most about twice that nearer. The recycled points follow the
/// bodies, so their separations stay exact to first order (see
/// the tests in `contact.rs`); what they miss is a change of
/// touching features, such as a clipped corner sliding along an
/// edge. A pair without points has only the bodies' origins to
/// go by: each may move that much, seen from the other. Testing the
/// anchors rather than B's origin recycles a brick on the ground
/// whichever body was inserted first: seen from the brick, a far
/// origin swings by the turn times its distance.
///
/// A ball's contact point is not a point of the ball: a turned
/// ball's stored point has rolled away from the real one, ahead
/// of it and off the ground, and the push there drives the roll (the
/// test `a_recycled_ball_rolls_at_five_sevenths_of_its_launch_speed` in
/// `tests/recycling.rs` keeps it). So a pair with a ball is
/// computed afresh whenever either body turned relative to the
/// other; sliding without turning keeps its point.
pub(crate) fn recycle_tolerance(a: &Shape, b: &Shape) -> [f32; 2] {
    let linear = 0.02 * a.min_half_extent().min(b.min_half_extent());
    let ball = matches!(a, Shape::Ball(_)) || matches!(b, Shape::Ball(_));
    let radius = a.bounding_radius().min(b.bounding_radius());
    let angular = if ball { 0.0 } else { linear / radius };
    [linear, angular]
}

/// Active contacts below which the narrow phase stays on the calling
/// thread, and the smallest share of them one task takes.
pub(crate) const PARALLEL_MIN_CONTACTS: usize = 2048;
pub(crate) const CONTACT_CHUNK: usize = 256;

/// How far beyond `shape` the narrow phase looks for points (before the
/// closing distance of the step is added): `speculative_distance`, at most
/// a quarter of the shape's smallest half extent. A pair takes the smaller
/// of its two shapes'; the broad phase grows each box by its shape's.
pub(crate) fn speculative_distance(s: &WorldSettings, shape: &Shape) -> f32 {
    s.speculative_distance.min(0.25 * shape.min_half_extent())
}

/// The narrow phase of one active contact: its speculative margin, then
/// its manifold recycled or computed afresh. Returns 1 if recycled.
fn update_contact(
    c: &mut Contact,
    colliders: &Arena<Collider>,
    bodies: &Arena<Body>,
    s: &WorldSettings,
    dt: f32,
) -> usize {
    let ca = colliders.at(c.collider_a).expect("contact collider");
    let cb = colliders.at(c.collider_b).expect("contact collider");
    let ba = bodies.at(c.body_a).expect("contact body");
    let bb = bodies.at(c.body_b).expect("contact body");
    // Speculative margin: a base scaled to the smaller body, plus how
    // far the two surfaces can close during this step.
    let base = speculative_distance(s, &ca.shape).min(speculative_distance(s, &cb.shape));
    // A turn moves a point at most twice its distance from the centre
    // (the angular terms' bound); the margin stays finite for any finite
    // velocities (`WORLD_BOUND`).
    let spin = |b: &Body| b.angular_velocity.length().min(2.0 / dt) * b.max_extent;
    let closing = (ba.linear_velocity - bb.linear_velocity).length() + spin(ba) + spin(bb);
    let margin = if s.continuous { (base + closing * dt).min(WORLD_BOUND) } else { base };
    // Recycle the manifold while the pair has barely moved relative
    // to itself (tolerances: `recycle_tolerance`).
    let [linear, angular] = c.recycle_tolerance;
    let (pa, pb) = (ca.world_pose, cb.world_pose);
    if c.bond != crate::contact::NONE {
        // A bonded pair's points are the bond's anchors.
        c.follow_bond(&pa, &pb);
        return 1;
    }
    let recycled = c.recycle(&pa, &pb, margin, linear, angular);
    c.recycled = recycled;
    if !recycled {
        let m = contact_manifold(&ca.shape, &pa, &cb.shape, &pb, margin);
        c.cache.store(&m, &pa, &pb, margin);
        c.set_manifold(m, base);
    }
    usize::from(recycled)
}

/// Updates the manifold of every active contact; returns how many were
/// recycled. On the threads of `pool` (or of the pool the step runs in)
/// when there are enough contacts and workers.
pub(crate) fn update_contacts(
    contacts: &mut ContactSet,
    colliders: &Arena<Collider>,
    bodies: &Arena<Body>,
    awake: &AwakeSet,
    settings: &WorldSettings,
    pool: Option<&rayon::ThreadPool>,
    dt: f32,
) -> usize {
    // What the threads rely on: the active list names each slot once
    // (each contact's `active_pos` is its one place), and only contacts
    // with an awake body.
    debug_assert!(contacts.active.iter().enumerate().all(|(k, &i)| {
        let c = &contacts.list[i as usize];
        contacts.active_pos(i) == k as u32 && (awake.is_awake(c.body_a) || awake.is_awake(c.body_b))
    }));
    let active = &contacts.active;
    let list = SharedItems::new(&mut contacts.list);
    let one = |i: u32| -> usize {
        // SAFETY: the active list names each slot once, so no two calls
        // (on any threads) reach the same contact.
        let c = unsafe { &mut list.part(i as usize..i as usize + 1)[0] };
        update_contact(c, colliders, bodies, settings, dt)
    };
    if workers(settings.threads, pool) > 1 && active.len() >= PARALLEL_MIN_CONTACTS {
        let run = || active.par_chunks(CONTACT_CHUNK).map(|chunk| chunk.iter().map(|&i| one(i)).sum::<usize>()).sum();
        match pool {
            Some(pool) => pool.install(run),
            None => run(),
        }
    } else {
        active.iter().map(|&i| one(i)).sum()
    }
}
