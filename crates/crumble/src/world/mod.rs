//! The [`World`]: bodies, colliders and contacts, and the step that
//! advances them.
//!
//! The world owns the state that persists from step to step: the bodies
//! and colliders (generational arenas), the broad phase, the contacts, the
//! awake set with its sleeping islands (`awake.rs`), and the solver with
//! what it keeps from step to step (`solver/step.rs`). [`World::step`]
//! (`world/step.rs`) runs the pipeline's stages over them in order: broad
//! phase (`world/proxies.rs`) → narrow phase (`narrow_phase.rs`) → islands
//! and waking (`awake.rs`) → solver (`solver/`) → continuous collision
//! (`ccd.rs`) → write-back (`solver/setup.rs`) and sleep (`awake.rs`) →
//! events (`world/events.rs`). Settings and their errors are in
//! `world/settings.rs`, the per-step profile in `world/profile.rs`.

mod bonds;
mod events;
mod fracture;
mod joints;
mod profile;
mod proxies;
mod settings;
mod snapshot;
mod step;
#[cfg(test)]
mod tests;

use std::sync::Arc;

use crate::arena::Arena;
use crate::awake::AwakeSet;
use crate::body::{Body, BodyBuilder, BodyHandle, BodyType};
use crate::broad_phase::BroadPhase;
use crate::collider::{Collider, ColliderBuilder, ColliderHandle};
use crate::contact::{ContactEvent, ContactSet, NONE};
use crate::mass::{body_mass, MassData, MassError};
use crate::math::{Mat3, Pose, Quat, Vec3};
use crate::shape::Shape;
use crate::solver::Solver;
use crate::threads::thread_pool;
use events::Events;
pub(crate) use profile::Visits;
pub use profile::{Profile, SolverStages};
use proxies::{proxy_aabb, proxy_margin};
pub use settings::{SolverExperiments, WorldError, WorldSettings};

/// Half-spaces have infinite bounding boxes; the broad phase sees them
/// clipped to this cube (metres from the origin).
pub const WORLD_BOUND: f32 = 1.0e6;

/// The simulation: owns bodies, colliders and contacts, and advances them
/// with [`step`](World::step).
pub struct World {
    settings: WorldSettings,
    bodies: Arena<Body>,
    colliders: Arena<Collider>,
    broad_phase: BroadPhase,
    contacts: ContactSet,
    /// The awake bodies and the sleeping islands.
    awake: AwakeSet,
    /// The solver's scratch and caches.
    solver: Solver,
    events: Events,
    /// The joints, the body pairs they keep from colliding, their events.
    joints: joints::JointSet,
    /// The bonds, the collider pairs they glue, their events.
    bonds: bonds::BondSet,
    fracture: fracture::FractureSet,
    /// Bodies whose state went non-finite in the last step.
    faulted: Vec<BodyHandle>,
    profile: Profile,
    /// The pool built for `WorldSettings::threads >= 2`.
    pool: Option<Arc<rayon::ThreadPool>>,
    /// Simulated time, seconds.
    time: f64,
    scratch: Scratch,
}

/// The world's scratch: what a step or an API call needs for a moment,
/// kept so that steady state does not allocate.
#[derive(Default)]
struct Scratch {
    /// Work counters of the step in progress (see `Profile`).
    visits: Visits,
    /// The contacts of a collider being removed.
    doomed_contacts: Vec<u32>,
    /// Colliders a fast body's sweep may hit (`continuous_collision`).
    ccd_candidates: Vec<u32>,
    /// Islands' sums of the energy bound (`energy.rs`).
    islands: Vec<crate::energy::Island>,
}

impl Default for World {
    fn default() -> Self {
        Self::new(WorldSettings::default()).expect("default settings are valid")
    }
}

fn finite_vec(v: Vec3, what: &'static str) -> Result<(), WorldError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(WorldError::NonFinite(what))
    }
}

