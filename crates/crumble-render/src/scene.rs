//! From crumble-scene bodies and their poses to [`Frame`]s: brick tones for
//! boxes (each brick a little different, from a hash of its index; a piece
//! of a broken brick in that brick's tone), steel for spheres, light grey
//! for the ground; each body drawn only while it is in the world.

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
/// Built from the bodies (it reads their shapes, starting poses and when
/// they are in the world); every frame after that needs the poses and the
/// time. The ground is drawn as a square centred under the bodies'
/// starting positions, large enough to reach the horizon's haze; shadows
/// cover the bodies' starting region with some room around it, fixed for
/// every frame so that they do not swim.
///
/// A body is drawn while it is in the world ([`SceneFrames::is_drawn`]):
/// a piece of a box that broke ([`BodyInfo::parent`]) from its
/// `spawn_time` on, a box that broke ([`BodyInfo::despawn`]) until then,
/// so that a frame shows either the whole brick or its pieces, never both
/// (they fill the same space) and never neither. Projectiles that wait for
/// their launch are drawn at their launch pose, as the scene placed them.
#[derive(Clone, Debug)]
pub struct SceneFrames {
    kinds: Vec<Kind>,
    /// Corners of the starting bounds of every body the scene made, for
    /// framing.
    corners: Vec<Vec3>,
    bounds: Option<Bounds>,
    shadow_bounds: Option<Bounds>,
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    /// A box or sphere, drawn at times `t` with `appears <= t < leaves`.
    Body {
        shape: Shape,
        material: Material,
        appears: f64,
        leaves: f64,
    },
    Ground {
        center: Vec3,
        half_size: f32,
    },
}

/// When body `b` is in the world: from its `spawn_time` if it is a piece
/// (before that it is a part of its parent, which is drawn instead), from
/// the start otherwise; until it broke, or for good.
fn span(b: &BodyInfo) -> (f64, f64) {
    let appears = if b.parent.is_some() { b.spawn_time } else { f64::NEG_INFINITY };
    (appears, b.despawn.map_or(f64::INFINITY, |(t, _)| t))
}

/// The body that piece `i` broke from first, following
/// [`BodyInfo::parent`] back to a body the scene made: a piece has its
/// brick's colour, as broken clay does. A parent comes before its pieces
/// in the list; an index that does not ends the walk.
fn origin(bodies: &[BodyInfo], mut i: usize) -> usize {
    while let Some((p, _)) = bodies[i].parent {
        if p >= i {
            break;
        }
        i = p;
    }
    i
}

