//! The world's joints (`joint.rs`): inserting and removing them, the pairs
//! of bodies they keep from colliding, and what the end of a step does
//! with them: each joint's separation, and breaking those whose force or
//! torque over the step went above their thresholds.

use super::{World, WorldError};
use crate::body::{BodyHandle, BodyType};
use crate::contact::NONE;
use crate::joint::{Joint, JointBody, JointBuilder, JointEvent, JointHandle, JointKind, JointOptions, NO_BODY};
use crate::math::{Pose, Vec3};

/// The world's joints and what goes with them.
#[derive(Default)]
pub(super) struct JointSet {
    pub(super) arena: crate::arena::Arena<Joint>,
    /// Body pairs `(lo, hi)` (slots) joined by a joint that keeps them from
    /// colliding, sorted, one entry per such joint.
    no_collide: Vec<(u32, u32)>,
    /// Events of the last step.
    pub(super) events: Vec<JointEvent>,
}

impl JointSet {
    /// Whether bodies `a` and `b` (slots) may not collide: a joint between
    /// them says so.
    pub(super) fn ignores(&self, a: u32, b: u32) -> bool {
        !self.no_collide.is_empty() && self.no_collide.binary_search(&(a.min(b), a.max(b))).is_ok()
    }
}

/// The largest spring frequency (Hz) and damping ratio.
const MAX_SPRING: f32 = 1.0e6;

/// A longest joint length, metres: what no scene needs and a float can
/// still square (the solver forms squared lengths).
const MAX_LENGTH: f32 = 1.0e6;

impl World {
    /// Adds a joint (see [`JointBuilder`] for the kinds and defaults). Both
    /// bodies are woken.
    ///
    /// Refused, with nothing changed: an unknown body
    /// ([`WorldError::UnknownBody`]); a body joined to itself, a joint
    /// without a dynamic body, anchors or an axis that are not finite, a
    /// zero axis, a length that is not positive, limits outside
    /// `[-π, π]` or reversed, a negative or non-finite spring, a break
    /// threshold that is NaN or not positive ([`WorldError::InvalidJoint`]).
    pub fn insert_joint(&mut self, builder: JointBuilder) -> Result<JointHandle, WorldError> {
        let bad = |why: &'static str| Err(WorldError::InvalidJoint(why));
        let side = |s: JointBody| -> Result<(u32, Option<BodyHandle>, Pose, bool), WorldError> {
            match s {
                JointBody::World => Ok((NO_BODY, None, Pose::IDENTITY, false)),
                JointBody::Body(h) => {
                    let b = self.bodies.get(h.0).ok_or(WorldError::UnknownBody)?;
                    Ok((h.0.index, Some(h), b.pose, b.body_type == BodyType::Dynamic))
                }
            }
        };
        let (a, ha, pose_a, dyn_a) = side(builder.a)?;
        let (b, hb, pose_b, dyn_b) = side(builder.b)?;
        if a == b {
            return bad(if a == NO_BODY { "both sides are the world" } else { "a body joined to itself" });
        }
        if !(dyn_a || dyn_b) {
            return bad("neither body is dynamic");
        }
        if !builder.anchor_values().iter().all(|p| p.is_finite() && p.abs().max_element() <= super::WORLD_BOUND) {
            return bad("anchor is not finite (or beyond the world's bound)");
        }
        let axis = builder.axis;
        if builder.kind == JointKind::Revolute {
            if !axis.is_finite() {
                return bad("axis is not finite");
            }
            if axis.length_squared() < 1e-12 {
                return bad("axis is zero");
            }
        }
        if let Some(why) = invalid_options(builder.kind, &builder.options) {
            return bad(why);
        }
        let (local_a, local_b) = builder.local_anchor_points(pose_a, pose_b, b == NO_BODY);
        if !(local_a.is_finite() && local_b.is_finite()) {
            return bad("anchor is not finite in a body's frame");
        }
        let (qa, qb) = (pose_a.rotation.normalize(), pose_b.rotation.normalize());
        let axis = axis.normalize_or(Vec3::Z);
        let reference = axis.any_orthonormal_vector();
        let joint = Joint {
            kind: builder.kind,
            a,
            b,
            handle_a: ha,
            handle_b: hb,
            local_a,
            local_b,
            axis_a: qa.inverse() * axis,
            axis_b: qb.inverse() * axis,
            ref_a: qa.inverse() * reference,
            ref_b: qb.inverse() * reference,
            relative: qa.inverse() * qb,
            options: builder.options,
            linear_impulse: Vec3::ZERO,
            angular_impulse: Vec3::ZERO,
            extra_impulse: [0.0; 2],
            force: Vec3::ZERO,
            torque: Vec3::ZERO,
            separation: 0.0,
        };
        Ok(self.add_joint(joint))
    }

