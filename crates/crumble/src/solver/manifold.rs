//! What both contact paths solve one manifold at a time: the rolling
//! resistance (the batches solve it lane by lane, only for the lanes that
//! roll) and restitution (once a step, constraint by constraint).

use std::ops::IndexMut;

use glam::{DMat3, DVec3, Mat3A, Vec3A};

use super::{BodyParams, SolverBody};
use crate::math::Vec3;

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

/// Rolling resistance, one pass: opposes the relative spin about the
/// tangents (rolling) and the normal (spinning in place), `axes`, the
/// three angular impulses clamped together to the ball of radius
/// `arm · total` (`arm` = `c_rr · r`, `total` = `Σλn`: the torque a
/// deformed contact patch can give). Returns the surface speed it changed
/// (the spin change times `lever`, the contact's distance from the farther
/// centre of mass) when `lever` is given, else 0.
///
/// The three rows are solved as one block. An angular impulse `L` changes
/// the relative spin by `M L`, `M = I_a⁻¹ + I_b⁻¹` (world frame), so the
/// impulse that stops it is `−M⁻¹ Δω`; in the orthonormal `axes` its
/// components are `axes[k] · L`. Solving the rows one at a time, each with
/// its own effective mass `1 / (axes[k]ᵀ M axes[k])`, ignores how a turn
/// about one axis spins a thin, tilted box about the others: the updates
/// then overshoot by up to the ratio of its moments, and a 2 × 80 × 2 mm
/// stick on a ball gained speed without bound.
///
/// The pass adds no energy (unless the bound shrank below the impulse the
/// pass started from: scaling that back in is the bound's doing, as for
/// friction). Adding `L` to the impulse changes the
/// kinetic energy by `ΔE(L) = L · Δω + ½ Lᵀ M L`, which needs only
/// products with `M`, never its inverse; `rolling_stop` checks the stopping
/// impulse against it, and `clamp_rolling` keeps the clamped impulse to it.
#[inline(always)]
pub(super) fn solve_rolling<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    (ia, ib): (usize, usize),
    axes: [Vec3A; 3],
    arm: f32,
    total: f32,
    impulse: &mut [f32; 3],
    lever: Option<f32>,
) -> f32 {
    let (a, b) = (&bodies[ia], &bodies[ib]);
    let m = a.inv_i + b.inv_i;
    let dw = b.w - a.w;
    let Some(stop) = rolling_stop(m, dw) else {
        return 0.0;
    };
    let bound = arm * total;
    let old = *impulse;
    let free: [f32; 3] = std::array::from_fn(|k| old[k] - stop.dot(axes[k]));
    let world = |x: [f32; 3]| (x[0] - old[0]) * axes[0] + (x[1] - old[1]) * axes[1] + (x[2] - old[2]) * axes[2];
    let gain = |x: [f32; 3]| {
        let l = world(x);
        l.dot(dw) + 0.5 * l.dot(m * l)
    };
    let k = || std::array::from_fn(|i| std::array::from_fn(|j| axes[i].dot(m * axes[j])));
    let new = clamp_rolling(old, free, bound, k, gain);
    *impulse = new;
    let axis = world(new);
    let a = &mut bodies[ia];
    a.w -= a.inv_i * axis;
    let b = &mut bodies[ib];
    b.w += b.inv_i * axis;
    match lever {
        Some(lever) => (m * axis).abs().max_element() * lever,
        None => 0.0,
    }
}

/// The angular impulse `s` whose negative stops the relative spin `dw`
/// (`M s = dw`), or `None` where `M` has no inverse (both bodies static
/// about some axis).
///
/// `M⁻¹` in f32 is exact enough for the bodies of an ordinary scene, and
/// is used when its stop leaves a relative spin under a thousandth of
/// `dw` (`|M s − dw| ≤ 10⁻³ |dw|`) and lowers the energy (`ΔE(−s) ≤ 0`).
/// A thin rod fails it: a 1.4 × 1.9 mm rod 1.7 m long turns 5 · 10⁵ times
/// more easily about its length than across it, `M`'s entries are ~10⁹
/// where its two small eigenvalues are ~10³ to 10⁴, and f32's determinant
/// (products of ~10²⁷ cancelling to ~10¹⁶) is noise; its "stop" quintupled
/// the spin it was to stop, and a random scene's normal impulses reached
/// 10³¹ in one step. There the inverse is taken in f64 and serves only as
/// a direction `d`, scaled to the minimum of the energy along it,
/// `t = (d · dw) / (dᵀ M d)` (both in f64), which lowers the energy by
/// `½ (d · dw)² / (dᵀ M d)` however far `d` is from the true stop.
fn rolling_stop(m: Mat3A, dw: Vec3A) -> Option<Vec3A> {
    let det = m.determinant();
    if det.is_finite() && det > 0.0 {
        let s = m.inverse() * dw;
        let left = (m * s - dw).length_squared();
        if left <= 1e-6 * dw.length_squared() && -s.dot(dw) + 0.5 * s.dot(m * s) <= 0.0 {
            return Some(s);
        }
    }
    let m64 = m.as_dmat3();
    let det = m64.determinant();
    if !(det.is_finite() && det > 0.0) {
        return None;
    }
    let dw64 = dw.as_dvec3();
    let d = m64.inverse() * dw64;
    let (along, curve) = (d.dot(dw64), d.dot(m64 * d));
    (curve > 0.0 && along.is_finite()).then(|| (d * (along / curve)).as_vec3a())
}

