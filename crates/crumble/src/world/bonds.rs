//! The world's bonds (`bond.rs`): inserting and removing them, handing
//! each to its pair's contact (which it takes the place of while it
//! holds), and what the end of a step does with them: each bond's forces
//! over the step, and breaking those that reached a limit.

use std::collections::HashMap;

use super::{World, WorldError};
use crate::body::{BodyHandle, BodyType};
use crate::bond::{
    face_stress, touch_tolerance, touching_faces, Bond, BondEvent, BondHandle, BondMode, BondSpec, BREAK_AT,
};
use crate::collider::ColliderHandle;
use crate::contact::{BondImpulse, Contact, FixedState, ManifoldCache, NONE};
use crate::math::Pose;

/// The world's bonds and what goes with them.
#[derive(Default)]
pub(super) struct BondSet {
    pub(super) arena: crate::arena::Arena<Bond>,
    /// The bond of each bonded collider pair `(lo, hi)` (as the contacts
    /// key theirs); only looked up, never walked, so its hashing leaks
    /// into no order.
    by_pair: HashMap<(u32, u32), u32, FixedState>,
    /// Events of the last step, in the order the bonds broke (slot order
    /// at the end of the step).
    pub(super) events: Vec<BondEvent>,
    /// The bonds breaking at the end of this step: slot, mode, force.
    breaking: Vec<(u32, BondMode, f32)>,
}

impl BondSet {
    /// The bond slot of collider pair `(a, b)` (`a < b`), if bonded.
    pub(super) fn of_pair(&self, a: u32, b: u32) -> Option<u32> {
        if self.by_pair.is_empty() {
            return None;
        }
        self.by_pair.get(&(a, b)).copied()
    }
}

impl World {
    /// Glues two touching bodies with a bond of `spec` (see [`crate::bond`])
    /// over the faces they touch along: the pair of their boxes' faces (or
    /// a box face and a half-space) most nearly opposed, within 3°, at most
    /// a millimetre apart (2% of the smaller box's smallest half extent if
    /// that is less), with the largest overlap. Both bodies are woken.
    ///
    /// Refused, with nothing changed: an unknown body
    /// ([`WorldError::UnknownBody`]); a body bonded to itself, neither
    /// body dynamic, a pair already bonded, a pair a joint keeps from
    /// colliding, bodies that do not touch face to face (balls have no
    /// faces), a strength or friction that is negative or not finite
    /// ([`WorldError::InvalidBond`]).
    pub fn insert_bond(&mut self, a: BodyHandle, b: BodyHandle, spec: BondSpec) -> Result<BondHandle, WorldError> {
        let bad = |why: &'static str| Err(WorldError::InvalidBond(why));
        if let Some(why) = spec.invalid() {
            return bad(why);
        }
        let ba = self.bodies.get(a.0).ok_or(WorldError::UnknownBody)?;
        let bb = self.bodies.get(b.0).ok_or(WorldError::UnknownBody)?;
        if a == b {
            return bad("a body bonded to itself");
        }
        if ba.body_type != BodyType::Dynamic && bb.body_type != BodyType::Dynamic {
            return bad("neither body is dynamic");
        }
        if self.joints.ignores(a.0.index, b.0.index) {
            return bad("a joint keeps the two bodies from colliding");
        }
        // The touching faces of the pair of colliders that touch most.
        let mut best = None;
        for &ci in &ba.colliders {
            for &cj in &bb.colliders {
                let (lo, hi) = (ci.min(cj), ci.max(cj));
                let (cl, ch) = (self.colliders.at(lo).expect("attached"), self.colliders.at(hi).expect("attached"));
                let tolerance = touch_tolerance(&cl.shape, &ch.shape);
                if let Some(face) = touching_faces(&cl.shape, &cl.world_pose, &ch.shape, &ch.world_pose, tolerance) {
                    if best.is_none_or(|(_, _, f): (u32, u32, crate::bond::FaceBond)| face.area > f.area) {
                        best = Some((lo, hi, face));
                    }
                }
            }
        }
        let Some((lo, hi, face)) = best else {
            return bad("the bodies do not touch face to face");
        };
        if self.bonds.of_pair(lo, hi).is_some() {
            return bad("the pair is already bonded");
        }
        let (cl, ch) = (self.colliders.at(lo).expect("attached"), self.colliders.at(hi).expect("attached"));
        let (pa, pb) = (cl.world_pose, ch.world_pose);
        let half = 0.5 * face.gap * face.normal;
        let (body_a, body_b) = (cl.body, ch.body);
        let handle = |x: u32| BodyHandle(self.bodies.handle_at(x).expect("live"));
        let bond = Bond {
            body_a,
            body_b,
            handle_a: handle(body_a),
            handle_b: handle(body_b),
            collider_a: lo,
            collider_b: hi,
            collider_handles: (
                ColliderHandle(self.colliders.handle_at(lo).expect("live")),
                ColliderHandle(self.colliders.handle_at(hi).expect("live")),
            ),
            spec,
            face,
            local_a: face.points.map(|p| pa.inverse_transform_point(p - half)),
            local_b: face.points.map(|p| pb.inverse_transform_point(p + half)),
            normal_a: pa.inverse_transform_vector(face.normal),
            contact_friction: crate::contact::combined_friction(cl.material.friction, ch.material.friction),
            contact_restitution: cl.material.restitution.max(ch.material.restitution),
            normal_force: 0.0,
            shear_force: 0.0,
            twist_torque: 0.0,
            utilisation: 0.0,
            opening: 0.0,
            slide: 0.0,
            // Half the anchors' diagonal (opposite corners 0 and 3).
            radius: 0.5 * (face.points[0] - face.points[3]).length(),
        };
        if !(bond.local_a.iter().chain(&bond.local_b).all(|p| p.is_finite()) && bond.normal_a.is_finite()) {
            return bad("the bond's anchors are not finite in the bodies' frames");
        }
        let h = self.bonds.arena.insert(bond);
        self.bonds.by_pair.insert((lo, hi), h.index);
        self.wake_body(body_a);
        self.wake_body(body_b);
        if let Some(id) = self.contacts.id_of(lo, hi) {
            self.attach_bond(id, h.index);
        }
        Ok(BondHandle(h))
    }

