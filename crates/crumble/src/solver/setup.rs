//! The solver stage's set-up, phase by phase: the solver bodies, which
//! contacts become constraints, the deepest stacks, the order (groups and
//! units) and each unit's relax budget, which `Solver::step`
//! (`solver/step.rs`) calls in that order; and its mirror after the step,
//! the solver bodies written back to the bodies (`finish_bodies`).

use glam::Vec3A;

use super::integrate::cap_speed;
use super::manifold::kinetic_energy;
use super::step::{RelaxBudget, Solver, StepContext};
use crate::arena::Arena;
use crate::awake::resting;
use crate::body::{Body, BodyType};
use crate::collider::Collider;
use crate::contact::{Contact, ContactSet, SCAN_AHEAD};
use crate::joint::{Joint, NO_BODY};
use crate::math::{Mat3, Pose, Quat, Vec3};
use crate::partition::unit_span;
use crate::solver::{
    self, BodyParams, ConstraintInput, Gyroscopic, JointConstraint, SharedItems, Side, Softness, SolverBody,
};
use crate::threads::{for_each_index, uninit};
use crate::world::WorldSettings;

/// What the solver builds each contact constraint from (see
/// [`ConstraintSetup::input`]).
pub(super) struct ConstraintSetup<'a> {
    /// Softness of contacts between two moving bodies and of contacts
    /// with a body that cannot move.
    pub(super) soft: Softness,
    pub(super) static_soft: Softness,
    pub(super) contacts: &'a [Contact],
    pub(super) bodies: &'a Arena<Body>,
    pub(super) solver_bodies: &'a [SolverBody],
    /// Per solver body, whether it turned too far to keep (see
    /// `Solver::solver_turned`).
    pub(super) turned: &'a [bool],
    /// Per solver body, its pose and centre of mass at the start of the
    /// step (`Solver::step_start`).
    pub(super) starts: &'a [(Pose, Vec3)],
    /// Per constraint: `(contact, a, b)` with the solver bodies before
    /// `private_statics`.
    pub(super) source: &'a [(u32, u32, u32)],
    /// Per slot: its index in `source`, and its solver bodies after
    /// `private_statics`.
    pub(super) order: &'a [u32],
    pub(super) pairs: &'a [[u32; 2]],
}

impl<'a> ConstraintSetup<'a> {
    /// Starts loading what `input(slot)` will read: the contact, and of
    /// each moving body its velocities and mass (the first two lines of
    /// its `SolverBody`) and its centre. A pass over the batches streams
    /// more than the cache holds, so by the next build these are gone.
    #[inline(always)]
    pub(super) fn prefetch(&self, slot: u32) {
        let (ci, ia, ib) = self.source[self.order[slot as usize] as usize];
        Contact::prefetch_solver_fields(&self.contacts[ci as usize]);
        for i in [ia, ib] {
            if i != 0 {
                let body = &self.solver_bodies[i as usize] as *const SolverBody as *const u8;
                crate::contact::prefetch(body);
                crate::contact::prefetch(body.wrapping_add(64));
                crate::contact::prefetch(&self.starts[i as usize].1 as *const Vec3 as *const u8);
            }
        }
    }

