//! Eight `f32` lanes (four with the `lanes4` feature), the vector type
//! of the batches (`contact_wide.rs`).
//!
//! [`F8`] holds one number per manifold of a batch and [`M8`] one flag per
//! manifold. Every operation works lane by lane with IEEE rounding, so a
//! lane gives the bits that the same operation gives on one `f32` (or on
//! one lane of a `glam::Vec4`); the comparisons, `max`, `min` and `select`
//! have the semantics of `glam`'s `Vec4` on the same target (on x86-64,
//! its SSE2 code: `max(a, b)` is `if a > b { a } else { b }`, which
//! decides where a NaN goes).
//!
//! Three implementations, chosen when compiling:
//!
//! - x86-64 with AVX enabled (`-C target-feature=+avx`, which this
//!   workspace's `.cargo/config.toml` sets): one 256-bit register, one
//!   instruction per operation, with the semantics of `glam`'s SSE2
//!   `Vec4`;
//! - everywhere else: two `glam::Vec4` halves (SSE2 on x86-64, NEON on
//!   AArch64), two instructions per operation: on x86-64 the same bits as
//!   AVX; on AArch64 NEON's `max`/`min`, which treat a NaN otherwise (as
//!   the four-lane batches did there);
//! - with the crate's `lanes4` feature, on any target: four
//!   lanes, one `glam::Vec4` (one SSE instruction per operation on
//!   x86-64), and batches of four manifolds ([`LANES`] is 4).
//!
//! Each stores its lanes in order (lane 0 first), so [`lane`] and
//! [`lane_mut`] index them as an array.
//!
//! The batches' width never changes the results: a batch holds manifolds
//! that share no moving body, placed in an order that keeps the order of
//! any two that do (`Batches::place`), and every lane computes what one
//! manifold alone would, so four lanes or eight give the same bits (CI
//! runs the unit tests that compare the batches with one constraint at a
//! time in both widths). Which is faster depends on the processor: where a
//! 256-bit operation costs two 128-bit ones, a chain-limited island, whose
//! batches of eight are half empty, runs faster in batches of four, and
//! full batches slower; where it costs one, eight lanes are faster.
//!
//! With AVX-512 the batches stay eight lanes wide: sixteen lanes give the
//! same bits but emptier batches, each batch's tries and sweeps held up by
//! its slowest lane. What AVX-512 does give is twice the vector registers,
//! which the passes use through a copy of their loop compiled for it
//! (`run_serial_avx512` in `schedule.rs`; docs/solver.md, "What was tried
//! and not kept").

use std::ops::{Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, Div, Mul, Neg, Not, Sub};

use glam::{BVec4A, Vec4};

/// Lanes per vector: manifolds per batch.
pub(crate) const LANES: usize = if cfg!(feature = "lanes4") { 4 } else { 8 };

/// The operations of two vectors that the `glam::Vec4`-based lanes (two
/// halves, or four lanes) take from `glam` as they are, through each
/// module's own `binary!` and `compare!`, which apply them to its parts.
#[cfg(any(feature = "lanes4", not(all(target_arch = "x86_64", target_feature = "avx"))))]
macro_rules! glam_binaries {
    () => {
        binary!(add, |a, b| a + b);
        binary!(sub, |a, b| a - b);
        binary!(mul, |a, b| a * b);
        binary!(div, |a, b| a / b);
        binary!(max, |a, b| a.max(b));
        binary!(min, |a, b| a.min(b));
    };
}

/// The comparisons, likewise (see `glam_binaries`).
#[cfg(any(feature = "lanes4", not(all(target_arch = "x86_64", target_feature = "avx"))))]
macro_rules! glam_comparisons {
    () => {
        compare!(cmpeq, |a, b| a.cmpeq(b));
        compare!(cmpne, |a, b| a.cmpne(b));
        compare!(cmpgt, |a, b| a.cmpgt(b));
        compare!(cmpge, |a, b| a.cmpge(b));
        compare!(cmplt, |a, b| a.cmplt(b));
        compare!(cmple, |a, b| a.cmple(b));
        compare!(cmpunord, |a, _b| a.is_nan_mask());
    };
}

