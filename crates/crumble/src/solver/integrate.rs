//! Integration: a substep's velocity update (forces, damping, the
//! gyroscopic term and the warm start body by body, see [`Warm`]) and its
//! position update.

use glam::Vec3A;

use super::{gyroscopic, BodiesView, BodyParams, SolverBody, Warm};
use crate::math::{Mat3, Quat, Vec3};

/// Which gyroscopic step a body takes, decided once per step from its
/// body-frame inertia.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Gyroscopic {
    /// None: an isotropic inertia (a sphere, a cube), or a body that is
    /// not dynamic.
    None,
    /// `gyroscopic_step_diagonal` with these moments, eight bodies at a
    /// time (`gyroscopic.rs`): every box that is not a cube.
    Diagonal(Vec3A),
    /// `gyroscopic_step_general`.
    General,
}

impl Gyroscopic {
    /// The step for a body-frame inertia `m`.
    pub fn of(m: &Mat3) -> Gyroscopic {
        let diagonal = m.x_axis.y == 0.0
            && m.x_axis.z == 0.0
            && m.y_axis.x == 0.0
            && m.y_axis.z == 0.0
            && m.z_axis.x == 0.0
            && m.z_axis.y == 0.0;
        let d = Vec3A::new(m.x_axis.x, m.y_axis.y, m.z_axis.z);
        if !diagonal {
            Gyroscopic::General
        } else if d.x == d.y && d.y == d.z {
            Gyroscopic::None
        } else {
            Gyroscopic::Diagonal(d)
        }
    }
}

/// The velocity update over `h` of the bodies of a piece of
/// `integrate_velocities`' ids (each body on its own, so the loop may be
/// split across threads): forces, damping, the gyroscopic term and the
/// caps, then the warm start or its mark as `warm` says. Bodies that are
/// not dynamic keep their velocity (and are never warm started: no contact
/// changes them).
pub(super) fn velocity_update(
    params: &[BodyParams],
    h: f32,
    max_speed: f32,
    max_rotation: f32,
    warm: Warm,
) -> impl Fn(&mut BodiesView, &[u32]) + Sync + '_ {
    // The new velocity `x` of a body whose last velocity's change by the
    // contacts is `*change` (with `Warm::Carry`).
    let finish = move |x: Vec3A, change: &mut Vec3A| -> Vec3A {
        match warm {
            Warm::No => x,
            Warm::Mark => {
                *change = x;
                x
            }
            Warm::Carry => {
                let d = *change;
                *change = x;
                x + d
            }
        }
    };
    // Forces and damping; the linear speed cap (which the gyroscopic
    // step does not change).
    let start = move |b: &SolverBody, p: &BodyParams| -> (Vec3A, Vec3A) {
        let mut v = b.v + h * Vec3A::from(p.accel);
        let mut w = b.w + h * Vec3A::from(p.ang_accel);
        v /= 1.0 + h * p.linear_damping;
        w /= 1.0 + h * p.angular_damping;
        // Caps: documented in WorldSettings.
        (cap_speed(v, max_speed), w)
    };
    let cap_rotation = move |mut w: Vec3A| {
        let rot = speed_of(w, w.length_squared()) * h;
        if rot > max_rotation {
            w *= max_rotation / rot;
        }
        w
    };
    move |view: &mut BodiesView, ids: &[u32]| {
        // Bodies with a diagonal inertia wait in `pending` and take the
        // gyroscopic step eight at a time (`gyroscopic.rs`).
        let mut pending = gyroscopic::Pending::default();
        let flush = |view: &mut BodiesView, pending: &mut gyroscopic::Pending| {
            let (n, ids) = (pending.len, pending.ids);
            let w = pending.step(h);
            for m in 0..n {
                let b = &mut view[ids[m] as usize];
                b.w = finish(cap_rotation(w[m]), &mut b.w0);
            }
        };
        for &i in ids {
            let p = &params[i as usize];
            if !p.dynamic {
                continue;
            }
            let b = &mut view[i as usize];
            if warm == Warm::Carry {
                b.v0 = b.v - b.v0;
                b.w0 = b.w - b.w0;
            }
            let (v, w) = start(b, p);
            b.v = finish(v, &mut b.v0);
            match p.gyroscopic {
                Gyroscopic::Diagonal(d) => {
                    if pending.push(i, w, b.dq * p.q0, d) {
                        flush(view, &mut pending);
                    }
                }
                // (In `Vec3`: a quaternion rotates a `Vec3A` with other
                // roundings.)
                Gyroscopic::General => {
                    let q = b.dq * p.q0;
                    let w = gyroscopic_step_general(w.into(), q, &p.local_inertia, &p.local_inv_inertia, h);
                    b.w = finish(cap_rotation(w.into()), &mut b.w0);
                }
                Gyroscopic::None => b.w = finish(cap_rotation(w), &mut b.w0),
            }
        }
        if pending.len > 0 {
            flush(view, &mut pending);
        }
    }
}