impl SceneFrames {
    /// Prepares frames of `bodies` (in [`Simulation::bodies`] order): the
    /// bodies of a scene as built, or every body a run ever had
    /// (crumble-cli's recordings). Either gives the same ground, shadows
    /// and camera: pieces are left out of the starting bounds, where they
    /// were a part of their parents.
    pub fn new(bodies: &[BodyInfo]) -> Self {
        let start: Vec<Instance> = bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| b.parent.is_none())
            .filter_map(|(i, b)| {
                let Kind::Body { shape, material, .. } = Self::kind_of(bodies, i, None) else { return None };
                let inst = Instance { shape, position: b.initial.position, rotation: b.initial.rotation, material };
                inst.validate(i).is_ok().then_some(inst)
            })
            .collect();
        let bounds = start.iter().map(Instance::bounds).reduce(Bounds::union).filter(Bounds::is_finite);
        let corners = start.iter().flat_map(|i| i.bounds().corners()).collect();
        let shadow_bounds = bounds.map(|b| {
            let grow = Vec3::splat(b.radius() * 0.35 + 0.25);
            Bounds::new(b.min - grow, b.max + grow)
        });
        let mut frames = Self { kinds: Vec::with_capacity(bodies.len()), corners, bounds, shadow_bounds };
        frames.follow(bodies);
        frames
    }

    /// How body `i` of `bodies` is drawn; the ground centred under
    /// `bounds` (the starting bounds), 60 of their radii on a side.
    fn kind_of(bodies: &[BodyInfo], i: usize, bounds: Option<Bounds>) -> Kind {
        let b = &bodies[i];
        let (appears, leaves) = span(b);
        let body = |shape, material| Kind::Body { shape, material, appears, leaves };
        match b.shape {
            BodyShape::Box { half_extents } if b.metal => body(Shape::Box { half_extents }, STEEL),
            BodyShape::Box { half_extents } => {
                body(Shape::Box { half_extents }, brick_material(origin(bodies, i), half_extents))
            }
            BodyShape::Sphere { radius } => body(Shape::Sphere { radius }, STEEL),
            BodyShape::Plane { height } => {
                let (center, radius) = bounds.map_or((Vec3::ZERO, 1.0), |b| (b.center(), b.radius().max(0.5)));
                Kind::Ground { center: Vec3::new(center.x, height, center.z), half_size: radius * 60.0 }
            }
        }
    }

    /// Follows `bodies` as a run changes them: learns the bodies added
    /// since this was made or last followed (the pieces of boxes that
    /// broke, appended by [`Simulation::step`]) and the times bodies left
    /// the world. The starting bounds, ground and shadows stay as they
    /// are. Returns the indices of the new bodies.
    pub fn follow(&mut self, bodies: &[BodyInfo]) -> std::ops::Range<usize> {
        for (kind, b) in self.kinds.iter_mut().zip(bodies) {
            if let Kind::Body { leaves, .. } = kind {
                *leaves = span(b).1;
            }
        }
        let known = self.kinds.len();
        for i in known..bodies.len() {
            self.kinds.push(Self::kind_of(bodies, i, self.bounds));
        }
        known..self.kinds.len()
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.kinds.len()
    }

    /// Whether there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.kinds.is_empty()
    }

    /// Whether body `i` is drawn at time `t`, seconds: the ground always;
    /// a piece from the time it broke off, a body that broke until then,
    /// any other body always. False for an index beyond the bodies known.
    pub fn is_drawn(&self, i: usize, t: f64) -> bool {
        match self.kinds.get(i) {
            Some(&Kind::Body { appears, leaves, .. }) => in_world(appears, leaves, t),
            Some(Kind::Ground { .. }) => true,
            None => false,
        }
    }

    /// The box around the starting poses of the bodies the scene made (the
    /// ground and the pieces of broken boxes left out); `None` when there
    /// is nothing but ground.
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

    /// The frame of the bodies drawn at time `t` ([`SceneFrames::is_drawn`]),
    /// in body order, at the poses `pose(i) = (position, rotation)` of each
    /// body `i` drawn (it is not asked for the others). Fails, naming the
    /// body, when a pose is not finite.
    pub fn frame_with(&self, t: f64, pose: impl FnMut(usize) -> (Vec3, Quat)) -> Result<Frame, RenderError> {
        self.build(t, self.kinds.iter().copied(), pose)
    }

    /// The frame at `t` of kinds `kinds` (in body order).
    fn build(
        &self,
        t: f64,
        kinds: impl Iterator<Item = Kind>,
        mut pose: impl FnMut(usize) -> (Vec3, Quat),
    ) -> Result<Frame, RenderError> {
        let mut instances = Vec::with_capacity(self.kinds.len());
        for (i, kind) in kinds.enumerate() {
            let inst = match kind {
                Kind::Body { shape, material, appears, leaves } => {
                    if !in_world(appears, leaves, t) {
                        continue;
                    }
                    let (position, rotation) = pose(i);
                    Instance { shape, position, rotation, material }
                }
                Kind::Ground { center, half_size } => Instance {
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

    /// The frame at time `t` for recorded poses: `positions[i]` and unit
    /// quaternions `rotations[i] = [x, y, z, w]`, in body order (the layout
    /// of crumble-cli's recordings, whose frames have a pose for every
    /// body of the run). Fails when the lengths differ from the number of
    /// bodies.
    pub fn frame(&self, t: f64, positions: &[[f32; 3]], rotations: &[[f32; 4]]) -> Result<Frame, RenderError> {
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
        self.frame_with(t, |i| (Vec3::from_array(positions[i]), Quat::from_array(rotations[i])))
    }

    /// The frame for the current poses of a running simulation, at its
    /// time. It reads which bodies are in the world from `sim.bodies`
    /// itself, so pieces added since this was made or followed are drawn
    /// too (in their brick's colour) and the boxes they broke from are not.
    pub fn frame_of(&self, sim: &Simulation) -> Result<Frame, RenderError> {
        let known = self.kinds.iter().zip(&sim.bodies).map(|(&kind, b)| match kind {
            Kind::Body { shape, material, appears, .. } => Kind::Body { shape, material, appears, leaves: span(b).1 },
            ground => ground,
        });
        let added = (self.kinds.len()..sim.bodies.len()).map(|i| Self::kind_of(&sim.bodies, i, self.bounds));
        self.build(sim.time(), known.chain(added), |i| {
            let p = sim.pose(i);
            (p.position, p.rotation)
        })
    }
}

/// Whether a body that enters the world at `appears` and leaves it at
/// `leaves` (seconds) is in it at `t`: from the first instant on, until
/// the second (a split's time is the broken body's last and its pieces'
/// first).
fn in_world(appears: f64, leaves: f64, t: f64) -> bool {
    appears <= t && t < leaves
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The headline wall in the built-in breakable `brick` (the ground
    /// too): its ball splits bricks in its first tenths of a second
    /// (measured: three, at 0.133 s and 0.150 s).
    fn breaking_wall() -> Simulation {
        let source = crumble_scene::builtin::find("brick_wall").unwrap().source.replace("\"clay\"", "\"brick\"");
        crumble_scene::build(&crumble_scene::parse(&source, "breaking_wall.toml").unwrap()).unwrap()
    }

    /// Steps `sim` until its body list grows (a box broke); the number of
    /// bodies before. Fails after 1 s without a split.
    fn until_a_split(sim: &mut Simulation) -> usize {
        let before = sim.bodies.len();
        while sim.bodies.len() == before {
            assert!(sim.time() < 1.0, "no brick broke in 1 s");
            sim.step().unwrap();
        }
        before
    }

    #[test]
    fn a_brick_is_drawn_until_it_breaks_and_its_pieces_from_then_on() {
        let mut sim = breaking_wall();
        let start = SceneFrames::new(&sim.bodies);
        let before = until_a_split(&mut sim);
        let now = sim.time();
        let frames = SceneFrames::new(&sim.bodies);
        let pieces: Vec<usize> = (before..sim.bodies.len()).collect();
        assert!(pieces.len() >= 2 && pieces.len().is_multiple_of(2), "pieces come in twos: {pieces:?}");
        let parents: Vec<usize> = pieces.iter().map(|&p| sim.bodies[p].parent.unwrap().0).collect();
        for (&piece, &parent) in pieces.iter().zip(&parents) {
            // The split's time is both the brick's last and the pieces'
            // first: at any instant one of them fills the space.
            assert!(frames.is_drawn(parent, now - 1e-9) && !frames.is_drawn(parent, now), "brick {parent}");
            assert!(!frames.is_drawn(piece, now - 1e-9) && frames.is_drawn(piece, now), "piece {piece}");
            // In the brick's colour (the edges follow the piece's size).
            let colour = |i| match frames.kinds[i] {
                Kind::Body { material, .. } => material.color,
                Kind::Ground { .. } => unreachable!(),
            };
            assert_eq!(colour(piece), colour(parent));
        }
        // The pieces were part of the wall at the start: the camera,
        // ground and shadows are the ones of the scene as built.
        assert_eq!(frames.bounds(), start.bounds());
        assert_eq!(frames.shadow_bounds, start.shadow_bounds);
        assert_eq!(frames.auto_camera(16.0 / 9.0, 45.0), start.auto_camera(16.0 / 9.0, 45.0));

        // Now: every body but the broken ones (the ground is one of the
        // bodies); just before: every body but the pieces.
        let broken = parents.len() / 2;
        let poses = |i: usize| {
            let p = sim.pose(i);
            (p.position, p.rotation)
        };
        assert_eq!(frames.frame_with(now, poses).unwrap().instances.len(), sim.bodies.len() - broken);
        assert_eq!(frames.frame_with(now - 1e-9, poses).unwrap().instances.len(), before);

        // Frames made before the split see it through the simulation, and
        // once they follow its bodies, through their own times.
        assert_eq!(start.frame_of(&sim).unwrap(), frames.frame_of(&sim).unwrap());
        let mut followed = start.clone();
        assert_eq!(followed.follow(&sim.bodies), before..sim.bodies.len());
        assert_eq!(followed.follow(&sim.bodies), sim.bodies.len()..sim.bodies.len(), "nothing new");
        assert_eq!(followed.frame_with(now, poses).unwrap(), frames.frame_with(now, poses).unwrap());
    }

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
