//! Joints as constraints of the solver: built once a step from the
//! world's joints (`joint.rs`), solved in every pass of their unit before
//! its contacts, warm started and summed like them.
//!
//! ## Rows
//!
//! A joint's *equality rows* hold its anchors together (three point rows),
//! keep a hinge's axis aligned (two angular rows) or a weld's orientation
//! (three), or a rod's length (one). Each row is a Jacobian `J` with
//! `Ċ = lin·(v_b − v_a) + ang_a·ω_a + ang_b·ω_b`, built again each
//! substep as the bodies turn (`prepare`). Its *one-sided rows* (a hinge's limits, a rope) and
//! *soft rows* (a distance joint's spring) are scalars solved by
//! Gauss–Seidel after the equality rows, each pass.
//!
//! ## Exact along the joint trees
//!
//! Gauss–Seidel over a chain's rows converges slowly, and worse the larger
//! the mass ratio: a heavy ball on light links stretches the chain pass
//! after pass (Rapier's high-mass-ratio chain needs sixteen extra passes;
//! Jolt's author advises against it). The equality rows of an island are
//! instead solved exactly along a spanning forest of its joints, in time
//! linear in their number (D. Baraff, "Linear-time dynamics using
//! Lagrange multipliers", SIGGRAPH 1996): the system
//!
//! ```text
//! [ M  Jᵀ ] [  Δv ]   [ 0 ]
//! [ J  0  ] [ −Δλ ] = [ b ]      b = target − J v
//! ```
//!
//! has one node per moving body (its 6 × 6 mass `M`) and per joint (its
//! rows), and where the joints form a tree (bodies that cannot move are
//! not nodes: a chain hanging from a fixed anchor is a tree) the matrix
//! has the tree's sparsity. Eliminating the nodes leaves first makes no
//! fill-in: each node's block becomes `D = H_ii − Σ_children H_ciᵀ D_c⁻¹
//! H_ci`, factored each substep (in `f64`: a 1000 : 1 mass ratio costs no
//! accuracy; beyond about 10¹⁰ : 1 the complements cancel), and each pass
//! is one sweep up the tree and one down. One pass leaves a tree's rows
//! satisfied to the rounding, and the contacts meet them by block
//! Gauss–Seidel. A unit whose joints close loops (a net) or hold a tree
//! to something immovable twice is solved joint by joint instead, each a
//! tree of one, by Gauss–Seidel between them (`Joints::build`).
//!
//! ## Rigid rows, drift by split impulse
//!
//! The velocity rows are rigid in every pass: no spring, no bias, so no
//! energy is pumped in. The relax passes ask `J v = 0`; the biased pass,
//! whose velocities move the bodies, asks for the anchors' curvature over
//! the substep (`curvature`), so that the joints hold to the next order.
//! What drift is left is removed in each biased pass by the split impulse
//! that pushes contacts apart: pseudo-velocities with `J p = −β C / h`
//! (`WorldSettings::position_correction_rate`), which move the bodies and
//! are then discarded.

#![allow(clippy::needless_range_loop)] // small dense matrices read best by index

use std::ops::{Index, Range};

use glam::Vec3A;

use super::{BodiesView, Pass, PassResult, Softness, SolverBody};
use crate::joint::{Joint, JointKind};
use crate::math::{Mat3, Pose, Quat, Vec3};

const NONE: u32 = u32::MAX;

/// A row's Jacobian: `Ċ = lin·(v_b − v_a) + ang_a·ω_a + ang_b·ω_b`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Row {
    lin: Vec3,
    ang_a: Vec3,
    ang_b: Vec3,
}

impl Row {
    fn point(e: Vec3, ra: Vec3, rb: Vec3) -> Row {
        Row { lin: e, ang_a: -ra.cross(e), ang_b: rb.cross(e) }
    }

    fn angular(u: Vec3) -> Row {
        Row { lin: Vec3::ZERO, ang_a: -u, ang_b: u }
    }

    fn negated(self) -> Row {
        Row { lin: -self.lin, ang_a: -self.ang_a, ang_b: -self.ang_b }
    }

    /// `J v` for the two bodies' velocities (or pseudo-velocities).
    #[inline]
    fn velocity(&self, va: Vec3, wa: Vec3, vb: Vec3, wb: Vec3) -> f32 {
        self.lin.dot(vb - va) + self.ang_a.dot(wa) + self.ang_b.dot(wb)
    }

    /// `J M⁻¹ Jᵀ`.
    fn inverse_mass(&self, a: &SolverBody, b: &SolverBody) -> f32 {
        let ia = Mat3::from(a.inv_i);
        let ib = Mat3::from(b.inv_i);
        (a.inv_mass + b.inv_mass) * self.lin.length_squared()
            + self.ang_a.dot(ia * self.ang_a)
            + self.ang_b.dot(ib * self.ang_b)
    }
}

/// A one-sided or soft row (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
enum ExtraKind {
    /// A hinge's lower limit: `C = θ − lo ≥ 0`.
    Lower,
    /// A hinge's upper limit: `C = hi − θ ≥ 0`.
    Upper,
    /// A rope: `C = L − |d| ≥ 0`.
    Rope,
    /// A distance joint's spring: `C = |d| − L`, soft.
    Spring,
}

#[derive(Clone, Copy, Debug)]
struct Extra {
    kind: ExtraKind,
    row: Row,
    /// `1 / (J M⁻¹ Jᵀ)`, 0 when the row cannot move anything.
    mass: f32,
    impulse: f32,
    total: f32,
}

/// One side of a joint at the start of the step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Side {
    /// Solver slot; 0 when the side cannot move (static, the world).
    pub slot: u32,
    pub pose: Pose,
    /// Centre of mass.
    pub com: Vec3,
}

/// A joint as the solver sees it for one step.
#[derive(Clone, Debug)]
pub(crate) struct JointConstraint {
    /// The joint's arena slot.
    pub joint: u32,
    pub a: u32,
    pub b: u32,
    kind: JointKind,
    /// Anchors in the world and arms from the centres of mass, at the
    /// start of the step.
    pa0: Vec3,
    pb0: Vec3,
    ra: Vec3,
    rb: Vec3,
    qa0: Quat,
    qb0: Quat,
    /// Hinge axis in the world at the start of the step, as each body
    /// carries it; the angle's reference directions likewise.
    axis_a0: Vec3,
    axis_b0: Vec3,
    ref_a0: Vec3,
    ref_b0: Vec3,
    /// A hinge's two directions across its axis at the start of the step
    /// (its angular rows turn with body `a` through the step).
    across0: [Vec3; 2],
    relative: Quat,
    length: f32,
    /// A hinge's limits (0, 0 without).
    limits: (f32, f32),
    /// Equality rows in use, and their Jacobians, impulses (this substep)
    /// and totals over the step.
    dim: usize,
    rows: [Row; 6],
    impulse: [f32; 6],
    total: [f32; 6],
    extras: [Extra; 2],
    n_extra: usize,
    /// A spring's coefficients for the substep.
    soft: Softness,
    /// Solved as a tree of its own between the others (it closes a loop,
    /// or holds a tree a second time to something that cannot move).
    closer: bool,
    /// The biased passes' velocity targets for the substep
    /// (`curvature`, found once by `UnitJoints::curve`).
    curve: [f32; 6],
    /// The point rows' impulse of the last substep of the step before
    /// (for the geometric stiffness, `stiffness`).
    last: Vec3,
}

/// A node of a joint tree: a moving body or a joint's equality rows.
#[derive(Clone, Debug)]
pub(crate) struct Node {
    /// A body's solver slot, or a joint's index among its unit's.
    item: u32,
    joint: bool,
    dim: usize,
    /// Index of the parent among the tree's nodes (`NONE` at the root).
    parent: u32,
    /// The factored block's inverse, `D⁻¹`.
    dinv: M6,
    /// The block `H` between this node and its parent (rows: this node's,
    /// columns: the parent's), and `L = D⁻¹ H`.
    h: M6,
    l: M6,
    /// The sweeps' vectors.
    y: V6,
    z: V6,
}