/// Each lane's square root, correctly rounded (as `f32::sqrt`).
#[cfg(any(feature = "lanes4", not(all(target_arch = "x86_64", target_feature = "avx"))))]
#[inline(always)]
fn sqrt4(v: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{__m128, _mm_sqrt_ps};
        // SAFETY: SSE is part of x86-64.
        Vec4::from(unsafe { _mm_sqrt_ps(__m128::from(v)) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        Vec4::from_array(v.to_array().map(f32::sqrt))
    }
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx", not(feature = "lanes4")))]
mod imp {
    use core::arch::x86_64::*;

    use glam::{BVec4A, Vec4};

    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct F8(pub __m256);

    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct M8(pub __m256);

    // SAFETY (every `unsafe` block below): AVX is enabled for the whole
    // build (this module exists only under `target_feature = "avx"`).

    #[inline(always)]
    pub fn splat(x: f32) -> F8 {
        F8(unsafe { _mm256_set1_ps(x) })
    }

    #[inline(always)]
    pub fn from_halves(lo: Vec4, hi: Vec4) -> F8 {
        F8(unsafe { _mm256_set_m128(__m128::from(hi), __m128::from(lo)) })
    }

    #[inline(always)]
    pub fn halves(v: F8) -> (Vec4, Vec4) {
        unsafe { (Vec4::from(_mm256_castps256_ps128(v.0)), Vec4::from(_mm256_extractf128_ps::<1>(v.0))) }
    }

    #[inline(always)]
    pub fn mask_from_halves(lo: BVec4A, hi: BVec4A) -> M8 {
        M8(unsafe { _mm256_set_m128(__m128::from(hi), __m128::from(lo)) })
    }

    macro_rules! binary {
        ($name:ident, $op:ident) => {
            #[inline(always)]
            pub fn $name(a: F8, b: F8) -> F8 {
                F8(unsafe { $op(a.0, b.0) })
            }
        };
    }
    binary!(add, _mm256_add_ps);
    binary!(sub, _mm256_sub_ps);
    binary!(mul, _mm256_mul_ps);
    binary!(div, _mm256_div_ps);
    binary!(max, _mm256_max_ps);
    binary!(min, _mm256_min_ps);

    #[inline(always)]
    pub fn neg(a: F8) -> F8 {
        F8(unsafe { _mm256_xor_ps(_mm256_set1_ps(-0.0), a.0) })
    }

    #[inline(always)]
    pub fn abs(a: F8) -> F8 {
        F8(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), a.0) })
    }

    #[inline(always)]
    pub fn sqrt(a: F8) -> F8 {
        F8(unsafe { _mm256_sqrt_ps(a.0) })
    }

    macro_rules! compare {
        ($name:ident, $pred:ident) => {
            #[inline(always)]
            pub fn $name(a: F8, b: F8) -> M8 {
                M8(unsafe { _mm256_cmp_ps::<$pred>(a.0, b.0) })
            }
        };
    }
    // The predicates of SSE's `cmpeqps`, `cmpgtps`, ... (`glam`'s).
    compare!(cmpeq, _CMP_EQ_OQ);
    compare!(cmpne, _CMP_NEQ_UQ);
    compare!(cmpgt, _CMP_GT_OS);
    compare!(cmpge, _CMP_GE_OS);
    compare!(cmplt, _CMP_LT_OS);
    compare!(cmple, _CMP_LE_OS);
    compare!(cmpunord, _CMP_UNORD_Q);

    #[inline(always)]
    pub fn select(m: M8, a: F8, b: F8) -> F8 {
        F8(unsafe { _mm256_blendv_ps(b.0, a.0, m.0) })
    }

    #[inline(always)]
    pub fn bitmask(m: M8) -> u32 {
        unsafe { _mm256_movemask_ps(m.0) as u32 }
    }

    #[inline(always)]
    pub fn mask_and(a: M8, b: M8) -> M8 {
        M8(unsafe { _mm256_and_ps(a.0, b.0) })
    }

    #[inline(always)]
    pub fn mask_or(a: M8, b: M8) -> M8 {
        M8(unsafe { _mm256_or_ps(a.0, b.0) })
    }

    #[inline(always)]
    pub fn mask_not(a: M8) -> M8 {
        M8(unsafe { _mm256_xor_ps(a.0, _mm256_castsi256_ps(_mm256_set1_epi32(-1))) })
    }

    #[inline(always)]
    pub fn mask_splat(on: bool) -> M8 {
        M8(unsafe { _mm256_castsi256_ps(_mm256_set1_epi32(-(on as i32))) })
    }
}

