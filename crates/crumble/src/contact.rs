//! Persistent contacts between pairs of colliders, and the events the world
//! reports when two colliders begin or stop touching.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use crate::body::BodyHandle;
use crate::collider::ColliderHandle;
use crate::collision::{Manifold, MAX_MANIFOLD_POINTS};
use crate::math::Vec3;

/// A fixed-key hasher: the same keys always land in the same order, so
/// nothing the world does depends on a random seed.
type FixedState = BuildHasherDefault<std::collections::hash_map::DefaultHasher>;

/// Whether a contact began or ended in the last step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactEventKind {
    /// The two colliders touch now and did not in the step before.
    Began,
    /// The two colliders touched in the step before and do not now (or one
    /// of them was removed).
    Ended,
}

/// A change in touching between two colliders during the last step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactEvent {
    /// Began or ended.
    pub kind: ContactEventKind,
    /// First collider of the pair.
    pub collider_a: ColliderHandle,
    /// Second collider of the pair.
    pub collider_b: ColliderHandle,
    /// Body of `collider_a`.
    pub body_a: BodyHandle,
    /// Body of `collider_b`.
    pub body_b: BodyHandle,
    /// Normal impulse (N·s) the pair exchanged during the step, over all
    /// its points and substeps: the momentum a hit transferred. 0 for
    /// `Ended`. A hard hit shows as a large impulse at `Began`; a brick
    /// settling on another shows about its weight times the step.
    pub normal_impulse: f32,
}

/// A pair of colliders whose fattened boxes overlap, with the manifold of
/// the last narrow phase and the impulses kept for warm starting.
#[derive(Clone, Debug)]
pub(crate) struct Contact {
    pub collider_a: u32,
    pub collider_b: u32,
    pub body_a: u32,
    pub body_b: u32,
    pub manifold: Manifold,
    /// Accumulated normal impulse per manifold point (same order as points).
    pub normal_impulse: [f32; MAX_MANIFOLD_POINTS],
    /// Accumulated friction impulse of the whole manifold (applied at its
    /// centre), as a world vector so that it survives a change of tangent
    /// basis between steps.
    pub friction_impulse: Vec3,
    /// Accumulated twist-friction impulse about the normal (N·m·s).
    pub twist_impulse: f32,
    /// Accumulated rolling-resistance angular impulse (world vector).
    pub rolling_impulse: Vec3,
    /// Rolling resistance bound per unit normal impulse, metres:
    /// `c_rr × ball radius` (0 when no ball is involved).
    pub rolling_arm: f32,
    /// Largest per-point accumulated normal impulse of the last step.
    pub max_normal_impulse: f32,
    /// Normal impulse the pair exchanged over the last step (all points).
    pub step_impulse: f32,
    pub friction: f32,
    pub restitution: f32,
    pub touching: bool,
}

impl Contact {
    pub fn new(collider_a: u32, collider_b: u32, body_a: u32, body_b: u32, friction: f32, restitution: f32) -> Self {
        Contact {
            collider_a,
            collider_b,
            body_a,
            body_b,
            manifold: Manifold::EMPTY,
            normal_impulse: [0.0; MAX_MANIFOLD_POINTS],
            friction_impulse: Vec3::ZERO,
            twist_impulse: 0.0,
            rolling_impulse: Vec3::ZERO,
            rolling_arm: 0.0,
            max_normal_impulse: 0.0,
            step_impulse: 0.0,
            friction,
            restitution,
            touching: false,
        }
    }

    /// Replaces the manifold, carrying each point's impulses over from the
    /// matching point of the old manifold (zero for a new point).
    ///
    /// A point matches the old point with the same feature id; failing
    /// that, the nearest unmatched old point within `tolerance` metres.
    /// The fallback matters for the most common case in a wall: two equal
    /// faces exactly on top of each other, where each corner is both an
    /// incident vertex and a clipped edge point, and rounding decides which
    /// feature names it from one step to the next. Without warm starting,
    /// a stack re-learns its impulses every step and creeps.
    pub fn set_manifold(&mut self, new: Manifold, tolerance: f32) {
        let old = self.manifold;
        let old_n = self.normal_impulse;
        self.normal_impulse = [0.0; MAX_MANIFOLD_POINTS];
        let mut taken = [false; MAX_MANIFOLD_POINTS];
        let mut matched = [false; MAX_MANIFOLD_POINTS];
        for (i, p) in new.points().iter().enumerate() {
            if let Some(j) = old.points().iter().enumerate().position(|(j, q)| !taken[j] && q.id == p.id) {
                taken[j] = true;
                matched[i] = true;
                self.normal_impulse[i] = old_n[j];
            }
        }
        let tol2 = tolerance * tolerance;
        for (i, p) in new.points().iter().enumerate() {
            if matched[i] {
                continue;
            }
            let mut best = None;
            let mut best_d2 = tol2;
            for (j, q) in old.points().iter().enumerate() {
                let d2 = (q.point - p.point).length_squared();
                if !taken[j] && d2 <= best_d2 {
                    best = Some(j);
                    best_d2 = d2;
                }
            }
            if let Some(j) = best {
                taken[j] = true;
                self.normal_impulse[i] = old_n[j];
            }
        }
        // Friction belongs to the patch, not to a point: keep it while any
        // point carried over, drop it when the contact changed entirely.
        if !taken.iter().any(|&t| t) {
            self.friction_impulse = Vec3::ZERO;
            self.twist_impulse = 0.0;
            self.rolling_impulse = Vec3::ZERO;
        }
        self.manifold = new;
    }
}

/// All contacts, in a Vec (iterated in a deterministic order) with a map
/// from the collider pair to its slot.
#[derive(Default)]
pub(crate) struct ContactSet {
    pub list: Vec<Contact>,
    index: HashMap<(u32, u32), u32, FixedState>,
}

impl ContactSet {
    pub fn insert(&mut self, c: Contact) {
        let key = (c.collider_a, c.collider_b);
        if self.index.contains_key(&key) {
            return;
        }
        self.index.insert(key, self.list.len() as u32);
        self.list.push(c);
    }

    /// Removes the contact of the pair; returns it when it existed.
    pub fn remove(&mut self, a: u32, b: u32) -> Option<Contact> {
        let i = self.index.remove(&(a, b))? as usize;
        let c = self.list.swap_remove(i);
        if i < self.list.len() {
            let moved = &self.list[i];
            self.index.insert((moved.collider_a, moved.collider_b), i as u32);
        }
        Some(c)
    }

    pub fn len(&self) -> usize {
        self.list.len()
    }
}