    /// What the constraint of slot `slot` is built from.
    #[inline(always)]
    pub(super) fn input(&self, slot: u32) -> ConstraintInput<'a> {
        let (ci, ia, ib) = self.source[self.order[slot as usize] as usize];
        let [a, b] = self.pairs[slot as usize];
        let c = &self.contacts[ci as usize];
        let (sa, sb) = (&self.solver_bodies[ia as usize], &self.solver_bodies[ib as usize]);
        // A body that moves has its centre in the solver's compact list;
        // slot 0 stands for every immovable body, so theirs is read from
        // the body itself.
        let center = |solver: u32, body: u32| -> Vec3A {
            if solver != 0 {
                self.starts[solver as usize].1.into()
            } else {
                self.bodies.at(body).expect("body").center_of_mass().into()
            }
        };
        ConstraintInput {
            a,
            b,
            sa,
            sb,
            // The solver's vectors are `Vec3A` (one SIMD register each);
            // the conversions change no bits.
            xa: center(ia, c.body_a),
            xb: center(ib, c.body_b),
            normal: c.manifold.normal,
            points: c.manifold.points(),
            normal_impulse: &c.normal_impulse,
            impact_approach: &c.impact_approach,
            impact_impulse: &c.impact_impulse,
            friction_impulse: c.friction_impulse.into(),
            rolling_impulse: c.rolling_impulse.into(),
            twist_impulse: c.twist_impulse,
            rolling_arm: c.rolling_arm,
            friction: c.friction,
            restitution: c.restitution,
            softness: if sa.inv_mass == 0.0 || sb.inv_mass == 0.0 { self.static_soft } else { self.soft },
            contact: ci,
            bond: (c.bond != crate::contact::NONE).then_some(c.bond_strength),
            bond_slide: c.bond_slide.into(),
            bond_twist: c.bond_twist,
            may_keep: c.recycled && !self.turned[ia as usize] && !self.turned[ib as usize],
        }
    }
}

/// Stores what the contact cache keeps of a constraint (`kept`) in its
/// contact `c`, for the next step's warm start and the reports.
///
/// A constraint whose impulses went non-finite (a body of the pair faulted
/// in the step: a force past `f32`) keeps nothing: its contact starts the
/// next step cold, as a new one (`solved_steps` 0: it settles as one). A
/// kept NaN would warm-start every later step and fault the pair's bodies
/// in each, so that one push past `f32` would stop them for good.
///
/// Returns the contact's end-of-step mark ([`Contact::report_mark`]),
/// read here where the contact is in the cache.
#[inline]
pub(super) fn keep_impulses(c: &mut Contact, kept: solver::Kept) -> u8 {
    if !kept.is_finite() {
        c.start_cold();
        return c.report_mark();
    }
    c.normal_impulse[..kept.len].copy_from_slice(&kept.normal_impulse[..kept.len]);
    c.step_impulse = kept.step_impulse;
    c.friction_impulse = kept.friction_impulse;
    c.twist_impulse = kept.twist_impulse;
    c.rolling_impulse = kept.rolling_impulse;
    c.max_normal_impulse = kept.max_normal_impulse;
    c.impact_approach = kept.impact_approach;
    c.impact_impulse = kept.impact_impulse;
    c.solved_steps = c.solved_steps.saturating_add(1);
    if c.bond != crate::contact::NONE {
        c.bond_impulse = kept.bond;
    }
    c.report_mark()
}