#[cfg(all(not(feature = "lanes4"), not(all(target_arch = "x86_64", target_feature = "avx"))))]
mod imp {
    use glam::{BVec4A, Vec4};

    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct F8(pub Vec4, pub Vec4);

    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct M8(pub BVec4A, pub BVec4A);

    #[inline(always)]
    pub fn splat(x: f32) -> F8 {
        F8(Vec4::splat(x), Vec4::splat(x))
    }

    #[inline(always)]
    pub fn from_halves(lo: Vec4, hi: Vec4) -> F8 {
        F8(lo, hi)
    }

    #[inline(always)]
    pub fn halves(v: F8) -> (Vec4, Vec4) {
        (v.0, v.1)
    }

    #[inline(always)]
    pub fn mask_from_halves(lo: BVec4A, hi: BVec4A) -> M8 {
        M8(lo, hi)
    }

    macro_rules! binary {
        ($name:ident, |$a:ident, $b:ident| $e:expr) => {
            #[inline(always)]
            pub fn $name(a: F8, b: F8) -> F8 {
                let f = |$a: Vec4, $b: Vec4| $e;
                F8(f(a.0, b.0), f(a.1, b.1))
            }
        };
    }
    glam_binaries!();

    #[inline(always)]
    pub fn neg(a: F8) -> F8 {
        F8(-a.0, -a.1)
    }

    #[inline(always)]
    pub fn abs(a: F8) -> F8 {
        F8(a.0.abs(), a.1.abs())
    }

    #[inline(always)]
    pub fn sqrt(a: F8) -> F8 {
        F8(super::sqrt4(a.0), super::sqrt4(a.1))
    }

    macro_rules! compare {
        ($name:ident, |$a:ident, $b:ident| $e:expr) => {
            #[inline(always)]
            pub fn $name(a: F8, b: F8) -> M8 {
                let f = |$a: Vec4, $b: Vec4| $e;
                M8(f(a.0, b.0), f(a.1, b.1))
            }
        };
    }
    glam_comparisons!();

    #[inline(always)]
    pub fn select(m: M8, a: F8, b: F8) -> F8 {
        F8(Vec4::select(m.0, a.0, b.0), Vec4::select(m.1, a.1, b.1))
    }

    #[inline(always)]
    pub fn bitmask(m: M8) -> u32 {
        m.0.bitmask() | (m.1.bitmask() << 4)
    }

    #[inline(always)]
    pub fn mask_and(a: M8, b: M8) -> M8 {
        M8(a.0 & b.0, a.1 & b.1)
    }

    #[inline(always)]
    pub fn mask_or(a: M8, b: M8) -> M8 {
        M8(a.0 | b.0, a.1 | b.1)
    }

    #[inline(always)]
    pub fn mask_not(a: M8) -> M8 {
        M8(!a.0, !a.1)
    }

    #[inline(always)]
    pub fn mask_splat(on: bool) -> M8 {
        M8(BVec4A::splat(on), BVec4A::splat(on))
    }
}

