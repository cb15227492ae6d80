//! Scene generators shared by the tests, the command-line tool, the
//! benchmarks and the viewer: the ground, brick walls, pyramids, stacks and
//! projectiles, built straight into a [`World`].

use crate::body::{BodyBuilder, BodyHandle};
use crate::collider::{ColliderBuilder, Material};
use crate::math::{Quat, Vec3};
use crate::world::{World, WorldError};

/// The brick of the seed report's wall: 215 × 65 × 102.5 mm (a UK standard
/// brick), fired clay at 2000 kg/m³, friction 0.6, restitution 0.1.
pub const BRICK_SIZE: Vec3 = Vec3::new(0.215, 0.065, 0.1025);

/// Material of [`BRICK_SIZE`] bricks. Rolling resistance 0.05: a ball on
/// brick and rubble slows at about 0.35 m/s².
pub const BRICK: Material =
    Material { density: 2000.0, friction: 0.6, restitution: 0.1, rolling_resistance: 0.05, strength: None };

/// A fired clay brick that breaks: [`BRICK`] with a tensile strength of
/// 1 MPa and a shear strength of 3 MPa (`docs/fracture.md` gives the
/// sources). Scene files' built-in `brick` material is this one.
pub const BREAKABLE_BRICK: Material = BRICK.with_strength(1.0e6, 3.0e6);

/// Steel: 7800 kg/m³, friction 0.4, restitution 0.1, rolling resistance 0.002.
pub const STEEL: Material =
    Material { density: 7800.0, friction: 0.4, restitution: 0.1, rolling_resistance: 0.002, strength: None };

/// How the bricks of consecutive rows are laid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bond {
    /// Every row directly on the one below (stack bond): weak, joints aligned.
    Stack,
    /// Odd rows shifted by half a brick, with a half brick at each end so
    /// that both ends of the wall are flush (running bond).
    Running,
}

/// A wall of bricks. The wall runs along `facing`'s local x axis, is
/// `thickness` (brick z) deep, and stands on `origin` (centre of its base).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallSpec {
    /// Number of rows.
    pub rows: u32,
    /// Full bricks per (even) row.
    pub bricks_per_row: u32,
    /// Brick size (full edges), metres.
    pub brick: Vec3,
    /// Gap between neighbouring bricks (mortar-free walls: 0), metres.
    pub gap: f32,
    /// Bond.
    pub bond: Bond,
    /// Centre of the wall's base.
    pub origin: Vec3,
    /// Rotation about y applied to the whole wall, radians.
    pub yaw: f32,
    /// Material of every brick.
    pub material: Material,
    /// Create the bricks asleep.
    pub sleeping: bool,
}

impl Default for WallSpec {
    /// The seed report's wall: 10 rows of 10 bricks, running bond, at the origin.
    fn default() -> Self {
        Self {
            rows: 10,
            bricks_per_row: 10,
            brick: BRICK_SIZE,
            gap: 0.0,
            bond: Bond::Running,
            origin: Vec3::ZERO,
            yaw: 0.0,
            material: BRICK,
            sleeping: false,
        }
    }
}

/// Adds a static ground (the half-space `y < height`).
pub fn add_ground(world: &mut World, height: f32, material: Material) -> Result<BodyHandle, WorldError> {
    let ground = world.insert_body(BodyBuilder::fixed())?;
    world.insert_collider(ColliderBuilder::ground(height)?.material(material), ground)?;
    Ok(ground)
}

/// Adds a dynamic box of full size `size` at `position` with `rotation`.
pub fn add_box(
    world: &mut World,
    size: Vec3,
    position: Vec3,
    rotation: Quat,
    material: Material,
    sleeping: bool,
) -> Result<BodyHandle, WorldError> {
    let shape = ColliderBuilder::cuboid(size.x * 0.5, size.y * 0.5, size.z * 0.5)?;
    let body = world.insert_body(BodyBuilder::dynamic().position(position).rotation(rotation).sleeping(sleeping))?;
    world.insert_collider(shape.material(material), body)?;
    Ok(body)
}