impl Solver {
    /// Solver bodies: slot 0 stands for every static body, awake body k
    /// takes slot k + 1, and each body's `solver_index` names its slot.
    /// Each body fills only its own entries, so the threads share the
    /// bodies out, with the same bits. (Written in place of what was
    /// there, not filled first: a fill is a serial pass over megabytes.)
    pub(super) fn prepare_bodies(&mut self, ctx: &StepContext, awake: &[u32], bodies: &mut Arena<Body>) {
        let s = ctx.settings;
        let n = awake.len();
        {
            let bodies = bodies.shared();
            let keep_rotation = SharedItems::new(&mut self.keep_rotation);
            let solver_bodies = SharedItems::new(uninit(&mut self.solver_bodies, n + 1));
            let body_params = SharedItems::new(uninit(&mut self.body_params, n + 1));
            let step_start = SharedItems::new(uninit(&mut self.step_start, n + 1));
            let turned = SharedItems::new(uninit(&mut self.solver_turned, n + 1));
            // SAFETY: slot 0 is no body's.
            unsafe {
                solver_bodies.part(0..1)[0].write(SolverBody::STATIC);
                body_params.part(0..1)[0].write(BodyParams::STATIC);
                step_start.part(0..1)[0].write((Pose::IDENTITY, Vec3::ZERO));
                turned.part(0..1)[0].write(false);
            }
            let one = |k: usize| {
                let (bi, slot) = (awake[k], k + 1);
                // SAFETY: the awake list names each body once, and body k
                // alone writes slot k + 1 of the solver's arrays.
                let (b, reference, sb, params, start, turned) = unsafe {
                    (
                        bodies.at_mut(bi).expect("awake body"),
                        &mut keep_rotation.part(bi as usize..bi as usize + 1)[0],
                        &mut solver_bodies.part(slot..slot + 1)[0],
                        &mut body_params.part(slot..slot + 1)[0],
                        &mut step_start.part(slot..slot + 1)[0],
                        &mut turned.part(slot..slot + 1)[0],
                    )
                };
                b.solver_index = slot as u32;
                // `|q − q_ref|` is half the angle between them, to first order
                // (a dot product near 1 could not resolve 1e-4 rad in `f32`).
                let q = b.pose.rotation;
                let d = if q.dot(*reference) < 0.0 { q + *reference } else { q - *reference };
                // (A NaN counts as turned.)
                let within = d.length_squared() <= (0.25 * solver::KEEP_ANGLE).powi(2);
                turned.write(!within);
                if !within {
                    *reference = q;
                }
                let dynamic = b.body_type == BodyType::Dynamic;
                let inv_i = b.world_inv_inertia();
                let body = SolverBody {
                    v: b.linear_velocity.into(),
                    w: b.angular_velocity.into(),
                    dp: Vec3A::ZERO,
                    dq: Quat::IDENTITY,
                    inv_mass: b.inv_mass,
                    inv_i: inv_i.into(),
                    pv: Vec3A::ZERO,
                    pw: Vec3A::ZERO,
                    v0: Vec3A::ZERO,
                    w0: Vec3A::ZERO,
                    stamp: 0,
                };
                let li = b.local_inertia;
                let mut p = BodyParams {
                    q0: b.pose.rotation,
                    local_inertia: li,
                    local_inv_inertia: b.local_inv_inertia,
                    accel: if dynamic { s.gravity * b.gravity_scale + b.force * b.inv_mass } else { Vec3::ZERO },
                    ang_accel: if dynamic { inv_i * b.torque } else { Vec3::ZERO },
                    linear_damping: b.linear_damping,
                    angular_damping: b.angular_damping,
                    dynamic,
                    gyroscopic: if dynamic { Gyroscopic::of(&li) } else { Gyroscopic::None },
                    start_energy: 0.0,
                    start_velocity: b.linear_velocity,
                };
                if dynamic {
                    p.start_energy = kinetic_energy(&body, &p);
                }
                sb.write(body);
                params.write(p);
                start.write((b.pose, b.center_of_mass()));
            };
            let parallel = ctx.workers > 1 && n >= solver::PARALLEL_MIN_BODIES;
            for_each_index(ctx.pool, parallel, n, one);
        }
        // SAFETY: slot 0 and every body's slot were written above.
        unsafe {
            self.solver_bodies.set_len(n + 1);
            self.body_params.set_len(n + 1);
            self.step_start.set_len(n + 1);
            self.solver_turned.set_len(n + 1);
        }
    }

