//! The world's part of a snapshot (`snapshot/`): which of its fields are
//! state and which scratch, and the checks that tie a restored world's
//! parts together (every index into bodies, colliders, contacts, bonds
//! and the broad phase names a live one that agrees).

use super::{Scratch, World};
use crate::contact::NONE;
use crate::joint::NO_BODY;
use crate::snapshot::codec::{field_layout, invalid, Persist, Reader, Writer};
use crate::snapshot::SnapshotError;
use crate::threads::thread_pool;

impl Persist for World {
    fn save(&self, w: &mut Writer) {
        self.settings.save(w);
        self.time.save(w);
        self.bodies.save(w);
        self.colliders.save(w);
        self.broad_phase.save(w);
        self.contacts.save(w);
        self.awake.save(w);
        self.solver.save(w);
        self.events.save(w);
        self.joints.save(w);
        self.bonds.save(w);
        self.fracture.save(w);
    }

    /// The world's state; its scratch (the last step's faults, profile and
    /// events, the step's buffers) starts empty, and it runs on the
    /// default threads (`WorldSettings::threads` 0).
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        let settings: crate::WorldSettings = Persist::load(r)?;
        settings.validate().map_err(|e| invalid(format!("the settings: {e}")))?;
        let mut world = World {
            settings,
            time: Persist::load(r)?,
            bodies: Persist::load(r)?,
            colliders: Persist::load(r)?,
            broad_phase: Persist::load(r)?,
            contacts: Persist::load(r)?,
            awake: Persist::load(r)?,
            solver: Persist::load(r)?,
            events: Persist::load(r)?,
            joints: Persist::load(r)?,
            bonds: Persist::load(r)?,
            fracture: Persist::load(r)?,
            faulted: Vec::new(),
            profile: Default::default(),
            pool: thread_pool(settings.threads).map_err(|e| invalid(e.to_string()))?,
            scratch: Scratch::default(),
        };
        world.awake.restored(&world.bodies).map_err(invalid)?;
        world.check_restored().map_err(invalid)?;
        let (bodies, colliders) = (&world.bodies, &world.colliders);
        let kinematic = |c: u32| {
            colliders.at(c).and_then(|c| bodies.at(c.body)).is_some_and(|b| b.body_type == crate::BodyType::Kinematic)
        };
        world.broad_phase.restored(kinematic);
        Ok(world)
    }

    fn layout(out: &mut String) {
        out.push_str("World{");
        field_layout(out, "settings", |w: &World| &w.settings);
        field_layout(out, "time", |w: &World| &w.time);
        field_layout(out, "bodies", |w: &World| &w.bodies);
        field_layout(out, "colliders", |w: &World| &w.colliders);
        field_layout(out, "broad_phase", |w: &World| &w.broad_phase);
        field_layout(out, "contacts", |w: &World| &w.contacts);
        field_layout(out, "awake", |w: &World| &w.awake);
        field_layout(out, "solver", |w: &World| &w.solver);
        field_layout(out, "events", |w: &World| &w.events);
        field_layout(out, "joints", |w: &World| &w.joints);
        field_layout(out, "bonds", |w: &World| &w.bonds);
        field_layout(out, "fracture", |w: &World| &w.fracture);
        out.push('}');
    }

    fn wipe(&mut self) {
        self.bodies.wipe();
        self.colliders.wipe();
        self.broad_phase.wipe();
        self.contacts.wipe();
        self.awake.wipe();
        self.awake.restored(&self.bodies).expect("a running world's awake set agrees with its bodies");
        self.solver.wipe();
        self.events.wipe();
        self.joints.wipe();
        self.bonds.wipe();
        self.fracture.wipe();
        self.faulted.clear();
        self.profile = Default::default();
        self.scratch = Scratch::default();
    }
}

impl World {
    /// About the bytes a snapshot of this world takes (to size the buffer
    /// once): `docs/snapshot.md` measures them per body, contact and
    /// kept constraint.
    pub(crate) fn snapshot_size_hint(&self) -> usize {
        4096 + 400 * self.bodies.slot_count() + 480 * self.contacts.list.len() + 500 * self.solver.kept_constraints()
    }