type M6 = [[f64; 6]; 6];
type V6 = [f64; 6];
const Z6: M6 = [[0.0; 6]; 6];

/// The joints of the step, in the solver's order (unit by unit; within
/// a unit, the trees root first, then the joints with one-sided or soft
/// rows only), their trees and each unit's share.
#[derive(Default)]
pub(crate) struct Joints {
    pub(crate) constraints: Vec<JointConstraint>,
    nodes: Vec<Node>,
    /// Each tree's nodes (relative to its unit's first node).
    trees: Vec<Range<u32>>,
    /// Per unit: its constraints, trees and nodes.
    pub(crate) units: Vec<UnitRanges>,
    // Scratch of `build_trees`.
    start: Vec<u32>,
    adjacent: Vec<u32>,
    visited: Vec<bool>,
    used: Vec<bool>,
    queue: Vec<u32>,
    order: Vec<u32>,
    fill: Vec<u32>,
    seeds: Vec<u32>,
    new_index: Vec<u32>,
    closers: Vec<u32>,
    redo: Vec<u32>,
    spare: Vec<JointConstraint>,
}

/// One unit's ranges in `Joints`' lists.
#[derive(Clone, Debug, Default)]
pub(crate) struct UnitRanges {
    constraints: Range<usize>,
    trees: Range<usize>,
    nodes: Range<usize>,
    /// Whether every row of the unit is a tree's (one pass solves them).
    pub(crate) exact: bool,
}

/// One unit's joints, as its substeps solve them.
pub(crate) struct UnitJoints<'a> {
    constraints: &'a mut [JointConstraint],
    nodes: &'a mut [Node],
    trees: &'a [Range<u32>],
}