    /// Which active contacts become constraints, between which solver
    /// bodies: those with points and a moving body. Returns the contact
    /// points and how many constraints are new (`WorldSettings::settle_steps`).
    pub(super) fn select_constraints(
        &mut self,
        s: &WorldSettings,
        bodies: &Arena<Body>,
        contacts: &mut ContactSet,
    ) -> (usize, usize) {
        let up = -s.gravity.normalize_or_zero();
        self.constraint_source.clear();
        self.constraint_height.clear();
        self.constraint_new.clear();
        self.constraint_moving.clear();
        let mut new_constraints = 0;
        let mut points = 0;
        // Every active contact's end-of-step mark is written in this step:
        // here for those not solved, by `keep_impulses` for the others.
        contacts.report.resize(contacts.list.len(), 0);
        for k in 0..contacts.active.len() {
            contacts.prefetch_active(k + SCAN_AHEAD);
            let ci = contacts.active[k];
            let c = &mut contacts.list[ci as usize];
            if c.manifold.is_empty() {
                // Not solved this step: new again when it next touches
                // (`WorldSettings::settle_steps`). Written only when it
                // changes, so that the scan dirties no line.
                if c.solved_steps != 0 {
                    c.solved_steps = 0;
                }
                // No impact goes on through a step without contact.
                if c.impact_approach != [0.0; crate::collision::MAX_MANIFOLD_POINTS] {
                    c.impact_approach = [0.0; crate::collision::MAX_MANIFOLD_POINTS];
                    c.impact_impulse = [0.0; crate::collision::MAX_MANIFOLD_POINTS];
                }
                contacts.report[ci as usize] = c.report_mark();
                continue;
            }
            let c = &*c;
            let (ba, bb) = (bodies.at(c.body_a).expect("body"), bodies.at(c.body_b).expect("body"));
            let index = |b: &Body| {
                if b.body_type != BodyType::Static && !b.sleeping {
                    b.solver_index
                } else {
                    0
                }
            };
            let (ia, ib) = (index(ba), index(bb));
            if ia == 0 && ib == 0 {
                contacts.report[ci as usize] = c.report_mark();
                continue;
            }
            self.constraint_source.push((ci, ia, ib));
            points += c.manifold.len();
            // Read here, where the contact's first line is in the cache
            // anyway (the units' count meets the constraints in slot
            // order: read from the contacts, each would be a miss).
            let new = u32::from(c.solved_steps) < s.settle_steps;
            self.constraint_new.push(new);
            new_constraints += usize::from(new);
            self.constraint_moving.push(new && moving(c, ba, bb, s.restitution_threshold));
            if s.experimental.ordered_relax {
                let center = c.manifold.points().iter().map(|p| p.point).sum::<Vec3>() / c.manifold.len() as f32;
                self.constraint_height.push(center.dot(up));
            }
        }
        (points, new_constraints)
    }

    /// The joints of the step, in the world's joint order: those with an
    /// awake dynamic body, each built against its sides' state at the
    /// start of the step for substeps of `h` (`JointConstraint::build`),
    /// with its solver-body pair (0: a side that cannot move).
    pub(super) fn select_joints(&mut self, bodies: &Arena<Body>, joints: &Arena<Joint>, h: f32) {
        self.joints.constraints.clear();
        self.joint_pairs.clear();
        for (handle, j) in joints.iter() {
            let side = |index: u32| -> (Side, bool) {
                if index == NO_BODY {
                    return (Side { slot: 0, pose: Pose::IDENTITY, com: Vec3::ZERO }, false);
                }
                let b = bodies.at(index).expect("a joint's body lives");
                if b.body_type == BodyType::Static || b.sleeping {
                    (Side { slot: 0, pose: b.pose, com: b.center_of_mass() }, false)
                } else {
                    let slot = b.solver_index;
                    let (pose, com) = self.step_start[slot as usize];
                    (Side { slot, pose, com }, b.body_type == BodyType::Dynamic)
                }
            };
            let ((a, da), (b, db)) = (side(j.a), side(j.b));
            let (sa, sb) = (&self.solver_bodies[a.slot as usize], &self.solver_bodies[b.slot as usize]);
            // A dynamic body without mass yet (no collider) moves with no
            // force: a joint to it has nothing to solve (its block would be
            // zero, and its impulse infinite).
            let moves = |d: bool, s: &SolverBody| d && s.inv_mass > 0.0;
            if !(moves(da, sa) || moves(db, sb)) {
                continue;
            }
            self.joints.constraints.push(JointConstraint::build(handle.index, j, a, b, sa, sb, h));
            self.joint_pairs.push((a.slot, b.slot));
        }
        self.stiffen(h);
    }