/// Four lanes: one `glam::Vec4` (see the module docs).
#[cfg(feature = "lanes4")]
mod imp {
    use glam::{BVec4A, Vec4};

    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(16))]
    pub struct F8(pub Vec4);

    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(16))]
    pub struct M8(pub BVec4A);

    #[inline(always)]
    pub fn splat(x: f32) -> F8 {
        F8(Vec4::splat(x))
    }
    macro_rules! binary {
        ($name:ident, |$a:ident, $b:ident| $e:expr) => {
            #[inline(always)]
            pub fn $name(a: F8, b: F8) -> F8 {
                let f = |$a: Vec4, $b: Vec4| $e;
                F8(f(a.0, b.0))
            }
        };
    }
    glam_binaries!();
    #[inline(always)]
    pub fn neg(a: F8) -> F8 {
        F8(-a.0)
    }
    #[inline(always)]
    pub fn abs(a: F8) -> F8 {
        F8(a.0.abs())
    }
    #[inline(always)]
    pub fn sqrt(a: F8) -> F8 {
        F8(super::sqrt4(a.0))
    }
    macro_rules! compare {
        ($name:ident, |$a:ident, $b:ident| $e:expr) => {
            #[inline(always)]
            pub fn $name(a: F8, b: F8) -> M8 {
                let f = |$a: Vec4, $b: Vec4| $e;
                M8(f(a.0, b.0))
            }
        };
    }
    glam_comparisons!();
    #[inline(always)]
    pub fn select(m: M8, a: F8, b: F8) -> F8 {
        F8(Vec4::select(m.0, a.0, b.0))
    }
    #[inline(always)]
    pub fn bitmask(m: M8) -> u32 {
        m.0.bitmask()
    }
    #[inline(always)]
    pub fn mask_and(a: M8, b: M8) -> M8 {
        M8(a.0 & b.0)
    }
    #[inline(always)]
    pub fn mask_or(a: M8, b: M8) -> M8 {
        M8(a.0 | b.0)
    }
    #[inline(always)]
    pub fn mask_not(a: M8) -> M8 {
        M8(!a.0)
    }
    #[inline(always)]
    pub fn mask_splat(on: bool) -> M8 {
        M8(BVec4A::splat(on))
    }
}

/// Eight `f32` lanes, or four (see the module docs).
pub(crate) use imp::F8;

/// Eight lane flags, or four, each all ones or all zeros (see the module docs).
pub(crate) use imp::M8;

const _: () = assert!(std::mem::size_of::<F8>() == 4 * LANES && std::mem::align_of::<F8>() == 4 * LANES);
const _: () = assert!(std::mem::size_of::<M8>() == 4 * LANES);

impl Default for F8 {
    #[inline(always)]
    fn default() -> Self {
        F8::ZERO
    }
}

impl Default for M8 {
    #[inline(always)]
    fn default() -> Self {
        M8::splat(false)
    }
}