impl JointConstraint {
    /// Builds the constraint of `joint` between sides `a` and `b`, whose
    /// solver bodies are `sa`, `sb`, for substeps of `h`.
    pub(crate) fn build(
        index: u32,
        joint: &Joint,
        a: Side,
        b: Side,
        sa: &SolverBody,
        sb: &SolverBody,
        h: f32,
    ) -> JointConstraint {
        let pa0 = a.pose.transform_point(joint.local_a);
        let pb0 = b.pose.transform_point(joint.local_b);
        let (ra, rb) = (pa0 - a.com, pb0 - b.com);
        let (qa0, qb0) = (a.pose.rotation, b.pose.rotation);
        let mut c = JointConstraint {
            joint: index,
            a: a.slot,
            b: b.slot,
            kind: joint.kind,
            pa0,
            pb0,
            ra,
            rb,
            qa0,
            qb0,
            axis_a0: qa0 * joint.axis_a,
            axis_b0: qb0 * joint.axis_b,
            ref_a0: qa0 * joint.ref_a,
            ref_b0: qb0 * joint.ref_b,
            across0: [Vec3::ZERO; 2],
            relative: joint.relative,
            length: joint.options.length,
            limits: joint.options.limits.unwrap_or((0.0, 0.0)),
            dim: 0,
            rows: [Row::default(); 6],
            impulse: [0.0; 6],
            total: [0.0; 6],
            extras: [Extra { kind: ExtraKind::Rope, row: Row::default(), mass: 0.0, impulse: 0.0, total: 0.0 }; 2],
            n_extra: 0,
            soft: Softness::default(),
            closer: false,
            curve: [0.0; 6],
            last: joint.linear_impulse,
        };
        let point = matches!(joint.kind, JointKind::Spherical | JointKind::Revolute | JointKind::Fixed);
        if point {
            for (k, e) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
                c.rows[k] = Row::point(e, ra, rb);
                c.impulse[k] = joint.linear_impulse[k];
            }
            c.dim = 3;
        }
        match joint.kind {
            JointKind::Revolute => {
                let (u1, u2) = c.axis_a0.any_orthonormal_pair();
                c.across0 = [u1, u2];
                for u in [u1, u2] {
                    c.rows[c.dim] = Row::angular(u);
                    c.impulse[c.dim] = joint.angular_impulse.dot(u);
                    c.dim += 1;
                }
                if let Some((_, _)) = joint.options.limits {
                    let lower = Row::angular(c.axis_a0);
                    c.push_extra(ExtraKind::Lower, lower, joint.extra_impulse[0]);
                    c.push_extra(ExtraKind::Upper, lower.negated(), joint.extra_impulse[1]);
                }
            }
            JointKind::Fixed => {
                for e in [Vec3::X, Vec3::Y, Vec3::Z] {
                    c.rows[c.dim] = Row::angular(e);
                    c.impulse[c.dim] = joint.angular_impulse.dot(e);
                    c.dim += 1;
                }
            }
            JointKind::Distance | JointKind::Rope => {
                let n = (pb0 - pa0).try_normalize().unwrap_or(Vec3::Y);
                let row = Row::point(n, ra, rb);
                match (joint.kind, joint.options.spring) {
                    (JointKind::Rope, _) => c.push_extra(ExtraKind::Rope, row.negated(), joint.extra_impulse[0]),
                    (_, Some((hz, zeta))) if hz > 0.0 => {
                        c.soft = Softness::new(hz, zeta, h);
                        c.push_extra(ExtraKind::Spring, row, joint.extra_impulse[0]);
                    }
                    _ => {
                        c.rows[0] = row;
                        c.impulse[0] = joint.linear_impulse.dot(n);
                        c.dim = 1;
                    }
                }
            }
            JointKind::Spherical => {}
        }
        for e in &mut c.extras[..c.n_extra] {
            let k = e.row.inverse_mass(sa, sb);
            e.mass = if k > 0.0 { 1.0 / k } else { 0.0 };
        }
        c
    }

    fn push_extra(&mut self, kind: ExtraKind, row: Row, impulse: f32) {
        self.extras[self.n_extra] = Extra { kind, row, mass: 0.0, impulse, total: 0.0 };
        self.n_extra += 1;
    }

    /// The rows again for the bodies' orientations and positions now: a
    /// substep's rows follow the arms as they turn (with the rows of the
    /// start of the step, a pendulum swinging 0.1 rad a step drifts
    /// `r θ² / 2` outwards each step, 2.5 mm for a 0.5 m arm, which the
    /// push-out only halves).
    fn refresh<B: Index<usize, Output = SolverBody> + ?Sized>(&mut self, bodies: &B) {
        let turn = |slot: u32| if slot == 0 { Quat::IDENTITY } else { bodies[slot as usize].dq };
        let (dqa, dqb) = (turn(self.a), turn(self.b));
        let (ra, rb) = (dqa * self.ra, dqb * self.rb);
        match self.kind {
            JointKind::Spherical | JointKind::Revolute | JointKind::Fixed => {
                for (k, e) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
                    self.rows[k] = Row::point(e, ra, rb);
                }
            }
            JointKind::Distance | JointKind::Rope => {
                let shift = |slot: u32| if slot == 0 { Vec3::ZERO } else { Vec3::from(bodies[slot as usize].dp) };
                let pa = self.pa0 + shift(self.a) + (ra - self.ra);
                let pb = self.pb0 + shift(self.b) + (rb - self.rb);
                let n = (pb - pa).try_normalize().unwrap_or(Vec3::Y);
                let row = Row::point(n, ra, rb);
                if self.dim == 1 {
                    self.rows[0] = row;
                }
                for e in &mut self.extras[..self.n_extra] {
                    e.row = if e.kind == ExtraKind::Rope { row.negated() } else { row };
                }
            }
        }
        if self.kind == JointKind::Revolute {
            for k in 0..2 {
                self.rows[3 + k] = Row::angular(dqa * self.across0[k]);
            }
            let axis = dqa * self.axis_a0;
            for e in &mut self.extras[..self.n_extra] {
                e.row = if e.kind == ExtraKind::Lower { Row::angular(axis) } else { Row::angular(-axis) };
            }
        }
        for k in 0..self.n_extra {
            let m = {
                let side = |slot: u32| &bodies[slot as usize];
                self.extras[k].row.inverse_mass(side(self.a), side(self.b))
            };
            self.extras[k].mass = if m > 0.0 { 1.0 / m } else { 0.0 };
        }
    }

    /// The geometric stiffness of the point rows under tension, implicit:
    /// `(side slot, h² K)` for each moving side pulled outwards along its
    /// arm. A body pulled at an anchor `r` from its centre by a force `f`
    /// along `r` (a link in a taut chain) is turned back by a torque
    /// `(f·r)(I − r̂r̂ᵀ) δθ` when it turns by `δθ`. With the force's
    /// direction taken at the start of each substep that stiffness is
    /// integrated explicitly, and a chain of light links under a heavy
    /// ball has it stiff: the links' zigzag mode (about `√(f r / I)`, 250
    /// rad/s for the wrecking ball's links) grows without bound once
    /// `h ω ≳ 1`, at 4 substeps of 60 Hz. Adding `h² K` to the body's
    /// inertia for the solver makes it implicit (after Tournier et al.,
    /// "Stable constrained dynamics", SIGGRAPH 2015); `h² f = h λ`, `λ` the
    /// last substep's impulse. Compression adds nothing.
    pub(crate) fn stiffness(&self, h: f32) -> [Option<(u32, Mat3)>; 2] {
        if !matches!(self.kind, JointKind::Spherical | JointKind::Revolute | JointKind::Fixed) {
            return [None, None];
        }
        let side = |slot: u32, r: Vec3, pull: Vec3| {
            let tension = h * pull.dot(r);
            let r2 = r.length_squared();
            (slot != 0 && tension > 0.0 && r2 > 0.0 && tension.is_finite())
                .then(|| (slot, tension * (Mat3::IDENTITY - Mat3::from_cols(r * r.x, r * r.y, r * r.z) / r2)))
        };
        [side(self.a, self.ra, -self.last), side(self.b, self.rb, self.last)]
    }

    /// The one-sided and soft rows' effective masses for the bodies'
    /// masses now (after `stiffness` changed them).
    pub(crate) fn update_masses(&mut self, solver_bodies: &[SolverBody]) {
        let (sa, sb) = (&solver_bodies[self.a as usize], &solver_bodies[self.b as usize]);
        for e in &mut self.extras[..self.n_extra] {
            let k = e.row.inverse_mass(sa, sb);
            e.mass = if k > 0.0 { 1.0 / k } else { 0.0 };
        }
    }

    /// Whether the joint has equality rows (and so is a tree node).
    pub(crate) fn has_rows(&self) -> bool {
        self.dim > 0
    }

    /// The anchors and the bodies' rotations now (`dp`, `dq` of the
    /// moving sides applied to the start of the step).
    fn now(&self, bodies: &BodiesView) -> (Vec3, Vec3, Quat, Quat) {
        let side = |slot: u32, p0: Vec3, r: Vec3| -> (Vec3, Quat) {
            if slot == 0 {
                (p0, Quat::IDENTITY)
            } else {
                let s = &bodies[slot as usize];
                (p0 + Vec3::from(s.dp) + (s.dq * r - r), s.dq)
            }
        };
        let (pa, dqa) = side(self.a, self.pa0, self.ra);
        let (pb, dqb) = side(self.b, self.pb0, self.rb);
        (pa, pb, dqa, dqb)
    }

    /// The equality rows' position errors now.
    fn errors(&self, bodies: &BodiesView) -> [f32; 6] {
        let (pa, pb, dqa, dqb) = self.now(bodies);
        let mut c = [0.0; 6];
        let d = pb - pa;
        match self.kind {
            JointKind::Spherical | JointKind::Revolute | JointKind::Fixed => {
                c[0] = d.x;
                c[1] = d.y;
                c[2] = d.z;
            }
            JointKind::Distance | JointKind::Rope => c[0] = d.length() - self.length,
        }
        match self.kind {
            JointKind::Revolute => {
                // The misalignment `a_a × a_b` along each row's direction
                // (for a small tilt θ about u ⊥ a, `a × a_b ≈ θ u`).
                let m = (dqa * self.axis_a0).cross(dqb * self.axis_b0);
                c[3] = self.rows[3].ang_b.dot(m);
                c[4] = self.rows[4].ang_b.dot(m);
            }
            JointKind::Fixed => {
                // The rotation from where `b` should be, `q_a q_rel`, to
                // where it is: twice its quaternion's vector part.
                let qa = dqa * self.qa0;
                let qb = dqb * self.qb0;
                let mut e = qb * (qa * self.relative).inverse();
                if e.w < 0.0 {
                    e = -e;
                }
                c[3] = 2.0 * e.x;
                c[4] = 2.0 * e.y;
                c[5] = 2.0 * e.z;
            }
            _ => {}
        }
        c
    }

    /// The velocity targets that cancel the equality rows' drift over the
    /// next position update, `−(h/2) C̈` to first order.
    ///
    /// The position update moves an anchor at `r` from the centre by
    /// `h v + R(hω) r − r = h (v + ω × r) + (h²/2) ω × (ω × r) + O(h³)`:
    /// rows with `J v = 0` keep the first-order part only, and each
    /// substep the anchors drift apart by the second (a ball on a 0.15 m
    /// arm swinging at 7 rad/s: 60 µm a substep at 240 Hz). Pulling that
    /// back by moving the positions alone (the split impulse) shortens the
    /// pendulum while it swings fast without taking the work from its
    /// speed, as a child pumps a swing: the ball gained 4 % of its energy
    /// each half swing. Asking `J v = −(h/2) C̈` instead makes the
    /// velocities follow the arc, and the split impulse has only third-
    /// order drift left. For a rod (`C = |d| − L`) `C̈` also has the
    /// tangential motion's `|ḋ_⊥|² / L`.
    fn curvature(&self, bodies: &BodiesView, h: f32) -> [f32; 6] {
        let mut out = [0.0; 6];
        let (va, wa) = velocities(bodies, self.a, false);
        let (vb, wb) = velocities(bodies, self.b, false);
        let turn = |slot: u32| if slot == 0 { Quat::IDENTITY } else { bodies[slot as usize].dq };
        let (ra, rb) = (turn(self.a) * self.ra, turn(self.b) * self.rb);
        // What the position update will do to each arm beyond `h ω × r`:
        // `(R(hω) r − r − h ω × r) / (h²/2)`, with the rotation the update
        // takes (`integrate_rotation`); `ω × (ω × r)` for small `hω`, and
        // bounded however fast the body turns, where the series is not.
        let beyond = |w: Vec3, r: Vec3| {
            let turned = super::integrate::integrate_rotation(Quat::IDENTITY, w, h) * r;
            (turned - r - h * w.cross(r)) * (2.0 / (h * h))
        };
        let bend = beyond(wb, rb) - beyond(wa, ra);
        match self.kind {
            JointKind::Spherical | JointKind::Revolute | JointKind::Fixed => {
                for k in 0..3 {
                    out[k] = -0.5 * h * self.rows[k].lin.dot(bend);
                }
            }
            JointKind::Distance | JointKind::Rope if self.dim == 1 => {
                let n = self.rows[0].lin;
                let rel = vb + wb.cross(rb) - va - wa.cross(ra);
                let across = rel - n * n.dot(rel);
                // The rod's turn lengthens it by `√(L² + (h ḋ⊥)²) − L`:
                // `(h²/2) |ḋ⊥|² / L` when small, at most `h |ḋ⊥|`.
                let l = self.length.max(1e-6);
                let turn = (l * l + (h * h) * across.length_squared()).sqrt() - l;
                out[0] = -0.5 * h * n.dot(bend) - turn / h;
            }
            _ => {}
        }
        out
    }

    /// The one-sided or soft row `k`'s position error now.
    fn extra_error(&self, k: usize, bodies: &BodiesView) -> f32 {
        let (pa, pb, dqa, dqb) = self.now(bodies);
        match self.extras[k].kind {
            ExtraKind::Lower | ExtraKind::Upper => {
                let axis = dqa * self.axis_a0;
                let (ra, rb) = (dqa * self.ref_a0, dqb * self.ref_b0);
                let angle = axis.dot(ra.cross(rb)).atan2(ra.dot(rb));
                let (lo, hi) = self.limits;
                if self.extras[k].kind == ExtraKind::Lower {
                    angle - lo
                } else {
                    hi - angle
                }
            }
            ExtraKind::Rope => self.length - (pb - pa).length(),
            ExtraKind::Spring => (pb - pa).length() - self.length,
        }
    }
}