    /// Puts a checked joint in the world: wakes its bodies, keeps them
    /// from colliding unless it lets them, and measures its separation.
    fn add_joint(&mut self, joint: Joint) -> JointHandle {
        let (a, b) = (joint.a, joint.b);
        for x in [a, b] {
            if x != NO_BODY {
                self.wake_body(x);
            }
        }
        if !joint.options.collide_connected && a != NO_BODY && b != NO_BODY {
            let pair = (a.min(b), a.max(b));
            let at = self.joints.no_collide.partition_point(|&p| p < pair);
            self.joints.no_collide.insert(at, pair);
            // A joint that keeps them from colliding takes the place of
            // any bond between them (a bond is a contact).
            self.remove_bonds_between(a, b);
            self.drop_contacts_between(a, b);
        }
        let raw = self.joints.arena.insert(joint);
        let sep = self.joint_separation(raw.index);
        self.joints.arena.at_mut(raw.index).expect("inserted").separation = sep;
        JointHandle(raw)
    }

    /// The joints of body `body` (slot), copied, in slot order.
    pub(super) fn joints_of(&self, body: u32) -> Vec<Joint> {
        self.joints.arena.iter().filter(|(_, j)| j.a == body || j.b == body).map(|(_, j)| j.clone()).collect()
    }

    /// Adds `joint`, a joint of a body that broke, to the piece `pick`
    /// chooses for its anchor (a world point): the anchor, the hinge's
    /// axis and reference and a weld's relative orientation carried from
    /// the broken body's frame (`was`, its pose when it broke) into the
    /// piece's; its warm start kept. A joint between two pieces of the
    /// same body is dropped.
    pub(super) fn pass_joint(&mut self, mut joint: Joint, was: u32, was_pose: Pose, pick: impl Fn(Vec3) -> BodyHandle) {
        let on_a = joint.a == was;
        let local = if on_a { joint.local_a } else { joint.local_b };
        let anchor = was_pose.transform_point(local);
        let piece = pick(anchor);
        let Some(body) = self.bodies.get(piece.0) else { return };
        let pose = body.pose;
        let turn = pose.rotation.inverse() * was_pose.rotation;
        let slot = piece.0.index;
        if on_a {
            (joint.a, joint.handle_a) = (slot, Some(piece));
            joint.local_a = pose.inverse_transform_point(anchor);
            (joint.axis_a, joint.ref_a) = (turn * joint.axis_a, turn * joint.ref_a);
            joint.relative = turn * joint.relative;
        } else {
            (joint.b, joint.handle_b) = (slot, Some(piece));
            joint.local_b = pose.inverse_transform_point(anchor);
            (joint.axis_b, joint.ref_b) = (turn * joint.axis_b, turn * joint.ref_b);
            joint.relative *= turn.inverse();
        }
        if joint.a == joint.b {
            return;
        }
        self.add_joint(joint);
    }

