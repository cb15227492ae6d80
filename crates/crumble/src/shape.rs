//! Collision shapes: cuboids (oriented boxes), balls and half-spaces, with
//! their volumes, mass properties and world-space bounding boxes.
//!
//! Every constructor validates its input and returns a [`ShapeError`] that
//! names the offending field, so that bad sizes never travel deeper into the
//! engine (where they would surface as NaN poses).

use crate::aabb::Aabb;
use crate::math::{Mat3, Pose, Vec3};
use glam::DVec3;

/// Why a shape or a mass could not be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ShapeError {
    /// A half extent was NaN, infinite, zero or negative.
    #[error("cuboid half extents must be finite and positive, got {0:?}")]
    InvalidHalfExtents([f32; 3]),
    /// A radius was NaN, infinite, zero or negative.
    #[error("ball radius must be finite and positive, got {0}")]
    InvalidRadius(f32),
    /// A half-space normal was not finite or was (nearly) zero: its largest
    /// component must exceed 1e-6.
    #[error("half-space normal must be finite and non-zero, got {0:?}")]
    InvalidNormal([f32; 3]),
    /// A half-space offset was not finite.
    #[error("half-space offset must be finite, got {0}")]
    InvalidOffset(f32),
    /// A density was NaN, infinite, zero or negative.
    #[error("density must be finite and positive, got {0}")]
    InvalidDensity(f32),
    /// The mass or inertia overflowed (a finite but enormous shape or density).
    #[error("mass properties overflow for this size and density (mass {0})")]
    MassOverflow(f32),
    /// Mass was asked of a shape that has none (a half-space is infinite).
    #[error("a half-space has infinite volume and cannot carry mass; make it static")]
    Unbounded,
}

/// An oriented box, described by its half extents along its local axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cuboid {
    half_extents: Vec3,
}

impl Cuboid {
    /// A box with the given half extents (metres), each finite and positive.
    pub fn new(half_extents: Vec3) -> Result<Self, ShapeError> {
        let ok = half_extents.is_finite() && half_extents.cmpgt(Vec3::ZERO).all();
        if !ok {
            return Err(ShapeError::InvalidHalfExtents(half_extents.to_array()));
        }
        Ok(Self { half_extents })
    }

    /// A box from its full size (edge lengths), each finite and positive.
    pub fn from_size(size: Vec3) -> Result<Self, ShapeError> {
        Self::new(size * 0.5).map_err(|_| ShapeError::InvalidHalfExtents(size.to_array()))
    }

    /// Half extents along the local x, y and z axes.
    #[inline]
    pub fn half_extents(&self) -> Vec3 {
        self.half_extents
    }

    /// The eight corners in the local frame; corner `i` has sign `+` on axis
    /// `k` when bit `k` of `i` is set.
    pub fn local_corners(&self) -> [Vec3; 8] {
        let h = self.half_extents;
        std::array::from_fn(|i| {
            Vec3::new(
                if i & 1 != 0 { h.x } else { -h.x },
                if i & 2 != 0 { h.y } else { -h.y },
                if i & 4 != 0 { h.z } else { -h.z },
            )
        })
    }
}

/// A ball (sphere) of a given radius centred on the body's origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ball {
    radius: f32,
}

impl Ball {
    /// A ball with the given radius (metres), finite and positive.
    pub fn new(radius: f32) -> Result<Self, ShapeError> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(ShapeError::InvalidRadius(radius));
        }
        Ok(Self { radius })
    }

    /// The radius in metres.
    #[inline]
    pub fn radius(&self) -> f32 {
        self.radius
    }
}

/// The solid half-space `{x : normal · x <= offset}`, in the collider's local
/// frame. Its surface is the plane `normal · x = offset`; the ground is
/// `HalfSpace::new(Vec3::Y, 0.0)`. Only static bodies may carry one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfSpace {
    normal: Vec3,
    offset: f32,
}

impl HalfSpace {
    /// A half-space with an outward `normal` (finite, largest component above 1e-6;
    /// normalised here) and the
    /// plane's signed `offset` from the origin along it.
    pub fn new(normal: Vec3, offset: f32) -> Result<Self, ShapeError> {
        // Scale by the largest component first so that a huge (finite)
        // normal does not overflow to an infinite length.
        let big = normal.abs().max_element();
        if !(normal.is_finite() && big > 1e-6) {
            return Err(ShapeError::InvalidNormal(normal.to_array()));
        }
        let scaled = normal / big;
        let len = scaled.length(); // in [1, √3]: no overflow, no underflow
        if !offset.is_finite() {
            return Err(ShapeError::InvalidOffset(offset));
        }
        Ok(Self { normal: scaled / len, offset })
    }