/// A moving side's velocities (or pseudo-velocities); zero for slot 0.
#[inline]
fn velocities(bodies: &BodiesView, slot: u32, pseudo: bool) -> (Vec3, Vec3) {
    if slot == 0 {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let b = &bodies[slot as usize];
    if pseudo {
        (b.pv.into(), b.pw.into())
    } else {
        (b.v.into(), b.w.into())
    }
}

/// Applies the impulse `(lin, ang)` to side `slot` (nothing for slot 0).
#[inline]
fn apply(bodies: &mut BodiesView, slot: u32, lin: Vec3, ang: Vec3, pseudo: bool) {
    if slot == 0 {
        return;
    }
    let b = &bodies[slot as usize];
    let (dv, dw) = (b.inv_mass * Vec3A::from(lin), b.inv_i * Vec3A::from(ang));
    add_velocity(&mut bodies[slot as usize], dv, dw, pseudo);
}

/// Adds `(dv, dw)` to a body's velocities, or to its pseudo-velocities.
#[inline]
fn add_velocity(b: &mut SolverBody, dv: Vec3A, dw: Vec3A, pseudo: bool) {
    if pseudo {
        b.pv += dv;
        b.pw += dw;
    } else {
        b.v += dv;
        b.w += dw;
    }
}

/// Applies impulse `lambda` along `row` to the constraint's two sides.
#[inline]
fn apply_row(bodies: &mut BodiesView, c: &JointConstraint, row: &Row, lambda: f32, pseudo: bool) {
    apply(bodies, c.a, -row.lin * lambda, row.ang_a * lambda, pseudo);
    apply(bodies, c.b, row.lin * lambda, row.ang_b * lambda, pseudo);
}

/// Whether solver slot `slot` is a node of the trees: a body that moves
/// (kinematic bodies and slot 0 hold their side fixed).
fn movable(solver_bodies: &[SolverBody], slot: u32) -> bool {
    slot != 0 && solver_bodies[slot as usize].inv_mass != 0.0
}

impl Joints {
    /// Orders the step's `constraints` (built in the world's joint order,
    /// `unit_of` giving each one's unit among `units`) unit by unit, finds
    /// each unit's joint trees root first and factors them.
    ///
    /// Root first: the search starts from the joints held by a body that
    /// cannot move (a chain's anchor), in the joints' order, then from the
    /// rest; each body is reached once, by the first joint that reaches
    /// it, and a joint to a body already reached closes a loop (it is then
    /// a tree of its own). The order depends only on the joints and their
    /// order: the same on any thread count.
    pub(crate) fn build(&mut self, unit_of: &[u32], units: usize, solver_bodies: &[SolverBody]) {
        let n = self.constraints.len();
        self.nodes.clear();
        self.trees.clear();
        self.units.clear();
        self.units.resize(units, UnitRanges::default());
        if n == 0 {
            return;
        }
        // Each joint's edges between moving bodies, in compressed rows.
        let bodies = solver_bodies.len();
        self.start.clear();
        self.start.resize(bodies + 1, 0);
        for c in &self.constraints {
            for s in [c.a, c.b] {
                if c.has_rows() && movable(solver_bodies, s) {
                    self.start[s as usize + 1] += 1;
                }
            }
        }
        for i in 0..bodies {
            self.start[i + 1] += self.start[i];
        }
        self.adjacent.clear();
        self.adjacent.resize(self.start[bodies] as usize, 0);
        let mut fill = std::mem::take(&mut self.fill);
        fill.clear();
        fill.extend_from_slice(&self.start);
        for (j, c) in self.constraints.iter().enumerate() {
            for s in [c.a, c.b] {
                if c.has_rows() && movable(solver_bodies, s) {
                    self.adjacent[fill[s as usize] as usize] = j as u32;
                    fill[s as usize] += 1;
                }
            }
        }
        self.visited.clear();
        self.visited.resize(bodies, false);
        self.used.clear();
        self.used.resize(n, false);
        // Seeds: unit by unit, the anchored joints first, in order.
        let anchored = |c: &JointConstraint| !(movable(solver_bodies, c.a) && movable(solver_bodies, c.b));
        let mut seeds = std::mem::take(&mut self.seeds);
        seeds.clear();
        seeds.extend(0..n as u32);
        seeds.sort_by_key(|&j| {
            let c = &self.constraints[j as usize];
            (unit_of[j as usize], !anchored(c), j)
        });
        // The new order of the joints (old indices), and per joint its new
        // index.
        self.order.clear();
        let mut new_index = std::mem::take(&mut self.new_index);
        new_index.clear();
        new_index.resize(n, NONE);
        let (mut closers, mut redo) = (std::mem::take(&mut self.closers), std::mem::take(&mut self.redo));
        let mut k = 0;
        while k < seeds.len() {
            let unit = unit_of[seeds[k] as usize] as usize;
            let run = seeds[k..].iter().take_while(|&&j| unit_of[j as usize] as usize == unit).count();
            let (first_constraint, first_tree, first_node) = (self.order.len(), self.trees.len(), self.nodes.len());
            closers.clear();
            for &seed in &seeds[k..k + run] {
                let c = &self.constraints[seed as usize];
                if self.used[seed as usize] || !c.has_rows() {
                    continue;
                }
                let tree_start = self.nodes.len();
                self.used[seed as usize] = true;
                self.push_joint(seed, NONE, first_constraint, &mut new_index);
                self.queue.clear();
                let c = &self.constraints[seed as usize];
                for s in [c.a, c.b] {
                    if movable(solver_bodies, s) && !self.visited[s as usize] {
                        self.visited[s as usize] = true;
                        self.push_body(s, 0);
                        self.queue.push(self.nodes.len() as u32 - 1);
                    }
                }
                let mut q = 0;
                while q < self.queue.len() {
                    let node = self.queue[q];
                    q += 1;
                    let x = self.nodes[node as usize].item;
                    for e in self.start[x as usize]..self.start[x as usize + 1] {
                        let j = self.adjacent[e as usize];
                        if self.used[j as usize] {
                            continue;
                        }
                        self.used[j as usize] = true;
                        let c = &self.constraints[j as usize];
                        let other = if c.a == x { c.b } else { c.a };
                        if !movable(solver_bodies, other) {
                            // A second hold on something that cannot move
                            // (a bridge's far end) would be a leaf whose
                            // block is zero, `D = 0`, which no elimination
                            // from the leaves can take: it is solved on
                            // its own, as a loop is.
                            closers.push(j);
                        } else if !self.visited[other as usize] {
                            self.push_joint(j, node - tree_start as u32, first_constraint, &mut new_index);
                            self.visited[other as usize] = true;
                            self.push_body(other, self.nodes.len() as u32 - 1 - tree_start as u32);
                            self.queue.push(self.nodes.len() as u32 - 1);
                        } else {
                            closers.push(j);
                        }
                    }
                }
                self.trees.push((tree_start - first_node) as u32..(self.nodes.len() - first_node) as u32);
            }
            // A unit whose joints close loops (a net, a bridge held at both
            // ends) is solved joint by joint, each as a tree of its own, in
            // the search's order (root first), by Gauss–Seidel between them
            // and warm started, as Box2D and Rapier solve every joint: one
            // spanning tree solved exactly with the loops' joints between
            // its passes converged so slowly along the long paths the tree
            // takes between neighbours that a falling 32 × 32 net's loops
            // opened by a metre.
            let no_loops = closers.is_empty();
            if !no_loops {
                redo.clear();
                redo.extend(self.order.drain(first_constraint..));
                redo.extend_from_slice(&closers);
                self.nodes.truncate(first_node);
                self.trees.truncate(first_tree);
                for &j in &redo {
                    self.constraints[j as usize].closer = true;
                    let tree_start = self.nodes.len();
                    self.push_joint(j, NONE, first_constraint, &mut new_index);
                    let c = &self.constraints[j as usize];
                    for s in [c.a, c.b] {
                        if movable(solver_bodies, s) {
                            self.push_body(s, 0);
                        }
                    }
                    self.trees.push((tree_start - first_node) as u32..(self.nodes.len() - first_node) as u32);
                }
            }
            // Then the joints with one-sided or soft rows only.
            for &j in &seeds[k..k + run] {
                if new_index[j as usize] == NONE {
                    new_index[j as usize] = (self.order.len() - first_constraint) as u32;
                    self.order.push(j);
                }
            }
            // One pass solves a unit exactly when no joint closed a loop
            // and none has one-sided or soft rows.
            let exact = no_loops && seeds[k..k + run].iter().all(|&j| self.constraints[j as usize].n_extra == 0);
            self.units[unit] = UnitRanges {
                constraints: first_constraint..self.order.len(),
                trees: first_tree..self.trees.len(),
                nodes: first_node..self.nodes.len(),
                exact,
            };
            k += run;
        }
        (self.fill, self.seeds, self.new_index, self.closers, self.redo) = (fill, seeds, new_index, closers, redo);
        // Joints in the new order (built in the spare list, which then
        // holds last step's).
        self.spare.clear();
        self.spare.extend(self.order.iter().map(|&j| self.constraints[j as usize].clone()));
        std::mem::swap(&mut self.constraints, &mut self.spare);
        // Factor each unit's trees.
        for u in 0..units {
            let r = self.units[u].clone();
            let (cs, nodes) = (&self.constraints[r.constraints.clone()], &mut self.nodes[r.nodes.clone()]);
            for t in &self.trees[r.trees.clone()] {
                factor(&mut nodes[t.start as usize..t.end as usize], cs, solver_bodies);
            }
        }
    }
}

impl Joints {
    /// Appends joint `j` as a node under `parent` (within its tree), giving
    /// it the next place in its unit's order (which starts at `first`).
    fn push_joint(&mut self, j: u32, parent: u32, first: usize, new_index: &mut [u32]) {
        let index = (self.order.len() - first) as u32;
        new_index[j as usize] = index;
        self.order.push(j);
        let dim = self.constraints[j as usize].dim;
        self.nodes.push(Node::new(index, true, dim, parent));
    }

    /// Appends the body of solver slot `slot` as a node under `parent`.
    fn push_body(&mut self, slot: u32, parent: u32) {
        self.nodes.push(Node::new(slot, false, 6, parent));
    }

    /// The solver slots of unit `u`'s joints' sides (0 for a side that
    /// cannot move), in the joints' order.
    pub(crate) fn unit_bodies(&self, u: usize) -> impl Iterator<Item = u32> + '_ {
        let r = self.units.get(u).map_or(0..0, |r| r.constraints.clone());
        self.constraints[r].iter().flat_map(|c| [c.a, c.b])
    }

    /// Whether one pass solves unit `u`'s joints exactly.
    pub(crate) fn exact(&self, u: usize) -> bool {
        self.units.get(u).is_some_and(|r| r.exact)
    }

    /// Whether any joint takes part this step.
    pub(crate) fn is_empty(&self) -> bool {
        self.constraints.is_empty()
    }

    /// Unit `u`'s joints (none past the units built).
    pub(crate) fn unit(&mut self, u: usize) -> UnitJoints<'_> {
        match self.units.get(u) {
            Some(r) => UnitJoints {
                constraints: &mut self.constraints[r.constraints.clone()],
                nodes: &mut self.nodes[r.nodes.clone()],
                trees: &self.trees[r.trees.clone()],
            },
            None => UnitJoints::empty(),
        }
    }

    /// Stores each joint's impulses (for the next step's warm start) and
    /// its force and torque over the step of `dt` in the world's joints.
    pub(crate) fn store(&self, joints: &mut crate::arena::Arena<Joint>, dt: f32) {
        for c in &self.constraints {
            let Some(j) = joints.at_mut(c.joint) else { continue };
            let (mut linear, mut angular) = (Vec3::ZERO, Vec3::ZERO);
            let (mut force, mut torque) = (Vec3::ZERO, Vec3::ZERO);
            for k in 0..c.dim {
                let row = &c.rows[k];
                if row.lin == Vec3::ZERO {
                    angular += row.ang_b * c.impulse[k];
                    torque += row.ang_b * c.total[k];
                } else {
                    linear += row.lin * c.impulse[k];
                    force += row.lin * c.total[k];
                }
            }
            for (k, e) in c.extras[..c.n_extra].iter().enumerate() {
                j.extra_impulse[k] = e.impulse;
                if e.row.lin == Vec3::ZERO {
                    torque += e.row.ang_b * e.total;
                } else {
                    force += e.row.lin * e.total;
                }
            }
            j.linear_impulse = match c.kind {
                JointKind::Distance | JointKind::Rope => linear,
                _ => Vec3::new(c.impulse[0], c.impulse[1], c.impulse[2]),
            };
            j.angular_impulse = angular;
            j.force = force / dt;
            j.torque = torque / dt;
            // A step in which a body of the joint faulted (a force past
            // `f32`) leaves non-finite impulses: the joint keeps none of
            // them, and reports no force, rather than warm-start the next
            // step with a NaN (and never breaks on one).
            let sound = [j.linear_impulse, j.angular_impulse, j.force, j.torque].iter().all(|v| v.is_finite())
                && j.extra_impulse.iter().all(|x| x.is_finite());
            if !sound {
                (j.linear_impulse, j.angular_impulse, j.force, j.torque) =
                    (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
                j.extra_impulse = Default::default();
            }
        }
    }
}

