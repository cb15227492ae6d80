//! Debug drawing with the renderer's own boxes (it has no line pipeline):
//! contact points as small cubes, normals and AABB edges as thin boxes.

use crumble::World;
use crumble_render::{Instance, Material, Shape};
use glam::{Quat, Vec3};

/// Contact points: bright yellow; normals: cyan; AABBs: green.
const CONTACT: Material = Material { color: [1.0, 0.85, 0.1], metalness: 0.0, edge_width: 0.0 };
const NORMAL: Material = Material { color: [0.1, 0.85, 1.0], metalness: 0.0, edge_width: 0.0 };
const AABB: Material = Material { color: [0.2, 0.95, 0.3], metalness: 0.0, edge_width: 0.0 };

/// Colour of a sleeping body's tint target (blue-grey), and how far to go.
const SLEEP_TINT: [f32; 3] = [0.25, 0.35, 0.85];
const SLEEP_MIX: f32 = 0.7;

/// A thin box from `a` to `b` of half thickness `half`; `None` when the
/// segment is too short to have a direction.
pub fn segment(a: Vec3, b: Vec3, half: f32, material: Material) -> Option<Instance> {
    let d = b - a;
    let len = d.length();
    let dir = d.try_normalize()?;
    Some(Instance {
        shape: Shape::Box { half_extents: Vec3::new(half, len * 0.5, half) },
        position: (a + b) * 0.5,
        rotation: Quat::from_rotation_arc(Vec3::Y, dir),
        material,
    })
}

/// Sizes of the debug marks for a scene `size` metres across, so that they
/// show at any scale.
#[derive(Clone, Copy, Debug)]
pub struct Marks {
    /// Half edge of a contact-point cube.
    pub point: f32,
    /// Length of a normal.
    pub normal: f32,
    /// Half thickness of normals and AABB edges.
    pub line: f32,
}

impl Marks {
    /// Marks for a scene whose bounds have radius `radius`.
    pub fn for_radius(radius: f32) -> Self {
        let r = if radius.is_finite() && radius > 0.0 { radius } else { 1.0 };
        Self { point: r * 0.006, normal: r * 0.06, line: r * 0.0015 }
    }
}

/// Appends a cube per contact point and a thin box along each manifold's
/// normal (from a to b) at each point. Returns the number of points.
pub fn contacts(world: &World, marks: Marks, out: &mut Vec<Instance>) -> usize {
    let mut count = 0;
    for (_, _, manifold) in world.contacts() {
        let n = manifold.normal;
        for p in manifold.points() {
            count += 1;
            if !p.point.is_finite() {
                continue;
            }
            out.push(Instance {
                shape: Shape::Box { half_extents: Vec3::splat(marks.point) },
                position: p.point,
                rotation: Quat::IDENTITY,
                material: CONTACT,
            });
            if n.is_finite() {
                out.extend(segment(p.point, p.point + n * marks.normal, marks.line, NORMAL));
            }
        }
    }
    count
}

/// Appends the twelve edges of every collider's bounding box (the ground's
/// infinite half space left out).
pub fn aabbs(world: &World, marks: Marks, out: &mut Vec<Instance>) {
    for (_, collider) in world.colliders() {
        if matches!(collider.shape(), crumble::Shape::HalfSpace(_)) {
            continue;
        }
        let b = collider.shape().aabb(&collider.world_pose());
        if !(b.min.is_finite() && b.max.is_finite()) {
            continue;
        }
        let corner = |i: u32| {
            Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            )
        };
        // Edges join corners that differ in one bit.
        for i in 0..8u32 {
            for bit in [1u32, 2, 4] {
                if i & bit == 0 {
                    out.extend(segment(corner(i), corner(i | bit), marks.line, AABB));
                }
            }
        }
    }
}

/// The material of a sleeping body: its colour pulled towards blue-grey.
pub fn sleeping(m: Material) -> Material {
    let mut color = m.color;
    for (c, t) in color.iter_mut().zip(SLEEP_TINT) {
        *c += (t - *c) * SLEEP_MIX;
    }
    Material { color, ..m }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_segment_spans_its_end_points() {
        let (a, b) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(1.5, 2.0, 2.0));
        let s = segment(a, b, 0.01, AABB).unwrap();
        let Shape::Box { half_extents } = s.shape else { panic!("not a box") };
        let tip = s.position + s.rotation * Vec3::new(0.0, half_extents.y, 0.0);
        assert!(tip.distance(b) < 1e-5, "{tip} vs {b}");
        assert!(segment(a, a, 0.01, AABB).is_none());
    }

    #[test]
    fn overlays_cover_a_resting_box() {
        let mut world = World::new(Default::default()).unwrap();
        crumble::scenes::add_ground(&mut world, 0.0, crumble::scenes::STEEL).unwrap();
        let size = Vec3::new(0.4, 0.2, 0.3);
        crumble::scenes::add_box(
            &mut world,
            size,
            Vec3::new(0.0, 0.1, 0.0),
            Quat::IDENTITY,
            crumble::scenes::STEEL,
            false,
        )
        .unwrap();
        for _ in 0..10 {
            world.step(1.0 / 60.0).unwrap();
        }
        let marks = Marks::for_radius(1.0);
        let mut out = Vec::new();
        let points = contacts(&world, marks, &mut out);
        assert!(points >= 4, "a box on the ground touches at its corners: {points}");
        assert_eq!(out.len(), points * 2, "a cube and a normal per point");
        out.clear();
        aabbs(&world, marks, &mut out);
        assert_eq!(out.len(), 12, "one box, twelve edges");
        for inst in &out {
            inst.validate(0).unwrap();
        }
        let tinted = sleeping(crumble_render::STEEL);
        assert!(tinted.color[2] > tinted.color[0]);
    }
}