    /// Removes a joint and wakes its bodies; bodies it kept from colliding
    /// collide again from the next step.
    pub fn remove_joint(&mut self, h: JointHandle) -> Result<(), WorldError> {
        self.joints.arena.get(h.0).ok_or(WorldError::UnknownJoint)?;
        self.remove_joint_slot(h.0.index);
        Ok(())
    }

    fn remove_joint_slot(&mut self, index: u32) {
        let Some(handle) = self.joints.arena.handle_at(index) else { return };
        let j = self.joints.arena.remove(handle).expect("live");
        for x in [j.a, j.b] {
            if x != NO_BODY {
                self.wake_body(x);
            }
        }
        if !j.options.collide_connected && j.a != NO_BODY && j.b != NO_BODY {
            let pair = (j.a.min(j.b), j.a.max(j.b));
            if let Ok(at) = self.joints.no_collide.binary_search(&pair) {
                self.joints.no_collide.remove(at);
            }
            // Their colliders' pairs were refused while the joint stood:
            // ask the broad phase again.
            for x in [j.a, j.b] {
                let colliders = self.bodies.at(x).map(|b| b.colliders.clone()).unwrap_or_default();
                for ci in colliders {
                    let proxy = self.colliders.at(ci).expect("attached").proxy;
                    self.broad_phase.requery(proxy);
                }
            }
        }
    }

    /// Wakes the bodies joined to body slot `body` (it was moved by hand).
    pub(super) fn wake_jointed_to(&mut self, body: u32) {
        let others: Vec<u32> = self
            .joints
            .arena
            .iter()
            .filter_map(|(_, j)| {
                if j.a == body {
                    Some(j.b)
                } else if j.b == body {
                    Some(j.a)
                } else {
                    None
                }
            })
            .filter(|&x| x != NO_BODY)
            .collect();
        for x in others {
            self.wake_body(x);
        }
    }

    /// Removes every joint of body slot `body` (the body is going).
    pub(super) fn remove_joints_of(&mut self, body: u32) {
        let doomed: Vec<u32> =
            self.joints.arena.iter().filter(|(_, j)| j.a == body || j.b == body).map(|(h, _)| h.index).collect();
        for index in doomed {
            self.remove_joint_slot(index);
        }
    }

    /// The joint, if the handle is live.
    pub fn joint(&self, h: JointHandle) -> Option<&Joint> {
        self.joints.arena.get(h.0)
    }

    /// All joints, in slot order.
    pub fn joints(&self) -> impl Iterator<Item = (JointHandle, &Joint)> {
        self.joints.arena.iter().map(|(h, j)| (JointHandle(h), j))
    }

    /// Number of joints.
    pub fn joint_count(&self) -> usize {
        self.joints.arena.len()
    }

    /// Joint events of the last step (the joints that broke), in joint
    /// slot order.
    pub fn joint_events(&self) -> &[JointEvent] {
        &self.joints.events
    }

    /// The world points of a joint's two anchors now.
    pub fn joint_anchors(&self, h: JointHandle) -> Option<(Vec3, Vec3)> {
        let j = self.joints.arena.get(h.0)?;
        Some(self.anchors_of(j))
    }

    fn anchors_of(&self, j: &Joint) -> (Vec3, Vec3) {
        let point = |x: u32, local: Vec3| match self.bodies.at(x) {
            Some(b) => b.pose.transform_point(local),
            None => local,
        };
        (point(j.a, j.local_a), point(j.b, j.local_b))
    }

    /// Joint slot `index`'s separation now (see [`Joint::separation`]).
    fn joint_separation(&self, index: u32) -> f32 {
        let Some(j) = self.joints.arena.at(index) else { return 0.0 };
        let (pa, pb) = self.anchors_of(j);
        let d = (pb - pa).length();
        match j.kind {
            JointKind::Spherical | JointKind::Revolute | JointKind::Fixed => d,
            JointKind::Distance if j.options.spring.is_some_and(|(hz, _)| hz > 0.0) => 0.0,
            JointKind::Distance => (d - j.options.length).abs(),
            JointKind::Rope => (d - j.options.length).max(0.0),
        }
    }

