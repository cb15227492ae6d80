//! The block solve of a manifold's normal points: the (pseudo-)inverse of
//! its Delassus block, the contact plane's axes, and the bounds of the
//! point sweeps and active-set tries that take over where the block step
//! is refused (see docs/solver.md, "The block solve and its active set").

use glam::Vec3A;

use crate::collision::MAX_MANIFOLD_POINTS;
use crate::math::{Mat3, Vec3, Vec4};

// The lanes below hold one manifold point each: exactly four.
const _: () = assert!(MAX_MANIFOLD_POINTS == 4, "Lanes3 and the Delassus block are Vec4: one lane per manifold point");

/// Lane `i` of `v`. Indexing a `Vec4` directly (`v[i]`) goes through a
/// `match` on `i` that compiles to a jump table, an indirect branch the
/// predictor mostly misses when `i` varies; through the lanes' array it is
/// a plain load.
#[inline(always)]
pub(crate) fn lane(v: &Vec4, i: usize) -> f32 {
    v.as_ref()[i]
}

/// Lane `i` of `v`, to write (see [`lane`]).
#[inline(always)]
pub(crate) fn lane_mut(v: &mut Vec4, i: usize) -> &mut f32 {
    &mut v.as_mut()[i]
}

/// The inverse of a manifold's Delassus block `k` over its `len` points,
/// or its pseudo-inverse for three or four, stored like `k`, and whether it
/// is usable (see `ContactConstraint::block_inverse`). `ra` are the points'
/// anchors from body A and `center_ra` their mean, `tangents` the contact
/// plane's axes.
pub(crate) fn block_inverse(
    len: usize,
    k: &[Vec4; MAX_MANIFOLD_POINTS],
    ra: &[Vec3A; MAX_MANIFOLD_POINTS],
    center_ra: Vec3A,
    tangents: &[Vec3A; 2],
) -> ([Vec4; MAX_MANIFOLD_POINTS], bool) {
    let mut kinv = [Vec4::ZERO; MAX_MANIFOLD_POINTS];
    let mut block = false;
    let k = |i: usize, j: usize| lane(&k[j], i);
    match len {
        1 if k(0, 0) > 0.0 => {
            *lane_mut(&mut kinv[0], 0) = 1.0 / k(0, 0);
            block = true;
        }
        2 => {
            let det = k(0, 0) * k(1, 1) - k(0, 1) * k(1, 0);
            // det / (k00 k11) = 1 - cos² of the angle between the two
            // rows: near 0 the points act almost as one.
            if det > BLOCK_CONDITION * k(0, 0) * k(1, 1) {
                let inv = 1.0 / det;
                *lane_mut(&mut kinv[0], 0) = k(1, 1) * inv;
                *lane_mut(&mut kinv[1], 1) = k(0, 0) * inv;
                *lane_mut(&mut kinv[0], 1) = -k(0, 1) * inv;
                *lane_mut(&mut kinv[1], 0) = -k(1, 0) * inv;
                block = true;
            }
        }
        3 | 4 => {
            // In-plane coordinates of the points about their centre
            // (the centre is their mean, so Σu = Σv = 0 and BᵀB is
            // block diagonal: len, then the 2 × 2 second moment).
            let uv: [(f32, f32); MAX_MANIFOLD_POINTS] = std::array::from_fn(|i| {
                let d = ra[i] - center_ra;
                (d.dot(tangents[0]), d.dot(tangents[1]))
            });
            let (mut suu, mut suv, mut svv) = (0.0f32, 0.0f32, 0.0f32);
            for &(u, v) in &uv[..len] {
                suu += u * u;
                suv += u * v;
                svv += v * v;
            }
            // The second moment's eigenvalues are the squared spreads
            // of the points along the patch's two principal axes; their
            // product over their squared sum is at most 1/4 and about
            // their ratio when that is small, whatever the patch's
            // orientation: below BLOCK_CONDITION the patch is a strip
            // (one side < ~3% of the other) and its moment across is
            // undetermined. (NaN fails the test too.)
            let det2 = suu * svv - suv * suv;
            let well_spread = det2 > BLOCK_CONDITION * (suu + svv) * (suu + svv);
            if !well_spread {
                return (kinv, block);
            }
            // Columns of P = (BᵀB)⁻¹ Bᵀ, one per point.
            let inv_len = 1.0 / len as f32;
            let p: [Vec3; MAX_MANIFOLD_POINTS] = std::array::from_fn(|i| {
                if i >= len {
                    return Vec3::ZERO;
                }
                let (u, v) = uv[i];
                Vec3::new(inv_len, (svv * u - suv * v) / det2, (suu * v - suv * u) / det2)
            });
            // W = Σ_ij K_ij p_i p_jᵀ = Σ_i p_i q_iᵀ with q_i = Σ_j K_ij p_j:
            // len² vector updates and len outer products instead of
            // len² outer products.
            let mut w = Mat3::ZERO;
            for i in 0..len {
                let q: Vec3 = (0..len).map(|j| p[j] * k(i, j)).sum();
                w += Mat3::from_cols(q * p[i].x, q * p[i].y, q * p[i].z);
            }
            let det = w.determinant();
            let diag = w.x_axis.x * w.y_axis.y * w.z_axis.z;
            // For a symmetric positive definite W, 0 < det ≤ the product
            // of its diagonal (Hadamard); their ratio measures how far
            // from singular it is, whatever the units of its rows.
            let regular = det > BLOCK_CONDITION * diag;
            if !regular {
                return (kinv, block);
            }
            let w_inv = w.inverse();
            for (j, pj) in p.iter().enumerate().take(len) {
                let q = w_inv * *pj;
                for (i, pi) in p.iter().enumerate().take(len) {
                    *lane_mut(&mut kinv[j], i) = pi.dot(q);
                }
            }
            block = true;
        }
        _ => {}
    }
    // An inverse that overflowed (a block whose entries are near `f32`'s
    // smallest, as for masses of ~1e13 kg) is not usable. The entries on
    // and above the diagonal: the ones a batch keeps (`mirror` copies them
    // below).
    block &= (0..len).all(|j| (0..=j).all(|i| lane(&kinv[j], i).is_finite()));
    (kinv, block)
}