impl Node {
    fn new(item: u32, joint: bool, dim: usize, parent: u32) -> Node {
        Node { item, joint, dim, parent, dinv: Z6, h: Z6, l: Z6, y: [0.0; 6], z: [0.0; 6] }
    }
}

/// Writes into `m` the Jacobian block of joint `c`'s rows with respect to
/// the body of solver slot `slot` (rows: the joint's, columns: v then ω),
/// or with `transposed` its transpose (rows: v then ω, columns: the
/// joint's). Entries past the joint's rows (or, transposed, its columns)
/// stay as they were (zero).
fn jacobian_into(m: &mut M6, c: &JointConstraint, slot: u32, transposed: bool) {
    for k in 0..c.dim {
        let (lin, ang) = side_row(c, slot, k);
        let row = [lin.x as f64, lin.y as f64, lin.z as f64, ang.x as f64, ang.y as f64, ang.z as f64];
        for (j, x) in row.into_iter().enumerate() {
            if transposed {
                m[j][k] = x;
            } else {
                m[k][j] = x;
            }
        }
    }
}

/// Row `k` of joint `c`'s Jacobian with respect to the body of solver
/// slot `slot`: its linear and angular parts.
#[inline]
fn side_row(c: &JointConstraint, slot: u32, k: usize) -> (Vec3, Vec3) {
    let r = &c.rows[k];
    if slot == c.b {
        (r.lin, r.ang_b)
    } else {
        (-r.lin, r.ang_a)
    }
}