    /// Bonds every pair of `bodies` that touch face to face (as
    /// [`insert_bond`](Self::insert_bond) finds them), and each of them to
    /// every static body it touches face to face (a ground, a block it
    /// stands on), with the spec `spec(a, b)` gives the pair; returns the
    /// bonds made, in the order made: pairs by their lower then higher
    /// body slot (a static body's pair by the other body's slot first). A
    /// pair already bonded is left as it is; pairs that do not touch are
    /// skipped. Candidates come from a sweep over the boxes' bounds along
    /// x, so a wall of 10,000 bricks is bonded in a few milliseconds.
    ///
    /// Refused, with nothing changed: an unknown body
    /// ([`WorldError::UnknownBody`]); a spec that is not valid
    /// ([`WorldError::InvalidBond`], for the first pair that gets one).
    pub fn bond_touching_with(
        &mut self,
        bodies: &[BodyHandle],
        mut spec: impl FnMut(BodyHandle, BodyHandle) -> BondSpec,
    ) -> Result<Vec<BondHandle>, WorldError> {
        // Every collider of the listed bodies and of the static bodies,
        // with its bounds grown by the touching tolerance (a millimetre at
        // most), and whether it is listed; half-spaces apart.
        let mut listed = vec![false; self.bodies.next_index() as usize];
        for h in bodies {
            self.bodies.get(h.0).ok_or(WorldError::UnknownBody)?;
            listed[h.0.index as usize] = true;
        }
        let mut boxes: Vec<(f32, f32, crate::aabb::Aabb, u32)> = Vec::new();
        let mut planes: Vec<u32> = Vec::new();
        for (h, c) in self.colliders.iter() {
            let on_list = listed[c.body as usize];
            let fixed = self.bodies.at(c.body).expect("parent").body_type == BodyType::Static;
            if !(on_list || fixed) {
                continue;
            }
            let index = h.index;
            if let crate::shape::Shape::HalfSpace(_) = c.shape {
                planes.push(index);
                continue;
            }
            let aabb = c.shape.aabb(&c.world_pose).expanded(1e-3);
            boxes.push((aabb.min.x, aabb.max.x, aabb, index));
        }
        boxes.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.3.cmp(&q.3)));
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        let body_of = |ci: u32| self.colliders.at(ci).expect("live").body;
        for (i, &(_, max_x, aabb, ci)) in boxes.iter().enumerate() {
            for &(min_x, _, other, cj) in &boxes[i + 1..] {
                if min_x > max_x {
                    break;
                }
                let (bi, bj) = (body_of(ci), body_of(cj));
                if bi != bj && (listed[bi as usize] || listed[bj as usize]) && aabb.overlaps(&other) {
                    pairs.push((bi, bj));
                }
            }
        }
        for &ci in &planes {
            let plane_body = body_of(ci);
            for &(_, _, _, cj) in &boxes {
                let bj = body_of(cj);
                if listed[bj as usize] && bj != plane_body {
                    pairs.push((bj, plane_body));
                }
            }
        }
        // Each pair once: two listed bodies lower slot first, else the
        // listed body first; in that order.
        let canon = |(a, b): (u32, u32)| match (listed[a as usize], listed[b as usize]) {
            (true, true) => (a.min(b), a.max(b)),
            (true, false) => (a, b),
            _ => (b, a),
        };
        for p in &mut pairs {
            *p = canon(*p);
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut made = Vec::new();
        for (a, b) in pairs {
            let ha = BodyHandle(self.bodies.handle_at(a).expect("live"));
            let hb = BodyHandle(self.bodies.handle_at(b).expect("live"));
            match self.insert_bond(ha, hb, spec(ha, hb)) {
                Ok(h) => made.push(h),
                Err(WorldError::InvalidBond("the bodies do not touch face to face"))
                | Err(WorldError::InvalidBond("the pair is already bonded"))
                | Err(WorldError::InvalidBond("neither body is dynamic"))
                | Err(WorldError::InvalidBond("a joint keeps the two bodies from colliding")) => {}
                Err(e) => {
                    for h in made {
                        self.remove_bond(h).expect("just made");
                    }
                    return Err(e);
                }
            }
        }
        Ok(made)
    }

    /// [`bond_touching_with`](Self::bond_touching_with) with one spec for
    /// every pair.
    pub fn bond_touching(&mut self, bodies: &[BodyHandle], spec: BondSpec) -> Result<Vec<BondHandle>, WorldError> {
        self.bond_touching_with(bodies, |_, _| spec)
    }

    /// Removes a bond; its pair collides as an ordinary contact from the
    /// next step on. Both bodies are woken.
    pub fn remove_bond(&mut self, h: BondHandle) -> Result<(), WorldError> {
        if self.bonds.arena.get(h.0).is_none() {
            return Err(WorldError::UnknownBond);
        }
        self.remove_bond_slot(h.0.index);
        Ok(())
    }

    /// The bond, if the handle is live.
    pub fn bond(&self, h: BondHandle) -> Option<&Bond> {
        self.bonds.arena.get(h.0)
    }

    /// All bonds, in slot order.
    pub fn bonds(&self) -> impl Iterator<Item = (BondHandle, &Bond)> {
        self.bonds.arena.iter().map(|(h, b)| (BondHandle(h), b))
    }

    /// Number of bonds.
    pub fn bond_count(&self) -> usize {
        self.bonds.arena.len()
    }

    /// Bond events of the last step (the bonds that broke), in the order
    /// they broke.
    pub fn bond_events(&self) -> &[BondEvent] {
        &self.bonds.events
    }

    /// Hands bond `slot` to the pair's contact `id`: from now on the
    /// contact's manifold is the bond's anchors, its points may pull, its
    /// friction is the bond's and it does not bounce.
    pub(super) fn attach_bond(&mut self, id: u32, slot: u32) {
        let bond = self.bonds.arena.at(slot).expect("live bond");
        let (pa, pb) = (self.collider_pose(bond.collider_a), self.collider_pose(bond.collider_b));
        let c = &mut self.contacts.list[id as usize];
        debug_assert!(c.collider_a == bond.collider_a && c.collider_b == bond.collider_b);
        let area = bond.face.area;
        c.bond = slot;
        // (At most `f32`'s largest: a strength near it, which `BondSpec`
        // accepts, times a large face stays finite, and unbreakable.)
        c.bond_strength =
            [bond.spec.tensile_strength * area / 4.0, bond.spec.shear_strength * area].map(|x| x.min(f32::MAX));
        c.bond_impulse = BondImpulse::ZERO;
        c.friction = bond.spec.friction;
        c.restitution = 0.0;
        let mut cache = ManifoldCache::EMPTY;
        cache.normal_a = bond.normal_a;
        cache.local_a = bond.local_a;
        cache.local_b = bond.local_b;
        cache.valid = true;
        c.cache = cache;
        c.follow_bond(&pa, &pb);
        // The narrow phase's points are gone: their impulses belong to
        // other points. And the bond is new: its unit settles (with its
        // bonds regularised, `BOND_SETTLING_PASSES`) as a fresh wall's does.
        c.normal_impulse = [0.0; crate::collision::MAX_MANIFOLD_POINTS];
        c.impact_approach = [0.0; crate::collision::MAX_MANIFOLD_POINTS];
        c.impact_impulse = [0.0; crate::collision::MAX_MANIFOLD_POINTS];
        c.solved_steps = 0;
    }

    fn collider_pose(&self, collider: u32) -> Pose {
        self.colliders.at(collider).expect("attached").world_pose
    }

    /// Gives contact `id` back to the narrow phase: the bond it held is
    /// gone. It keeps its pushing impulses (a bond that pulled keeps
    /// none of its pull).
    fn detach_bond(&mut self, id: u32, bond: &Bond) {
        let c = &mut self.contacts.list[id as usize];
        c.bond = NONE;
        c.bond_strength = [0.0; 2];
        c.bond_impulse = BondImpulse::ZERO;
        (c.bond_slide, c.bond_twist) = (crate::math::Vec3::ZERO, 0.0);
        // The bond's shear was held by cohesion, which a contact has not:
        // its friction starts afresh.
        (c.friction_impulse, c.twist_impulse) = (crate::math::Vec3::ZERO, 0.0);
        c.friction = bond.contact_friction;
        c.restitution = bond.contact_restitution;
        c.cache.valid = false;
        c.recycled = false;
        for x in &mut c.normal_impulse {
            *x = x.max(0.0);
        }
        // A bond that breaks in a step ends between the solver's write-back
        // and the events: the contact's mark follows.
        self.contacts.remark(id);
    }

    /// Removes bond `slot` (live) and gives its contact, if any, back to
    /// the narrow phase; wakes both bodies.
    fn remove_bond_slot(&mut self, slot: u32) {
        let h = self.bonds.arena.handle_at(slot).expect("live bond");
        let bond = self.bonds.arena.remove(h).expect("live bond");
        self.bonds.by_pair.remove(&(bond.collider_a, bond.collider_b));
        if let Some(id) = self.contacts.id_of(bond.collider_a, bond.collider_b) {
            self.detach_bond(id, &bond);
        }
        for x in [bond.body_a, bond.body_b] {
            if self.bodies.at(x).is_some() {
                self.wake_body(x);
            }
        }
    }

    /// Removes every bond between body slots `a` and `b`.
    pub(super) fn remove_bonds_between(&mut self, a: u32, b: u32) {
        self.remove_bonds_where(|x| (x.body_a, x.body_b) == (a, b) || (x.body_a, x.body_b) == (b, a));
    }

    /// Removes every bond of collider slot `collider` (it is going).
    pub(super) fn remove_bonds_of_collider(&mut self, collider: u32) {
        self.remove_bonds_where(|x| x.collider_a == collider || x.collider_b == collider);
    }

    /// Removes every bond that `doomed` picks, in slot order.
    fn remove_bonds_where(&mut self, doomed: impl Fn(&Bond) -> bool) {
        if self.bonds.arena.len() == 0 {
            return;
        }
        let slots: Vec<u32> = self.bonds.arena.iter().filter(|(_, x)| doomed(x)).map(|(h, _)| h.index).collect();
        for slot in slots {
            self.remove_bond_slot(slot);
        }
    }

    /// A bonded contact the broad phase lost (its bodies were moved apart
    /// beyond the margins): its bond breaks, `Separated`. Called with the
    /// contact already removed.
    pub(super) fn bond_separated(&mut self, removed: &Contact) {
        if removed.bond != NONE {
            self.bonds.breaking.push((removed.bond, BondMode::Separated, 0.0));
        }
    }

    /// The end of a step for the bonds: each bonded contact the solver
    /// worked on is judged on the step's impulses (see `bond.rs`), and
    /// the bonds that reached a limit break, in slot order. Returns how
    /// many broke.
    pub(super) fn finish_bonds(&mut self, dt: f32) -> usize {
        if self.bonds.arena.len() == 0 {
            return 0;
        }
        let mut breaking = std::mem::take(&mut self.bonds.breaking);
        for k in 0..self.contacts.active.len() {
            let id = self.contacts.active[k];
            let c = &mut self.contacts.list[id as usize];
            if c.bond == NONE {
                continue;
            }
            let impulse = std::mem::replace(&mut c.bond_impulse, BondImpulse::ZERO);
            let slot = c.bond;
            let opening = c.manifold.points().iter().map(|p| p.separation).fold(f32::NEG_INFINITY, f32::max);
            let slide = c.bond_slide.length();
            let bond = self.bonds.arena.at_mut(slot).expect("a contact's bond is live");
            let (n, tension, shear) = face_stress(impulse.normal, impulse.friction, impulse.twist, bond.radius, dt);
            let spec = bond.spec;
            let area = bond.face.area;
            let tension_limit = spec.tensile_strength * area;
            let shear_limit = spec.shear_strength * area + spec.friction * n.max(0.0);
            bond.normal_force = n;
            (bond.opening, bond.slide) = (opening, slide);
            bond.shear_force = impulse.friction.length() / dt;
            bond.twist_torque = impulse.twist.abs() / dt;
            let ratio = |x: f32, limit: f32| {
                if limit > 0.0 {
                    x / limit
                } else if x > 0.0 {
                    f32::INFINITY
                } else {
                    0.0
                }
            };
            let (ut, us) = (ratio(tension, tension_limit), ratio(shear, shear_limit));
            bond.utilisation = ut.max(us);
            // (A NaN breaks nothing: it compares false.)
            if ut >= BREAK_AT {
                breaking.push((slot, BondMode::Tension, tension));
            } else if us >= BREAK_AT {
                breaking.push((slot, BondMode::Shear, shear));
            }
        }
        breaking.sort_unstable_by_key(|&(slot, _, _)| slot);
        breaking.dedup_by_key(|&mut (slot, _, _)| slot);
        for &(slot, mode, force) in &breaking {
            let Some(h) = self.bonds.arena.handle_at(slot) else {
                continue;
            };
            let b = self.bonds.arena.at(slot).expect("live");
            self.bonds.events.push(BondEvent::Broken {
                bond: BondHandle(h),
                body_a: b.handle_a,
                body_b: b.handle_b,
                mode,
                force,
                user_data: b.spec.user_data,
            });
            self.remove_bond_slot(slot);
        }
        let n = breaking.len();
        breaking.clear();
        self.bonds.breaking = breaking;
        n
    }
}