    /// The end of a step for the joints: each one's separation, then, in
    /// slot order, those whose force or torque over the step went above
    /// their thresholds are removed and reported. Returns how many broke.
    pub(super) fn finish_joints(&mut self) -> usize {
        self.joints.events.clear();
        if self.joints.arena.len() == 0 {
            return 0;
        }
        let slots: Vec<u32> = self.joints.arena.iter().map(|(h, _)| h.index).collect();
        let mut broken = Vec::new();
        for &index in &slots {
            let sep = self.joint_separation(index);
            let j = self.joints.arena.at_mut(index).expect("live");
            j.separation = sep;
            let (force, torque) = (j.force.length(), j.torque.length());
            if force > j.options.break_force || torque > j.options.break_torque {
                let handle = JointHandle(self.joints.arena.handle_at(index).expect("live"));
                let j = self.joints.arena.at(index).expect("live");
                broken.push(JointEvent::Broken {
                    joint: handle,
                    body_a: j.handle_a,
                    body_b: j.handle_b,
                    force,
                    torque,
                    user_data: j.options.user_data,
                });
                self.remove_joint_slot(index);
            }
        }
        let n = broken.len();
        self.joints.events = broken;
        n
    }

    /// Removes the contacts between bodies `a` and `b` (slots), as removing
    /// a collider removes its contacts (`remove_collider_slot`).
    /// The broad phase forgets their pairs, which its filter then refuses
    /// while the joint stands.
    fn drop_contacts_between(&mut self, a: u32, b: u32) {
        let mut doomed = std::mem::take(&mut self.scratch.doomed_contacts);
        doomed.clear();
        let mut id = self.contacts.first_of(a);
        while id != NONE {
            let c = &self.contacts.list[id as usize];
            if c.other(a) == b {
                doomed.push(id);
                let (ca, cb) = (self.colliders.at(c.collider_a), self.colliders.at(c.collider_b));
                if let (Some(ca), Some(cb)) = (ca, cb) {
                    self.broad_phase.forget_pair(ca.proxy, cb.proxy);
                }
            }
            id = self.contacts.next_of(id, a);
        }
        self.drop_contacts(doomed);
    }
}

crate::snapshot::codec::persist!(JointSet { arena, no_collide } scratch { events });

/// Why a joint of `kind` cannot have `options`, if it cannot: what
/// `insert_joint` refuses, and restore with it.
pub(crate) fn invalid_options(kind: JointKind, options: &JointOptions) -> Option<&'static str> {
    if matches!(kind, JointKind::Distance | JointKind::Rope)
        && !(options.length.is_finite() && options.length > 0.0 && options.length <= MAX_LENGTH)
    {
        return Some("length must be positive and finite (at most 1e6 m)");
    }
    if let Some((lo, hi)) = options.limits {
        let pi = std::f32::consts::PI;
        if kind != JointKind::Revolute {
            return Some("limits are for revolute joints");
        }
        if !(lo.is_finite() && hi.is_finite() && -pi <= lo && lo <= hi && hi <= pi) {
            return Some("limits must satisfy -pi <= lo <= hi <= pi");
        }
    }
    if let Some((hz, zeta)) = options.spring {
        if kind != JointKind::Distance {
            return Some("a spring is for distance joints");
        }
        // Far beyond any a step can resolve, and short of overflowing the
        // soft step's coefficients (`(2π f h)²`).
        if !((0.0..=MAX_SPRING).contains(&hz) && (0.0..=MAX_SPRING).contains(&zeta)) {
            return Some("spring frequency and damping ratio must be in [0, 1e6]");
        }
    }
    if [options.break_force, options.break_torque].iter().any(|t| t.is_nan() || *t <= 0.0) {
        return Some("break thresholds must be positive (infinite: never)");
    }
    None
}