/// Makes a joint's block `D` (its own block is zero, less its children's
/// complements `Hᵀ D⁻¹ H`: `−Σ J M⁻¹ Jᵀ`-like, negative definite for
/// independent rows) a whisker more negative, which keeps it invertible
/// when its rows are nearly dependent.
fn whisker(d: &mut M6, dim: usize) {
    let scale = (0..dim).map(|k| d[k][k].abs()).fold(0.0, f64::max).max(1e-30);
    for (k, row) in d.iter_mut().enumerate().take(dim) {
        row[k] -= 1e-9 * scale;
    }
}

/// Factors a tree's nodes (in search order: parents before children):
/// from the leaves up, each node's block less its children's Schur
/// complements, inverted (see the module docs). Every block is worked on
/// in place: a node's `dinv` holds its block `D` until it is inverted.
fn factor<B: Index<usize, Output = SolverBody> + ?Sized>(
    nodes: &mut [Node],
    cs: &[JointConstraint],
    solver_bodies: &B,
) {
    if single(nodes) {
        // One joint and its bodies (leaves, `D = M`): the joint's block is
        // `−Σ J M⁻¹ Jᵀ` over its moving bodies, formed straight from their
        // inverse masses, and nothing else is needed (see `solve_single`).
        let c = &cs[nodes[0].item as usize];
        let dim = c.dim;
        let mut d = Z6;
        for body in &nodes[1..] {
            let b = &solver_bodies[body.item as usize];
            let inv_i = Mat3::from(b.inv_i);
            for r in 0..dim {
                let (lr, ar) = side_row(c, body.item, r);
                let ir = inv_i * ar;
                for k in 0..dim {
                    let (lk, ak) = side_row(c, body.item, k);
                    d[r][k] -= (b.inv_mass * lr.dot(lk)) as f64 + ir.dot(ak) as f64;
                }
            }
        }
        whisker(&mut d, dim);
        invert_definite(&mut d, dim, true);
        nodes[0].dinv = d;
        return;
    }
    // Each node's own block, and its block `H` with its parent.
    for i in 0..nodes.len() {
        let parent_item = match nodes[i].parent {
            NONE => None,
            p => Some(nodes[p as usize].item),
        };
        let node = &mut nodes[i];
        node.dinv = Z6;
        if !node.joint {
            let b = &solver_bodies[node.item as usize];
            let m = 1.0 / b.inv_mass as f64;
            let inertia = inverse3(&Mat3::from(b.inv_i));
            for k in 0..3 {
                node.dinv[k][k] = m;
                for l in 0..3 {
                    node.dinv[3 + k][3 + l] = inertia[k][l];
                }
            }
        }
        node.h = Z6;
        if let Some(parent) = parent_item {
            if node.joint {
                jacobian_into(&mut node.h, &cs[node.item as usize], parent, false);
            } else {
                // (The parent of a body is a joint: `parent` is its index.)
                jacobian_into(&mut node.h, &cs[parent as usize], node.item, true);
            }
        }
    }
    // Leaves first: `D_i` is final once all its children are done.
    for i in (0..nodes.len()).rev() {
        let (head, tail) = nodes.split_at_mut(i);
        let node = &mut tail[0];
        let dim = node.dim;
        if node.joint {
            whisker(&mut node.dinv, dim);
        }
        invert_definite(&mut node.dinv, dim, node.joint);
        if node.parent != NONE {
            let parent = &mut head[node.parent as usize];
            // L = D⁻¹ H, and D_p −= Hᵀ L.
            node.l = Z6;
            factor_edge(&node.dinv, &node.h, &mut node.l, &mut parent.dinv, dim, parent.dim);
        }
    }
}

/// One edge of the factorisation: `l = dinv h` (`dinv` of `n × n`, `h` of
/// `n × m`) and `parent −= hᵀ l`, for the shapes the trees meet (bodies
/// 6, joints of 1, 3, 5 or 6 rows) in copies with fixed bounds, which the
/// compiler unrolls; any other over the whole 6 × 6.
fn factor_edge(dinv: &M6, h: &M6, l: &mut M6, parent: &mut M6, n: usize, m: usize) {
    match (n, m) {
        (6, 3) => factor_edge_fixed::<6, 3>(dinv, h, l, parent),
        (3, 6) => factor_edge_fixed::<3, 6>(dinv, h, l, parent),
        (6, 5) => factor_edge_fixed::<6, 5>(dinv, h, l, parent),
        (5, 6) => factor_edge_fixed::<5, 6>(dinv, h, l, parent),
        (6, 6) => factor_edge_fixed::<6, 6>(dinv, h, l, parent),
        (6, 1) => factor_edge_fixed::<6, 1>(dinv, h, l, parent),
        (1, 6) => factor_edge_fixed::<1, 6>(dinv, h, l, parent),
        // Every block is zero past its rows and columns: the whole 6 × 6
        // products give the same.
        _ => factor_edge_fixed::<6, 6>(dinv, h, l, parent),
    }
}

#[inline(always)]
fn factor_edge_fixed<const N: usize, const M: usize>(dinv: &M6, h: &M6, l: &mut M6, parent: &mut M6) {
    for r in 0..N {
        for c in 0..M {
            let mut s = 0.0;
            for i in 0..N {
                s += dinv[r][i] * h[i][c];
            }
            l[r][c] = s;
        }
    }
    for r in 0..M {
        for c in 0..M {
            let mut s = 0.0;
            for i in 0..N {
                s += h[i][r] * l[i][c];
            }
            parent[r][c] -= s;
        }
    }
}

/// Whether a tree is one joint and its moving bodies (each a leaf).
fn single(nodes: &[Node]) -> bool {
    nodes.len() <= 3 && nodes[0].joint && nodes[1..].iter().all(|n| !n.joint && n.parent == 0)
}

/// `solve_tree` for a tree of one joint: the rows' impulse change is
/// `Δλ = (J M⁻¹ Jᵀ)⁻¹ (target − J v)` (the joint's factored block is its
/// negated inverse), applied to the bodies through their inverse masses.
fn solve_single(
    bodies: &mut BodiesView,
    node: &Node,
    cs: &mut [JointConstraint],
    pseudo: bool,
    targets: impl Fn(&JointConstraint, &BodiesView) -> [f32; 6],
) -> f32 {
    let c = &mut cs[node.item as usize];
    let (va, wa) = velocities(bodies, c.a, pseudo);
    let (vb, wb) = velocities(bodies, c.b, pseudo);
    let target = targets(c, bodies);
    let mut b = [0.0; 6];
    let mut residual: f32 = 0.0;
    for k in 0..c.dim {
        let e = target[k] - c.rows[k].velocity(va, wa, vb, wb);
        residual = residual.max(e.abs());
        b[k] = e as f64;
    }
    // A three-row joint (a ball joint) reads only its block's leading
    // 3 × 3: the same bits as the full product, whose other terms add
    // `0 × 0` to sums that are never −0.0 (they start at +0.0, and a sum
    // that cancels rounds to +0.0).
    let x = if c.dim == 3 { mat_vec3(&node.dinv, &b) } else { mat_vec(&node.dinv, &b) };
    let (mut lin, mut ang_a, mut ang_b) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
    for k in 0..c.dim {
        let d = -x[k] as f32;
        if !pseudo {
            c.impulse[k] += d;
        }
        let r = &c.rows[k];
        lin += r.lin * d;
        ang_a += r.ang_a * d;
        ang_b += r.ang_b * d;
    }
    apply(bodies, c.a, -lin, ang_a, pseudo);
    apply(bodies, c.b, lin, ang_b, pseudo);
    residual
}

/// `m v` over the whole 6 × 6 block.
#[inline(always)]
fn mat_vec(m: &M6, v: &V6) -> V6 {
    std::array::from_fn(|r| (0..6).fold(0.0, |s, c| s + m[r][c] * v[c]))
}