    /// The unit outward normal (pointing out of the solid).
    #[inline]
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The plane's offset along the normal.
    #[inline]
    pub fn offset(&self) -> f32 {
        self.offset
    }

    /// The world-space normal and offset for a collider at `pose`.
    #[inline]
    pub fn world_plane(&self, pose: &Pose) -> (Vec3, f32) {
        let n = pose.transform_vector(self.normal);
        (n, self.offset + n.dot(pose.position))
    }
}

/// Mass and rotational inertia of a shape about its centre of mass, which for
/// every shape here is the local origin. The inertia tensor is diagonal in the
/// local frame, so only its three principal moments are stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassProperties {
    /// Mass in kilograms.
    pub mass: f32,
    /// Principal moments of inertia about the local x, y, z axes (kg·m²).
    pub principal_inertia: Vec3,
}

impl MassProperties {
    /// The inertia tensor in world space for a body with orientation `pose`:
    /// `R · diag(I) · Rᵀ`.
    pub fn world_inertia(&self, pose: &Pose) -> Mat3 {
        let r = pose.basis();
        r * Mat3::from_diagonal(self.principal_inertia) * r.transpose()
    }
}

/// A collision shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// An oriented box.
    Cuboid(Cuboid),
    /// A sphere.
    Ball(Ball),
    /// An infinite solid half-space (the ground).
    HalfSpace(HalfSpace),
}

impl From<Cuboid> for Shape {
    fn from(c: Cuboid) -> Self {
        Shape::Cuboid(c)
    }
}
impl From<Ball> for Shape {
    fn from(b: Ball) -> Self {
        Shape::Ball(b)
    }
}
impl From<HalfSpace> for Shape {
    fn from(h: HalfSpace) -> Self {
        Shape::HalfSpace(h)
    }
}

impl Shape {
    /// A box from half extents; see [`Cuboid::new`].
    pub fn cuboid(half_extents: Vec3) -> Result<Shape, ShapeError> {
        Cuboid::new(half_extents).map(Shape::Cuboid)
    }

    /// A ball from its radius; see [`Ball::new`].
    pub fn ball(radius: f32) -> Result<Shape, ShapeError> {
        Ball::new(radius).map(Shape::Ball)
    }

    /// A half-space; see [`HalfSpace::new`].
    pub fn half_space(normal: Vec3, offset: f32) -> Result<Shape, ShapeError> {
        HalfSpace::new(normal, offset).map(Shape::HalfSpace)
    }

    /// The ground: the half-space below the plane `y = height`.
    pub fn ground(height: f32) -> Result<Shape, ShapeError> {
        Self::half_space(Vec3::Y, height)
    }

    /// Volume in m³ (infinite for a half-space).
    pub fn volume(&self) -> f32 {
        match self {
            Shape::Cuboid(c) => {
                let h = c.half_extents;
                8.0 * h.x * h.y * h.z
            }
            Shape::Ball(b) => 4.0 / 3.0 * std::f32::consts::PI * b.radius.powi(3),
            Shape::HalfSpace(_) => f32::INFINITY,
        }
    }

    /// Mass properties for a uniform density in kg/m³, computed in f64 and
    /// rounded once. Box: `I_x = m (h_y² + h_z²) / 3` (the usual
    /// `m (w² + d²) / 12` written with half extents). Ball: `I = 2 m r² / 5`.
    pub fn mass_properties(&self, density: f32) -> Result<MassProperties, ShapeError> {
        if !(density.is_finite() && density > 0.0) {
            return Err(ShapeError::InvalidDensity(density));
        }
        let (mass, moments) = self.mass_and_moments(f64::from(density)).ok_or(ShapeError::Unbounded)?;
        let (mass, principal_inertia) = (mass as f32, moments.as_vec3());
        if !(mass.is_finite() && mass > 0.0 && principal_inertia.is_finite()) {
            return Err(ShapeError::MassOverflow(mass));
        }
        Ok(MassProperties { mass, principal_inertia })
    }

