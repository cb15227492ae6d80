//! From crumble-scene bodies and their poses to [`Frame`]s: brick tones for
//! boxes (each brick a little different, from a hash of its index), steel
//! for spheres, light grey for the ground.

use crumble_scene::{BodyInfo, BodyShape, Simulation};
use glam::{Quat, Vec3};

use crate::camera::{Bounds, Camera, AUTO_VIEW_DIRECTION};
use crate::frame::{Frame, Instance, Material, Shape};
use crate::RenderError;

/// Brick tones (sRGB) that boxes are drawn in.
pub const BRICK_TONES: [[f32; 3]; 4] = [[0.62, 0.24, 0.16], [0.70, 0.31, 0.20], [0.55, 0.21, 0.15], [0.66, 0.36, 0.25]];

/// Steel, for spheres.
pub const STEEL: Material = Material { color: [0.70, 0.72, 0.75], metalness: 0.85, edge_width: 0.0 };

/// Light grey, for the ground.
pub const GROUND: Material = Material::matte([0.74, 0.74, 0.72]);

/// A 64-bit mix of `x` (splitmix64's finaliser): a fixed, well-spread hash.
fn mix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// The material of the box with body index `index`: one of
/// [`BRICK_TONES`], made up to 7 % lighter or darker, both picked by a hash
/// of the index, so the same brick has the same colour in every frame and
/// every run. `half_extents` sets the width of the darkened edges.
pub fn brick_material(index: usize, half_extents: Vec3) -> Material {
    let h = mix64(index as u64);
    let tone = BRICK_TONES[(h % BRICK_TONES.len() as u64) as usize];
    let shade = 0.93 + 0.14 * ((h >> 16) & 0xffff) as f32 / 65535.0;
    let color = tone.map(|c| (c * shade).clamp(0.0, 1.0));
    let edge_width = (half_extents.min_element() * 0.12).min(0.006);
    Material { color, metalness: 0.0, edge_width }
}

/// Turns the bodies of a built scene and their poses into frames.
///
/// Built once from the bodies (it reads their shapes and starting poses);
/// every frame after that only needs the poses. The ground is drawn as a
/// square centred under the bodies' starting positions, large enough to
/// reach the horizon's haze; shadows cover the bodies' starting region with
/// some room around it, fixed for every frame so that they do not swim.
#[derive(Clone, Debug)]
pub struct SceneFrames {
    kinds: Vec<Kind>,
    /// Corners of every body's starting bounds, for framing.
    corners: Vec<Vec3>,
    bounds: Option<Bounds>,
    shadow_bounds: Option<Bounds>,
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Body(Shape, Material),
    Ground { height: f32, center: Vec3, half_size: f32 },
}

impl SceneFrames {
    /// Prepares frames of `bodies` (in [`Simulation::bodies`] order).
    pub fn new(bodies: &[BodyInfo]) -> Self {
        let mut kinds = Vec::with_capacity(bodies.len());
        let mut start: Vec<Instance> = Vec::new();
        for (i, b) in bodies.iter().enumerate() {
            let kind = match b.shape {
                BodyShape::Box { half_extents } if b.metal => Kind::Body(Shape::Box { half_extents }, STEEL),
                BodyShape::Box { half_extents } => {
                    Kind::Body(Shape::Box { half_extents }, brick_material(i, half_extents))
                }
                BodyShape::Sphere { radius } => Kind::Body(Shape::Sphere { radius }, STEEL),
                BodyShape::Plane { height } => Kind::Ground { height, center: Vec3::ZERO, half_size: 1.0 },
            };
            if let Kind::Body(shape, material) = kind {
                let inst = Instance { shape, position: b.initial.position, rotation: b.initial.rotation, material };
                if inst.validate(i).is_ok() {
                    start.push(inst);
                }
            }
            kinds.push(kind);
        }
        let bounds = start.iter().map(Instance::bounds).reduce(Bounds::union).filter(Bounds::is_finite);
        let corners = start.iter().flat_map(|i| i.bounds().corners()).collect();
        let (center, radius) = bounds.map_or((Vec3::ZERO, 1.0), |b| (b.center(), b.radius().max(0.5)));
        for k in &mut kinds {
            if let Kind::Ground { height, .. } = *k {
                *k = Kind::Ground { height, center: Vec3::new(center.x, height, center.z), half_size: radius * 60.0 };
            }
        }
        let shadow_bounds = bounds.map(|b| {
            let grow = Vec3::splat(b.radius() * 0.35 + 0.25);
            Bounds::new(b.min - grow, b.max + grow)
        });
        Self { kinds, corners, bounds, shadow_bounds }
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.kinds.len()
    }