/// `m v` over the leading 3 × 3 of the block (the rest of the result 0).
#[inline(always)]
fn mat_vec3(m: &M6, v: &V6) -> V6 {
    std::array::from_fn(|r| if r < 3 { (0..3).fold(0.0, |s, c| s + m[r][c] * v[c]) } else { 0.0 })
}

/// `mᵀ v` over the whole 6 × 6 block.
#[inline(always)]
fn mat_t_vec(m: &M6, v: &V6) -> V6 {
    std::array::from_fn(|c| (0..6).fold(0.0, |s, r| s + m[r][c] * v[r]))
}

/// The inverse of a body's inverse inertia (as the solver holds it), in
/// `f64`; zero when singular.
fn inverse3(m: &Mat3) -> M3 {
    inverse_3x3(std::array::from_fn(|r| std::array::from_fn(|c| m.col(c)[r] as f64)))
}

type M3 = [[f64; 3]; 3];

/// Inverts in place the leading `n × n` block of `m`, which is definite:
/// positive (a body's block, its mass plus what its child joints add) or,
/// with `negative`, negative (a joint's). Three rows by cofactors (zero
/// when singular), any other size by `LDLᵀ` ([`invert_ldl`], zero when
/// not definite): a node whose block gives zero moves nothing.
fn invert_definite(m: &mut M6, n: usize, negative: bool) {
    debug_assert!(n <= 6, "a block of {n} rows");
    match n {
        3 => {
            let inv = inverse_3x3(std::array::from_fn(|r| [m[r][0], m[r][1], m[r][2]]));
            for r in 0..3 {
                m[r][..3].copy_from_slice(&inv[r]);
            }
        }
        1 => invert_ldl::<1>(m, negative),
        2 => invert_ldl::<2>(m, negative),
        4 => invert_ldl::<4>(m, negative),
        5 => invert_ldl::<5>(m, negative),
        6 => invert_ldl::<6>(m, negative),
        _ => {}
    }
}

/// A 3 × 3 inverse by cofactors; zero when singular.
#[inline(always)]
fn inverse_3x3(a: M3) -> M3 {
    let c = [
        [
            a[1][1] * a[2][2] - a[1][2] * a[2][1],
            a[0][2] * a[2][1] - a[0][1] * a[2][2],
            a[0][1] * a[1][2] - a[0][2] * a[1][1],
        ],
        [
            a[1][2] * a[2][0] - a[1][0] * a[2][2],
            a[0][0] * a[2][2] - a[0][2] * a[2][0],
            a[0][2] * a[1][0] - a[0][0] * a[1][2],
        ],
        [
            a[1][0] * a[2][1] - a[1][1] * a[2][0],
            a[0][1] * a[2][0] - a[0][0] * a[2][1],
            a[0][0] * a[1][1] - a[0][1] * a[1][0],
        ],
    ];
    let det = a[0][0] * c[0][0] + a[0][1] * c[1][0] + a[0][2] * c[2][0];
    if det == 0.0 || !det.is_finite() {
        return [[0.0; 3]; 3];
    }
    let inv = 1.0 / det;
    c.map(|row| row.map(|x| x * inv))
}

/// Inverts in place the leading `N × N` block of `m`, symmetric and
/// definite (negative with `negative`), from its lower triangle.
///
/// With `s A = L D Lᵀ` (`s` the sign that makes `s A` positive definite,
/// `L` unit lower triangular, `D` diagonal and positive), `A⁻¹ = s Xᵀ D⁻¹
/// X` with `X = L⁻¹`, also unit lower triangular, so that entry `(r, c)`
/// of the inverse is `s Σ_{k ≥ max(r, c)} X_kr X_kc / D_k`. A definite
/// block needs no pivoting, and the three triangular sweeps take about
/// `N³` products, half of what Gauss–Jordan with pivoting takes: the
/// factoring of a chain of bodies each substep is mostly these 6 × 6
/// inverses. A pivot that is not positive and finite (the block not
/// definite after all, or singular) gives zero. A block that rounding
/// leaves indefinite would need a mass ratio past the `f64` limit the
/// module docs give, where the complements cancel anyway.
#[inline(always)]
fn invert_ldl<const N: usize>(m: &mut M6, negative: bool) {
    let sign = if negative { -1.0 } else { 1.0 };
    let mut l = [[0.0f64; N]; N];
    let mut d = [0.0f64; N];
    for j in 0..N {
        let mut dj = sign * m[j][j];
        for k in 0..j {
            dj -= l[j][k] * l[j][k] * d[k];
        }
        if dj <= 0.0 || !dj.is_finite() {
            *m = Z6;
            return;
        }
        d[j] = dj;
        let inv = 1.0 / dj;
        for i in j + 1..N {
            let mut s = sign * m[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k] * d[k];
            }
            l[i][j] = s * inv;
        }
    }
    // X = L⁻¹, row by row: X_ij = −Σ_{j ≤ k < i} L_ik X_kj.
    let mut x = [[0.0f64; N]; N];
    for i in 0..N {
        x[i][i] = 1.0;
        for j in 0..i {
            let mut s = 0.0;
            for k in j..i {
                s -= l[i][k] * x[k][j];
            }
            x[i][j] = s;
        }
    }
    let dinv = d.map(|v| sign / v);
    for r in 0..N {
        for c in 0..=r {
            let mut s = 0.0;
            for k in r..N {
                s += x[k][r] * x[k][c] * dinv[k];
            }
            m[r][c] = s;
            m[c][r] = s;
        }
    }
}