/// How far from singular (the ratio of a determinant to the product of the
/// diagonal, 1 for orthogonal rows) a manifold's block must be for the
/// solver to solve it in one step (`ContactConstraint::block_inverse`).
pub(crate) const BLOCK_CONDITION: f32 = 1e-3;

/// Two unit vectors spanning the plane normal to `n`.
pub(crate) fn tangent_basis(n: Vec3) -> [Vec3; 2] {
    let t1 = if n.x.abs() >= 0.57735 { Vec3::new(n.y, -n.x, 0.0) } else { Vec3::new(0.0, n.z, -n.y) }.normalize();
    [t1, n.cross(t1)]
}

/// Sweeps over the normal points of one manifold per solver pass, when
/// neither the block step (`ContactConstraint::block_inverse`,
/// `block_step`) nor its active-set tries (`active_set_step`) solve it: the
/// tries guessed wrong which points let go, the points are nearly
/// collinear, or the contact is soft.
///
/// A single sweep solves the points of a face contact one after the other:
/// the first point takes the whole correction as if it were alone, which
/// spins the body, and the later points only partly undo the spin. Over a
/// stack this leaves every brick with a rocking velocity that depends on the
/// point order, and a column creeps sideways and tilts. Sweeping the few
/// points of a manifold several times converges that small coupled block
/// locally (four sweeps leave a column's creep a few hundredths of a
/// millimetre); the block step solves it exactly.
pub(crate) const MANIFOLD_SWEEPS: usize = 4;

/// A sweep of a manifold that changes no normal velocity by more than this
/// (m/s; a thousandth of the relax tolerance) ends its sweeps early.
pub(super) const SWEEP_TOLERANCE: f32 = 1e-6;

/// Tries of the active-set step after the block step's first (see
/// `active_set_step`): one try solves most of the faces the block step
/// refused, two nearly all; a third lets a face whose first try clamped
/// nothing (all four corners free: singular) drop its fastest-opening
/// corner and then one more (docs/solver.md, "The block solve and its
/// active set").
pub(crate) const ACTIVE_SET_TRIES: usize = 3;