/// The rolling impulse a pass keeps: `free` (the impulse that stops the
/// relative spin, `rolling_stop`) if it lies in the ball of radius
/// `bound`, else the point of the ball with the least energy, in the
/// `axes` frame where `M` reads `k()` (`k[i][j] = axes[i] · M axes[j]`,
/// formed only for a clamped pass); the
/// energy change `gain(x)` from the pass's start then is at most that of
/// the start scaled into the ball (a `bound` that shrank), which is kept
/// if rounding says otherwise.
///
/// Scaling `free` back to the ball, the usual clamp, is that point only
/// where `M` is round (a ball on the ground): elsewhere it can gain energy.
/// It also shortens the part of the impulse that `free` had set exactly
/// along the axis the bodies turn most easily about, and a thin rod spins
/// up about its length; a ball rolling on a brick gained ~10⁻⁸ J a pass.
/// The least-energy point is `x(μ) = (k + μ I)⁻¹ k f` with `μ ≥ 0` chosen
/// so that `|x(μ)| = bound` (the multiplier of the ball; `|x|` falls as `μ`
/// grows). Newton's method on `1/|x(μ)| − 1/bound`, nearly linear in `μ`,
/// finds it from `μ = 0`: in 20,000 random cases with moments spread over
/// fifteen decades, the median took 5 steps and the slowest 15 (a step
/// past the root comes back, as `μ` is kept at 0 or more). It runs in f64,
/// as `k` may span ten decades, and whatever it ends with is scaled into
/// the ball.
fn clamp_rolling(
    old: [f32; 3],
    free: [f32; 3],
    bound: f32,
    k: impl Fn() -> [[f32; 3]; 3],
    gain: impl Fn([f32; 3]) -> f32,
) -> [f32; 3] {
    let norm2 = |x: [f32; 3]| x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
    if norm2(free) <= bound * bound {
        return free;
    }
    let start = {
        let n2 = norm2(old);
        if n2 > bound * bound {
            let s = bound / n2.sqrt();
            old.map(|c| c * s)
        } else {
            old
        }
    };
    let k = DMat3::from_cols_array_2d(&k().map(|c| c.map(f64::from)));
    let f = DVec3::from_array(free.map(f64::from));
    let (kf, r) = (k * f, f64::from(bound));
    let mut mu = 0.0_f64;
    let mut x = f;
    for _ in 0..PROJECTION_STEPS {
        let shifted = k + DMat3::from_diagonal(DVec3::splat(mu));
        let det = shifted.determinant();
        if !(det.is_finite() && det > 0.0) {
            break;
        }
        let inv = shifted.inverse();
        x = inv * kf;
        let n = x.length();
        if !(n.is_finite() && n > 0.0) || (n - r).abs() <= 1e-9 * r {
            break;
        }
        // d|x|/dμ = −x·(k + μI)⁻¹x / |x|, so d(1/|x|)/dμ = x·(k + μI)⁻¹x / |x|³.
        let slope = x.dot(inv * x) / (n * n * n);
        if !(slope.is_finite() && slope > 0.0) {
            break;
        }
        mu = (mu + (1.0 / r - 1.0 / n) / slope).max(0.0);
    }
    let n = x.length();
    let x = if n > r && n.is_finite() { x * (r / n) } else { x };
    let x = x.as_vec3().to_array();
    if x.iter().all(|c| c.is_finite()) && gain(x) <= gain(start) {
        x
    } else {
        start
    }
}

/// Newton steps `clamp_rolling` takes at most (stopping once `|x|` is
/// within 10⁻⁹ of the radius).
const PROJECTION_STEPS: usize = 16;