/// Adds a wall; returns its bricks row by row, left to right.
pub fn add_wall(world: &mut World, spec: &WallSpec) -> Result<Vec<BodyHandle>, WorldError> {
    let mut out = Vec::new();
    let rot = Quat::from_rotation_y(spec.yaw);
    let (bw, bh) = (spec.brick.x, spec.brick.y);
    let pitch = bw + spec.gap;
    let length = spec.bricks_per_row as f32 * pitch - spec.gap;
    for row in 0..spec.rows {
        let y = spec.origin.y + bh * 0.5 + row as f32 * (bh + spec.gap);
        // (centre x along the wall, brick width) for each brick of the row.
        let mut row_bricks: Vec<(f32, f32)> = Vec::new();
        let offset = spec.bond == Bond::Running && row % 2 == 1;
        let left = -length * 0.5;
        if offset {
            let half = (bw - spec.gap) * 0.5;
            row_bricks.push((left + half * 0.5, half));
            for i in 0..spec.bricks_per_row.saturating_sub(1) {
                let x0 = left + half + spec.gap + i as f32 * pitch;
                row_bricks.push((x0 + bw * 0.5, bw));
            }
            row_bricks.push((-left - half * 0.5, half));
        } else {
            for i in 0..spec.bricks_per_row {
                row_bricks.push((left + i as f32 * pitch + bw * 0.5, bw));
            }
        }
        for (x, w) in row_bricks {
            let size = Vec3::new(w, bh, spec.brick.z);
            let p = spec.origin + rot * Vec3::new(x, y - spec.origin.y, 0.0);
            out.push(add_box(world, size, p, rot, spec.material, spec.sleeping)?);
        }
    }
    Ok(out)
}

/// Adds a planar pyramid of cubes of edge `size` (in the x–y plane), `base`
/// cubes wide at the bottom, centred on `origin`; `gap` between cubes.
pub fn add_pyramid(
    world: &mut World,
    base: u32,
    size: f32,
    gap: f32,
    origin: Vec3,
    material: Material,
) -> Result<Vec<BodyHandle>, WorldError> {
    let mut out = Vec::new();
    let pitch = size + gap;
    for level in 0..base {
        let count = base - level;
        let y = origin.y + size * 0.5 + level as f32 * pitch;
        let x0 = origin.x - (count as f32 - 1.0) * pitch * 0.5;
        for i in 0..count {
            let p = Vec3::new(x0 + i as f32 * pitch, y, origin.z);
            out.push(add_box(world, Vec3::splat(size), p, Quat::IDENTITY, material, false)?);
        }
    }
    Ok(out)
}

/// Adds a vertical stack of `count` boxes of full size `size`; each level is
/// shifted by `offset` (x, z) from the one below.
pub fn add_stack(
    world: &mut World,
    count: u32,
    size: Vec3,
    origin: Vec3,
    offset: Vec3,
    material: Material,
) -> Result<Vec<BodyHandle>, WorldError> {
    let mut out = Vec::new();
    for level in 0..count {
        let p = origin + Vec3::new(offset.x * level as f32, size.y * (level as f32 + 0.5), offset.z * level as f32);
        out.push(add_box(world, size, p, Quat::IDENTITY, material, false)?);
    }
    Ok(out)
}

/// Adds a ball of `radius` at `position` moving at `velocity`; a bullet
/// (swept against dynamic bodies too) when `bullet`.
pub fn add_ball(
    world: &mut World,
    radius: f32,
    position: Vec3,
    velocity: Vec3,
    material: Material,
    bullet: bool,
) -> Result<BodyHandle, WorldError> {
    let shape = ColliderBuilder::ball(radius)?;
    let body = world.insert_body(BodyBuilder::dynamic().position(position).linear_velocity(velocity).bullet(bullet))?;
    world.insert_collider(shape.material(material), body)?;
    Ok(body)
}