    /// Mass and principal moments of inertia about the shape's centre, in
    /// f64, for a uniform `density`; `None` for a half-space (the formulas
    /// are [`Shape::mass_properties`]'). The body's sums (`crate::mass`)
    /// take these unrounded.
    pub(crate) fn mass_and_moments(&self, density: f64) -> Option<(f64, DVec3)> {
        match self {
            Shape::Cuboid(c) => {
                let h = c.half_extents.as_dvec3();
                let m = density * 8.0 * h.x * h.y * h.z;
                let h2 = h * h;
                Some((m, DVec3::new(h2.y + h2.z, h2.z + h2.x, h2.x + h2.y) * (m / 3.0)))
            }
            Shape::Ball(b) => {
                let r = f64::from(b.radius);
                let m = density * 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
                Some((m, DVec3::splat(0.4 * m * r * r)))
            }
            Shape::HalfSpace(_) => None,
        }
    }

    /// The tight world-space bounding box at `pose`. A half-space's box is
    /// infinite along the directions its plane extends in; the broad phase
    /// keeps half-spaces out of its tree for that reason.
    pub fn aabb(&self, pose: &Pose) -> Aabb {
        match self {
            Shape::Cuboid(c) => {
                // Extent along world axis k is sum_j |R_kj| h_j.
                let r = pose.basis();
                let h = c.half_extents;
                let ext = r.x_axis.abs() * h.x + r.y_axis.abs() * h.y + r.z_axis.abs() * h.z;
                Aabb::from_center_half_extents(pose.position, ext)
            }
            Shape::Ball(b) => Aabb::from_center_half_extents(pose.position, Vec3::splat(b.radius)),
            Shape::HalfSpace(h) => {
                let (n, d) = h.world_plane(pose);
                let inf = f32::INFINITY;
                let mut min = Vec3::splat(-inf);
                let mut max = Vec3::splat(inf);
                // A plane aligned with a world axis bounds the solid along it.
                for k in 0..3 {
                    let mut axis = Vec3::ZERO;
                    axis[k] = 1.0;
                    if (n - axis).length_squared() < 1e-12 {
                        max[k] = d;
                    } else if (n + axis).length_squared() < 1e-12 {
                        min[k] = -d;
                    }
                }
                Aabb::new(min, max)
            }
        }
    }

    /// Radius of the smallest ball about the origin that holds the shape
    /// (infinite for a half-space). Used to scale tolerances to body size.
    pub fn bounding_radius(&self) -> f32 {
        match self {
            Shape::Cuboid(c) => c.half_extents.length(),
            Shape::Ball(b) => b.radius,
            Shape::HalfSpace(_) => f32::INFINITY,
        }
    }

    /// Smallest half extent (the radius for a ball; infinite for a half-space).
    pub fn min_half_extent(&self) -> f32 {
        match self {
            Shape::Cuboid(c) => c.half_extents.min_element(),
            Shape::Ball(b) => b.radius,
            Shape::HalfSpace(_) => f32::INFINITY,
        }
    }
}

/// A shape is loaded as its constructor would accept it (finite, positive
/// sizes; a unit half-space normal), keeping its saved bits.
impl crate::snapshot::codec::Persist for Shape {
    fn save(&self, w: &mut crate::snapshot::codec::Writer) {
        match self {
            Shape::Cuboid(c) => {
                w.u8(0);
                c.half_extents.save(w);
            }
            Shape::Ball(b) => {
                w.u8(1);
                w.f32(b.radius);
            }
            Shape::HalfSpace(h) => {
                w.u8(2);
                h.normal.save(w);
                w.f32(h.offset);
            }
        }
    }
    fn load(r: &mut crate::snapshot::codec::Reader) -> Result<Self, crate::snapshot::SnapshotError> {
        use crate::snapshot::codec::invalid;
        let bad = |e: ShapeError| invalid(format!("a shape: {e}"));
        match r.u8()? {
            0 => Ok(Shape::Cuboid(Cuboid::new(Vec3::load(r)?).map_err(bad)?)),
            1 => Ok(Shape::Ball(Ball::new(r.f32()?).map_err(bad)?)),
            2 => {
                let (normal, offset) = (Vec3::load(r)?, r.f32()?);
                HalfSpace::new(normal, offset).map_err(bad)?;
                if !normal.is_normalized() {
                    return Err(invalid("a half-space whose normal is not of unit length"));
                }
                Ok(Shape::HalfSpace(HalfSpace { normal, offset }))
            }
            k => Err(invalid(format!("a shape numbered {k}"))),
        }
    }
    fn layout(out: &mut String) {
        out.push_str("Shape(Cuboid{half_extents},Ball{radius},HalfSpace{normal,offset})");
    }
}