/// `pub fn name(self, o: F8) -> Out { imp::name(self, o) }` for each
/// listed operation of two vectors.
macro_rules! forward {
    ($($(#[$doc:meta])* $name:ident(o) -> $out:ty;)*) => {
        $(
            $(#[$doc])*
            #[inline(always)]
            pub fn $name(self, o: F8) -> $out {
                imp::$name(self, o)
            }
        )*
    };
}

impl F8 {
    pub const ZERO: F8 = F8::from_const(0.0);
    pub const ONE: F8 = F8::from_const(1.0);

    /// `x` in every lane, in a constant.
    const fn from_const(x: f32) -> F8 {
        // SAFETY: every representation is `LANES` `f32` in order.
        unsafe { std::mem::transmute::<[f32; LANES], F8>([x; LANES]) }
    }

    #[inline(always)]
    pub fn splat(x: f32) -> F8 {
        imp::splat(x)
    }

    #[inline(always)]
    pub fn from_array(a: [f32; LANES]) -> F8 {
        // SAFETY: every representation is `LANES` `f32` in order.
        unsafe { std::mem::transmute::<[f32; LANES], F8>(a) }
    }

    #[inline(always)]
    pub fn to_array(self) -> [f32; LANES] {
        // SAFETY: as in `from_array`.
        unsafe { std::mem::transmute::<F8, [f32; LANES]>(self) }
    }

    forward! {
        /// `if self > o { self } else { o }`, lane by lane.
        max(o) -> F8;
        /// `if self < o { self } else { o }`, lane by lane.
        min(o) -> F8;
        cmpeq(o) -> M8;
        /// True where the lanes differ or either is a NaN.
        cmpne(o) -> M8;
        cmpgt(o) -> M8;
        cmpge(o) -> M8;
        cmplt(o) -> M8;
        cmple(o) -> M8;
    }

    #[inline(always)]
    pub fn abs(self) -> F8 {
        imp::abs(self)
    }

    /// Correctly rounded, as `f32::sqrt`.
    #[inline(always)]
    pub fn sqrt(self) -> F8 {
        imp::sqrt(self)
    }

    #[inline(always)]
    pub fn is_nan_mask(self) -> M8 {
        imp::cmpunord(self, self)
    }

    /// `|x| < ∞` (false for NaN), as `Vec4::is_finite_mask`.
    #[inline(always)]
    pub fn is_finite_mask(self) -> M8 {
        self.abs().cmplt(F8::splat(f32::INFINITY))
    }

    /// `a` where `mask` is set, else `b`.
    #[inline(always)]
    pub fn select(mask: M8, a: F8, b: F8) -> F8 {
        imp::select(mask, a, b)
    }

    /// The largest lane (for numbers; which NaN wins is not specified).
    #[inline(always)]
    pub fn max_element(self) -> f32 {
        width::max_element(self)
    }
}

impl M8 {
    #[inline(always)]
    pub fn splat(on: bool) -> M8 {
        imp::mask_splat(on)
    }

    /// Lane `m` set where bit `m` of `bits` is.
    #[inline(always)]
    pub fn from_bits(bits: u32) -> M8 {
        width::from_bits(bits)
    }

    /// Bit `m` set where lane `m` is.
    #[inline(always)]
    pub fn bitmask(self) -> u32 {
        imp::bitmask(self)
    }

    #[inline(always)]
    pub fn any(self) -> bool {
        self.bitmask() != 0
    }
}

macro_rules! operator {
    ($trait:ident, $method:ident, $f:path) => {
        impl $trait for F8 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, o: F8) -> F8 {
                $f(self, o)
            }
        }
    };
}
operator!(Add, add, imp::add);
operator!(Sub, sub, imp::sub);
operator!(Mul, mul, imp::mul);
operator!(Div, div, imp::div);

macro_rules! with_scalar {
    ($trait:ident, $method:ident) => {
        impl $trait<f32> for F8 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, o: f32) -> F8 {
                self.$method(F8::splat(o))
            }
        }
        impl $trait<F8> for f32 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, o: F8) -> F8 {
                F8::splat(self).$method(o)
            }
        }
    };
}
with_scalar!(Add, add);
with_scalar!(Sub, sub);
with_scalar!(Mul, mul);
with_scalar!(Div, div);

impl AddAssign for F8 {
    #[inline(always)]
    fn add_assign(&mut self, o: F8) {
        *self = *self + o;
    }
}

impl Neg for F8 {
    type Output = F8;
    #[inline(always)]
    fn neg(self) -> F8 {
        imp::neg(self)
    }
}

impl BitAnd for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitand(self, o: M8) -> M8 {
        imp::mask_and(self, o)
    }
}

impl BitOr for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitor(self, o: M8) -> M8 {
        imp::mask_or(self, o)
    }
}

impl BitAndAssign for M8 {
    #[inline(always)]
    fn bitand_assign(&mut self, o: M8) {
        *self = *self & o;
    }
}

impl BitOrAssign for M8 {
    #[inline(always)]
    fn bitor_assign(&mut self, o: M8) {
        *self = *self | o;
    }
}

impl Not for M8 {
    type Output = M8;
    #[inline(always)]
    fn not(self) -> M8 {
        imp::mask_not(self)
    }
}

/// Lane `m` of `v` (a plain load through the lanes' array).
#[inline(always)]
pub(crate) fn lane(v: &F8, m: usize) -> f32 {
    // SAFETY: every representation is `LANES` `f32` in order.
    let lanes = unsafe { &*(v as *const F8 as *const [f32; LANES]) };
    lanes[m]
}

/// Lane `m` of `v`, to write.
#[inline(always)]
pub(crate) fn lane_mut(v: &mut F8, m: usize) -> &mut f32 {
    // SAFETY: as in `lane`.
    let lanes = unsafe { &mut *(v as *mut F8 as *mut [f32; LANES]) };
    &mut lanes[m]
}

/// Four values per lane into four vectors: `out[j]` lane `m` is
/// `rows[m][j]` (one 4 × 4 transpose per four lanes).
#[inline(always)]
pub(crate) fn columns(rows: [Vec4; LANES]) -> [F8; 4] {
    width::columns(rows)
}

