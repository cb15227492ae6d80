//! Axis-aligned bounding boxes.

use crate::math::Vec3;

/// An axis-aligned box `[min, max]` in world space.
///
/// The layout is fixed (`repr(C)`: the six numbers in the order min x, y,
/// z, max x, y, z), which the broad phase's box test reads as two vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

// `AabbProbe` reads the six numbers as two overlapping vectors.
const _: () = assert!(std::mem::size_of::<Aabb>() == 24 && std::mem::offset_of!(Aabb, max) == 12);

impl Aabb {
    /// A box from its two corners (`min <= max` componentwise is expected).
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// The box centred at `center` with half extents `half`.
    pub fn from_center_half_extents(center: Vec3, half: Vec3) -> Self {
        Self { min: center - half, max: center + half }
    }

    /// True when the two boxes overlap or touch.
    #[inline]
    pub fn overlaps(&self, other: &Aabb) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }

    /// True when `other` lies entirely inside `self`.
    #[inline]
    pub fn contains(&self, other: &Aabb) -> bool {
        self.min.cmple(other.min).all() && other.max.cmple(self.max).all()
    }

    /// The smallest box holding both.
    #[inline]
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// The box grown by `margin` on every side.
    #[inline]
    pub fn expanded(&self, margin: f32) -> Aabb {
        Aabb { min: self.min - Vec3::splat(margin), max: self.max + Vec3::splat(margin) }
    }

    /// Half the surface area (the cost measure used by the AABB tree).
    #[inline]
    pub fn half_area(&self) -> f32 {
        let d = self.max - self.min;
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// Centre of the box.
    #[inline]
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// True when every coordinate is finite.
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }
}

crate::snapshot::codec::persist!(Aabb { min, max });

/// A box to test many boxes against ([`AabbProbe::overlaps`]), for the
/// broad phase's tree descents, where the test of each node is most of
/// the work: the same answer as [`Aabb::overlaps`], from two vector
/// compares instead of six compares and branches.
#[derive(Clone, Copy)]
pub(crate) struct AabbProbe {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse"))]
    max: std::arch::x86_64::__m128,
    #[cfg(all(target_arch = "x86_64", target_feature = "sse"))]
    min: std::arch::x86_64::__m128,
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse")))]
    aabb: Aabb,
}

impl AabbProbe {
    /// The probe of `aabb`.
    #[inline(always)]
    pub(crate) fn new(aabb: &Aabb) -> Self {
        #[cfg(all(target_arch = "x86_64", target_feature = "sse"))]
        {
            use std::arch::x86_64::_mm_setr_ps;
            let (lo, hi) = (aabb.min, aabb.max);
            // SAFETY: compiled only where the target has SSE.
            unsafe { AabbProbe { max: _mm_setr_ps(hi.x, hi.y, hi.z, 0.0), min: _mm_setr_ps(0.0, lo.x, lo.y, lo.z) } }
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "sse")))]
        {
            AabbProbe { aabb: *aabb }
        }
    }

    /// Whether `b` overlaps or touches the probe's box: exactly
    /// [`Aabb::overlaps`] (a NaN compares false in both).
    #[inline(always)]
    pub(crate) fn overlaps(&self, b: &Aabb) -> bool {
        #[cfg(all(target_arch = "x86_64", target_feature = "sse"))]
        {
            use std::arch::x86_64::{_mm_cmple_ps, _mm_loadu_ps, _mm_movemask_ps};
            let p = (b as *const Aabb).cast::<f32>();
            // SAFETY: compiled only where the target has SSE, and both
            // loads lie within `b`'s six numbers (`repr(C)`): the first
            // reads min x, y, z and max x, the second min z and max x, y,
            // z. Lanes 0–2 of the first compare test `b.min <= max`, lanes
            // 1–3 of the second `min <= b.max`.
            unsafe {
                let low = _mm_loadu_ps(p);
                let high = _mm_loadu_ps(p.add(2));
                let below = _mm_movemask_ps(_mm_cmple_ps(low, self.max));
                let above = _mm_movemask_ps(_mm_cmple_ps(self.min, high));
                (below & 0b0111 == 0b0111) & (above & 0b1110 == 0b1110)
            }
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "sse")))]
        {
            self.aabb.overlaps(b)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The probe answers as `Aabb::overlaps` on boxes that overlap, touch
    /// on a face or corner, miss along each axis alone, or hold a NaN: each
    /// axis of each box drawn from a few coordinates that make every one of
    /// those (`min` may even exceed `max`).
    #[test]
    fn the_probe_answers_as_overlaps() {
        let values = [-2.0f32, -1.0, 0.0, -0.0, 0.5, 1.0, 3.0, f32::NAN];
        let mut seed = 0x9e37_79b9_u32;
        let mut pick = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            values[(seed % values.len() as u32) as usize]
        };
        let (mut same, mut overlapping) = (0, 0);
        for _ in 0..200_000 {
            let mut corner = || Vec3::new(pick(), pick(), pick());
            let (a, b) = (Aabb::new(corner(), corner()), Aabb::new(corner(), corner()));
            let want = a.overlaps(&b);
            assert_eq!(AabbProbe::new(&a).overlaps(&b), want, "{a:?} against {b:?}");
            same += 1;
            overlapping += usize::from(want);
        }
        // Both answers were asked for often.
        assert!(overlapping > 1000 && same - overlapping > 1000, "{overlapping} of {same} overlapped");
    }
}