/// The gyroscopic step: the torque-free rigid body's `I ω̇ = -ω × Iω`,
/// integrated implicitly in the body frame with one Newton step (Catto, "Numerical Methods", GDC
/// 2015), then rescaled so that `|Iω|` (conserved exactly by the continuous
/// equation, since `Iω · (ω × Iω) = 0`) is kept, and scaled down where it
/// would still gain energy. Explicit Euler on this term gains energy and
/// flings spinning boxes; implicit Euler alone slowly loses angular
/// momentum.
///
/// The step both forms share. `inertia(v)` is `I v`; `newton(ω₁, L, f)`
/// is `ω₁ − J⁻¹ f`, with `f(ω) = I(ω − ω₁) + h ω × Iω` at `ω₁`
/// (`h ω₁ × L`) and `J = I + h (skew(ω₁) I − skew(L))` its Jacobian, or a
/// fallback when `J` is near singular.
#[inline(always)]
pub(super) fn implicit_gyroscopic(
    w_world: Vec3,
    q: Quat,
    h: f32,
    inertia: impl Fn(Vec3) -> Vec3,
    newton: impl Fn(Vec3, Vec3, Vec3) -> Vec3,
) -> Vec3 {
    let w1 = q.inverse() * w_world;
    let l1 = inertia(w1);
    let l1_len = l1.length();
    if l1_len == 0.0 {
        return w_world;
    }
    let mut w2 = newton(w1, l1, h * w1.cross(l1));
    let l2_len = inertia(w2).length();
    if l2_len > 0.0 && l2_len.is_finite() {
        w2 *= l1_len / l2_len;
    }
    // Nor may the step gain energy (`2E = ω · Iω`). Implicit Euler loses
    // both: dotting `I(ω₂ − ω₁) = −h ω₂ × Iω₂` with ω₂ gives E₂ ≤ E₁, and
    // with Iω₂ gives |L₂| ≤ |L₁|. Restoring |L| multiplies E by
    // (|L₁|/|L₂|)², a gain wherever |L| fell faster than √E: a
    // 1 × 700 × 5000 mm plate spinning freely gained 2.5 times its energy
    // in ten seconds. So the scale is the smaller of the two that restore
    // |L| and E: neither grows, and the one not restored shrinks.
    let (e1, e2) = (w1.dot(l1), w2.dot(inertia(w2)));
    if e2 > e1 {
        w2 *= (e1 / e2).sqrt();
    }
    if !w2.is_finite() {
        return w_world;
    }
    q * w2
}

/// The gyroscopic step for any body-frame inertia: `J` formed and inverted.
pub(super) fn gyroscopic_step_general(w_world: Vec3, q: Quat, inertia: &Mat3, inv_inertia: &Mat3, h: f32) -> Vec3 {
    implicit_gyroscopic(
        w_world,
        q,
        h,
        |v| *inertia * v,
        |w1, l1, f| {
            let j = *inertia + h * (skew(w1) * *inertia - skew(l1));
            let det = j.determinant();
            if det.abs() > 1e-20 * inertia.determinant().abs().max(f32::MIN_POSITIVE) {
                w1 - j.inverse() * f
            } else {
                w1 - *inv_inertia * f
            }
        },
    )
}

fn skew(v: Vec3) -> Mat3 {
    Mat3::from_cols(Vec3::new(0.0, v.z, -v.y), Vec3::new(-v.z, 0.0, v.x), Vec3::new(v.y, -v.x, 0.0))
}

/// The position update over `h` of body `i`: moved by its velocities and
/// the push-out's pseudo-velocities, which are then discarded.
pub(super) fn position_update(h: f32) -> impl Fn(&mut BodiesView, usize) + Sync {
    let one = move |b: &mut SolverBody| {
        b.dp += h * (b.v + b.pv);
        b.dq = integrate_rotation(b.dq, (b.w + b.pw).into(), h);
        b.pv = Vec3A::ZERO;
        b.pw = Vec3A::ZERO;
    };
    move |view: &mut BodiesView, i: usize| one(&mut view[i])
}

/// `q + h/2 (ω, 0) ⊗ q`, renormalised.
#[inline]
pub(crate) fn integrate_rotation(q: Quat, w: Vec3, h: f32) -> Quat {
    let dq = Quat::from_xyzw(w.x, w.y, w.z, 0.0) * q;
    let r = Quat::from_xyzw(q.x + 0.5 * h * dq.x, q.y + 0.5 * h * dq.y, q.z + 0.5 * h * dq.z, q.w + 0.5 * h * dq.w);
    r.normalize()
}

/// `|v|` given `|v|²` (`speed2`). Above about 1.8e19 the square overflows
/// `f32` to infinity, and a cap that divided by its root would zero the
/// velocity (or, for the rotation cap, the angular velocity): there the length is taken of `v` scaled down by its largest
/// component first. A finite square takes the plain root (the same bits
/// as always).
#[inline]
pub(super) fn speed_of(v: Vec3A, speed2: f32) -> f32 {
    if speed2.is_finite() {
        speed2.sqrt()
    } else {
        let largest = v.abs().max_element();
        largest * (v / largest).length()
    }
}

/// `v` with its length capped to `max` (m/s), its direction kept.
#[inline]
pub(crate) fn cap_speed(v: Vec3A, max: f32) -> Vec3A {
    let speed2 = v.length_squared();
    if speed2 > max * max {
        v * (max / speed_of(v, speed2))
    } else {
        v
    }
}