    /// The joints' geometric stiffness (`JointConstraint::stiffness`)
    /// added to their bodies' inertia for the whole step, in every
    /// constraint's response alike (the joints', and the contacts', whose
    /// batches are then built afresh): solved with one body's inertia in
    /// the tree and another in the loop that closes on it, Gauss–Seidel
    /// between them diverged (a falling 32 × 32 net went non-finite).
    fn stiffen(&mut self, h: f32) {
        self.stiffened.clear();
        for c in &self.joints.constraints {
            self.stiffened.extend(c.stiffness(h).into_iter().flatten());
        }
        if self.stiffened.is_empty() && !self.was_stiffened {
            return;
        }
        // The bodies' masses differ from the last step's: no batch keeps
        // what it was built with.
        self.bodies_changed = true;
        self.was_stiffened = !self.stiffened.is_empty();
        // Summed per body in a fixed order (the joints'), then applied.
        self.stiffened.sort_by_key(|&(slot, _)| slot);
        let mut k = 0;
        while k < self.stiffened.len() {
            let slot = self.stiffened[k].0;
            let mut sum = Mat3::ZERO;
            while k < self.stiffened.len() && self.stiffened[k].0 == slot {
                sum += self.stiffened[k].1;
                k += 1;
            }
            let b = &mut self.solver_bodies[slot as usize];
            let inertia = Mat3::from(b.inv_i).inverse() + sum;
            let inv = inertia.inverse();
            if inv.is_finite() {
                b.inv_i = inv.into();
            }
        }
        for c in &mut self.joints.constraints {
            c.update_masses(&self.solver_bodies);
        }
    }

    /// Each joint's unit: its island's, or for an island of joints alone
    /// a unit after the partition's (numbered in the joints' order); then
    /// the joints are ordered unit by unit and their trees found
    /// (`Joints::build`). Returns the number of units.
    fn assign_joint_units(&mut self) -> usize {
        let contact_units = self.partition.units().len();
        let mut total = contact_units;
        self.joint_units.clear();
        for &(a, b) in &self.joint_pairs {
            let slot = if a != 0 { a } else { b };
            let unit = match self.partition.unit_of_body(slot) {
                Some(u) => u,
                None => {
                    let root = self.partition.island_of(slot) as usize;
                    if self.island_unit.len() <= root {
                        self.island_unit.resize(root + 1, u32::MAX);
                    }
                    if self.island_unit[root] == u32::MAX {
                        self.island_unit[root] = total as u32;
                        self.island_roots.push(root as u32);
                        total += 1;
                    }
                    self.island_unit[root]
                }
            };
            self.joint_units.push(unit);
        }
        for &r in &self.island_roots {
            self.island_unit[r as usize] = u32::MAX;
        }
        self.island_roots.clear();
        self.joints.build(&self.joint_units, total, &self.solver_bodies);
        total
    }

    /// Each body's layer in its stack, and the deepest stack's layers: a
    /// unit's deepest stack sets its minimum number of relax passes
    /// (`WorldSettings::relax_per_layer`, `RelaxBudget`). Slot 0 is every
    /// static body, and kinematic bodies have no inverse mass: both hold
    /// stacks up.
    pub(super) fn measure_stacks(&mut self) -> u32 {
        let solver_bodies = &self.solver_bodies;
        // Joints are edges too: a body hanging on a chain is as many
        // layers from its anchor as the chain has links.
        let pairs = self.constraint_source.iter().map(|&(_, a, b)| (a, b)).chain(self.joint_pairs.iter().copied());
        self.stack_depth.deepest(solver_bodies.len(), pairs, |i| solver_bodies[i].inv_mass == 0.0)
    }