impl World {
    /// An empty world with the given settings.
    pub fn new(settings: WorldSettings) -> Result<World, WorldError> {
        settings.validate()?;
        Ok(World {
            settings,
            bodies: Arena::default(),
            colliders: Arena::default(),
            broad_phase: BroadPhase::new(settings.aabb_margin),
            contacts: ContactSet::default(),
            awake: AwakeSet::default(),
            solver: Solver::default(),
            events: Events::default(),
            joints: joints::JointSet::default(),
            bonds: bonds::BondSet::default(),
            fracture: fracture::FractureSet::default(),
            faulted: Vec::new(),
            profile: Profile::default(),
            pool: thread_pool(settings.threads)?,
            time: 0.0,
            scratch: Scratch::default(),
        })
    }

    /// The settings in force.
    pub fn settings(&self) -> &WorldSettings {
        &self.settings
    }

    /// Replaces the settings (validated first).
    ///
    /// Settings that differ only in [`threads`](WorldSettings::threads)
    /// change nothing else: that is [`set_threads`](Self::set_threads).
    pub fn set_settings(&mut self, settings: WorldSettings) -> Result<(), WorldError> {
        settings.validate()?;
        if (WorldSettings { threads: self.settings.threads, ..settings }) == self.settings {
            return self.set_threads(settings.threads);
        }
        self.solver.bodies_changed();
        if settings.threads != self.settings.threads {
            self.pool = thread_pool(settings.threads)?;
        }
        // Static colliders inserted from now on take the new margin (those
        // in the tree keep their boxes); moving ones take theirs at their
        // next step, sleepers when they next fall asleep.
        self.broad_phase.set_margin(settings.aabb_margin);
        self.settings = settings;
        Ok(())
    }

    /// Sets the threads the step may use (see
    /// [`WorldSettings::threads`]): the results stay the same bits, so a
    /// world restored from a snapshot may continue on other threads than
    /// the one that was saved.
    pub fn set_threads(&mut self, threads: usize) -> Result<(), WorldError> {
        let settings = WorldSettings { threads, ..self.settings };
        settings.validate()?;
        if threads != self.settings.threads {
            self.pool = thread_pool(threads)?;
        }
        self.settings = settings;
        Ok(())
    }

    /// Simulated time so far, seconds.
    pub fn time(&self) -> f64 {
        self.time
    }

    // ------------------------------------------------------------------
    // Bodies and colliders
    // ------------------------------------------------------------------