/// The inverse of [`columns`]: `out[m][j]` is lane `m` of `cols[j]`.
#[inline(always)]
pub(crate) fn rows(cols: [F8; 4]) -> [Vec4; LANES] {
    width::rows(cols)
}

/// Lanes 0–3 of `bits` as four flags.
#[inline(always)]
fn four_flags(bits: u32) -> BVec4A {
    BVec4A::new(bits & 1 != 0, bits & 2 != 0, bits & 4 != 0, bits & 8 != 0)
}

/// What the widths do otherwise beyond their operations: the largest
/// lane, masks from bits, and the transposes between lanes and rows.
/// Eight lanes go through their two halves.
#[cfg(not(feature = "lanes4"))]
mod width {
    use glam::Vec4;

    use super::{four_flags, imp, transpose4, F8, LANES, M8};

    #[inline(always)]
    pub fn max_element(v: F8) -> f32 {
        let (lo, hi) = imp::halves(v);
        lo.max(hi).max_element()
    }

    #[inline(always)]
    pub fn from_bits(bits: u32) -> M8 {
        imp::mask_from_halves(four_flags(bits), four_flags(bits >> 4))
    }

    #[inline(always)]
    pub fn columns(rows: [Vec4; LANES]) -> [F8; 4] {
        let lo = transpose4([rows[0], rows[1], rows[2], rows[3]]);
        let hi = transpose4([rows[4], rows[5], rows[6], rows[7]]);
        std::array::from_fn(|j| imp::from_halves(lo[j], hi[j]))
    }

    #[inline(always)]
    pub fn rows(cols: [F8; 4]) -> [Vec4; LANES] {
        let halves = cols.map(imp::halves);
        let lo = transpose4(halves.map(|h| h.0));
        let hi = transpose4(halves.map(|h| h.1));
        [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2], hi[3]]
    }
}

/// The same for four lanes: one vector, one transpose.
#[cfg(feature = "lanes4")]
mod width {
    use glam::Vec4;

    use super::{four_flags, transpose4, F8, LANES, M8};

    #[inline(always)]
    pub fn max_element(v: F8) -> f32 {
        v.0.max_element()
    }

    #[inline(always)]
    pub fn from_bits(bits: u32) -> M8 {
        M8(four_flags(bits))
    }

    #[inline(always)]
    pub fn columns(rows: [Vec4; LANES]) -> [F8; 4] {
        transpose4(rows).map(F8)
    }

    #[inline(always)]
    pub fn rows(cols: [F8; 4]) -> [Vec4; LANES] {
        transpose4(cols.map(|c| c.0))
    }
}