    /// The order the solver visits the constraints in, as a slot for each
    /// (the batches are laid out in slot order, and each constraint is
    /// built straight into its batch lane), and per slot its constraint,
    /// its solver bodies and its moving bodies.
    pub(super) fn order_constraints(&mut self, s: &WorldSettings) {
        let count = self.constraint_source.len();
        let up = -s.gravity.normalize_or_zero();
        if s.experimental.ordered_relax {
            // Bottom-up by the height of each manifold's centre (see
            // `SolverExperiments::ordered_relax`). Stable sort, total order
            // on the keys: deterministic. The order is the point, so it is
            // solved serially, as one group.
            let heights = &self.constraint_height;
            self.constraint_order.clear();
            self.constraint_order.extend(0..count as u32);
            self.constraint_order.sort_by(|&i, &j| heights[i as usize].total_cmp(&heights[j as usize]));
            self.constraint_slot.clear();
            self.constraint_slot.resize(count, 0);
            for (k, &i) in self.constraint_order.iter().enumerate() {
                self.constraint_slot[i as usize] = k as u32;
            }
            self.partition.all_serial(count);
        } else {
            // Cut the constraints into groups that share no moving body
            // (`partition.rs`), each group contiguous and in the
            // partition's order. (Unchanged, it keeps the last step's slots.)
            let starts = &self.step_start;
            let regrouped = self.partition.build(
                self.solver_bodies.len(),
                self.constraint_source.iter().map(|&(_, a, b)| (a, b)),
                self.joint_pairs.iter().copied(),
                |i| starts[i].1,
                up,
            );
            if regrouped {
                self.partition.slots(&mut self.constraint_slot);
            }
        }
        // Per slot: which constraint, its solver bodies (each group with a
        // private static stand-in, `private_statics`, later), and its
        // moving bodies, which order the batches.
        self.constraint_order.resize(count, 0);
        self.constraint_pairs.resize(count, [0; 2]);
        self.constraint_movers.resize(count, [u32::MAX; 2]);
        for (i, (&(_, ia, ib), &slot)) in self.constraint_source.iter().zip(&self.constraint_slot).enumerate() {
            let mover = |x: u32| if self.solver_bodies[x as usize].inv_mass != 0.0 { x } else { u32::MAX };
            self.constraint_order[slot as usize] = i as u32;
            self.constraint_pairs[slot as usize] = [ia, ib];
            self.constraint_movers[slot as usize] = [mover(ia), mover(ib)];
        }
    }

    /// Each unit's bodies (kinematic ones too: a unit integrates them),
    /// the moving bodies in none, and each unit's relax budget; then each
    /// group's private static stand-in. Returns how many units settle.
    pub(super) fn form_units(&mut self, s: &WorldSettings, new_constraints: usize) -> usize {
        let total = self.assign_joint_units();
        self.unit_bodies.clear();
        self.unit_starts.clear();
        self.body_unit.clear();
        self.body_unit.resize(self.solver_bodies.len(), u32::MAX);
        let groups = self.partition.groups();
        let contact_units = self.partition.units().len();
        for u in 0..total {
            self.unit_starts.push(self.unit_bodies.len() as u32);
            let pairs = match self.partition.units().get(u) {
                Some(phases) => &self.constraint_pairs[unit_span(groups, phases)],
                None => &[],
            };
            let joints = self.joints.unit_bodies(u);
            for x in pairs.iter().flatten().copied().chain(joints) {
                if x != 0 && self.body_unit[x as usize] == u32::MAX {
                    self.body_unit[x as usize] = u as u32;
                    self.unit_bodies.push(x);
                }
            }
        }
        self.unit_starts.push(self.unit_bodies.len() as u32);
        self.unit_budgets.clear();
        let mut settling = 0;
        for (u, w) in self.unit_starts.windows(2).enumerate() {
            let depth = self.unit_bodies[w[0] as usize..w[1] as usize]
                .iter()
                .map(|&i| self.stack_depth.layer(i as usize))
                .max()
                .unwrap_or(0);
            let mut budget = RelaxBudget::new(s, depth);
            let Some(phases) = self.partition.units().get(u) else {
                // Joints alone: one pass solves trees without loops or
                // one-sided rows exactly (`solver/joints.rs`). Otherwise the
                // trees and the rows between them meet by Gauss–Seidel, and
                // along a net's loops (each closing on a path through the
                // tree as long as the net) that converges too slowly for
                // passes beyond the stack's minimum to pay: a 32 × 32 net
                // falling from one edge ran every substep to the cap of 64
                // and never slept; at its minimum (20) it falls as far,
                // with joints open 4 cm at most instead of 2, and sleeps
                // within 7 s.
                budget = if self.joints.exact(u) { budget.exact() } else { budget.no_more_than_min() };
                self.unit_budgets.push(budget);
                continue;
            };
            debug_assert!(u < contact_units);
            // A unit at least half of whose constraints are new settles
            // (`WorldSettings::settle_steps`); a step with none new skips
            // the count.
            if new_constraints > 0 {
                let slots = unit_span(groups, phases);
                let total = slots.len();
                let order = &self.constraint_order[slots];
                let new = order.iter().filter(|&&i| self.constraint_new[i as usize]).count();
                if total > 0 && 2 * new >= total {
                    // A unit in which something moves (a new contact whose
                    // bodies move against each other faster than a resting
                    // contact may, `moving`) is not a pile coming to rest:
                    // it settles within the ordinary cap, not
                    // `max_settle_iterations` (`RelaxBudget::settling`;
                    // the measurements are in `docs/solver.md`, "Settling").
                    let moves = order.iter().any(|&i| self.constraint_moving[i as usize]);
                    budget = budget.settling(s, moves);
                    settling += 1;
                }
            }
            self.unit_budgets.push(budget);
        }
        self.free_bodies.clear();
        self.free_bodies
            .extend((1..self.solver_bodies.len() as u32).filter(|&i| self.body_unit[i as usize] == u32::MAX));
        solver::private_statics(&mut self.solver_bodies, &mut self.constraint_pairs, self.partition.groups());
        settling
    }

