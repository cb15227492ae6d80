//! Fracture: a box of a breakable material (`Material::strength`) splits
//! into two boxes along one of its own axis planes when the step's
//! impulses put more stress across that plane than the material bears.
//!
//! A box cut by a plane normal to one of its axes is two boxes, so
//! fracture never leaves the engine's shapes: the pieces tile the parent
//! exactly, their masses sum to its mass, and their inertias about the
//! parent's centre sum to its inertia (the parallel-axis theorem), so a
//! split that gives each piece the parent's rigid velocity field keeps
//! linear and angular momentum.
//!
//! # The cut analysis
//!
//! At the end of a step a breakable box knows the impulses that reached
//! it (contacts, bonds, joints; gravity), where they acted, and how its velocity
//! changed. For a candidate plane (axis `k`, offset `s` in the box's frame)
//! take the piece `P` on its positive side: mass `m_P`, centre offset
//! `r_P` from the box's centre, inertia `I_P` about its own centre. As a
//! part of the rigid box, `P`'s momentum changed by
//! `m_P (Δv + Δω × r_P)` and its angular momentum about the plane's
//! centre `o` by `I_P Δω + (r_P − r_o) × m_P (Δv + Δω × r_P)`. The impulses
//! applied to `P` from outside account for part of that; the rest came
//! across the plane from the other piece:
//!
//! ```text
//! J_int = m_P Δv_P − Σ_{p ∈ P} J_p − m_P g dt
//! H_int = ΔL_P(o) − Σ_{p ∈ P} (p − o) × J_p − (r_P − r_o) × m_P g dt
//! ```
//!
//! (a load exactly on the plane counts half on each side). Over the step
//! that is a force `F = J_int / dt` and a moment `M = H_int / dt` on the
//! section, a rectangle `a × b` of area `A`. With `n` the plane's normal
//! (pointing into `P`), the section bears
//!
//! - tension `σ = −F·n / A + |M·u| / Z_u + |M·w| / Z_w` at its worst edge,
//!   `Z_u = a_u a_w² / 6` the elastic section modulus for bending about
//!   the in-plane axis `u` (and likewise `w`): Euler–Bernoulli beam theory;
//! - shear `τ = 1.5 |F_t| / A + |M·n| (3 a + 1.8 b) / (a² b²)`, `F_t` the
//!   in-plane part of `F`, 1.5 the peak over the mean of a rectangle's
//!   parabolic shear flow, and the second term the peak torsional shear of
//!   a rectangle with long side `a` and short side `b` (Roark's formula).
//!
//! The box splits on the candidate plane with the largest of `σ / f_t`
//! and `τ / f_s` when that reaches 1. Candidates are the three planes
//! normal to each axis at −½, 0 and +½ of the half extent (the middle, and
//! quarter planes where a hit near an end breaks a corner off), skipping
//! any that would leave a piece thinner than `WorldSettings::min_piece`.
//! Like bonds, the judgement reads the step's impulses, so strengths in
//! pascals mean the same at any time step; a brick loaded only by gravity
//! and the bricks it carries is stressed to a few kilopascals, a
//! thousandth of a fired brick's strength, and never breaks.
//!
//! # The pieces
//!
//! Each piece takes the parent's rigid velocity field at its centre, and
//! so keeps, with the other, the parent's momentum and angular momentum.
//! Nothing more: a rigid body stores no strain energy, so any part of the
//! step's internal impulse given back to the pieces at the crack would be
//! kinetic energy the body never had (given back, the pull and moment in
//! excess of the section's strength sent the pieces of bricks ground
//! between heavy balls to 1,000 m/s). The loads of the next step, the ball
//! still pushing, part them. Bonds of the parent pass to the pieces whose
//! faces still touch the bonded neighbour, none joining the two pieces;
//! its joints pass to the piece that holds their anchor.

use crate::collider::Strength;
use crate::math::{Mat3, Quat, Vec3};
use crate::BodyHandle;

/// Which strength a split reached.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FractureMode {
    /// The tensile stress at an edge of the section (pull and bending).
    Tension,
    /// The shear stress on the section (sliding and twisting).
    Shear,
}

/// What happened to a breakable body during the last step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FractureEvent {
    /// The body split in two and was removed at the end of the step; its
    /// pieces took its place (see the module docs).
    Split {
        /// The body that broke (its handle is now stale).
        parent: BodyHandle,
        /// The pieces: on the negative side of the plane, then the
        /// positive side.
        pieces: [BodyHandle; 2],
        /// The cut's axis in the parent's frame (0, 1 or 2).
        axis: usize,
        /// The cut's offset along that axis from the parent's centre, m.
        offset: f32,
        /// Which strength was reached.
        mode: FractureMode,
        /// The stress over the strength (at least 1).
        ratio: f32,
    },
}