    /// Checks that a restored world's parts agree (see the module docs).
    fn check_restored(&self) -> Result<(), String> {
        if !self.time.is_finite() || self.time < 0.0 {
            return Err(format!("time {}", self.time));
        }
        let n_bodies = self.bodies.slot_count();
        let body = |i: u32| self.bodies.at(i);
        let collider = |i: u32| self.colliders.at(i);
        // A pose a body or a collider can hold: finite, its rotation
        // normalised (within rounding of many steps).
        let unit = |p: &crate::math::Pose| p.is_finite() && (p.rotation.length() - 1.0).abs() <= 1e-3;
        for (h, b) in self.bodies.iter() {
            let i = h.index;
            let finite = unit(&b.pose)
                && b.linear_velocity.is_finite()
                && b.angular_velocity.is_finite()
                && b.local_com.is_finite()
                && b.mass.is_finite()
                && b.inv_mass.is_finite()
                && b.local_inv_inertia.is_finite();
            // (Between steps no body has a place among the solver's.)
            if b.solver_index != u32::MAX {
                return Err(format!("body {i}: a place among the solver's bodies between steps"));
            }
            if !finite {
                return Err(format!(
                    "body {i}: a pose, velocity or mass that is not finite, or a rotation not of unit length"
                ));
            }
            // What `insert_body` accepts of a builder (a split makes its
            // pieces from the parent's), and the step's own sums.
            let damping = [b.linear_damping, b.angular_damping].iter().all(|d| d.is_finite() && *d >= 0.0);
            let sums = b.force.is_finite() && b.torque.is_finite() && b.local_inertia.is_finite();
            // (A sleep time may pass `f32`'s largest: steps of absurd
            // length add up while a body rests without sleeping.)
            let sleep = b.sleep_time >= 0.0;
            if !(damping && b.gravity_scale.is_finite() && sums && sleep) {
                return Err(format!(
                    "body {i}: a damping, gravity scale, force, inertia or sleep time that is not finite or is negative"
                ));
            }
            for &c in &b.colliders {
                if collider(c).is_none_or(|c| c.body != i) {
                    return Err(format!("body {i}: collider {c} is not its own"));
                }
            }
        }
        // The extents, from the colliders (which are checked by now):
        // the broad phase sweeps each proxy by them.
        for (h, b) in self.bodies.iter() {
            let (min, max) = self.extents(h.index);
            let same = min.to_bits() == b.min_extent.to_bits() && max.to_bits() == b.max_extent.to_bits();
            if !same || !max.is_finite() || min.is_nan() {
                return Err(format!("body {}: extents that are not its colliders'", h.index));
            }
        }
        for (h, c) in self.colliders.iter() {
            let i = h.index;
            let owned = body(c.body).is_some_and(|b| b.colliders.contains(&i));
            if !owned || self.broad_phase.leaf_user(c.proxy) != Some(i) {
                return Err(format!("collider {i}: its body or its broad-phase proxy"));
            }
            // A static body's proxy is static and no other is: the pairs
            // leave static pairs out by it, and the sweep of a fast body
            // finds the static bodies by it (`query_fixed`).
            let is_static = body(c.body).is_some_and(|b| b.body_type == crate::BodyType::Static);
            if self.broad_phase.is_static(c.proxy) != is_static {
                return Err(format!(
                    "collider {i}: a broad-phase proxy static where its body is not, or not where it is"
                ));
            }
            // (A split makes its pieces at the collider's pose.)
            if !unit(&c.world_pose) || !unit(&c.local_pose) {
                return Err(format!("collider {i}: a pose that is not finite or a rotation not of unit length"));
            }
        }
        self.broad_phase.check_restored()?;
        for (id, c) in self.contacts.list.iter().enumerate().filter(|(_, c)| c.is_live()) {
            let pair = collider(c.collider_a).zip(collider(c.collider_b));
            let own_bond = |b: &crate::bond::Bond| {
                (b.collider_a.min(b.collider_b), b.collider_a.max(b.collider_b))
                    == (c.collider_a.min(c.collider_b), c.collider_a.max(c.collider_b))
            };
            let ok = pair.is_some_and(|(a, b)| a.body == c.body_a && b.body == c.body_b)
                && (c.bond == NONE || self.bonds.arena.at(c.bond).is_some_and(own_bond));
            if !ok {
                return Err(format!("contact {id}: its colliders, bodies or bond"));
            }
        }
        if self.contacts.heads() > n_bodies.max(1) {
            return Err("contact lists of bodies that do not exist".into());
        }
        if self.solver.kept_rotations() < n_bodies {
            return Err("the solver keeps fewer orientations than there are bodies".into());
        }
        for (h, j) in self.joints.arena.iter() {
            if [j.a, j.b].iter().any(|&b| b != NO_BODY && body(b).is_none()) || j.a == j.b {
                return Err(format!("joint {}: its bodies", h.index));
            }
            // (A step keeps no non-finite impulse: `Joints::store`.)
            let frames = [j.local_a, j.local_b, j.axis_a, j.axis_b, j.ref_a, j.ref_b];
            let state = [j.linear_impulse, j.angular_impulse, j.force, j.torque];
            let finite = frames.iter().chain(&state).all(|v| v.is_finite())
                && j.relative.is_finite()
                && j.extra_impulse.iter().all(|x| x.is_finite());
            if !finite {
                return Err(format!("joint {}: an anchor, axis, impulse or force that is not finite", h.index));
            }
            if let Some(why) = super::joints::invalid_options(j.kind, &j.options) {
                return Err(format!("joint {}: {why}", h.index));
            }
        }
        for (h, b) in self.bonds.arena.iter() {
            let sides = [(b.body_a, b.collider_a), (b.body_b, b.collider_b)];
            if sides.iter().any(|&(bi, ci)| collider(ci).is_none_or(|c| c.body != bi)) {
                return Err(format!("bond {}: its bodies and colliders", h.index));
            }
            // What `insert_bond` takes, and the contact's coefficients the
            // bond hands back when it lets go (as the contact's are checked).
            let coefficients = b.contact_friction.is_finite()
                && b.contact_friction >= 0.0
                && (0.0..=1.0).contains(&b.contact_restitution);
            if let Some(why) = b.spec.invalid().or((!coefficients).then_some("its contact's friction or restitution")) {
                return Err(format!("bond {}: {why}", h.index));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
impl World {
    /// Each part's saved bytes, by name (for tests that say where two
    /// worlds differ).
    pub(crate) fn snapshot_parts(&self) -> Vec<(&'static str, Vec<u8>)> {
        use crate::snapshot::codec::saved as part;
        let mut parts = self.solver.snapshot_parts();
        parts.extend([
            part("settings", &self.settings),
            part("bodies", &self.bodies),
            part("colliders", &self.colliders),
            part("broad phase", &self.broad_phase),
            part("contacts", &self.contacts),
            part("awake", &self.awake),
            part("events", &self.events),
            part("joints", &self.joints),
            part("bonds", &self.bonds),
            part("fracture", &self.fracture),
        ]);
        parts
    }
}

/// Regression tests of forged snapshots that restore once accepted and a
/// step then broke: each forges a running world's state (its snapshot
/// then carries a valid header and checksum) and requires restore to
/// refuse it, naming what is wrong.
#[cfg(test)]
mod forged {
    use crate::scenes::{add_ball, add_ground, add_pyramid, add_wall, WallSpec, BRICK, STEEL};
    use crate::{SnapshotError, Vec3, World, WorldSettings};

    const DT: f32 = 1.0 / 60.0;

    fn pile() -> World {
        let mut w = World::new(WorldSettings { threads: 1, ..WorldSettings::default() }).unwrap();
        add_ground(&mut w, 0.0, BRICK).unwrap();
        add_pyramid(&mut w, 3, 0.5, 0.0, Vec3::ZERO, BRICK).unwrap();
        add_ball(&mut w, 0.05, Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.0, -20.0, 0.0), STEEL, true).unwrap();
        w.step(DT).unwrap();
        w
    }

    fn refused(w: &World, says: &str) {
        match World::restore(&w.snapshot()) {
            Err(SnapshotError::Invalid { what }) => assert!(what.contains(says), "refused for `{what}`, not `{says}`"),
            other => panic!("a forged snapshot ({says}) was not refused: {:?}", other.map(|_| ())),
        }
    }

    /// An awake body left out of the awake list: its island index was
    /// `u32::MAX` and `find_islands` indexed with it.
    #[test]
    fn an_awake_body_missing_from_the_awake_list_is_refused() {
        let mut w = pile();
        w.awake.list_mut().clear();
        refused(&w, "not in the awake list");
    }

    /// A body with a place among the solver's between steps: continuous
    /// collision read the solver's bodies at it.
    #[test]
    fn a_body_with_a_solver_place_between_steps_is_refused() {
        let mut w = pile();
        let ground = w.bodies.iter().find(|(_, b)| b.body_type == crate::BodyType::Static).unwrap().0.index;
        w.bodies.at_mut(ground).unwrap().solver_index = 1000;
        refused(&w, "solver's bodies");
    }

    /// A body whose largest extent is not its colliders': the broad phase
    /// swept its proxy by an infinite turn and its box was not finite (a
    /// debug assertion; found by the fuzz target).
    #[test]
    fn a_body_with_extents_not_its_colliders_is_refused() {
        for (min, max) in [(None, Some(f32::INFINITY)), (None, Some(f32::NAN)), (None, Some(7.0)), (Some(-1.0), None)] {
            let mut w = pile();
            let brick = w.bodies.iter().find(|(_, b)| b.body_type == crate::BodyType::Dynamic).unwrap().0.index;
            let b = w.bodies.at_mut(brick).unwrap();
            b.min_extent = min.unwrap_or(b.min_extent);
            b.max_extent = max.unwrap_or(b.max_extent);
            refused(&w, "extents");
        }
    }

    /// A collider whose pose holds a rotation of zero length: a brick that
    /// split made its pieces at that pose, which `insert_body` refused (a
    /// debug assertion; found by the fuzz target). Likewise a body's
    /// damping below zero, which a piece takes from its parent.
    #[test]
    fn a_collider_pose_or_body_damping_insert_would_refuse_is_refused() {
        let zero = crate::Quat::from_xyzw(0.0, 0.0, 0.0, 0.0);
        let poses: [fn(&mut crate::collider::Collider, crate::Quat); 2] =
            [|c, q| c.local_pose.rotation = q, |c, q| c.world_pose.rotation = q];
        for forge in poses {
            let mut w = pile();
            let brick = w.colliders.iter().find(|(_, c)| !matches!(c.shape, crate::Shape::HalfSpace(_))).unwrap();
            forge(w.colliders.at_mut(brick.0.index).unwrap(), zero);
            refused(&w, "collider");
        }
        let bodies: [fn(&mut crate::Body); 4] = [
            |b| b.angular_damping = -1.0,
            |b| b.gravity_scale = f32::NAN,
            |b| b.torque.x = f32::INFINITY,
            |b| b.sleep_time = f32::NAN,
        ];
        for forge in bodies {
            let mut w = pile();
            let body = w.bodies.iter().find(|(_, b)| b.body_type == crate::BodyType::Dynamic).unwrap().0.index;
            forge(w.bodies.at_mut(body).unwrap());
            refused(&w, "damping, gravity scale, force, inertia or sleep time");
        }
    }

    /// The flags that steer `query_fixed` are derived afresh on restore,
    /// not read: a world whose kinematic proxy lost its flag, whose
    /// internal nodes lost theirs and whose dynamic leaf claims one (as a
    /// snapshot of an earlier build or a forged one holds) restores with
    /// them right (`World::validate` checks each proxy's kind against its
    /// body, `BroadPhase::validate` the internal nodes), and the sweep
    /// still finds the kinematic body. A static proxy whose body is not
    /// static, or the reverse, is refused.
    #[test]
    fn the_fixed_proxies_flags_are_derived_on_restore_and_a_wrong_static_one_refused() {
        let mut w = pile();
        let plate = w.insert_body(crate::BodyBuilder::kinematic().position(Vec3::new(5.0, 1.0, 0.0))).unwrap();
        w.insert_collider(crate::ColliderBuilder::cuboid(1.0, 1.0, 0.005).unwrap(), plate).unwrap();
        w.step(DT).unwrap();
        let proxy = |w: &World, body: crate::BodyType| {
            w.colliders.iter().find(|(_, c)| w.bodies.at(c.body).unwrap().body_type == body).unwrap().1.proxy
        };
        let (kinematic, dynamic) = (proxy(&w, crate::BodyType::Kinematic), proxy(&w, crate::BodyType::Dynamic));
        w.broad_phase.forge_fixed_flags(kinematic, dynamic);
        let restored = World::restore(&w.snapshot()).unwrap();
        restored.validate();
        restored.broad_phase.validate();
        let around = crate::Aabb::from_center_half_extents(Vec3::new(5.0, 1.0, 0.0), Vec3::splat(0.1));
        let mut found = Vec::new();
        restored.broad_phase.query_fixed(&around, |c| {
            found.push(c);
            true
        });
        assert_eq!(found, vec![restored.broad_phase.user(kinematic)], "query_fixed after the restore");
        // A dynamic brick's proxy forged static.
        let mut w = pile();
        let dynamic = proxy(&w, crate::BodyType::Dynamic);
        w.broad_phase.forge_static(dynamic);
        refused(&w, "static where its body is not");
    }

    /// Forged heights in the broad phase's tree: balancing rotated a leaf
    /// as if it had children.
    #[test]
    fn a_broad_phase_tree_with_wrong_heights_is_refused() {
        let mut w = pile();
        let proxies: Vec<_> = w.colliders.iter().map(|(_, c)| c.proxy).collect();
        for (k, &p) in proxies.iter().enumerate() {
            w.broad_phase.set_height(p, 10 * k as u32);
        }
        refused(&w, "height");
    }

    /// Inner nodes of the tree at the largest height: the check of a
    /// parent's height (one more than its taller child's) overflowed
    /// (found by the fuzz target).
    #[test]
    fn a_broad_phase_tree_at_the_largest_height_is_refused() {
        let mut w = pile();
        w.broad_phase.set_inner_heights(u32::MAX);
        refused(&w, "height");
    }

    /// A standing grouping whose pairs lack the mark before the joints'
    /// links: the check of the links sliced past the end (found by the
    /// fuzz target).
    #[test]
    fn a_standing_grouping_without_its_mark_is_refused() {
        let mut w = pile();
        w.solver.partition.last_pairs_mut().clear();
        refused(&w, "mark");
    }

    /// The groupings' count at its largest: the next grouping overflowed
    /// it (found by the fuzz target). It wraps; the world steps on.
    #[test]
    fn a_grouping_count_at_its_largest_steps_on() {
        let mut w = pile();
        w.solver.partition.set_generation(u64::MAX);
        let mut copy = World::restore(&w.snapshot()).expect("any count restores");
        // (The ball reaches the pile and the contacts change: a grouping.)
        for _ in 0..60 {
            copy.step(DT).unwrap();
        }
    }

    /// A standing grouping whose groups of one phase share moving
    /// bodies: the threads solved dependent constraints at once (a data
    /// race: the same bytes gave different results from run to run).
    #[test]
    fn a_grouping_whose_groups_share_bodies_is_refused() {
        let mut w = World::new(WorldSettings { threads: 1, sleep_enabled: false, ..WorldSettings::default() }).unwrap();
        add_ground(&mut w, 0.0, BRICK).unwrap();
        add_wall(&mut w, &WallSpec { rows: 6, bricks_per_row: 6, ..WallSpec::default() }).unwrap();
        for _ in 0..40 {
            w.step(DT).unwrap();
        }
        World::restore(&w.snapshot()).expect("the unforged world restores");
        assert!(w.solver.partition.forge_singletons(), "the wall's grouping stands");
        refused(&w, "share body");
    }

    /// A contact whose kept impulses hold a NaN: the step warm-started
    /// with it, and the two computations of what the contact keeps
    /// disagreed on the NaN's bits (a debug assertion; found by the fuzz
    /// target). Each kind of number is refused on its own.
    #[test]
    fn a_contact_with_a_non_finite_number_is_refused() {
        type Forge = fn(&mut crate::contact::Contact);
        let forges: [(Forge, &str); 6] = [
            (|c| c.friction_impulse.x = f32::NAN, "friction, twist or rolling impulse"),
            (|c| c.normal_impulse[0] = f32::INFINITY, "normal impulse"),
            (|c| c.impact_impulse[1] = f32::NAN, "carried impact"),
            (|c| c.friction = -1.0, "friction coefficient"),
            (|c| c.restitution = f32::NAN, "restitution"),
            (|c| c.cache.separation[0] = f32::NAN, "recycling cache"),
        ];
        for (forge, says) in forges {
            let mut w = pile();
            let c = w.contacts.list.iter_mut().find(|c| c.is_live()).expect("the pile has contacts");
            forge(c);
            refused(&w, says);
        }
    }

    /// A kept constraint with a NaN among its numbers (a mass, an arm, a
    /// direction): the step's batches would start from it. A NaN in the
    /// block inverse of a lane whose block solve is off is read by nothing
    /// (a block too ill-conditioned to invert is left so) and restores.
    #[test]
    fn a_kept_constraint_with_a_non_finite_number_is_refused() {
        use crate::solver::{BLOCK_INVERSE_NUMBERS, LANE_NUMBERS};
        let forged = |at: usize, block: bool| {
            let mut copy = World::restore(&pile().snapshot()).expect("the unforged world restores");
            let lanes = copy.solver.carried.as_mut().expect("a restored world carries its lanes");
            assert!(!lanes.is_empty(), "the pile keeps constraints");
            let middle = lanes.len() / 2;
            lanes[middle].numbers[at] = f32::NAN.to_bits();
            lanes[middle].block = block;
            World::restore(&copy.snapshot()).map(|_| ())
        };
        match forged(7, false) {
            Err(SnapshotError::Invalid { what }) => assert!(what.contains("kept constraint"), "refused for `{what}`"),
            other => panic!("a NaN in a kept constraint was not refused: {other:?}"),
        }
        let in_inverse = LANE_NUMBERS - BLOCK_INVERSE_NUMBERS / 2;
        assert!(forged(in_inverse, true).is_err(), "a NaN in the inverse of a block in use");
        forged(in_inverse, false).expect("a NaN in the inverse of a block not in use");
    }

    /// A joint whose warm-start impulse is a NaN.
    #[test]
    fn a_joint_with_a_non_finite_impulse_is_refused() {
        let mut w = pile();
        let bodies: Vec<_> = w.bodies().filter(|(_, b)| b.is_dynamic()).map(|(h, _)| h).take(2).collect();
        w.insert_joint(crate::JointBuilder::spherical(bodies[0], bodies[1])).unwrap();
        w.step(DT).unwrap();
        World::restore(&w.snapshot()).expect("the unforged world restores");
        let slot = w.joints.arena.iter().next().expect("one joint").0.index;
        w.joints.arena.at_mut(slot).unwrap().angular_impulse.y = f32::NAN;
        refused(&w, "joint 0");
    }

    /// Options `insert_joint` refuses (a break threshold of NaN: a joint
    /// that never breaks and reports nothing), and a bond's spec
    /// `insert_bond` refuses (a negative strength) or contact friction
    /// below zero (handed to the contact when the bond lets go).
    #[test]
    fn joint_options_and_bond_specs_insert_would_refuse_are_refused() {
        let mut w = pile();
        let bodies: Vec<_> = w.bodies().filter(|(_, b)| b.is_dynamic()).map(|(h, _)| h).take(2).collect();
        w.insert_joint(crate::JointBuilder::spherical(bodies[0], bodies[1])).unwrap();
        let slot = w.joints.arena.iter().next().expect("one joint").0.index;
        w.joints.arena.at_mut(slot).unwrap().options.break_force = f32::NAN;
        refused(&w, "break thresholds");
        let bond = |forge: fn(&mut crate::bond::Bond), says: &str| {
            let mut w = pile();
            let bricks: Vec<_> = w.bodies().filter(|(_, b)| b.is_dynamic()).map(|(h, _)| h).take(3).collect();
            assert!(!w.bond_touching(&bricks, crate::BondSpec::LIME_MORTAR).unwrap().is_empty(), "touching bricks");
            let slot = w.bonds.arena.iter().next().unwrap().0.index;
            forge(w.bonds.arena.at_mut(slot).unwrap());
            refused(&w, says);
        };
        bond(|b| b.spec.tensile_strength = -1.0, "tensile strength");
        bond(|b| b.contact_friction = -0.5, "contact's friction");
    }
}
