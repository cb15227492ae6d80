//! The gyroscopic step of eight bodies at a time (four with the `lanes4`
//! feature: `LANES`).
//!
//! Every box that is not a cube has a diagonal inertia in its body frame
//! and takes the diagonal gyroscopic step in every substep (its scalar
//! reference is `gyroscopic_step_diagonal`, in `reference.rs`).
//! That step is one long chain of dependent operations (two rotations, a
//! Newton step with a 3 × 3 solve, two lengths and two divisions), so a
//! body at a time the processor mostly waits on it. Here the same step runs
//! on eight bodies side by side, one per lane: the same chain, eight times
//! the work per instruction. The lanes are independent, so a body's result
//! does not depend on which bodies share its batch (nor on the threads).
//! Each lane does the scalar step's operations in its order, with its
//! roundings, and the guards choose as its branches do: the same bits
//! (`a_batch_of_bodies_takes_the_scalar_gyroscopic_step`).

use glam::{Quat, Vec3A, Vec4};

use super::contact_wide::{narrow, rotate_inverse, widen, W3};
use super::lanes::{columns, F8, LANES};

/// The gyroscopic step of each lane's body: `w` its world angular
/// velocity, `q` its orientation (unit quaternion), `d` the diagonal of its
/// body-frame inertia, over `h`. Lanes whose step the scalar form gives up
/// on (zero angular momentum, a result that is not finite) keep `w`.
#[inline(always)]
pub(super) fn diagonal_lanes(w: W3, q: [F8; 4], d: W3, h: f32) -> W3 {
    let h = F8::splat(h);
    let (u, qw) = (W3 { x: q[0], y: q[1], z: q[2] }, q[3]);
    // Into the body frame (`q⁻¹ ω`), and the angular momentum there.
    let w1 = rotate_inverse(u, qw, w);
    let l1 = W3 { x: d.x * w1.x, y: d.y * w1.y, z: d.z * w1.z };
    let l1_len = l1.dot(l1).sqrt();
    // One Newton step on `f(ω) = I(ω − ω₁) + h ω × Iω` from `ω₁`, where
    // `f = h ω₁ × L₁`; the Jacobian's columns (see
    // `gyroscopic_step_diagonal`), then Cramer's rule.
    let f = w1.cross(l1).scale(h);
    let c0 = W3 { x: d.x, y: h * (w1.z * d.x - l1.z), z: h * (l1.y - w1.y * d.x) };
    let c1 = W3 { x: h * (l1.z - w1.z * d.y), y: d.y, z: h * (w1.x * d.y - l1.x) };
    let c2 = W3 { x: h * (w1.y * d.z - l1.y), y: h * (l1.x - w1.x * d.z), z: d.z };
    let (r0, r1, r2) = (c1.cross(c2), c2.cross(c0), c0.cross(c1));
    let det = c0.dot(r0);
    let volume = (d.x * d.y * d.z).abs().max(F8::splat(f32::MIN_POSITIVE));
    let regular = det.abs().cmpgt(F8::splat(1e-20) * volume);
    let newton = w1 - W3 { x: f.dot(r0) / det, y: f.dot(r1) / det, z: f.dot(r2) / det };
    let fallback = w1 - W3 { x: f.x / d.x, y: f.y / d.y, z: f.z / d.z };
    let mut w2 = W3::select(regular, newton, fallback);
    // Keep `|Iω|`, which the continuous equation conserves.
    let l2 = W3 { x: d.x * w2.x, y: d.y * w2.y, z: d.z * w2.z };
    let l2_len = l2.dot(l2).sqrt();
    let rescale = l2_len.cmpgt(F8::ZERO) & l2_len.is_finite_mask();
    w2 = W3::select(rescale, w2.scale(l1_len / l2_len), w2);
    // Nor gain energy (`2E = ω · Iω`).
    let e1 = w1.dot(l1);
    let e2 = w2.dot(W3 { x: d.x * w2.x, y: d.y * w2.y, z: d.z * w2.z });
    w2 = W3::select(e2.cmpgt(e1), w2.scale((e1 / e2).sqrt()), w2);
    let finite = w2.x.is_finite_mask() & w2.y.is_finite_mask() & w2.z.is_finite_mask();
    let keep = l1_len.cmpeq(F8::ZERO) | !finite;
    // Back to the world frame (`q ω₂`: the inverse of the inverse).
    W3::select(keep, w, rotate_inverse(-u, qw, w2))
}

/// Bodies waiting for their gyroscopic step, up to `LANES`: their angular
/// velocities, orientations and inertia diagonals, one row per lane.
#[derive(Default)]
pub(super) struct Pending {
    pub len: usize,
    pub ids: [u32; LANES],
    w: [Vec4; LANES],
    q: [Vec4; LANES],
    d: [Vec4; LANES],
}

impl Pending {
    /// Adds body `id`; true when all `LANES` lanes are taken.
    #[inline(always)]
    pub fn push(&mut self, id: u32, w: Vec3A, q: Quat, d: Vec3A) -> bool {
        let n = self.len;
        self.ids[n] = id;
        self.w[n] = widen(w);
        self.q[n] = Vec4::from(q);
        self.d[n] = widen(d);
        self.len += 1;
        self.len == LANES
    }

    /// The new angular velocity of each pending body, in the order they
    /// were added (the lanes past `len` repeat lane 0, whose result is
    /// dropped), and empties the list.
    #[inline(always)]
    pub fn step(&mut self, h: f32) -> [Vec3A; LANES] {
        let n = self.len;
        for m in n..LANES {
            (self.w[m], self.q[m], self.d[m]) = (self.w[0], self.q[0], self.d[0]);
        }
        self.len = 0;
        let out = diagonal_lanes(W3::gather(self.w), columns(self.q), W3::gather(self.d), h);
        out.scatter().map(narrow)
    }
}