/// An impulse a box received over the step, N·s, at a world point, with
/// an angular impulse (N·m·s) about that point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Load {
    pub point: Vec3,
    pub impulse: Vec3,
    pub angular: Vec3,
}

/// A breakable box over a step, in the world frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxState {
    /// Its centre and orientation when the step began, where the narrow
    /// phase found the loads' points.
    pub centre: Vec3,
    pub rotation: Quat,
    /// Its orientation when the step ended.
    pub rotation_end: Quat,
    pub half: Vec3,
    pub mass: f32,
    /// Its centre's velocity and its angular velocity when the step began
    /// and when it ended.
    pub v0: Vec3,
    pub w0: Vec3,
    pub v1: Vec3,
    pub w1: Vec3,
    /// The impulse of the forces that act on every part in proportion to
    /// its mass over the step (gravity, and forces applied to the body),
    /// N·s.
    pub body_impulse: Vec3,
    /// The angular velocity a torque applied to the body gave it over the
    /// step, rad/s: every part turns with it, so it strains nothing.
    pub torque_spin: Vec3,
}

/// A plane that a box may split on, with what crossed it in the step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cut {
    pub axis: usize,
    pub offset: f32,
    pub mode: FractureMode,
    /// The larger of stress over strength, tension and shear (a NaN
    /// never breaks).
    pub ratio: f32,
}

/// A piece of a box cut on (`axis`, `offset`): `side` −1 or +1. Its
/// centre in the box's frame and its half extents.
pub(crate) fn piece(half: Vec3, axis: usize, offset: f32, side: f32) -> (Vec3, Vec3) {
    let e = half[axis];
    let mut centre = Vec3::ZERO;
    let mut h = half;
    if side > 0.0 {
        centre[axis] = 0.5 * (offset + e);
        h[axis] = 0.5 * (e - offset);
    } else {
        centre[axis] = 0.5 * (offset - e);
        h[axis] = 0.5 * (e + offset);
    }
    (centre, h)
}

/// The inertia of a uniform box of mass `m` and half extents `h` about its
/// centre, in its own frame.
pub(crate) fn box_inertia(m: f32, h: Vec3) -> Mat3 {
    let (x, y, z) = (h.x * h.x, h.y * h.y, h.z * h.z);
    Mat3::from_diagonal(Vec3::new(y + z, x + z, x + y) * (m / 3.0))
}

/// The offsets (in units of the half extent) of the candidate planes.
const CANDIDATES: [f32; 3] = [0.0, -0.5, 0.5];

/// The candidate plane whose section is most overloaded, if any plane
/// leaves both pieces at least `min_piece` thick (see the module docs).
pub(crate) fn worst_cut(b: &BoxState, loads: &[Load], strength: Strength, dt: f32, min_piece: f32) -> Option<Cut> {
    let r = Mat3::from_quat(b.rotation);
    // What the loads on each candidate's positive side sum to, in one pass
    // over the loads: their impulse and their moment about the box's
    // centre (a plane's centre `o` is then `Σ (p − o) × J = Σ p × J −
    // o × Σ J` away). A load within 1e-4 of the half extent of a plane
    // counts half on each side.
    let mut sums = [[(Vec3::ZERO, Vec3::ZERO); 3]; 3];
    for l in loads {
        let arm = l.point - b.centre;
        let local = r.transpose() * arm;
        let moment = arm.cross(l.impulse) + l.angular;
        for axis in 0..3 {
            let e = b.half[axis];
            for (k, &q) in CANDIDATES.iter().enumerate() {
                let d = local[axis] - q * e;
                let w = if d > 1e-4 * e {
                    1.0
                } else if d < -1e-4 * e {
                    continue;
                } else {
                    0.5
                };
                let sum = &mut sums[axis][k];
                sum.0 += l.impulse * w;
                sum.1 += moment * w;
            }
        }
    }
    let mut best: Option<Cut> = None;
    for (axis, per_axis) in sums.iter().enumerate() {
        let e = b.half[axis];
        for (&q, &sum) in CANDIDATES.iter().zip(per_axis) {
            let s = q * e;
            if e - s.abs() < min_piece {
                continue;
            }
            let cut = judge(b, &r, sum, strength, dt, axis, s);
            if cut.ratio.is_nan() {
                continue;
            }
            if best.is_none_or(|c| cut.ratio > c.ratio) {
                best = Some(cut);
            }
        }
    }
    best
}