    /// Adds a body. Its mass comes from the colliders attached later.
    pub fn insert_body(&mut self, builder: BodyBuilder) -> Result<BodyHandle, WorldError> {
        self.solver.bodies_changed();
        finite_vec(builder.pose.position, "body position")?;
        if !builder.pose.rotation.is_finite() || !normalizable(builder.pose.rotation) {
            return Err(WorldError::NonFinite("body rotation (a non-zero quaternion)"));
        }
        finite_vec(builder.linear_velocity, "body linear velocity")?;
        finite_vec(builder.angular_velocity, "body angular velocity")?;
        for (name, v) in [("linear_damping", builder.linear_damping), ("angular_damping", builder.angular_damping)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(WorldError::InvalidBody { name, value: v });
            }
        }
        if !builder.gravity_scale.is_finite() {
            return Err(WorldError::InvalidBody { name: "gravity_scale", value: builder.gravity_scale });
        }
        let body = Body::from_builder(&builder);
        let raw = self.bodies.insert(body);
        self.awake.insert(raw.index, self.bodies.at(raw.index).expect("inserted"));
        self.solver.insert_body(raw.index, builder.pose.rotation);
        Ok(BodyHandle(raw))
    }

    /// Attaches a collider to `body` and updates the body's mass.
    pub fn insert_collider(
        &mut self,
        builder: ColliderBuilder,
        body: BodyHandle,
    ) -> Result<ColliderHandle, WorldError> {
        self.solver.bodies_changed();
        builder.material.validate()?;
        if !builder.local_pose.is_finite() || !normalizable(builder.local_pose.rotation) {
            return Err(WorldError::NonFinite("collider local pose"));
        }
        let b = self.bodies.get(body.0).ok_or(WorldError::UnknownBody)?;
        if matches!(builder.shape, Shape::HalfSpace(_)) && b.body_type != BodyType::Static {
            return Err(WorldError::HalfSpaceOnMovingBody);
        }
        let local_pose = Pose::new(builder.local_pose.position, builder.local_pose.rotation.normalize());
        let mass =
            self.prospective_mass(body.0.index, None, Some((&builder.shape, builder.material.density, &local_pose)))?;
        let b = self.bodies.get(body.0).expect("checked");
        let world_pose = b.pose.mul_pose(&local_pose);
        let aabb = proxy_aabb(&self.settings, &builder.shape, &world_pose, Vec3::ZERO, 0.0);
        let slot = self.colliders.next_index();
        let margin = proxy_margin(&self.settings, &builder.shape, 0.0, b.sleeping);
        let proxy = match b.body_type {
            BodyType::Static => self.broad_phase.insert_static(aabb, slot),
            BodyType::Kinematic => self.broad_phase.insert_kinematic(aabb, slot, margin),
            BodyType::Dynamic => self.broad_phase.insert_with_margin(aabb, slot, margin),
        };
        self.fracture.any |= builder.material.strength.is_some();
        let raw = self.colliders.insert(Collider {
            shape: builder.shape,
            local_pose,
            material: builder.material,
            body: body.0.index,
            proxy,
            world_pose,
        });
        debug_assert_eq!(raw.index, slot);
        self.bodies.get_mut(body.0).expect("checked").colliders.push(raw.index);
        self.update_mass(body.0.index, mass);
        Ok(ColliderHandle(raw))
    }

    /// Removes a body, its joints, its colliders and their contacts.
    /// Contacts that were touching are reported as ended after the next
    /// step.
    pub fn remove_body(&mut self, body: BodyHandle) -> Result<(), WorldError> {
        self.solver.bodies_changed();
        let b = self.bodies.get(body.0).ok_or(WorldError::UnknownBody)?;
        if b.sleeping {
            self.wake_body(body.0.index);
        }
        self.remove_joints_of(body.0.index);
        let colliders = self.bodies.get(body.0).expect("checked").colliders.clone();
        for c in colliders {
            self.remove_collider_slot(c);
        }
        self.bodies.remove(body.0);
        self.awake.remove(body.0.index);
        Ok(())
    }

    /// Removes a collider and updates its body's mass.
    pub fn remove_collider(&mut self, collider: ColliderHandle) -> Result<(), WorldError> {
        self.solver.bodies_changed();
        let body = self.colliders.get(collider.0).ok_or(WorldError::UnknownCollider)?.body;
        let mass = self.prospective_mass(body, Some(collider.0.index), None)?;
        self.wake_body(body);
        self.remove_collider_slot(collider.0.index);
        if let Some(b) = self.bodies.at_mut(body) {
            b.colliders.retain(|&c| c != collider.0.index);
        }
        self.update_mass(body, mass);
        Ok(())
    }

    fn remove_collider_slot(&mut self, index: u32) {
        let Some(c) = self.colliders.at(index) else {
            return;
        };
        let body = c.body;
        self.remove_bonds_of_collider(index);
        let c = self.colliders.at(index).expect("live");
        self.broad_phase.remove(c.proxy);
        // The collider's contacts, from its body's contact list.
        let mut doomed = std::mem::take(&mut self.scratch.doomed_contacts);
        doomed.clear();
        let mut id = self.contacts.first_of(body);
        while id != NONE {
            let c = &self.contacts.list[id as usize];
            if c.collider_a == index || c.collider_b == index {
                doomed.push(id);
            }
            id = self.contacts.next_of(id, body);
        }
        // What rests on the collider must be free to fall once it is gone:
        // wake the sleeping bodies it touches or nearly touches (a sleeping
        // wall on a removed ground would otherwise hang in the air).
        for &id in &doomed {
            let c = &self.contacts.list[id as usize];
            if c.in_reach() {
                self.wake_body(c.other(body));
            }
        }
        self.drop_contacts(doomed);
        let h = self.colliders.handle_at(index).expect("live");
        self.colliders.remove(h);
    }

    /// Drops contacts `doomed` (ids), and keeps the vector for reuse.
    fn drop_contacts(&mut self, mut doomed: Vec<u32>) {
        // Drop them in the order in which a scan of the active list meets
        // them (the order the whole contact list was once scanned in), so
        // that the active list, and with it the solver's order, ends up as
        // it did before contacts could be set aside. A swap-remove at `pos`
        // moves the last active contact there; if that one is doomed too,
        // it is the largest position left and the scan would meet it next.
        doomed.sort_unstable_by_key(|&id| (self.contacts.active_pos(id), id));
        let n_active = doomed.iter().take_while(|&&id| self.contacts.is_active(id)).count();
        let (mut lo, mut hi) = (0, n_active);
        while lo < hi {
            let mut id = doomed[lo];
            lo += 1;
            loop {
                let pos = self.contacts.active_pos(id) as usize;
                self.drop_contact(id);
                if lo < hi && self.contacts.active.get(pos) == Some(&doomed[hi - 1]) {
                    hi -= 1;
                    id = doomed[hi];
                } else {
                    break;
                }
            }
        }
        for &id in &doomed[n_active..] {
            self.drop_contact(id);
        }
        self.scratch.doomed_contacts = doomed;
    }

    /// The mass data `body` would have with its colliders, leaving out
    /// `without` and adding `with`: what attaching or removing a collider
    /// checks before it changes anything.
    fn prospective_mass(
        &self,
        body: u32,
        without: Option<u32>,
        with: Option<(&Shape, f32, &Pose)>,
    ) -> Result<Option<MassData>, MassError> {
        let Some(b) = self.bodies.at(body) else {
            return Ok(None);
        };
        if b.body_type != BodyType::Dynamic {
            return Ok(None);
        }
        let attached = b.colliders.iter().filter(|&&ci| Some(ci) != without).map(|&ci| {
            let c = self.colliders.at(ci).expect("attached collider");
            (&c.shape, c.material.density, &c.local_pose)
        });
        body_mass(attached.chain(with))
    }

    /// Sets the body's mass, centre of mass and inertia to `data`, which
    /// the caller computed for the colliders it now has and checked
    /// ([`World::prospective_mass`]: the same colliders in the same order,
    /// so the same sums), and its extents from the colliders.
    fn update_mass(&mut self, body: u32, data: Option<MassData>) {
        let Some(b) = self.bodies.at(body) else {
            return;
        };
        let old_com_world = b.center_of_mass();
        let dynamic = b.body_type == BodyType::Dynamic;
        let b = self.bodies.at_mut(body).expect("checked");
        match data {
            Some(m) => {
                b.mass = m.mass;
                b.inv_mass = m.inv_mass;
                b.local_com = m.local_com;
                b.local_inertia = m.inertia;
                b.local_inv_inertia = m.inv_inertia;
            }
            None => {
                b.mass = 0.0;
                b.inv_mass = 0.0;
                b.local_com = if dynamic { Vec3::ZERO } else { b.local_com };
                b.local_inertia = Mat3::ZERO;
                b.local_inv_inertia = Mat3::ZERO;
            }
        }
        // Keep the body's velocity field: the new centre of mass moves with
        // the old one's velocity plus the rotation's contribution.
        let new_com = b.center_of_mass();
        b.linear_velocity += b.angular_velocity.cross(new_com - old_com_world);
        let (min_extent, max_extent) = self.extents(body);
        let b = self.bodies.at_mut(body).expect("checked");
        (b.min_extent, b.max_extent) = (min_extent, max_extent);
    }

    /// A body's extents from its colliders and centre of mass: the
    /// smallest half extent of its shapes (infinite without colliders)
    /// and the farthest any point of a bounded shape lies from its centre
    /// of mass (0 without one). Restore checks them against these.
    pub(crate) fn extents(&self, body: u32) -> (f32, f32) {
        let b = self.bodies.at(body).expect("a live body");
        let shapes = b.colliders.iter().map(|&ci| self.colliders.at(ci).expect("attached collider"));
        let min_extent = shapes.clone().map(|c| c.shape.min_half_extent()).fold(f32::INFINITY, f32::min);
        let mut max_extent: f32 = 0.0;
        for c in shapes {
            let r = c.shape.bounding_radius();
            if r.is_finite() {
                max_extent = max_extent.max((c.local_pose.position - b.local_com).length() + r);
            }
        }
        (min_extent, max_extent)
    }

    /// The body, if the handle is live.
    pub fn body(&self, h: BodyHandle) -> Option<&Body> {
        self.bodies.get(h.0)
    }

    /// The collider, if the handle is live.
    pub fn collider(&self, h: ColliderHandle) -> Option<&Collider> {
        self.colliders.get(h.0)
    }

    /// Handles of the colliders attached to a body.
    pub fn body_colliders(&self, h: BodyHandle) -> Vec<ColliderHandle> {
        self.bodies
            .get(h.0)
            .map(|b| b.colliders.iter().filter_map(|&c| self.colliders.handle_at(c).map(ColliderHandle)).collect())
            .unwrap_or_default()
    }

    /// All bodies, in slot order.
    pub fn bodies(&self) -> impl Iterator<Item = (BodyHandle, &Body)> {
        self.bodies.iter().map(|(h, b)| (BodyHandle(h), b))
    }

    /// A 64-bit checksum of every body's motion: FNV-1a over the bits of
    /// its position, rotation, linear and angular velocity, bodies in slot
    /// order. Two worlds with the same checksum almost surely hold the
    /// same motion to the bit; the checksum example prints it to compare
    /// builds, machines and thread counts, and the Python package's
    /// `World.checksum` is this.
    pub fn motion_checksum(&self) -> u64 {
        let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
        for (_, body) in self.bodies() {
            let words = body
                .position()
                .to_array()
                .into_iter()
                .chain(body.rotation().to_array())
                .chain(body.linear_velocity().to_array())
                .chain(body.angular_velocity().to_array());
            for x in words {
                for byte in x.to_bits().to_le_bytes() {
                    hash = (hash ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
                }
            }
        }
        hash
    }

    /// All colliders, in slot order.
    pub fn colliders(&self) -> impl Iterator<Item = (ColliderHandle, &Collider)> {
        self.colliders.iter().map(|(h, c)| (ColliderHandle(h), c))
    }

    /// Number of bodies.
    pub fn body_count(&self) -> usize {
        self.bodies.len()
    }

    /// The collider's body handle.
    pub fn collider_body(&self, h: ColliderHandle) -> Option<BodyHandle> {
        let c = self.colliders.get(h.0)?;
        self.bodies.handle_at(c.body).map(BodyHandle)
    }

    fn body_mut(&mut self, h: BodyHandle) -> Result<&mut Body, WorldError> {
        self.bodies.get_mut(h.0).ok_or(WorldError::UnknownBody)
    }

    /// Sets the linear velocity (wakes the body). Ignored for static bodies.
    pub fn set_linear_velocity(&mut self, h: BodyHandle, v: Vec3) -> Result<(), WorldError> {
        finite_vec(v, "linear velocity")?;
        let b = self.body_mut(h)?;
        if b.body_type != BodyType::Static {
            b.linear_velocity = v;
            self.wake_body(h.0.index);
        }
        Ok(())
    }

    /// Sets the angular velocity, world frame (wakes the body).
    pub fn set_angular_velocity(&mut self, h: BodyHandle, w: Vec3) -> Result<(), WorldError> {
        finite_vec(w, "angular velocity")?;
        let b = self.body_mut(h)?;
        if b.body_type != BodyType::Static {
            b.angular_velocity = w;
            self.wake_body(h.0.index);
        }
        Ok(())
    }

    /// Moves the body to a new pose at once (a teleport: no velocity is
    /// implied). Wakes it.
    pub fn set_pose(&mut self, h: BodyHandle, pose: Pose) -> Result<(), WorldError> {
        if !pose.is_finite() || !normalizable(pose.rotation) {
            return Err(WorldError::NonFinite("pose"));
        }
        let b = self.body_mut(h)?;
        b.pose = Pose::new(pose.position, pose.rotation.normalize());
        self.wake_body(h.0.index);
        // A teleport is motion no velocity shows (a kinematic platform
        // animated by poses moves at "zero" speed): wake the sleeping
        // bodies it touched, which would otherwise float where it was or
        // be passed through (see `wake_touched`).
        let bi = h.0.index;
        let mut id = self.contacts.first_of(bi);
        while id != NONE {
            let next = self.contacts.next_of(id, bi);
            let c = &self.contacts.list[id as usize];
            if c.in_reach() {
                self.wake_body(c.other(bi));
            }
            id = next;
        }
        // And the bodies joined to it, which a joint now pulls.
        self.wake_jointed_to(bi);
        self.sync_colliders(h.0.index);
        let colliders = self.bodies.get(h.0).expect("checked").colliders.clone();
        for ci in colliders {
            let c = self.colliders.at(ci).expect("attached");
            let aabb = proxy_aabb(&self.settings, &c.shape, &c.world_pose, Vec3::ZERO, 0.0);
            self.broad_phase.update(c.proxy, aabb);
        }
        Ok(())
    }

    /// Adds a force through the centre of mass for the next step, N.
    pub fn apply_force(&mut self, h: BodyHandle, f: Vec3) -> Result<(), WorldError> {
        finite_vec(f, "force")?;
        let b = self.body_mut(h)?;
        finite_vec(b.force + f, "the body's total force")?;
        b.force += f;
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Adds a torque for the next step, N·m, world frame.
    pub fn apply_torque(&mut self, h: BodyHandle, t: Vec3) -> Result<(), WorldError> {
        finite_vec(t, "torque")?;
        let b = self.body_mut(h)?;
        finite_vec(b.torque + t, "the body's total torque")?;
        b.torque += t;
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Adds a force applied at a world point for the next step: the force
    /// through the centre of mass plus the torque `(p − X) × F` (the seed
    /// report's `F × (p − X)` term, written with the usual sign).
    pub fn apply_force_at_point(&mut self, h: BodyHandle, f: Vec3, p: Vec3) -> Result<(), WorldError> {
        finite_vec(f, "force")?;
        finite_vec(p, "point")?;
        let b = self.body_mut(h)?;
        let x = b.center_of_mass();
        let (force, torque) = (b.force + f, b.torque + (p - x).cross(f));
        finite_vec(force, "the body's total force")?;
        finite_vec(torque, "the body's total torque")?;
        (b.force, b.torque) = (force, torque);
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Applies an impulse through the centre of mass at once, N·s.
    pub fn apply_impulse(&mut self, h: BodyHandle, j: Vec3) -> Result<(), WorldError> {
        finite_vec(j, "impulse")?;
        let b = self.body_mut(h)?;
        let v = b.linear_velocity + b.inv_mass * j;
        finite_vec(v, "the velocity the impulse gives")?;
        b.linear_velocity = v;
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Applies an impulse at a world point at once: `Δv = J/m`,
    /// `Δω = I⁻¹ ((p − X) × J)`. Refused, with nothing changed, when the
    /// velocities it gives are not finite (huge finite arguments).
    pub fn apply_impulse_at_point(&mut self, h: BodyHandle, j: Vec3, p: Vec3) -> Result<(), WorldError> {
        finite_vec(j, "impulse")?;
        finite_vec(p, "point")?;
        let b = self.body_mut(h)?;
        let x = b.center_of_mass();
        let v = b.linear_velocity + b.inv_mass * j;
        let w = b.angular_velocity + b.world_inv_inertia() * (p - x).cross(j);
        finite_vec(v, "the velocity the impulse gives")?;
        finite_vec(w, "the angular velocity the impulse gives")?;
        (b.linear_velocity, b.angular_velocity) = (v, w);
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Wakes a body and its whole sleeping island.
    pub fn wake_up(&mut self, h: BodyHandle) -> Result<(), WorldError> {
        self.bodies.get(h.0).ok_or(WorldError::UnknownBody)?;
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Checks the sleep bookkeeping and panics on the first inconsistency:
    /// the awake set holds exactly the awake dynamic and kinematic bodies,
    /// every sleeping body is in the island that names it, a contact is
    /// active exactly when one of its bodies is awake, and the contact
    /// lists are sound, and each collider's proxy is static or kinematic
    /// as its body is. O(bodies + contacts): meant for tests and
    /// debugging, not for every step. (The broad phase has its own
    /// `validate`; its pairs catch up with API moves only at the next step.)
    pub fn validate(&self) {
        self.contacts.validate();
        self.awake.validate(&self.bodies, &self.contacts);
        for (h, b) in self.bodies.iter() {
            for &ci in &b.colliders {
                let c = self.colliders.at(ci);
                assert_eq!(c.map(|c| c.body), Some(h.index), "collider {ci} of body {}", h.index);
                let proxy = c.expect("checked").proxy;
                let kinds = (self.broad_phase.is_static(proxy), self.broad_phase.is_kinematic(proxy));
                let want = (b.body_type == BodyType::Static, b.body_type == BodyType::Kinematic);
                assert_eq!(kinds, want, "proxy of collider {ci}: (static, kinematic)");
            }
        }
        for c in self.contacts.iter() {
            let (ca, cb) = (self.colliders.at(c.collider_a), self.colliders.at(c.collider_b));
            assert_eq!(ca.map(|x| x.body), Some(c.body_a), "contact's collider a");
            assert_eq!(cb.map(|x| x.body), Some(c.body_b), "contact's collider b");
        }
    }

    /// Contact events (began / ended) of the last step.
    pub fn contact_events(&self) -> &[ContactEvent] {
        &self.events.list
    }

    /// Timings and counts of the last step.
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// Bodies whose state went non-finite in the last step; each was put
    /// back to its pose at the start of that step and stopped.
    pub fn faulted_bodies(&self) -> &[BodyHandle] {
        &self.faulted
    }

    /// Current contact manifolds of touching pairs: `(collider a, collider b,
    /// manifold)`, normal from a to b, sleeping ones included, in contact
    /// slot order. For drawing and debugging.
    pub fn contacts(&self) -> impl Iterator<Item = (ColliderHandle, ColliderHandle, &crate::collision::Manifold)> {
        self.contacts.iter().filter(|c| !c.manifold.is_empty()).filter_map(|c| {
            Some((
                ColliderHandle(self.colliders.handle_at(c.collider_a)?),
                ColliderHandle(self.colliders.handle_at(c.collider_b)?),
                &c.manifold,
            ))
        })
    }

    /// Wakes the body's sleeping island, if it sleeps (`AwakeSet::wake_body`).
    fn wake_body(&mut self, body: u32) {
        self.awake.wake_body(body, &mut self.bodies, &mut self.contacts, &mut self.scratch.visits);
    }

    /// Updates the world poses of a body's colliders.
    fn sync_colliders(&mut self, body: u32) {
        let Some(b) = self.bodies.at(body) else {
            return;
        };
        let pose = b.pose;
        for k in 0..b.colliders.len() {
            let ci = self.bodies.at(body).expect("live").colliders[k];
            let c = self.colliders.at_mut(ci).expect("attached");
            c.world_pose = pose.mul_pose(&c.local_pose);
        }
    }

    /// Tests: the solver, to switch it to its references and look at its
    /// batches and partition.
    #[cfg(test)]
    pub(crate) fn solver_mut(&mut self) -> &mut Solver {
        &mut self.solver
    }
}

/// Whether a rotation given to the world has a unit direction to take:
/// not (near) zero, and not so long that its squared length overflows
/// (`normalize` would then give the zero quaternion).
fn normalizable(q: Quat) -> bool {
    let length2 = q.length_squared();
    length2.is_finite() && length2 >= 1e-12
}
