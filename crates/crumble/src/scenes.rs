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
pub const BRICK: Material = Material { density: 2000.0, friction: 0.6, restitution: 0.1, rolling_resistance: 0.05 };

/// Steel: 7800 kg/m³, friction 0.4, restitution 0.1, rolling resistance 0.002.
pub const STEEL: Material = Material { density: 7800.0, friction: 0.4, restitution: 0.1, rolling_resistance: 0.002 };

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
