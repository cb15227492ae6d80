//! [`World::step`] and the stages it runs that belong to the world itself:
//! the broad-phase update, continuous collision, the write-back of poses,
//! and sleep. The narrow phase is `narrow_phase.rs`, islands and sleep
//! `awake.rs`, the solver `solver/`, and events `world/events.rs`.

use std::time::Instant;

use super::{Profile, World, WorldError, WorldSettings, WORLD_BOUND};
use crate::aabb::Aabb;
use crate::awake::resting;
use crate::body::{BodyHandle, BodyType};
use crate::ccd;
use crate::contact::{Contact, ContactEventKind};
use crate::math::{Pose, Vec3};
use crate::narrow_phase::{self, recycle_tolerance, speculative_distance};
use crate::shape::Shape;
use crate::solver::{self, StepContext};
use crate::threads::{for_each_index, workers};

impl World {
    /// Advances the world by `dt` seconds in `settings.substeps` substeps.
    ///
    /// The stages, one call and one profile line each: broad phase →
    /// narrow phase → islands (wake, group) → solver (integration inside)
    /// → continuous collision → write-back, sleep and events.
    pub fn step(&mut self, dt: f32) -> Result<(), WorldError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(WorldError::InvalidTimeStep(dt));
        }
        let start = Instant::now();
        self.begin_step();
        let mut p = Profile::default();

        let t = Instant::now();
        p.proxies_moved = self.update_broad_phase(dt);
        p.broad_phase = t.elapsed();

        let t = Instant::now();
        p.recycled_manifolds = self.update_contacts(dt);
        p.narrow_phase = t.elapsed();

        let t = Instant::now();
        p.islands_count = self.update_islands();
        p.islands = t.elapsed();

        let t = Instant::now();
        self.solve(dt, &mut p);
        p.solver = t.elapsed().saturating_sub(p.integration);

        let t = Instant::now();
        p.ccd_hits = self.continuous_collision();
        p.continuous = t.elapsed();

        let t = Instant::now();
        self.finish_bodies(dt);
        self.update_sleep();
        self.report_events();
        p.sleep = t.elapsed();

        p.total = start.elapsed();
        self.end_step(p, dt);
        Ok(())
    }

    /// What every step starts with: the events held back since the last
    /// one, no faults, no visits counted.
    fn begin_step(&mut self) {
        self.events.begin_step();
        self.faulted.clear();
        self.scratch.visits = Default::default();
    }

    /// What every step ends with: the counts of what it worked on, and the
    /// clock.
    fn end_step(&mut self, mut p: Profile, dt: f32) {
        p.bodies = self.bodies.len();
        p.pairs = self.contacts.len();
        p.bodies_visited = self.scratch.visits.bodies;
        p.contacts_visited = self.scratch.visits.contacts;
        self.profile = p;
        self.time += dt as f64;
    }

    /// The awake set put in order (see `AwakeSet::refresh`); a change of it
    /// may make a solver body stand for another body.
    fn refresh_awake(&mut self) {
        if self.awake.refresh(&self.bodies, &mut self.scratch.visits) {
            self.solver.bodies_changed();
        }
    }

    /// The narrow phase (`narrow_phase.rs`); returns the recycled manifolds.
    fn update_contacts(&mut self, dt: f32) -> usize {
        self.scratch.visits.contacts += self.contacts.active.len();
        let pool = self.pool.as_deref();
        narrow_phase::update_contacts(
            &mut self.contacts,
            &self.colliders,
            &self.bodies,
            &self.awake,
            &self.settings,
            pool,
            dt,
        )
    }

    /// Wakes the sleeping islands that awake bodies disturb, then groups
    /// the awake bodies into islands; returns how many.
    fn update_islands(&mut self) -> usize {
        let visits = &mut self.scratch.visits;
        self.awake.wake_touched(&mut self.bodies, &mut self.contacts, &self.settings, visits);
        self.refresh_awake();
        self.awake.find_islands(&self.bodies, &self.contacts, &mut self.scratch.visits)
    }

    /// The solver stage (`solver/step.rs`).
    fn solve(&mut self, dt: f32, p: &mut Profile) {
        let awake = self.awake.list();
        p.awake_bodies = awake.len();
        p.active_contacts = self.contacts.active.len();
        // The solver's set-up loops visit exactly these.
        self.scratch.visits.bodies += awake.len();
        self.scratch.visits.contacts += self.contacts.active.len();
        let pool = self.pool.as_deref();
        let ctx = StepContext { settings: &self.settings, dt, pool, workers: workers(self.settings.threads, pool) };
        self.solver.step(&ctx, awake, &mut self.bodies, &mut self.contacts, p);
    }

    /// Puts resting islands to sleep (`AwakeSet::update_sleep`); their
    /// proxies take a sleeper's margin (see `proxy_margin`): a wide one is
    /// re-inserted narrow now, a narrow one stays.
    fn update_sleep(&mut self) {
        let visits = &mut self.scratch.visits;
        let asleep = self.awake.update_sleep(&mut self.bodies, &mut self.contacts, &self.settings, visits);
        for &bi in asleep {
            let b = self.bodies.at(bi).expect("asleep");
            for &ci in &b.colliders {
                let c = self.colliders.at(ci).expect("attached");
                let aabb = proxy_aabb(&self.settings, &c.shape, &c.world_pose, Vec3::ZERO, 0.0);
                let margin = proxy_margin(&self.settings, &c.shape, 0.0, true);
                self.broad_phase.update_with_margin(c.proxy, aabb, margin);
            }
        }
    }

    /// Updates the awake bodies' proxies and turns the broad phase's new
    /// and lost pairs into contacts. Returns how many proxies moved.
    pub(super) fn update_broad_phase(&mut self, dt: f32) -> usize {
        self.refresh_awake();
        self.scratch.visits.bodies += self.awake.list().len();
        for i in 0..self.awake.list().len() {
            let bi = self.awake.list()[i];
            let b = self.bodies.at(bi).expect("awake body");
            // The swept box must cover rotation too: grow by ω · extent · dt.
            let v = b.linear_velocity;
            let turn = b.angular_velocity.length() * b.max_extent * dt;
            let travel = v.length() * dt + turn;
            let spin = if self.settings.continuous { turn } else { 0.0 };
            for &ci in &b.colliders {
                let c = self.colliders.at(ci).expect("attached");
                let aabb = proxy_aabb(&self.settings, &c.shape, &c.world_pose, v, dt).expanded(spin);
                let margin = proxy_margin(&self.settings, &c.shape, travel, false);
                self.broad_phase.update_with_margin(c.proxy, aabb, margin);
            }
        }
        let (bodies, colliders) = (&self.bodies, &self.colliders);
        self.broad_phase.update_pairs_filtered(|a, b| {
            let (Some(ca), Some(cb)) = (colliders.at(a), colliders.at(b)) else {
                return false;
            };
            if ca.body == cb.body {
                return false;
            }
            let (ba, bb) = (bodies.at(ca.body).expect("parent"), bodies.at(cb.body).expect("parent"));
            ba.body_type == BodyType::Dynamic || bb.body_type == BodyType::Dynamic
        });
        self.scratch.visits.contacts += self.broad_phase.lost_pairs().len() + self.broad_phase.new_pairs().len();
        for k in 0..self.broad_phase.lost_pairs().len() {
            let (a, b) = self.broad_phase.lost_pairs()[k];
            if let Some(c) = self.contacts.remove(a, b) {
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
            let friction = (ca.material.friction * cb.material.friction).sqrt();
            let restitution = ca.material.restitution.max(cb.material.restitution);
            let mut contact = Contact::new(a, b, ca.body, cb.body, friction, restitution);
            // Rolling resistance acts on balls: the larger coefficient of the
            // two materials, times the ball's radius (the larger ball's).
            let radius = |sh: &Shape| if let Shape::Ball(b) = sh { b.radius() } else { 0.0 };
            let c_rr = ca.material.rolling_resistance.max(cb.material.rolling_resistance);
            contact.rolling_arm = c_rr * radius(&ca.shape).max(radius(&cb.shape));
            contact.recycle_tolerance = recycle_tolerance(&ca.shape, &cb.shape);
            // Active unless both bodies rest (a sleeping body inserted next
            // to another sleeping or static one).
            let active = self.awake.is_awake(contact.body_a) || self.awake.is_awake(contact.body_b);
            if let Some(id) = self.contacts.insert(contact) {
                if active {
                    self.contacts.activate(id);
                }
            }
        }
        self.broad_phase.moved_count()
    }

    /// Continuous collision (`ccd.rs`); returns the bodies put back.
    fn continuous_collision(&mut self) -> usize {
        ccd::continuous_collision(
            &self.settings,
            self.awake.list(),
            &self.bodies,
            &self.colliders,
            &self.broad_phase,
            &mut self.solver,
            &mut self.scratch.ccd_candidates,
            &mut self.scratch.visits,
        )
    }

    /// Writes the solver's result back to the bodies, guards against
    /// non-finite state, and updates sleep timers and collider poses.
    fn finish_bodies(&mut self, dt: f32) {
        let threshold = self.settings.sleep_threshold;
        let n = self.awake.list().len();
        self.scratch.visits.bodies += n;
        // Awake positions of the bodies whose step was not finite: rare, so
        // a lock costs nothing, and no per-step pass marks or scans them.
        let faults = std::sync::Mutex::new(Vec::new());
        {
            let awake = self.awake.list();
            let (solver_bodies, step_start) = (&self.solver.solver_bodies, &self.solver.step_start);
            let bodies = self.bodies.shared();
            let colliders = self.colliders.shared();
            let one = |k: usize| {
                let bi = awake[k];
                // SAFETY: the awake list names each body once, and each
                // collider has one body.
                let b = unsafe { bodies.at_mut(bi) }.expect("awake body");
                let si = b.solver_index as usize;
                b.solver_index = u32::MAX;
                let sb = &solver_bodies[si];
                let (pose0, com0) = step_start[si];
                let q = (sb.dq * pose0.rotation).normalize();
                let com = com0 + Vec3::from(sb.dp);
                let pose = Pose::new(com - q * b.local_com, q);
                if pose.is_finite() && sb.v.is_finite() && sb.w.is_finite() {
                    b.pose = pose;
                    b.linear_velocity = sb.v.into();
                    b.angular_velocity = sb.w.into();
                } else {
                    // Guard: never let NaN or infinity into a pose. Put the
                    // body back where the step began and stop it.
                    b.pose = pose0;
                    b.linear_velocity = Vec3::ZERO;
                    b.angular_velocity = Vec3::ZERO;
                    b.faulted = true;
                    faults.lock().unwrap_or_else(|e| e.into_inner()).push(k);
                }
                b.force = Vec3::ZERO;
                b.torque = Vec3::ZERO;
                if b.can_sleep && resting(b, threshold) && b.body_type == BodyType::Dynamic {
                    b.sleep_time += dt;
                } else {
                    b.sleep_time = 0.0;
                }
                for &ci in &b.colliders {
                    // SAFETY: as above; `ci` is this body's own collider.
                    let c = unsafe { colliders.at_mut(ci) }.expect("attached");
                    c.world_pose = b.pose.mul_pose(&c.local_pose);
                }
            };
            let parallel = workers(self.settings.threads, self.pool.as_deref()) > 1 && n >= solver::PARALLEL_MIN_BODIES;
            for_each_index(self.pool.as_deref(), parallel, n, one);
        }
        // The faults in the awake order, whatever the threads.
        let mut faults = faults.into_inner().unwrap_or_else(|e| e.into_inner());
        faults.sort_unstable();
        for k in faults {
            let h = self.bodies.handle_at(self.awake.list()[k]).expect("live");
            self.faulted.push(BodyHandle(h));
        }
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