impl<'a> UnitJoints<'a> {
    /// No joints (a unit of contacts only, or the free bodies).
    pub(crate) fn empty() -> UnitJoints<'a> {
        UnitJoints { constraints: &mut [], nodes: &mut [], trees: &[] }
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.constraints.is_empty()
    }

    /// The rows for the bodies' state now, and the trees factored anew:
    /// what each substep after a step's first does before its warm start
    /// (the first's were built with the step).
    pub(crate) fn prepare(&mut self, bodies: BodiesView) {
        if self.constraints.is_empty() {
            return;
        }
        for c in self.constraints.iter_mut() {
            c.refresh(&bodies);
        }
        for t in self.trees {
            factor(&mut self.nodes[t.start as usize..t.end as usize], self.constraints, &bodies);
        }
    }

    /// The biased passes' targets for the substep of `h`, from the
    /// velocities before them (see `curvature`). Found once: the repeated
    /// biased passes of a settling unit would otherwise feed each pass's
    /// result into the next one's target, which grows as `ω²`, and a net
    /// folding onto itself spun up without bound.
    pub(crate) fn curve(&mut self, bodies: BodiesView, h: f32, cap: f32) {
        for c in self.constraints.iter_mut() {
            // (A loop's rows are rigid: their targets would not agree
            // around the loop, and its warm-started impulses would grow.)
            // Each target is a correction of the second order, held to the
            // push-out's speed cap: velocities that a pass is about to take
            // back (a warm start against a rod, 250 m/s) made a target of
            // hundreds of m/s, and the joints came apart.
            c.curve = if c.closer { [0.0; 6] } else { c.curvature(&bodies, h).map(|x| x.clamp(-cap, cap)) };
        }
    }

    /// The warm start (`Stage::WarmStart`), every substep: the joints
    /// solved by Gauss–Seidel between the trees (a net's loops, a second
    /// hold, `closer`) and the one-sided and soft rows apply the impulses
    /// they accumulated so far, as contacts do (without, a falling net's
    /// loops opened by a metre); a tree's own rows start from zero.
    ///
    /// A tree's solve is exact, so it needs no starting guess, and one
    /// would do harm: the last substep's impulse applied along rows the
    /// bodies have turned away from since keeps a part across the new rows
    /// that the solve leaves alone, a push along the motion. A pendulum on
    /// a 0.5 m arm swinging from 60° gained a third of its energy in ten
    /// seconds so; without, it loses a little to each projection instead.
    pub(crate) fn warm_start(&mut self, mut bodies: BodiesView) {
        for c in self.constraints.iter_mut() {
            if !c.closer {
                c.impulse = [0.0; 6];
            }
            for k in 0..c.dim {
                if c.closer {
                    apply_row(&mut bodies, c, &c.rows[k], c.impulse[k], false);
                }
            }
            for e in &c.extras[..c.n_extra] {
                apply_row(&mut bodies, c, &e.row, e.impulse, false);
            }
        }
    }

    /// Adds the substep's impulses to the step's totals (as the contacts
    /// do at the start of each later biased pass and after the last).
    pub(crate) fn accumulate(&mut self) {
        for c in self.constraints.iter_mut() {
            for k in 0..c.dim {
                c.total[k] += c.impulse[k];
            }
            for e in &mut c.extras[..c.n_extra] {
                e.total += e.impulse;
            }
        }
    }

    /// One pass over the unit's joints: each tree solved exactly, then the
    /// one-sided and soft rows by Gauss–Seidel. In a biased pass, the
    /// drift is pushed out through pseudo-velocities (see the module
    /// docs). Returns the largest velocity change of a row, m/s (rad/s).
    pub(crate) fn solve(&mut self, mut bodies: BodiesView, pass: &Pass) -> PassResult {
        let mut residual: f32 = 0.0;
        let (cs, nodes) = (&mut *self.constraints, &mut *self.nodes);
        let beta = pass.split.map(|s| s.beta);
        for t in self.trees {
            let tree = &mut nodes[t.start as usize..t.end as usize];
            // The biased pass's velocities carry the bodies through the
            // position update: they take the anchors' curvature over the
            // substep into account, so that the joints hold to second
            // order (see `curvature`). The relax passes are rigid.
            let r = if pass.use_bias {
                solve_tree(&mut bodies, tree, cs, false, |c, _| c.curve)
            } else {
                solve_tree(&mut bodies, tree, cs, false, |_, _| [0.0; 6])
            };
            residual = residual.max(r);
            if pass.use_bias {
                // The drift: `J p = −β C / h` on the pseudo-velocities
                // (or, without split impulses, on the velocities).
                let rate = beta.unwrap_or(0.3) * pass.inv_h;
                let cap = pass.max_push;
                solve_tree(&mut bodies, tree, cs, beta.is_some(), |c, bodies| {
                    let e = c.errors(bodies);
                    let mut out = [0.0; 6];
                    for k in 0..c.dim {
                        out[k] = (-rate * e[k]).clamp(-cap, cap);
                    }
                    out
                });
            }
            if pass.stamp != 0 && r > pass.tolerance {
                for n in tree.iter().filter(|n| !n.joint) {
                    bodies[n.item as usize].stamp = pass.stamp;
                }
            }
        }
        for c in cs.iter_mut() {
            for k in 0..c.n_extra {
                residual = residual.max(solve_extra(&mut bodies, c, k, pass));
            }
        }
        PassResult { residual, solved: cs.len() as u32 }
    }
}

/// One exact solve of a tree's rows: the right-hand sides `target − J v`
/// (`target` from `targets`, per joint and row, given the bodies), one
/// sweep up and one down, the bodies' changes applied and, for the
/// velocities, the joints' impulses accumulated. Returns the largest
/// `|target − J v|` before the solve.
fn solve_tree(
    bodies: &mut BodiesView,
    tree: &mut [Node],
    cs: &mut [JointConstraint],
    pseudo: bool,
    targets: impl Fn(&JointConstraint, &BodiesView) -> [f32; 6],
) -> f32 {
    if single(tree) {
        return solve_single(bodies, &tree[0], cs, pseudo, targets);
    }
    let mut residual: f32 = 0.0;
    for node in tree.iter_mut() {
        node.y = [0.0; 6];
        if node.joint {
            let c = &cs[node.item as usize];
            let (va, wa) = velocities(bodies, c.a, pseudo);
            let (vb, wb) = velocities(bodies, c.b, pseudo);
            let target = targets(c, bodies);
            for k in 0..c.dim {
                let b = target[k] - c.rows[k].velocity(va, wa, vb, wb);
                residual = residual.max(b.abs());
                node.y[k] = b as f64;
            }
        }
    }
    // Up: z = D⁻¹ y, and the parent's y less Hᵀ z. Every block is 6 × 6
    // with zeros past a node's rows (as `factor` leaves them), so the
    // products run over fixed bounds, unrolled, whatever the rows.
    for i in (0..tree.len()).rev() {
        let p = tree[i].parent;
        let z = mat_vec(&tree[i].dinv, &tree[i].y);
        tree[i].z = z;
        if p != NONE {
            let hz = mat_t_vec(&tree[i].h, &z);
            let y = &mut tree[p as usize].y;
            for c in 0..6 {
                y[c] -= hz[c];
            }
        }
    }
    // Down: x = z − L x_parent (x kept in z; parents come first).
    for i in 0..tree.len() {
        let p = tree[i].parent;
        if p != NONE {
            let lx = mat_vec(&tree[i].l, &tree[p as usize].z);
            for r in 0..6 {
                tree[i].z[r] -= lx[r];
            }
        }
    }
    for node in tree.iter() {
        let x = node.z.map(|v| v as f32);
        if node.joint {
            if !pseudo {
                let c = &mut cs[node.item as usize];
                for k in 0..c.dim {
                    c.impulse[k] -= x[k];
                }
            }
        } else {
            let (dv, dw) = (Vec3A::new(x[0], x[1], x[2]), Vec3A::new(x[3], x[4], x[5]));
            add_velocity(&mut bodies[node.item as usize], dv, dw, pseudo);
        }
    }
    residual
}

/// One pass over one-sided or soft row `k` of `c` (Gauss–Seidel, its
/// own effective mass). Returns its velocity change.
fn solve_extra(bodies: &mut BodiesView, c: &mut JointConstraint, k: usize, pass: &Pass) -> f32 {
    let e = c.extras[k];
    // A spring is a force: the soft step applies it once a substep, in
    // the biased pass (as Box2D's soft step does with its one relax
    // pass); solved again in each of the relax passes, after the bodies
    // moved, it damped a ζ = 0.1 spring into a creep.
    if e.mass == 0.0 || (e.kind == ExtraKind::Spring && !pass.use_bias) {
        return 0.0;
    }
    let error = c.extra_error(k, bodies);
    let (va, wa) = velocities(bodies, c.a, false);
    let (vb, wb) = velocities(bodies, c.b, false);
    let jv = e.row.velocity(va, wa, vb, wb);
    let (old, new) = match e.kind {
        ExtraKind::Spring => {
            let s = c.soft;
            let d = -e.mass * s.mass_scale * (jv + s.bias_rate * error) - s.impulse_scale * e.impulse;
            (e.impulse, e.impulse + d)
        }
        _ => {
            // One-sided: the gap may close this substep (speculative),
            // no further; a violation stops, and the biased pass pushes
            // it out below.
            let bias = error.max(0.0) * pass.inv_h;
            let d = -e.mass * (jv + bias);
            (e.impulse, (e.impulse + d).max(0.0))
        }
    };
    c.extras[k].impulse = new;
    apply_row(bodies, c, &e.row, new - old, false);
    if pass.use_bias && e.kind != ExtraKind::Spring && error < 0.0 {
        let beta = pass.split.map(|s| s.beta).unwrap_or(0.3);
        let pseudo = pass.split.is_some();
        let (pva, pwa) = velocities(bodies, c.a, pseudo);
        let (pvb, pwb) = velocities(bodies, c.b, pseudo);
        let jp = e.row.velocity(pva, pwa, pvb, pwb);
        let target = (-beta * error * pass.inv_h).min(pass.max_push);
        let push = (e.mass * (target - jp)).max(0.0);
        apply_row(bodies, c, &e.row, push, pseudo);
    }
    ((new - old) / e.mass).abs()
}