    /// Writes the solver's result back to the `awake` bodies (each fills
    /// only its own, so on the threads when there are many), guards
    /// against non-finite state, and updates sleep timers and collider
    /// poses. Returns the positions in `awake` of the bodies whose step was
    /// not finite, in order: each was put back where the step began and
    /// stopped.
    /// Solver body `si`'s share of its island's energy bound
    /// (`energy.rs`) over a step of `dt`: its kinetic energy now and at the
    /// step's start, the energy it may hold, and its weight `m |a|`;
    /// `None` under an applied torque, whose work is not tracked.
    ///
    /// What it may hold is the start plus the work of gravity and its
    /// applied force, `m a · (v₀ + v₁) dt / 2`: in free flight
    /// (`v₁ = v₀ + a dt`) exactly the gain `½ m (v₁² − v₀²)`. It counts the
    /// motion the velocities made, not the body's displacement: the
    /// push-out moves a body without velocity, and gravity's work over
    /// that lift is not the body's to lose.
    pub(crate) fn energy_share(&self, si: usize, dt: f32) -> Option<EnergyShare> {
        let (b, p) = (&self.solver_bodies[si], &self.body_params[si]);
        if !p.dynamic || p.ang_accel != Vec3::ZERO {
            return None;
        }
        let mass = 1.0 / b.inv_mass;
        let travel = (p.start_velocity + Vec3::from(b.v)) * (0.5 * dt);
        Some(EnergyShare {
            now: kinetic_energy(b, p),
            start: p.start_energy,
            allowed: p.start_energy
                + mass * p.accel.dot(travel)
                + self.impact_allowance.get(si).copied().unwrap_or(0.0),
            weight: mass * p.accel.length(),
        })
    }

    /// Caps solver body `si`'s speed at `max_speed` and its angular speed
    /// at `max_spin`, by direction (see `energy.rs`).
    pub(crate) fn cap_velocity(&mut self, si: usize, max_speed: f32, max_spin: f32) {
        let b = &mut self.solver_bodies[si];
        b.v = cap_speed(b.v, max_speed);
        b.w = cap_speed(b.w, max_spin);
    }

    /// Scales solver body `si`'s velocities by `s` (see `energy.rs`).
    pub(crate) fn scale_velocity(&mut self, si: usize, s: f32) {
        let b = &mut self.solver_bodies[si];
        b.v *= s;
        b.w *= s;
    }

