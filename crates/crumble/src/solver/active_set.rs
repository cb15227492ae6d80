//! The block step's later tries: the manifold's points split into those
//! that push and those let go, the pushing ones solved exactly.
//!
//! The first try (`block_step`) applies `−K⁺ e` to all of a manifold's
//! points and clamps the impulses that would turn negative. When a point
//! is clamped, the others' errors are no longer cancelled and the step is
//! refused. That is the common case once bricks tumble: a brick tilted
//! on an edge has two corners pressing and two a hair open (speculative,
//! `e > 0`), and `K⁺ e` wants the open ones to pull. Without more tries,
//! most manifolds of a struck wall are refused each pass, and their
//! batches run the point sweeps (`MANIFOLD_SWEEPS`), nearly always all
//! four of them.
//!
//! The clamped try still tells which points should let go: those it
//! clamped. With that guess of the active set `F` (the points that keep
//! an impulse) and the let-go set `C` (impulse 0), the complementarity
//! problem of the manifold becomes a linear system for the change
//! `δ_F = λ_F − λ_old,F` that leaves every pushing point at zero velocity
//! error:
//!
//! ```text
//! e_F + K_FF δ_F + K_FC (0 − λ_old,C) = 0   ⇒   K_FF δ_F = K_FC λ_old,C − e_F.
//! ```
//!
//! (Solving for the change, not for `λ_F` itself, keeps the right-hand
//! side the size of the errors: under a heavy load `K_F· λ_old` is large
//! and nearly cancels `e`, and its rounding alone refused a few correct
//! guesses.) The caller then checks the answer as it checks the first
//! try (`block_check`): every pushing point met and every let-go point
//! not closing, to a rounding allowance, with the impulses clamped at
//! zero. While the guess is wrong it is mended, up to `ACTIVE_SET_TRIES`
//! tries in all (`contact_wide::active_set_tries`; its scalar reference is
//! `active_set_step` in `reference.rs`): pushing points that
//! came out pulling let go, let-go points left closing push; or, when the
//! system was singular (all four corners of a loaded face free, whose
//! block has rank 3), the point that opens fastest (largest `e`) lets go.
//! If the last try is refused too, the sweeps run as before.
//!
//! The split-impulse push-out (pseudo-velocities, `λ_old = 0` each
//! substep) takes the same tries on the points that have a push target;
//! the others take no part, as in its sweeps (which a resting wall's
//! push-out would otherwise run in full every substep).
//!
//! `K_FF` is the block of the free points: positive definite for up to
//! three corners of a face (or the points of a smaller manifold) that are
//! not collinear. It is solved as one 4 × 4 system with the let-go and unused
//! points' rows and columns replaced by the identity (their right-hand
//! side 0, so their unknowns come out 0), by an `LDLᵀ` factorisation
//! without pivoting, which a positive definite matrix does not need. Each
//! pivot must keep at least `BLOCK_CONDITION` of its diagonal entry (the
//! ratio is 1 for a point whose row is orthogonal to the ones before):
//! all four points of a face (rank 3) or three collinear ones fail it.
//!
//! Written once over [`Num`], for the eight lanes of a batch (`F8`) and for
//! one constraint (`f32`, the reference in the tests), so that both give
//! the same bits: the same operations in the same order, and neither
//! fuses a multiply and an add.

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Sub};

use super::block::BLOCK_CONDITION;
use super::lanes::{F8, M8};

/// Points of a manifold.
const P: usize = 4;

/// One number (`f32`) or eight lanes of them (`F8`), with what the tries
/// need.
pub(crate) trait Num:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    /// `bool` for `f32`, a lane mask for `F8`.
    type Mask: Copy + BitAnd<Output = Self::Mask> + BitOr<Output = Self::Mask>;
    fn splat(x: f32) -> Self;
    fn gt(self, o: Self) -> Self::Mask;
    /// `a` where `m` holds, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// `on` in every lane.
    fn mask_splat(on: bool) -> Self::Mask;
    /// `a` where `m` holds, else `b`, for masks.
    #[inline(always)]
    fn mask_select(m: Self::Mask, a: Self::Mask, b: Self::Mask) -> Self::Mask {
        (m & a) | (Self::mask_not(m) & b)
    }
    fn mask_not(m: Self::Mask) -> Self::Mask;
}

