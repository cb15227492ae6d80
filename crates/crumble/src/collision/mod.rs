//! The narrow phase: exact contact between two shapes.
//!
//! [`contact_manifold`] takes two shapes at two poses and returns a
//! [`Manifold`]: a unit normal pointing from the first shape toward the
//! second and up to four contact points. One function per shape pair does the
//! work (`box_box`, `ball_box`, ...), chosen by a `match` on the pair; pairs
//! given in the other order are computed in canonical order and flipped.
//!
//! Points are reported while the shapes are closer than `margin` (speculative
//! contacts, `separation > 0`), so that the solver can stop a fast approach
//! before the shapes overlap. Each point carries a [`FeatureId`] naming the
//! pair of features (face, edge, vertex) that produced it; it stays the same
//! from step to step while the same features touch, which is what lets the
//! solver warm-start its impulses.

pub mod ball_ball;
pub mod ball_box;
pub mod ball_half_space;
pub mod box_box;
pub mod box_half_space;
pub mod sat;
pub mod toi;

use crate::math::{Pose, Vec3};
use crate::shape::Shape;

/// Most points a manifold holds. Four points are enough to hold a box face
/// flat against another face.
pub const MAX_MANIFOLD_POINTS: usize = 4;

/// Identifies the pair of features that made a contact point. Equal ids in
/// two consecutive steps (for the same pair of colliders, in the same order)
/// mean "the same contact", and the solver carries its impulse over.
pub type FeatureId = u32;

/// One contact point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactPoint {
    /// World-space point half-way between the two surfaces.
    pub point: Vec3,
    /// Signed distance between the surfaces along the manifold normal:
    /// negative when they overlap (penetration depth is `-separation`),
    /// positive for a speculative point.
    pub separation: f32,
    /// Which features touch; see [`FeatureId`].
    pub id: FeatureId,
}

impl ContactPoint {
    /// A point with every field zero (used to fill unused slots).
    pub const ZERO: ContactPoint = ContactPoint { point: Vec3::ZERO, separation: 0.0, id: 0 };
}

/// Contact between two shapes: a shared unit normal (from shape A toward
/// shape B) and up to [`MAX_MANIFOLD_POINTS`] points.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Manifold {
    /// Points in use. First, so that "is it empty?" (asked of every
    /// contact in several loops a step) reads the line that holds the
    /// contact's bodies (see `Contact`).
    len: u8,
    /// Unit normal pointing from A toward B. Meaningless when empty.
    pub normal: Vec3,
    points: [ContactPoint; MAX_MANIFOLD_POINTS],
}

impl Default for Manifold {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Manifold {
    /// A manifold with no points.
    pub const EMPTY: Manifold =
        Manifold { len: 0, normal: Vec3::ZERO, points: [ContactPoint::ZERO; MAX_MANIFOLD_POINTS] };

    /// An empty manifold with the given normal, to be filled with [`push`](Self::push).
    pub fn with_normal(normal: Vec3) -> Self {
        Manifold { normal, ..Self::EMPTY }
    }

    /// Appends a point; returns false (and drops it) when full.
    pub fn push(&mut self, p: ContactPoint) -> bool {
        if (self.len as usize) < MAX_MANIFOLD_POINTS {
            self.points[self.len as usize] = p;
            self.len += 1;
            true
        } else {
            false
        }
    }

    /// The contact points.
    #[inline]
    pub fn points(&self) -> &[ContactPoint] {
        &self.points[..self.len as usize]
    }

    /// Mutable access to the contact points.
    #[inline]
    pub fn points_mut(&mut self) -> &mut [ContactPoint] {
        &mut self.points[..self.len as usize]
    }

    /// Number of points.
    #[inline]
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// True when there is no point.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The smallest separation of any point (most negative = deepest), or
    /// `None` when empty.
    pub fn min_separation(&self) -> Option<f32> {
        self.points().iter().map(|p| p.separation).reduce(f32::min)
    }

    /// The same contact seen from the other shape: the normal is negated;
    /// points, separations and feature ids are unchanged.
    pub fn flipped(mut self) -> Self {
        self.normal = -self.normal;
        self
    }
}

/// Contact between shape `a` at `pose_a` and shape `b` at `pose_b`, with
/// points reported while the surfaces are closer than `margin` (metres).
///
/// The normal points from `a` toward `b`. Two half-spaces never collide.
pub fn contact_manifold(a: &Shape, pose_a: &Pose, b: &Shape, pose_b: &Pose, margin: f32) -> Manifold {
    use Shape::*;
    match (a, b) {
        (Cuboid(ca), Cuboid(cb)) => box_box::manifold(ca, pose_a, cb, pose_b, margin),
        (Cuboid(c), HalfSpace(h)) => box_half_space::manifold(c, pose_a, h, pose_b, margin),
        (HalfSpace(h), Cuboid(c)) => box_half_space::manifold(c, pose_b, h, pose_a, margin).flipped(),
        (Ball(s), Cuboid(c)) => ball_box::manifold(s, pose_a, c, pose_b, margin),
        (Cuboid(c), Ball(s)) => ball_box::manifold(s, pose_b, c, pose_a, margin).flipped(),
        (Ball(sa), Ball(sb)) => ball_ball::manifold(sa, pose_a, sb, pose_b, margin),
        (Ball(s), HalfSpace(h)) => ball_half_space::manifold(s, pose_a, h, pose_b, margin),
        (HalfSpace(h), Ball(s)) => ball_half_space::manifold(s, pose_b, h, pose_a, margin).flipped(),
        (HalfSpace(_), HalfSpace(_)) => Manifold::EMPTY,
    }
}

crate::snapshot::codec::persist!(ContactPoint { point, separation, id });
crate::snapshot::codec::persist!(Manifold { len, normal, points });