/// The stress across one plane (see the module docs), given what the
/// loads on its positive side sum to: their impulse and their moment about
/// the box's centre.
fn judge(
    b: &BoxState,
    r: &Mat3,
    (load, load_moment): (Vec3, Vec3),
    strength: Strength,
    dt: f32,
    axis: usize,
    s: f32,
) -> Cut {
    let e = b.half[axis];
    let (c_local, h) = piece(b.half, axis, s, 1.0);
    let m = b.mass * (e - s) / (2.0 * e);
    let r_p = *r * c_local;
    let mut o_local = Vec3::ZERO;
    o_local[axis] = s;
    let r_o = *r * o_local;
    let i_p = *r * box_inertia(m, h) * r.transpose();
    // The change of the positive piece's momentum and of its angular
    // momentum about the plane's centre, as a part of the rigid box (its
    // centre's velocity at the step's end taken where the step turned it
    // to, so that spin's centripetal pull counts) ...
    let r_p1 = Mat3::from_quat(b.rotation_end) * c_local;
    let dv_p = (b.v1 + b.w1.cross(r_p1)) - (b.v0 + b.w0.cross(r_p));
    let mut j = dv_p * m;
    let mut hm = i_p * (b.w1 - b.w0) + (r_p - r_o).cross(dv_p * m);
    // ... less what reached it from outside: the body forces (the piece's
    // share, and of an applied torque what turns the piece with the box)
    // and the loads.
    let g = b.body_impulse * (m / b.mass) + b.torque_spin.cross(r_p) * m;
    j -= g + load;
    hm -= (r_p - r_o).cross(g) + i_p * b.torque_spin + load_moment - r_o.cross(load);
    let n = r.col(axis);
    let (u, v) = (r.col((axis + 1) % 3), r.col((axis + 2) % 3));
    let (a_u, a_v) = (2.0 * b.half[(axis + 1) % 3], 2.0 * b.half[(axis + 2) % 3]);
    let area = a_u * a_v;
    let (f, mo) = (j / dt, hm / dt);
    let normal = f.dot(n);
    // Bending about u stresses the section along v, and the reverse.
    let z_u = a_u * a_v * a_v / 6.0;
    let z_v = a_v * a_u * a_u / 6.0;
    let sigma = -normal / area + mo.dot(u).abs() / z_u + mo.dot(v).abs() / z_v;
    let (long, short) = if a_u >= a_v { (a_u, a_v) } else { (a_v, a_u) };
    let shear = (f - n * normal).length();
    let tau = 1.5 * shear / area + mo.dot(n).abs() * (3.0 * long + 1.8 * short) / (long * long * short * short);
    let (rt, rs) = (sigma / strength.tensile, tau / strength.shear);
    let (mode, ratio) = if rt >= rs { (FractureMode::Tension, rt) } else { (FractureMode::Shear, rs) };
    Cut { axis, offset: s, mode, ratio }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pieces of any candidate cut tile the box: their volumes sum to
    /// its volume, their mass-weighted centres to its centre, and their
    /// inertias about its centre (parallel axes) to its inertia.
    #[test]
    fn the_pieces_of_a_cut_tile_the_box() {
        let half = Vec3::new(0.1075, 0.0325, 0.05125);
        let m = 2.86;
        let whole = box_inertia(m, half);
        for axis in 0..3 {
            for q in CANDIDATES {
                let s = q * half[axis];
                let mut volume = 0.0;
                let mut moment = Vec3::ZERO;
                let mut inertia = Mat3::ZERO;
                for side in [-1.0, 1.0] {
                    let (c, h) = piece(half, axis, s, side);
                    let v = 8.0 * h.x * h.y * h.z;
                    let mp = m * v / (8.0 * half.x * half.y * half.z);
                    volume += v;
                    moment += c * mp;
                    // Parallel axes: I + m (|c|² 1 − c cᵀ).
                    let shift = Mat3::from_diagonal(Vec3::splat(c.length_squared()))
                        - Mat3::from_cols(c * c.x, c * c.y, c * c.z);
                    inertia += box_inertia(mp, h) + shift * mp;
                }
                let full = 8.0 * half.x * half.y * half.z;
                assert!((volume - full).abs() < 1e-6 * full, "axis {axis} at {s}: volume {volume} of {full}");
                assert!(moment.length() < 1e-6, "axis {axis} at {s}: centre off by {moment}");
                for k in 0..3 {
                    let (a, b) = (inertia.col(k), whole.col(k));
                    assert!((a - b).length() < 1e-5 * whole.col(k).length(), "axis {axis} at {s}: {a} vs {b}");
                }
            }
        }
    }
}