/// A wrecking ball: a ball on a chain of box links hanging from a fixed
/// point, released at an angle (the seed report's Figure 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WreckingBallSpec {
    /// Where the chain hangs from (a point in the world), metres.
    pub anchor: Vec3,
    /// Number of links.
    pub links: u32,
    /// A link's full size: its length along y, the joints at its ends.
    pub link: Vec3,
    /// The links' material.
    pub link_material: Material,
    /// The ball's radius, metres.
    pub ball_radius: f32,
    /// The ball's material.
    pub ball_material: Material,
    /// Angle of the chain from the vertical at release, radians.
    pub release_angle: f32,
    /// The horizontal direction the ball swings towards from its release
    /// (it starts on the opposite side).
    pub direction: Vec3,
    /// Adds a rope from the anchor straight to the ball, as long as the
    /// chain: it bounds the ball's distance from the anchor alone, as a
    /// steel cable inside a chain would.
    pub tether: bool,
}

impl Default for WreckingBallSpec {
    /// The `wrecking_ball` scene's: 20 steel links of 120 × 30 × 30 mm
    /// (0.84 kg) and a steel ball of 0.15 m radius (110 kg), hanging 2.55 m
    /// below the anchor, released from 60° to swing along +z, no tether.
    fn default() -> Self {
        WreckingBallSpec {
            anchor: Vec3::new(0.0, 3.0, 0.0),
            links: 20,
            link: Vec3::new(0.03, 0.12, 0.03),
            link_material: STEEL,
            ball_radius: 0.15,
            ball_material: STEEL,
            release_angle: 60f32.to_radians(),
            direction: Vec3::Z,
            tether: false,
        }
    }
}

/// What [`add_wrecking_ball`] made.
#[derive(Clone, Debug, PartialEq)]
pub struct WreckingBall {
    /// The links, from the anchor down.
    pub links: Vec<BodyHandle>,
    /// The ball.
    pub ball: BodyHandle,
    /// The joints: the anchor's, between the links, the ball's, then the
    /// tether if any.
    pub joints: Vec<crate::joint::JointHandle>,
}

impl WreckingBallSpec {
    /// The chain's direction from the anchor at release (unit).
    pub fn hanging_direction(&self) -> Vec3 {
        let side = self.direction.normalize_or(Vec3::Z);
        -Vec3::Y * self.release_angle.cos() - side * self.release_angle.sin()
    }

    /// The distance from the anchor to the ball's centre, metres.
    pub fn length(&self) -> f32 {
        self.links as f32 * self.link.y + self.ball_radius
    }
}

/// Adds a wrecking ball (see [`WreckingBallSpec`]): links joined end to end
/// by spherical joints, the first to the world at the anchor, the ball to
/// the last at its top.
pub fn add_wrecking_ball(world: &mut World, spec: &WreckingBallSpec) -> Result<WreckingBall, WorldError> {
    use crate::joint::{JointBody, JointBuilder};
    let d = spec.hanging_direction();
    let along = Quat::from_rotation_arc(Vec3::NEG_Y, d);
    let (mut links, mut joints) = (Vec::new(), Vec::new());
    let len = spec.link.y;
    let mut previous = JointBody::World;
    for i in 0..spec.links {
        let center = spec.anchor + d * ((i as f32 + 0.5) * len);
        let link = add_box(world, spec.link, center, along, spec.link_material, false)?;
        let joint = JointBuilder::spherical(previous, link).anchor(spec.anchor + d * (i as f32 * len));
        joints.push(world.insert_joint(joint)?);
        links.push(link);
        previous = JointBody::Body(link);
    }
    let bottom = spec.anchor + d * (spec.links as f32 * len);
    let center = bottom + d * spec.ball_radius;
    let ball = add_ball(world, spec.ball_radius, center, Vec3::ZERO, spec.ball_material, false)?;
    joints.push(world.insert_joint(JointBuilder::spherical(previous, ball).anchor(bottom))?);
    if spec.tether {
        let rope = JointBuilder::rope(JointBody::World, ball, spec.length()).anchors(spec.anchor, center);
        joints.push(world.insert_joint(rope)?);
    }
    Ok(WreckingBall { links, ball, joints })
}