/// The bonds and those breaking at the end of the next step; the pair
/// map follows from the bonds (it is only looked up, never iterated).
impl crate::snapshot::codec::Persist for BondSet {
    fn save(&self, w: &mut crate::snapshot::codec::Writer) {
        self.arena.save(w);
        self.breaking.save(w);
    }
    fn load(r: &mut crate::snapshot::codec::Reader) -> Result<Self, crate::snapshot::SnapshotError> {
        use crate::snapshot::codec::{invalid, Persist};
        let mut set = BondSet { arena: Persist::load(r)?, breaking: Persist::load(r)?, ..BondSet::default() };
        for (h, b) in set.arena.iter() {
            let key = (b.collider_a.min(b.collider_b), b.collider_a.max(b.collider_b));
            if set.by_pair.insert(key, h.index).is_some() {
                return Err(invalid(format!("bond {}: a second bond of its colliders", h.index)));
            }
        }
        if set.breaking.iter().any(|&(slot, _, _)| set.arena.at(slot).is_none()) {
            return Err(invalid("a breaking bond that is not there"));
        }
        Ok(set)
    }
    fn layout(out: &mut String) {
        out.push_str("BondSet{arena:");
        crate::arena::Arena::<Bond>::layout(out);
        out.push_str(",breaking:Vec<(u32,BondMode,f32)>}");
    }
    fn wipe(&mut self) {
        self.events.clear();
    }
}
