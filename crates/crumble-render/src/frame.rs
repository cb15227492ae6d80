//! What to draw: a [`Frame`] is a list of [`Instance`]s (a shape, its pose
//! and its colour), independent of any physics type.

use glam::{Quat, Vec3};

use crate::camera::Bounds;
use crate::RenderError;

/// The shape of one instance, in its own frame (centred on its position).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A box with these half edge lengths, metres.
    Box {
        /// Half extents along the body's x, y, z.
        half_extents: Vec3,
    },
    /// A sphere.
    Sphere {
        /// Radius, metres.
        radius: f32,
    },
    /// A horizontal square (the ground), facing +y, `2 × half_size` metres
    /// on a side. It receives shadows but casts none.
    Plane {
        /// Half the side length, metres.
        half_size: f32,
    },
}

/// A colour and how it reflects light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Base colour, sRGB, each channel 0 to 1.
    pub color: [f32; 3],
    /// 0 for a matte surface (brick, ground) to 1 for bare metal (steel),
    /// which mirrors the sky and shows a sharp highlight.
    pub metalness: f32,
    /// Width of the darkened bevel along a box's edges, metres (0 for none):
    /// it keeps neighbouring bricks of a wall apart on screen.
    pub edge_width: f32,
}

impl Material {
    /// A matte colour without edge darkening.
    pub const fn matte(color: [f32; 3]) -> Self {
        Self { color, metalness: 0.0, edge_width: 0.0 }
    }
}

/// One thing to draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Shape and size.
    pub shape: Shape,
    /// Centre, metres.
    pub position: Vec3,
    /// Orientation, body to world (normalised when drawn).
    pub rotation: Quat,
    /// Colour and finish.
    pub material: Material,
}

impl Instance {
    /// Checks the numbers: finite position and rotation, a rotation of
    /// non-zero length, positive finite sizes, colour channels in [0, 1].
    /// `index` is only used in the message.
    pub fn validate(&self, index: usize) -> Result<(), RenderError> {
        let bad = |reason: String| Err(RenderError::InvalidInstance { index, reason });
        if !self.position.is_finite() {
            return bad(format!("position {} is not finite", self.position));
        }
        if !self.rotation.is_finite() || self.rotation.length_squared() < 1e-12 {
            return bad(format!("rotation {} is not a finite non-zero quaternion", self.rotation));
        }
        let sizes_ok = match self.shape {
            Shape::Box { half_extents } => half_extents.is_finite() && half_extents.min_element() > 0.0,
            Shape::Sphere { radius } => radius.is_finite() && radius > 0.0,
            Shape::Plane { half_size } => half_size.is_finite() && half_size > 0.0,
        };
        if !sizes_ok {
            return bad(format!("size must be positive and finite: {:?}", self.shape));
        }
        let m = &self.material;
        if !m.color.iter().chain([&m.metalness]).all(|c| (0.0..=1.0).contains(c)) {
            return bad(format!("colour {:?} and metalness {} must be in [0, 1]", m.color, m.metalness));
        }
        if !(m.edge_width.is_finite() && m.edge_width >= 0.0) {
            return bad(format!("edge width must be finite and not negative, got {}", m.edge_width));
        }
        Ok(())
    }

    /// The instance's world-space bounding box (loose for rotated boxes:
    /// the box of its bounding sphere).
    pub fn bounds(&self) -> Bounds {
        let r = match self.shape {
            Shape::Box { half_extents } => {
                // Exact for a rotated box: |R| · h per axis.
                let m = glam::Mat3::from_quat(self.rotation.normalize());
                let e = Vec3::new(
                    m.row(0).abs().dot(half_extents),
                    m.row(1).abs().dot(half_extents),
                    m.row(2).abs().dot(half_extents),
                );
                return Bounds::new(self.position - e, self.position + e);
            }
            Shape::Sphere { radius } => Vec3::splat(radius),
            Shape::Plane { half_size } => Vec3::new(half_size, 0.0, half_size),
        };
        Bounds::new(self.position - r, self.position + r)
    }
}

/// Everything drawn in one image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frame {
    /// The instances, in any order (the renderer groups them by shape).
    pub instances: Vec<Instance>,
    /// The region that casts and receives shadows: the shadow map covers
    /// the sphere around this box, so a fixed box keeps shadows steady from
    /// frame to frame. `None`: the bounds of this frame's boxes and spheres.
    pub shadow_bounds: Option<Bounds>,
}

impl Frame {
    /// The bounds of the boxes and spheres (planes left out), `None` when
    /// there are none.
    pub fn object_bounds(&self) -> Option<Bounds> {
        self.instances
            .iter()
            .filter(|i| !matches!(i.shape, Shape::Plane { .. }))
            .map(Instance::bounds)
            .reduce(Bounds::union)
    }
}
