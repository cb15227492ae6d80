//! Colliders: a shape with a material, attached to a body at a local pose.

use crate::arena::RawHandle;
use crate::math::{Pose, Vec3};
use crate::shape::{Shape, ShapeError};

/// A Copy handle to a collider in a [`World`](crate::World).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ColliderHandle(pub(crate) RawHandle);

impl ColliderHandle {
    /// The slot index (stable while the collider lives).
    pub fn index(self) -> u32 {
        self.0.index
    }
}

/// Surface and bulk properties of a collider.
///
/// Defaults: density 1000 kg/m³ (water), friction 0.6, restitution 0.
/// Two colliders in contact combine as `sqrt(μa μb)` for friction and
/// `max(ea, eb)` for restitution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// kg/m³, finite and positive.
    pub density: f32,
    /// Coulomb friction coefficient, finite and ≥ 0.
    pub friction: f32,
    /// Coefficient of restitution, in [0, 1].
    pub restitution: f32,
    /// Rolling resistance coefficient `c_rr` (dimensionless, ≥ 0): a ball
    /// rolling on this material feels a torque of at most `c_rr · N · r`,
    /// so it slows at about `c_rr · g · 5/7`. Acts only on balls.
    pub rolling_resistance: f32,
    /// How strong the material is, when a box of it may break
    /// (`fracture.rs`); `None` (the default) never breaks.
    pub strength: Option<Strength>,
}

/// The strengths of a breakable material, pascals (see `fracture.rs`): a
/// box of it splits along one of its own axis planes when the stress the
/// step's impulses put across that plane reaches one of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strength {
    /// Tensile strength, Pa, finite and positive: the largest tensile
    /// stress at the edge of a cut section (pull plus bending).
    pub tensile: f32,
    /// Shear strength, Pa, finite and positive: the largest shear stress
    /// on a cut section (sliding plus twisting).
    pub shear: f32,
}

impl Material {
    /// The default material: 1000 kg/m³, friction 0.6, no restitution, no
    /// rolling resistance, unbreakable. A `const`, for materials written
    /// as `Material { density: 2000.0, ..Material::DEFAULT }`.
    pub const DEFAULT: Material =
        Material { density: 1000.0, friction: 0.6, restitution: 0.0, rolling_resistance: 0.0, strength: None };
}

impl Default for Material {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Material {
    /// A material from density, friction and restitution (no rolling resistance).
    pub fn new(density: f32, friction: f32, restitution: f32) -> Self {
        Self { density, friction, restitution, rolling_resistance: 0.0, strength: None }
    }

    /// The same material, breakable with these strengths (Pa): see
    /// [`Strength`].
    pub const fn with_strength(mut self, tensile: f32, shear: f32) -> Self {
        self.strength = Some(Strength { tensile, shear });
        self
    }

    /// The same material with a rolling resistance coefficient.
    pub fn with_rolling_resistance(mut self, c_rr: f32) -> Self {
        self.rolling_resistance = c_rr;
        self
    }

    /// Checks every field; the error names the bad one.
    pub fn validate(&self) -> Result<(), MaterialError> {
        if !(self.density.is_finite() && self.density > 0.0) {
            return Err(MaterialError::Density(self.density));
        }
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return Err(MaterialError::Friction(self.friction));
        }
        if !(self.restitution.is_finite() && (0.0..=1.0).contains(&self.restitution)) {
            return Err(MaterialError::Restitution(self.restitution));
        }
        if !(self.rolling_resistance.is_finite() && self.rolling_resistance >= 0.0) {
            return Err(MaterialError::RollingResistance(self.rolling_resistance));
        }
        if let Some(st) = self.strength {
            for x in [st.tensile, st.shear] {
                if !(x.is_finite() && x > 0.0) {
                    return Err(MaterialError::Strength(x));
                }
            }
        }
        Ok(())
    }
}

/// A material field out of range.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MaterialError {
    /// Density not finite and positive.
    #[error("material density must be finite and positive, got {0}")]
    Density(f32),
    /// Friction not finite and non-negative.
    #[error("material friction must be finite and >= 0, got {0}")]
    Friction(f32),
    /// Restitution outside [0, 1].
    #[error("material restitution must be in [0, 1], got {0}")]
    Restitution(f32),
    /// Rolling resistance not finite and non-negative.
    #[error("material rolling resistance must be finite and >= 0, got {0}")]
    RollingResistance(f32),
    /// A strength not finite and positive.
    #[error("material strength must be finite and positive (Pa), got {0}")]
    Strength(f32),
}

/// Describes a collider to attach with
/// [`World::insert_collider`](crate::World::insert_collider).
///
/// Defaults: at the body's origin with no rotation, [`Material::default`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColliderBuilder {
    pub(crate) shape: Shape,
    pub(crate) local_pose: Pose,
    pub(crate) material: Material,
}

impl ColliderBuilder {
    /// A collider of the given (already validated) shape.
    pub fn new(shape: impl Into<Shape>) -> Self {
        Self { shape: shape.into(), local_pose: Pose::IDENTITY, material: Material::default() }
    }

    /// A box with half extents `(hx, hy, hz)` in metres.
    pub fn cuboid(hx: f32, hy: f32, hz: f32) -> Result<Self, ShapeError> {
        Shape::cuboid(Vec3::new(hx, hy, hz)).map(Self::new)
    }

    /// A ball of the given radius in metres.
    pub fn ball(radius: f32) -> Result<Self, ShapeError> {
        Shape::ball(radius).map(Self::new)
    }

    /// The ground: the half-space below `y = height` (attach to a static body).
    pub fn ground(height: f32) -> Result<Self, ShapeError> {
        Shape::ground(height).map(Self::new)
    }

    /// Pose relative to the body's origin (default identity).
    pub fn local_pose(mut self, pose: Pose) -> Self {
        self.local_pose = pose;
        self
    }

    /// The material (default [`Material::default`]).
    pub fn material(mut self, m: Material) -> Self {
        self.material = m;
        self
    }

    /// Density in kg/m³.
    pub fn density(mut self, d: f32) -> Self {
        self.material.density = d;
        self
    }

    /// Friction coefficient.
    pub fn friction(mut self, f: f32) -> Self {
        self.material.friction = f;
        self
    }

    /// Restitution coefficient.
    pub fn restitution(mut self, e: f32) -> Self {
        self.material.restitution = e;
        self
    }
}

/// A collider as the world keeps it.
#[derive(Clone, Debug)]
pub struct Collider {
    pub(crate) shape: Shape,
    pub(crate) local_pose: Pose,
    pub(crate) material: Material,
    /// Slot index of the parent body.
    pub(crate) body: u32,
    pub(crate) proxy: crate::broad_phase::ProxyId,
    /// World pose, updated at the end of each step.
    pub(crate) world_pose: Pose,
}

impl Collider {
    /// The shape.
    pub fn shape(&self) -> &Shape {
        &self.shape
    }
    /// Pose relative to the parent body's origin.
    pub fn local_pose(&self) -> Pose {
        self.local_pose
    }
    /// World pose (as of the last step or edit).
    pub fn world_pose(&self) -> Pose {
        self.world_pose
    }
    /// The material.
    pub fn material(&self) -> Material {
        self.material
    }
}