impl Num for f32 {
    type Mask = bool;
    #[inline(always)]
    fn splat(x: f32) -> f32 {
        x
    }
    #[inline(always)]
    fn gt(self, o: f32) -> bool {
        self > o
    }
    #[inline(always)]
    fn select(m: bool, a: f32, b: f32) -> f32 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn mask_splat(on: bool) -> bool {
        on
    }
    #[inline(always)]
    fn mask_not(m: bool) -> bool {
        !m
    }
}

impl Num for F8 {
    type Mask = M8;
    #[inline(always)]
    fn splat(x: f32) -> F8 {
        F8::splat(x)
    }
    #[inline(always)]
    fn gt(self, o: F8) -> M8 {
        self.cmpgt(o)
    }
    #[inline(always)]
    fn select(m: M8, a: F8, b: F8) -> F8 {
        F8::select(m, a, b)
    }
    #[inline(always)]
    fn mask_splat(on: bool) -> M8 {
        M8::splat(on)
    }
    #[inline(always)]
    fn mask_not(m: M8) -> M8 {
        !m
    }
}

/// The impulses `λ` that leave the points of `free` at zero velocity
/// error with the others at zero impulse (see the module docs): `k` the
/// manifold's Delassus block (`k[i][j] = K_ij`, exactly symmetric),
/// `old` the impulses before the step, `e` the points' velocity errors.
/// `free` must be false for unused points. Returns `λ` (0 outside
/// `free`, not clamped: a negative `λ_F` means the guess was wrong) and
/// whether every pivot kept `BLOCK_CONDITION` of its diagonal entry (else
/// `λ` means nothing).
#[inline(always)]
pub(crate) fn solve<T: Num>(k: &[[T; P]; P], old: &[T; P], e: &[T; P], free: &[T::Mask; P]) -> ([T; P], T::Mask) {
    let (zero, one) = (T::splat(0.0), T::splat(1.0));
    // Right-hand side `K_FC λ_old,C − e_F`, summed left to right.
    let let_go: [T; P] = std::array::from_fn(|j| T::select(free[j], zero, old[j]));
    let b: [T; P] = std::array::from_fn(|i| {
        let row = k[i][0] * let_go[0] + k[i][1] * let_go[1] + k[i][2] * let_go[2] + k[i][3] * let_go[3];
        T::select(free[i], row - e[i], zero)
    });
    // The system: `K_FF` where both points are free, the identity
    // elsewhere.
    let a = |i: usize, j: usize| {
        if i == j {
            T::select(free[i], k[i][i], one)
        } else {
            T::select(free[i] & free[j], k[i][j], zero)
        }
    };
    // `A = L D Lᵀ`, column by column; `u_ij = l_ij d_j` before the
    // scaling. One division per pivot (`r_j = 1 / d_j`), not one per
    // entry: divisions are the slow part of this chain.
    let d0 = a(0, 0);
    let r0 = one / d0;
    let (l10, l20, l30) = (a(1, 0) * r0, a(2, 0) * r0, a(3, 0) * r0);
    let d1 = a(1, 1) - l10 * a(1, 0);
    let r1 = one / d1;
    let u21 = a(2, 1) - l20 * a(1, 0);
    let u31 = a(3, 1) - l30 * a(1, 0);
    let (l21, l31) = (u21 * r1, u31 * r1);
    let d2 = a(2, 2) - l20 * a(2, 0) - l21 * u21;
    let r2 = one / d2;
    let u32 = a(3, 2) - l30 * a(2, 0) - l31 * u21;
    let l32 = u32 * r2;
    let d3 = a(3, 3) - l30 * a(3, 0) - l31 * u31 - l32 * u32;
    let r3 = one / d3;
    let c = T::splat(BLOCK_CONDITION);
    let sound = d0.gt(c * a(0, 0)) & d1.gt(c * a(1, 1)) & d2.gt(c * a(2, 2)) & d3.gt(c * a(3, 3));
    // `L y = b`, `z = D⁻¹ y`, `Lᵀ x = z`.
    let y0 = b[0];
    let y1 = b[1] - l10 * y0;
    let y2 = b[2] - l20 * y0 - l21 * y1;
    let y3 = b[3] - l30 * y0 - l31 * y1 - l32 * y2;
    let x3 = y3 * r3;
    let x2 = y2 * r2 - l32 * x3;
    let x1 = y1 * r1 - l21 * x2 - l31 * x3;
    let x0 = y0 * r0 - l10 * x1 - l20 * x2 - l30 * x3;
    let delta = [x0, x1, x2, x3];
    (std::array::from_fn(|i| T::select(free[i], old[i] + delta[i], zero)), sound)
}