/// A contact point as restitution reads it: anchors, effective mass, and
/// the step's approach speed (`ContactConstraint::relative_velocity`).
pub(crate) struct RestitutionPoint {
    pub ra: Vec3A,
    pub rb: Vec3A,
    pub normal_mass: f32,
    pub approach: f32,
    /// The impulse the impact took in earlier steps (0 unless carried).
    pub carried: f32,
}

/// A point still closing at the end of its step faster than this
/// fraction of its approach speed has not finished its impact (a
/// speculative contact has only slowed it so far): it bounces when it has.
const STILL_CLOSING: f32 = 0.01;

/// One point's restitution (see `apply_restitution`): if it approached
/// faster than `threshold` and took an impulse, adds the impulse that makes
/// its normal velocity `-e` times the approach speed (never pulling), to
/// the point's `impulse` and its `max` and `total` and to the bodies; but
/// at most `e` times the impulse the point took in the step (`total`, plus
/// `p.carried` from the step before, below: Poisson's law). That bound is what keeps restitution from adding
/// energy: it gives back at most `e` of what the impact took. Newton's
/// target alone bounced points that had not touched: a speculative point
/// 0.2 m from the ground on the far corner of a spinning plate, whose
/// approach the solver had only trimmed to what the gap allows, was sent
/// back at `e` times its full approach speed, and a pinched plate gained
/// five times its energy.
///
/// An impact may span steps: a speculative contact slows a point that has
/// not yet touched to what the gap allows, and the point touches in the
/// next step. Bounced at the first step's end, it got back `e` of only
/// what that step took: a ball dropped on the ground from 0.5, 0.8 or
/// 1.5 m rose to 37%, 0% and 12% of `e²` times the height, from 1 m to
/// 96%, and at 8 substeps from 1 m to 10%. So a point still closing at
/// the step's end (faster than `STILL_CLOSING` of its approach) does not
/// bounce yet: it returns its approach speed and the impulse taken so far,
/// which its contact carries into the next step (`Contact::impact_approach`,
/// `impact_impulse`), where they become the point's approach speed and
/// count towards Poisson's bound (`p.carried`). Returns `None` otherwise.
/// An impact is carried once: a point still closing at the end of the
/// step it was carried into bounces then. One that keeps closing is being
/// pressed, not struck: a 2.8 m plate pivoting onto its edge carried its
/// corners' impulses for step after step and got back more than it lost.
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
) -> Option<(f32, f32)> {
    if p.approach > -threshold || *max == 0.0 {
        return None;
    }
    let vn = relative_velocity(&bodies[ia], &bodies[ib], p.ra, p.rb).dot(normal);
    let taken = *total + p.carried;
    if p.carried == 0.0 && vn < STILL_CLOSING * p.approach {
        return Some((p.approach, taken));
    }
    let delta = -p.normal_mass * (vn + e * p.approach);
    let old = *impulse;
    let new = (old + delta.min(e * taken)).max(0.0);
    let applied = new - old;
    *impulse = new;
    *max = max.max(new);
    *total += applied;
    apply(bodies, ia, ib, p.ra, p.rb, applied * normal);
    None
}

/// The kinetic energy of a dynamic solver body `b` with parameters `p`, J:
/// `½ m |v|² + ½ ωᵀ I ω`, the rotation's in the body frame.
#[inline]
pub(crate) fn kinetic_energy(b: &SolverBody, p: &BodyParams) -> f32 {
    let w = (b.dq * p.q0).inverse() * Vec3::from(b.w);
    0.5 * b.v.length_squared() / b.inv_mass + 0.5 * w.dot(p.local_inertia * w)
}

/// Restitution's energy check on the pair of one manifold. Each point's
/// bounce is bounded by Poisson's law (`restitute`), but the points of a
/// manifold bounce one after another, each with its own effective mass,
/// and close points on a thin body are coupled: a rod landing on its
/// 2 mm end, its four corners bouncing in turn, span about its long axis
/// at hundreds of radians a second and left with four times the energy it
/// fell with. So after a manifold's bounce, the pair's kinetic energy may
/// not exceed what it had when the step began plus the work of gravity
/// and the applied forces over its motion since (`m a · Δx`, which
/// symplectic Euler's own gain stays below); where it would, the
/// manifold's bounce is undone and its contact stays inelastic this step.
/// A pair with a kinematic body (which may drive energy in) or an applied
/// torque (whose work is not tracked) is not checked.
pub(crate) struct EnergyCheck {
    pair: (usize, usize),
    allowed: f32,
    /// The part of `allowed` from impacts carried from earlier steps
    /// (`allow_carried`).
    carried: f32,
    saved: [(Vec3A, Vec3A); 2],
}

