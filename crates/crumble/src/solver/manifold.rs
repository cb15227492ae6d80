//! What both contact paths solve one manifold at a time: the rolling
//! resistance (the batches solve it lane by lane, only for the lanes that
//! roll) and restitution (once a step, constraint by constraint).

use std::ops::IndexMut;

use glam::Vec3A;

use super::SolverBody;

#[inline]
fn apply<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    ia: usize,
    ib: usize,
    ra: Vec3A,
    rb: Vec3A,
    p: Vec3A,
) {
    let a = &mut bodies[ia];
    a.v -= a.inv_mass * p;
    a.w -= a.inv_i * ra.cross(p);
    let b = &mut bodies[ib];
    b.v += b.inv_mass * p;
    b.w += b.inv_i * rb.cross(p);
}

#[inline]
fn relative_velocity(a: &SolverBody, b: &SolverBody, ra: Vec3A, rb: Vec3A) -> Vec3A {
    (b.v + b.w.cross(rb)) - (a.v + a.w.cross(ra))
}

/// The rolling resistance's part of a warm start: angular impulses
/// `impulse[k]` about `axes[k]` (the two tangents and the normal).
#[inline(always)]
pub(super) fn warm_start_rolling<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    (ia, ib): (usize, usize),
    axes: [Vec3A; 3],
    impulse: [f32; 3],
) {
    let [r0, r1, r2] = impulse;
    let roll = r0 * axes[0] + r1 * axes[1] + r2 * axes[2];
    let a = &mut bodies[ia];
    a.w -= a.inv_i * roll;
    let b = &mut bodies[ib];
    b.w += b.inv_i * roll;
}

/// The velocity change that an impulse change `d` makes along a row of
/// effective mass `mass` (`|d| / mass`; 0 for a row that cannot move).
#[inline(always)]
pub(super) fn velocity_change(d: f32, mass: f32) -> f32 {
    if mass > 0.0 {
        d.abs() / mass
    } else {
        0.0
    }
}

/// Rolling resistance, one pass: opposes the relative spin about the
/// tangents (rolling) and the normal (spinning in place), `axes`, the
/// three angular impulses clamped together to the ball of radius
/// `c_rr · r · Σλn` (the torque a deformed contact patch can give), with
/// `(arm, mass)` = `(c_rr · r, effective masses about the axes)` and
/// `total` = `Σλn`. Returns the surface speed it changed (the spin change
/// times `lever`, the contact's distance from the farther centre of mass)
/// when `lever` is given, else 0.
#[inline(always)]
pub(super) fn solve_rolling<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    (ia, ib): (usize, usize),
    axes: [Vec3A; 3],
    (arm, mass): (f32, [f32; 3]),
    total: f32,
    impulse: &mut [f32; 3],
    lever: Option<f32>,
) -> f32 {
    let (a, b) = (&bodies[ia], &bodies[ib]);
    let dw = b.w - a.w;
    let bound = arm * total;
    let old = *impulse;
    let mut new: [f32; 3] = std::array::from_fn(|k| old[k] - mass[k] * dw.dot(axes[k]));
    let mag2: f32 = new.iter().map(|x| x * x).sum();
    if mag2 > bound * bound {
        let k = bound / mag2.sqrt();
        new.iter_mut().for_each(|x| *x *= k);
    }
    *impulse = new;
    let mut slip: f32 = 0.0;
    if let Some(lever) = lever {
        for k in 0..3 {
            slip = slip.max(velocity_change(new[k] - old[k], mass[k]) * lever);
        }
    }
    let axis = (new[0] - old[0]) * axes[0] + (new[1] - old[1]) * axes[1] + (new[2] - old[2]) * axes[2];
    let a = &mut bodies[ia];
    a.w -= a.inv_i * axis;
    let b = &mut bodies[ib];
    b.w += b.inv_i * axis;
    slip
}

/// A contact point as restitution reads it: anchors, effective mass, and
/// the step's approach speed (`ContactConstraint::relative_velocity`).
pub(crate) struct RestitutionPoint {
    pub ra: Vec3A,
    pub rb: Vec3A,
    pub normal_mass: f32,
    pub approach: f32,
}

/// One point's restitution (see `apply_restitution`): if it approached
/// faster than `threshold` and took an impulse, adds the impulse that makes
/// its normal velocity `-e` times the approach speed (never pulling), to
/// the point's `impulse` and its `max` and `total` and to the bodies.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn restitute(
    bodies: &mut [SolverBody],
    (ia, ib): (usize, usize),
    normal: Vec3A,
    e: f32,
    threshold: f32,
    p: RestitutionPoint,
    impulse: &mut f32,
    max: &mut f32,
    total: &mut f32,
) {
    if p.approach > -threshold || *max == 0.0 {
        return;
    }
    let vn = relative_velocity(&bodies[ia], &bodies[ib], p.ra, p.rb).dot(normal);
    let delta = -p.normal_mass * (vn + e * p.approach);
    let old = *impulse;
    let new = (old + delta).max(0.0);
    let applied = new - old;
    *impulse = new;
    *max = max.max(new);
    *total += applied;
    apply(bodies, ia, ib, p.ra, p.rb, applied * normal);
}