/// The guess after a try whose system was singular (`sound` false): the
/// free point with the largest error `e` (the first of equals) lets go.
#[inline(always)]
pub(crate) fn drop_most_opening<T: Num>(e: &[T; P], free: &[T::Mask; P]) -> [T::Mask; P] {
    // The index of the largest, one-hot, kept as masks.
    let mut best = T::splat(f32::NEG_INFINITY);
    let mut pick: [T::Mask; P] = [T::mask_splat(false); P];
    for i in 0..P {
        let better = free[i] & e[i].gt(best);
        best = T::select(better, e[i], best);
        for (j, p) in pick.iter_mut().enumerate() {
            let here = T::mask_splat(i == j);
            *p = T::mask_select(better, here, *p);
        }
    }
    std::array::from_fn(|i| free[i] & T::mask_not(pick[i]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::lanes::{lane, LANES};

    /// A symmetric positive definite block (a brick face's corners about
    /// its centre, unit masses) and a random-ish right-hand side.
    fn block() -> [[f32; P]; P] {
        let uv = [(-1.0f32, -0.5f32), (1.0, -0.5), (1.0, 0.5), (-1.0, 0.5)];
        // K = B W Bᵀ with B rows (1, u, v) and W positive definite, made
        // exactly symmetric as the solver's blocks are.
        let w = [[2.0f32, 0.1, -0.2], [0.1, 3.0, 0.3], [-0.2, 0.3, 4.0]];
        let k: [[f32; P]; P] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let bi = [1.0, uv[i].0, uv[i].1];
                let bj = [1.0, uv[j].0, uv[j].1];
                (0..3).map(|r| (0..3).map(|s| bi[r] * w[r][s] * bj[s]).sum::<f32>()).sum()
            })
        });
        std::array::from_fn(|i| std::array::from_fn(|j| k[i.min(j)][i.max(j)]))
    }

    /// Three corners of a face pushing, the fourth let go: the pushing
    /// ones end at zero velocity error, the let-go one at zero impulse;
    /// all four pushing (a face's rank-3 block) is refused.
    #[test]
    fn three_corners_are_solved_and_four_refused() {
        let k = block();
        let old = [0.3, 0.2, 0.1, 0.4];
        let e = [-0.5, 0.25, -0.125, 2.0];
        let free = [true, true, true, false];
        let (x, sound) = solve::<f32>(&k, &old, &e, &free);
        assert!(sound);
        assert_eq!(x[3], 0.0);
        for i in 0..3 {
            let after: f32 = e[i] + (0..P).map(|j| k[i][j] * (x[j] - old[j])).sum::<f32>();
            assert!(after.abs() < 1e-5, "point {i} left {after}");
        }
        let (_, sound) = solve::<f32>(&k, &old, &e, &[true; 4]);
        assert!(!sound, "a face's four corners have a singular block");
        // Two opposite corners: a 2 × 2 system, also solved.
        let (x, sound) = solve::<f32>(&k, &old, &e, &[true, false, true, false]);
        assert!(sound && x[1] == 0.0 && x[3] == 0.0);
        for i in [0, 2] {
            let after: f32 = e[i] + (0..P).map(|j| k[i][j] * (x[j] - old[j])).sum::<f32>();
            assert!(after.abs() < 1e-5, "point {i} left {after}");
        }
    }

    /// After a singular try the free point that opens fastest lets go
    /// (the first of equals); with no free point, nothing changes.
    #[test]
    fn the_fastest_opening_point_lets_go() {
        let all = [true; P];
        assert_eq!(drop_most_opening::<f32>(&[-0.1, 0.3, 0.3, 0.2], &all), [true, false, true, true]);
        assert_eq!(
            drop_most_opening::<f32>(&[-0.1, 0.3, 0.5, 0.2], &[true, true, false, true]),
            [true, false, false, true]
        );
        assert_eq!(drop_most_opening::<f32>(&[-0.1, -0.3, -0.5, -0.2], &all), [false, true, true, true]);
        assert_eq!(drop_most_opening::<f32>(&[0.1; P], &[false; P]), [false; P]);
    }

    /// Eight lanes give each lane the bits of the one-number solve.
    #[test]
    fn the_lanes_give_the_bits_of_one_solve() {
        let k = block();
        let sets = [
            [true, true, true, false],
            [false, true, true, true],
            [true, false, true, false],
            [false, false, false, true],
            [true, true, true, true],
            [false; 4],
            [true, true, false, false],
            [false, true, false, true],
        ];
        let scale = |m: usize| 1.0 + 0.37 * m as f32;
        // Eight sets, a batch's lanes at a time (one batch of eight, or two
        // of four).
        for base in (0..sets.len()).step_by(LANES) {
            let kk: [[F8; P]; P] = std::array::from_fn(|i| {
                std::array::from_fn(|j| F8::from_array(std::array::from_fn(|m| k[i][j] * scale(base + m))))
            });
            let old = [0.3f32, 0.2, 0.1, 0.4];
            let e = [-0.5f32, 0.25, -0.125, 2.0];
            let oo: [F8; P] =
                std::array::from_fn(|i| F8::from_array(std::array::from_fn(|m| old[i] / scale(base + m))));
            let ee: [F8; P] = std::array::from_fn(|i| F8::from_array(std::array::from_fn(|m| e[i] * scale(base + m))));
            let ff: [M8; P] =
                std::array::from_fn(|i| M8::from_bits((0..LANES).map(|m| u32::from(sets[base + m][i]) << m).sum()));
            let (x, sound) = solve::<F8>(&kk, &oo, &ee, &ff);
            let dropped = drop_most_opening::<F8>(&ee, &ff);
            for (m, set) in sets[base..base + LANES].iter().enumerate() {
                let km: [[f32; P]; P] = std::array::from_fn(|i| std::array::from_fn(|j| k[i][j] * scale(base + m)));
                let om = old.map(|o| o / scale(base + m));
                let em = e.map(|x| x * scale(base + m));
                let (xm, sm) = solve::<f32>(&km, &om, &em, set);
                assert_eq!(sound.bitmask() >> m & 1 == 1, sm, "lane {m}: pivots");
                for i in 0..P {
                    assert_eq!(lane(&x[i], m).to_bits(), xm[i].to_bits(), "lane {m}, point {i}");
                }
                let dm = drop_most_opening::<f32>(&em, set);
                let dl: [bool; P] = std::array::from_fn(|i| dropped[i].bitmask() >> m & 1 == 1);
                assert_eq!(dl, dm, "lane {m}: the point let go");
            }
        }
    }
}