/// `out[j][m] = x[m][j]` (a 4 × 4 transpose, eight shuffles on SSE).
#[inline(always)]
pub(crate) fn transpose4(x: [Vec4; 4]) -> [Vec4; 4] {
    let t = glam::Mat4::from_cols(x[0], x[1], x[2], x[3]).transpose();
    [t.x_axis, t.y_axis, t.z_axis, t.w_axis]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The workspace builds x86-64 with AVX (`.cargo/config.toml`), and CI
    /// tests the portable halves separately with `--cfg crumble_no_avx`:
    /// RUSTFLAGS set by accident would replace `+avx` and leave the AVX
    /// code untested without this.
    #[cfg(target_arch = "x86_64")]
    #[test]
    #[allow(clippy::assertions_on_constants)] // the build's settings are the point
    fn x86_64_builds_use_avx_unless_asked_not_to() {
        assert!(
            cfg!(target_feature = "avx") || cfg!(crumble_no_avx),
            "built without AVX: RUSTFLAGS replace .cargo/config.toml's +avx (with the lanes4 feature too); add it, or --cfg crumble_no_avx"
        );
    }

    /// A few awkward values: signed zeros, a subnormal, infinities, NaN
    /// (eight: each operand takes every rotation of them, so that a
    /// four-lane build meets each of them in each operand too).
    const ODD: [f32; 8] = [0.0, -0.0, 1.5, -2.25, 1e-40, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];

    fn rotated(k: usize) -> [f32; LANES] {
        std::array::from_fn(|m| ODD[(m + k) % ODD.len()])
    }

    /// Bit for bit, NaN payloads and signs included.
    fn same(a: F8, b: [f32; LANES]) -> bool {
        a.to_array().iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
    }

    /// Every operation gives, lane by lane, what `glam::Vec4` gives on the
    /// same numbers: the batches' bits do not change with their width.
    #[test]
    fn every_lane_does_what_a_vec4_lane_does() {
        const QUARTERS: usize = LANES / 4;
        for (j, k) in (0..ODD.len()).flat_map(|j| (0..ODD.len()).map(move |k| (j, k))) {
            let (a, b) = (rotated(j), rotated(k));
            let (fa, fb) = (F8::from_array(a), F8::from_array(b));
            let four = |x: [f32; LANES], h: usize| Vec4::from_slice(&x[4 * h..4 * h + 4]);
            let by_vec4 = |f: &dyn Fn(Vec4, Vec4) -> Vec4| -> [f32; LANES] {
                let parts: [Vec4; QUARTERS] = std::array::from_fn(|h| f(four(a, h), four(b, h)));
                std::array::from_fn(|m| parts[m / 4][m % 4])
            };
            assert!(same(fa + fb, by_vec4(&|x, y| x + y)));
            assert!(same(fa - fb, by_vec4(&|x, y| x - y)));
            assert!(same(fa * fb, by_vec4(&|x, y| x * y)));
            assert!(same(fa / fb, by_vec4(&|x, y| x / y)));
            assert!(same(fa.max(fb), by_vec4(&|x, y| x.max(y))));
            assert!(same(fa.min(fb), by_vec4(&|x, y| x.min(y))));
            assert!(same(-fa, by_vec4(&|x, _| -x)));
            assert!(same(fa.abs(), by_vec4(&|x, _| x.abs())));
            assert!(same(fa.sqrt(), a.map(f32::sqrt)));
            let masks = |f: &dyn Fn(Vec4, Vec4) -> BVec4A| {
                (0..QUARTERS).fold(0, |bits, h| bits | (f(four(a, h), four(b, h)).bitmask() << (4 * h)))
            };
            assert_eq!(fa.cmpeq(fb).bitmask(), masks(&|x, y| x.cmpeq(y)));
            assert_eq!(fa.cmpne(fb).bitmask(), masks(&|x, y| x.cmpne(y)));
            assert_eq!(fa.cmpgt(fb).bitmask(), masks(&|x, y| x.cmpgt(y)));
            assert_eq!(fa.cmpge(fb).bitmask(), masks(&|x, y| x.cmpge(y)));
            assert_eq!(fa.cmplt(fb).bitmask(), masks(&|x, y| x.cmplt(y)));
            assert_eq!(fa.cmple(fb).bitmask(), masks(&|x, y| x.cmple(y)));
            assert_eq!(fa.is_nan_mask().bitmask(), masks(&|x, _| x.is_nan_mask()));
            assert_eq!(fa.is_finite_mask().bitmask(), masks(&|x, _| x.is_finite_mask()));
            let m = fa.cmpgt(fb);
            assert!(same(F8::select(m, fa, fb), by_vec4(&|x, y| Vec4::select(x.cmpgt(y), x, y))));
            let all = (1u32 << LANES) - 1;
            assert_eq!((!m).bitmask(), !m.bitmask() & all);
            assert_eq!((m & fa.cmpeq(fa)).bitmask(), m.bitmask() & fa.cmpeq(fa).bitmask());
            let bits = 0b1010_0110 & all;
            assert_eq!(M8::from_bits(bits).bitmask(), bits);
        }
        let v = F8::from_array(std::array::from_fn(|m| [3.0, -1.0, 7.5, 0.0, 2.0, 9.0, -4.0, 1.0][m]));
        assert_eq!(v.max_element(), if LANES == 8 { 9.0 } else { 7.5 });
        assert_eq!(lane(&v, 2), 7.5);
        let rows: [Vec4; LANES] = std::array::from_fn(|m| Vec4::new(m as f32, 10.0 + m as f32, 20.0, -(m as f32)));
        let cols = columns(rows);
        assert_eq!(lane(&cols[1], LANES - 1), 10.0 + (LANES - 1) as f32);
        assert_eq!(lane(&cols[3], 3), -3.0);
        assert_eq!(super::rows(cols), rows);
    }
}
