//! The broad-phase stage: each awake collider's proxy box (its shape's
//! box grown by its speculative distance, swept along the body's motion)
//! and margin handed to the tree (`broad_phase.rs`), and the tree's new
//! and lost pairs turned into contacts.

use super::{World, WorldSettings, WORLD_BOUND};
use crate::aabb::Aabb;
use crate::body::BodyType;
use crate::contact::{Contact, ContactEventKind};
use crate::math::{Pose, Vec3};
use crate::narrow_phase::{recycle_tolerance, speculative_distance};
use crate::shape::Shape;

impl World {
    /// Updates the awake bodies' proxies and turns the broad phase's new
    /// and lost pairs into contacts. Returns how many proxies moved.
    pub(super) fn update_broad_phase(&mut self, dt: f32) -> usize {
        self.scratch.visits.bodies += self.awake.list().len();
        for i in 0..self.awake.list().len() {
            let bi = self.awake.list()[i];
            let b = self.bodies.at(bi).expect("awake body");
            // The swept box must cover rotation too: grow by ω · extent · dt,
            // at most twice the extent (no turn moves a point farther),
            // which also keeps the box finite for any finite ω.
            let v = b.linear_velocity;
            let turn = b.angular_velocity.length().min(2.0 / dt) * b.max_extent * dt;
            let travel = v.length() * dt + turn;
            let spin = if self.settings.continuous { turn } else { 0.0 };
            for &ci in &b.colliders {
                let c = self.colliders.at(ci).expect("attached");
                let aabb = proxy_aabb(&self.settings, &c.shape, &c.world_pose, v, dt).expanded(spin);
                let margin = proxy_margin(&self.settings, &c.shape, travel, false);
                self.broad_phase.update_with_margin(c.proxy, aabb, margin);
            }
        }
        let limit = self.settings.max_pairs_per_collider as usize * self.colliders.len();
        self.broad_phase.set_pair_limit(limit);
        let (bodies, colliders, joints) = (&self.bodies, &self.colliders, &self.joints);
        self.broad_phase.update_pairs_filtered(|a, b| {
            let (Some(ca), Some(cb)) = (colliders.at(a), colliders.at(b)) else {
                return false;
            };
            if ca.body == cb.body || joints.ignores(ca.body, cb.body) {
                return false;
            }
            let (ba, bb) = (bodies.at(ca.body).expect("parent"), bodies.at(cb.body).expect("parent"));
            ba.body_type == BodyType::Dynamic || bb.body_type == BodyType::Dynamic
        });
        self.scratch.visits.contacts += self.broad_phase.lost_pairs().len() + self.broad_phase.new_pairs().len();
        for k in 0..self.broad_phase.lost_pairs().len() {
            let (a, b) = self.broad_phase.lost_pairs()[k];
            if let Some(c) = self.contacts.remove(a, b) {
                self.bond_separated(&c);
                if c.touching {
                    if let Some(e) = self.event_for(&c, ContactEventKind::Ended, 0.0) {
                        self.events.list.push(e);
                    }
                }
            }
        }
        for k in 0..self.broad_phase.new_pairs().len() {
            let (a, b) = self.broad_phase.new_pairs()[k];
            let (Some(ca), Some(cb)) = (self.colliders.at(a), self.colliders.at(b)) else {
                continue;
            };
            let friction = crate::contact::combined_friction(ca.material.friction, cb.material.friction);
            let restitution = ca.material.restitution.max(cb.material.restitution);
            let mut contact = Contact::new(a, b, ca.body, cb.body, friction, restitution);
            // Rolling resistance acts on balls: the larger coefficient of the
            // two materials, times the ball's radius (the larger ball's).
            let radius = |sh: &Shape| if let Shape::Ball(b) = sh { b.radius() } else { 0.0 };
            let c_rr = ca.material.rolling_resistance.max(cb.material.rolling_resistance);
            // (At most `f32`'s largest: a contact's numbers stay finite.)
            contact.rolling_arm = (c_rr * radius(&ca.shape).max(radius(&cb.shape))).min(f32::MAX);
            contact.recycle_tolerance = recycle_tolerance(&ca.shape, &cb.shape);
            // Active unless both bodies rest (a sleeping body inserted next
            // to another sleeping or static one).
            let active = self.awake.is_awake(contact.body_a) || self.awake.is_awake(contact.body_b);
            if let Some(id) = self.contacts.insert(contact) {
                if active {
                    self.contacts.activate(id);
                }
                if let Some(slot) = self.bonds.of_pair(a, b) {
                    self.attach_bond(id, slot);
                }
            }
        }
        self.broad_phase.moved_count()
    }
}

/// The broad-phase margin of a collider of a moving body that travels
/// `travel` metres in a step, or is `asleep`: a tenth of its smallest
/// extent, at least `aabb_margin` and at most five times it, unless
/// `travel` exceeds that or the body sleeps, when it is `aabb_margin`.
///
/// A unit cube of a collapsing pile moves a centimetre or two a step:
/// with a margin of a tenth of its size it leaves its fat box (a tree
/// re-insertion and a query) rarely, where 2 cm made it leave about
/// every other step. A brick keeps 2 cm: a wider margin pairs it with
/// bricks it does not touch. A body that travels farther than the wide
/// margin every step leaves any fat box every step, and its box is
/// already swept along its path, so there the wide margin buys nothing
/// and only pairs it with (and wakes) more bodies beside its path.
/// Static colliders never move and keep `aabb_margin`, and so do
/// sleeping bodies' (set when they fall asleep or are created asleep):
/// a wide sleeping box beside a fast body's path would pair with it and
/// wake. A woken body widens its margin when it next leaves its fat box.
pub(super) fn proxy_margin(s: &WorldSettings, shape: &Shape, travel: f32, asleep: bool) -> f32 {
    let m = s.aabb_margin;
    let wide = (0.2 * shape.min_half_extent()).clamp(m, 5.0 * m);
    if asleep || travel > wide {
        m
    } else {
        wide
    }
}

/// Box the broad phase keeps for a collider: the shape's box, grown by
/// its speculative distance and swept along the body's motion over the
/// step, so that a fast body finds what it is about to hit.
///
/// The speculative distance is the shape's own
/// ([`speculative_distance`]; a pair's is the smaller of its two), not
/// the setting: a brick's is 8.1 mm, not 20. Grown by 20 mm and
/// fattened by the 20 mm margin, each brick's box would reach 40 mm
/// beyond it and overlap those of the bricks two courses up and down,
/// 65 mm away: pairs the narrow phase would visit every step to find
/// nothing.
pub(super) fn proxy_aabb(s: &WorldSettings, shape: &Shape, pose: &Pose, velocity: Vec3, dt: f32) -> Aabb {
    let tight = shape.aabb(pose);
    let grown = tight.expanded(speculative_distance(s, shape));
    let sweep = if s.continuous { velocity * dt } else { Vec3::ZERO };
    let swept = Aabb::new(grown.min + sweep.min(Vec3::ZERO), grown.max + sweep.max(Vec3::ZERO));
    let bound = Vec3::splat(WORLD_BOUND);
    Aabb::new(swept.min.clamp(-bound, bound), swept.max.clamp(-bound, bound))
}