    pub(crate) fn finish_bodies(
        &self,
        ctx: &StepContext,
        awake: &[u32],
        bodies: &mut Arena<Body>,
        colliders: &mut Arena<Collider>,
    ) -> Vec<usize> {
        let (threshold, dt) = (ctx.settings.sleep_threshold, ctx.dt);
        let n = awake.len();
        // Positions of the bodies whose step was not finite: rare, so a
        // lock costs nothing, and no per-step pass marks or scans them.
        let faults = std::sync::Mutex::new(Vec::new());
        {
            let (solver_bodies, step_start) = (&self.solver_bodies, &self.step_start);
            let bodies = bodies.shared();
            let colliders = colliders.shared();
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
                    b.faulted = false;
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
            let parallel = ctx.workers > 1 && n >= solver::PARALLEL_MIN_BODIES;
            for_each_index(ctx.pool, parallel, n, one);
        }
        // The faults in the awake order, whatever the threads.
        let mut faults = faults.into_inner().unwrap_or_else(|e| e.into_inner());
        faults.sort_unstable();
        faults
    }

    /// Solver body `slot`'s displacement over the step.
    pub(crate) fn displacement(&self, slot: usize) -> Vec3 {
        Vec3::from(self.solver_bodies[slot].dp)
    }

    /// Shortens solver body `slot`'s displacement over the step to
    /// `dp` (continuous collision puts it back before an impact), and
    /// takes from its kinetic energy the work its forces would have done
    /// over the part it no longer travels, `m a · (Δx − dp)`: a body put
    /// back while falling keeps the height it did not fall, so it may not
    /// keep the speed it gained falling it too (that is energy from
    /// nowhere, `m g Δh`). Only the linear speed is reduced.
    pub(crate) fn put_back(&mut self, slot: usize, dp: Vec3) {
        let (b, p) = (&mut self.solver_bodies[slot], &self.body_params[slot]);
        let skipped = Vec3::from(b.dp) - dp;
        b.dp = dp.into();
        let work = p.accel.dot(skipped) / b.inv_mass;
        let kinetic = 0.5 * b.v.length_squared() / b.inv_mass;
        if work > 0.0 && kinetic > 0.0 {
            b.v *= ((kinetic - work).max(0.0) / kinetic).sqrt();
        }
    }

    /// Where solver body `slot` (whose centre of mass is `local_com` in
    /// its frame) started the step, turned to its end-of-step orientation,
    /// and its displacement: the straight sweep continuous collision tests.
    pub(crate) fn sweep(&self, slot: usize, local_com: Vec3) -> (Pose, Vec3) {
        let sb = &self.solver_bodies[slot];
        let (pose0, com0) = self.step_start[slot];
        let q = (sb.dq * pose0.rotation).normalize();
        (Pose::new(com0 - q * local_com, q), sb.dp.into())
    }
}

/// A body's part of its island's energy bound (`Solver::energy_share`), J
/// (`weight` in N).
pub(crate) struct EnergyShare {
    pub now: f32,
    pub start: f32,
    pub allowed: f32,
    pub weight: f32,
}

/// Whether the bodies of contact `c` (between `a` and `b`) move against
/// each other (in any direction: closing, parting or sliding) at some
/// point of its manifold faster than `resting` (`restitution_threshold`,
/// the speed below which a contact counts as resting), with their
/// velocities at the start of the step. Sleeping and static bodies stand
/// still.
fn moving(c: &Contact, a: &Body, b: &Body, resting: f32) -> bool {
    // Each body's velocity field: its linear velocity, its angular one and
    // its centre of mass (still for a static or sleeping body).
    let field = |body: &Body| {
        if body.body_type == BodyType::Static || body.sleeping {
            (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO)
        } else {
            (body.linear_velocity, body.angular_velocity, body.center_of_mass())
        }
    };
    let ((va, wa, ca), (vb, wb, cb)) = (field(a), field(b));
    let limit = resting * resting;
    c.manifold.points().iter().any(|p| {
        let relative = (va + wa.cross(p.point - ca)) - (vb + wb.cross(p.point - cb));
        relative.length_squared() > limit
    })
}