impl EnergyCheck {
    /// The check of the pair `(ia, ib)` before its bounce; `None` when
    /// the pair is not checked.
    pub fn new(bodies: &[SolverBody], params: &[BodyParams], (ia, ib): (usize, usize)) -> Option<EnergyCheck> {
        let mut allowed = 0.0;
        for i in [ia, ib] {
            let (b, p) = (&bodies[i], params_of(params, i));
            if !p.dynamic {
                if b.v != Vec3A::ZERO || b.w != Vec3A::ZERO {
                    return None;
                }
                continue;
            }
            if p.ang_accel != Vec3::ZERO {
                return None;
            }
            allowed += p.start_energy + p.accel.dot(b.dp.into()) / b.inv_mass;
        }
        let saved = [(bodies[ia].v, bodies[ia].w), (bodies[ib].v, bodies[ib].w)];
        Some(EnergyCheck { pair: (ia, ib), allowed, carried: 0.0, saved })
    }

    /// Adds what an impact carried from earlier steps took from the pair:
    /// the bounce may give back part of it, though the step began after it
    /// was taken. `points` are the manifold's points, each as the impulse
    /// `J_i` it took since the impact began (`carried`), its approach speed
    /// `u_i` then (negative) and its anchors. Impulses `J` along the normal
    /// at points closing at `−u` change the pair's kinetic energy by
    /// `−Σ J_i |u_i| + ½ Jᵀ A J`, where `½ Jᵀ A J` is the energy of the
    /// velocity change the impulses alone would give the bodies (`A` the
    /// points' coupled effective inverse mass): so that is what they took.
    /// Summing `J_i |u_i| − J_i² / 2m_i` point by point instead counts
    /// twice what close points take together.
    pub fn allow_carried(
        &mut self,
        bodies: &[SolverBody],
        normal: Vec3A,
        points: impl Iterator<Item = (f32, f32, Vec3A, Vec3A)>,
    ) {
        let (ia, ib) = self.pair;
        let (mut work, mut push, mut turn_a, mut turn_b) = (0.0, 0.0, Vec3A::ZERO, Vec3A::ZERO);
        for (carried, approach, ra, rb) in points {
            if carried > 0.0 && approach < 0.0 {
                work += carried * -approach;
                push += carried;
                turn_a += ra.cross(normal) * carried;
                turn_b += rb.cross(normal) * carried;
            }
        }
        if work <= 0.0 {
            return;
        }
        let (a, b) = (&bodies[ia], &bodies[ib]);
        let given = 0.5
            * (push * push * (a.inv_mass + b.inv_mass) + turn_a.dot(a.inv_i * turn_a) + turn_b.dot(b.inv_i * turn_b));
        let taken = (work - given).max(0.0);
        self.allowed += taken;
        self.carried += taken;
    }

    /// After a bounce that stood (`undo_if_gained` false): gives what the
    /// carried impacts took back to the island's energy bound too
    /// (`energy.rs`), through `allowance`, per solver body: to the pair's
    /// first dynamic body.
    pub fn record_carried(&self, params: &[BodyParams], allowance: &mut [f32]) {
        if self.carried > 0.0 {
            let (ia, ib) = self.pair;
            let at = if params_of(params, ia).dynamic { ia } else { ib };
            if let Some(x) = allowance.get_mut(at) {
                *x += self.carried;
            }
        }
    }

    /// Whether the bounce left the pair with more than it may have, beyond
    /// rounding (1e-4 of it); if so, the bodies' velocities are put back
    /// and the caller puts back the points' impulses.
    pub fn undo_if_gained(&self, bodies: &mut [SolverBody], params: &[BodyParams]) -> bool {
        let (ia, ib) = self.pair;
        let energy = |i: usize| {
            let p = params_of(params, i);
            if p.dynamic {
                kinetic_energy(&bodies[i], p)
            } else {
                0.0
            }
        };
        let now = energy(ia) + energy(ib);
        if now <= self.allowed * 1.0001 {
            return false;
        }
        (bodies[ia].v, bodies[ia].w) = self.saved[0];
        (bodies[ib].v, bodies[ib].w) = self.saved[1];
        true
    }
}

/// Body `i`'s parameters. The solver bodies past the parameters are the
/// static bodies' private copies (`private_statics`).
fn params_of(params: &[BodyParams], i: usize) -> &BodyParams {
    params.get(i).unwrap_or(&BodyParams::STATIC)
}