    /// Whether there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.kinds.is_empty()
    }

    /// The box around the bodies' starting poses (the ground left out);
    /// `None` when there is nothing but ground.
    pub fn bounds(&self) -> Option<Bounds> {
        self.bounds
    }

    /// The automatic camera for an image of width / height `aspect`: the
    /// closest view from [`AUTO_VIEW_DIRECTION`] (front, right, above) with
    /// every body's starting bounds in the image, centred
    /// ([`Camera::framing_points`]). With no bodies, it looks at the origin
    /// from 5 m.
    pub fn auto_camera(&self, aspect: f32, fov_y_deg: f32) -> Camera {
        Camera::framing_points(self.corners.iter().copied(), aspect, fov_y_deg, AUTO_VIEW_DIRECTION)
    }

    /// The frame for the poses `pose(i) = (position, rotation)` of every
    /// body `i`. Fails, naming the body, when a pose is not finite.
    pub fn frame_with(&self, mut pose: impl FnMut(usize) -> (Vec3, Quat)) -> Result<Frame, RenderError> {
        let mut instances = Vec::with_capacity(self.kinds.len());
        for (i, kind) in self.kinds.iter().enumerate() {
            let inst = match *kind {
                Kind::Body(shape, material) => {
                    let (position, rotation) = pose(i);
                    Instance { shape, position, rotation, material }
                }
                Kind::Ground { center, half_size, .. } => Instance {
                    shape: Shape::Plane { half_size },
                    position: center,
                    rotation: Quat::IDENTITY,
                    material: GROUND,
                },
            };
            inst.validate(i)?;
            instances.push(inst);
        }
        Ok(Frame { instances, shadow_bounds: self.shadow_bounds })
    }

    /// The frame for recorded poses: `positions[i]` and unit quaternions
    /// `rotations[i] = [x, y, z, w]`, in body order (the layout of
    /// crumble-cli's recordings). Fails when the lengths differ from the
    /// number of bodies.
    pub fn frame(&self, positions: &[[f32; 3]], rotations: &[[f32; 4]]) -> Result<Frame, RenderError> {
        if positions.len() != self.kinds.len() || rotations.len() != self.kinds.len() {
            return Err(RenderError::InvalidInstance {
                index: positions.len().min(rotations.len()),
                reason: format!(
                    "{} positions and {} rotations for {} bodies",
                    positions.len(),
                    rotations.len(),
                    self.kinds.len()
                ),
            });
        }
        self.frame_with(|i| (Vec3::from_array(positions[i]), Quat::from_array(rotations[i])))
    }

    /// The frame for the current poses of a running simulation.
    pub fn frame_of(&self, sim: &Simulation) -> Result<Frame, RenderError> {
        self.frame_with(|i| {
            let p = sim.pose(i);
            (p.position, p.rotation)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brick_colours_vary_but_are_fixed_per_index() {
        let h = Vec3::new(0.1, 0.03, 0.05);
        let colours: Vec<[f32; 3]> = (0..50).map(|i| brick_material(i, h).color).collect();
        assert_eq!(colours, (0..50).map(|i| brick_material(i, h).color).collect::<Vec<_>>());
        let distinct = colours.iter().filter(|c| **c != colours[0]).count();
        assert!(distinct > 40, "{distinct}");
        for c in colours {
            assert!(c[0] > c[1] * 1.5 && c[0] > c[2] * 1.8, "brick-red: {c:?}");
        }
    }
}
