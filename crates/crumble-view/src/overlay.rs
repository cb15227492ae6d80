//! Debug drawing with the renderer's own shapes (it has no line pipeline):
//! contact points as small cubes, normals, AABB edges, joints and bonds as
//! thin boxes, joint anchors as small spheres.

use crumble::{BodyHandle, JointKind, World};
use crumble_render::{Instance, Material, Shape};
use glam::{Quat, Vec3};

use crate::bonds::{diagonals, outline, utilisation_color, BreakMarks, Tracker};

/// Contact points: bright yellow; normals: cyan; AABBs: green.
const CONTACT: Material = Material { color: [1.0, 0.85, 0.1], metalness: 0.0, edge_width: 0.0 };
const NORMAL: Material = Material { color: [0.1, 0.85, 1.0], metalness: 0.0, edge_width: 0.0 };
const AABB: Material = Material { color: [0.2, 0.95, 0.3], metalness: 0.0, edge_width: 0.0 };

/// A joint further than this from holding ([`crumble::Joint::separation`],
/// metres) is drawn in [`STRETCHED`]: a solved joint stays well under a
/// millimetre, so a red one is being pulled apart.
pub const STRETCH_TOLERANCE: f32 = 1e-3;
/// Joints by kind: spherical orange, revolute magenta, fixed white,
/// distance violet, rope tan; any kind stretched: red.
const SPHERICAL: Material = Material::matte([1.0, 0.55, 0.1]);
const REVOLUTE: Material = Material::matte([0.9, 0.25, 0.9]);
const FIXED: Material = Material::matte([0.95, 0.95, 0.95]);
const DISTANCE: Material = Material::matte([0.55, 0.45, 1.0]);
const ROPE: Material = Material::matte([0.8, 0.62, 0.35]);
/// A joint stretched beyond [`STRETCH_TOLERANCE`].
pub const STRETCHED: Material = Material::matte([1.0, 0.1, 0.1]);
/// The mouse's grab: pink, whatever the joint overlay shows.
pub const GRAB: Material = Material::matte([1.0, 0.35, 0.65]);

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
    /// Radius of a joint anchor's sphere.
    pub fn anchor(&self) -> f32 {
        self.point * 1.5
    }

    /// Half thickness of a joint's line (a little thicker than the others).
    pub fn joint_line(&self) -> f32 {
        self.line * 1.5
    }

    /// Half thickness of a bond's outline: twice the other lines, so that
    /// the part standing out of a wall's surface (half of it) is as wide
    /// as the other lines.
    pub fn bond_line(&self) -> f32 {
        self.line * 2.0
    }
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

/// The colour of a joint of `kind`, or [`STRETCHED`] when its separation
/// is above [`STRETCH_TOLERANCE`].
pub fn joint_material(kind: JointKind, separation: f32) -> Material {
    if separation > STRETCH_TOLERANCE {
        return STRETCHED;
    }
    match kind {
        JointKind::Spherical => SPHERICAL,
        JointKind::Revolute => REVOLUTE,
        JointKind::Fixed => FIXED,
        JointKind::Distance => DISTANCE,
        JointKind::Rope => ROPE,
    }
}

/// Appends a line from `a` to `b` with a sphere at each end (one when the
/// two meet, as a spherical, revolute or fixed joint's anchors do).
/// Nothing for points that are not finite.
pub fn link(a: Vec3, b: Vec3, marks: Marks, material: Material, out: &mut Vec<Instance>) {
    if !(a.is_finite() && b.is_finite()) {
        return;
    }
    let r = marks.anchor();
    let sphere =
        |position| Instance { shape: Shape::Sphere { radius: r }, position, rotation: Quat::IDENTITY, material };
    out.push(sphere(a));
    if a.distance(b) > r {
        out.push(sphere(b));
        out.extend(segment(a, b, marks.joint_line(), material));
    }
}

/// Appends every joint (but those of `hidden`, the mouse's helper body,
/// whose joint is drawn as the grab): a line between its two anchors with
/// a sphere at each, coloured by [`joint_material`]. Returns the number of
/// joints drawn and of those, how many are stretched.
pub fn joints(world: &World, marks: Marks, hidden: Option<BodyHandle>, out: &mut Vec<Instance>) -> (usize, usize) {
    let (mut drawn, mut stretched) = (0, 0);
    for (h, joint) in world.joints() {
        let (a, b) = joint.bodies();
        if hidden.is_some() && (a == hidden || b == hidden) {
            continue;
        }
        let Some((pa, pb)) = world.joint_anchors(h) else { continue };
        let material = joint_material(joint.kind(), joint.separation());
        drawn += 1;
        stretched += usize::from(joint.separation() > STRETCH_TOLERANCE);
        link(pa, pb, marks, material, out);
    }
    (drawn, stretched)
}

/// Appends the outline of every bond's face, four thin boxes joining its
/// anchors around the rectangle, coloured by its utilisation
/// ([`utilisation_color`]: green unloaded, yellow at half, red at its
/// strength). The outline lies on the face's edges: where two bricks meet
/// at a wall's surface, half of it stands out of the surface and shows as
/// a coloured mortar joint; inside the wall it is hidden, as the mortar
/// is. Returns the number of bonds drawn.
pub fn bonds(world: &World, tracker: &Tracker, marks: Marks, out: &mut Vec<Instance>) -> usize {
    let mut drawn = 0;
    for (h, bond) in world.bonds() {
        let Some(anchors) = tracker.anchors(world, h, bond) else { continue };
        let material = Material::matte(utilisation_color(bond.utilisation()));
        drawn += 1;
        for (p, q) in outline(&anchors) {
            out.extend(segment(p, q, marks.bond_line(), material));
        }
    }
    drawn
}

/// A break mark's colours: a white flash as the bond breaks, magenta for
/// most of its time, dark purple as it goes. Not red: red is an intact
/// bond at its strength, and a wall breaking shows both side by side.
const BREAK_FLASH: [f32; 3] = [1.0, 1.0, 1.0];
const BREAK_MAGENTA: [f32; 3] = [1.0, 0.1, 0.85];
const BREAK_DARK: [f32; 3] = [0.25, 0.0, 0.22];
/// Share of a break mark's time that the flash fades to red over.
const FLASH: f32 = 0.25;

/// The material and the half thickness (in bond lines,
/// [`Marks::bond_line`]) of a break mark with `left` of its time left, 1
/// as the bond breaks to 0 as the mark goes: the flash turns magenta over
/// the first quarter, then darkens, while the lines thin from three bond
/// lines to none. The renderer has no transparency: the mark fades by
/// thinning and darkening.
pub fn break_style(left: f32) -> (Material, f32) {
    let left = if left.is_nan() { 0.0 } else { left.clamp(0.0, 1.0) };
    let mix = |a: [f32; 3], b: [f32; 3], t: f32| -> [f32; 3] { std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t) };
    let color = if left > 1.0 - FLASH {
        mix(BREAK_MAGENTA, BREAK_FLASH, (left - (1.0 - FLASH)) / FLASH)
    } else {
        mix(BREAK_DARK, BREAK_MAGENTA, left / (1.0 - FLASH))
    };
    (Material::matte(color), 3.0 * left)
}

/// Appends the mark of each bond broken within the last
/// [`BREAK_MARK_SECONDS`](crate::bonds::BREAK_MARK_SECONDS) of simulated
/// time `now`: the rectangle where its face was, crossed by its
/// diagonals, in [`break_style`]. Returns the number of marks drawn.
pub fn breaks(list: &BreakMarks, now: f64, marks: Marks, out: &mut Vec<Instance>) -> usize {
    let mut drawn = 0;
    for (mark, left) in list.visible(now) {
        let (material, thickness) = break_style(left);
        let half = marks.bond_line() * thickness;
        if half <= 0.0 {
            continue;
        }
        drawn += 1;
        for (p, q) in outline(&mark.anchors).into_iter().chain(diagonals(&mark.anchors)) {
            out.extend(segment(p, q, half, material));
        }
    }
    drawn
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

    #[test]
    fn joints_are_drawn_by_kind_and_red_when_stretched() {
        let mut world = World::new(Default::default()).unwrap();
        let spec = crumble::scenes::WreckingBallSpec { links: 3, ..Default::default() };
        let chain = crumble::scenes::add_wrecking_ball(&mut world, &spec).unwrap();
        let marks = Marks::for_radius(3.0);
        let mut out = Vec::new();
        assert_eq!(joints(&world, marks, None, &mut out), (4, 0), "three links and the ball, none stretched");
        // A spherical joint's anchors meet: one sphere each, in orange, at the anchors.
        assert_eq!(out.len(), 4);
        for (inst, &h) in out.iter().zip(&chain.joints) {
            assert!(matches!(inst.shape, Shape::Sphere { .. }) && inst.material == SPHERICAL, "{inst:?}");
            let (pa, _) = world.joint_anchors(h).unwrap();
            assert!(inst.position.distance(pa) < 1e-6, "{} vs {pa}", inst.position);
        }

        // A rigid distance joint inserted 1 m longer than its anchors are
        // apart is 1 m from holding: red, with a sphere at each end and a
        // line between them.
        let (pa, pb) = (Vec3::new(2.0, 1.0, 0.0), world.body(chain.ball).unwrap().position());
        let rod = crumble::JointBuilder::distance(crumble::JointBody::World, chain.ball, pa.distance(pb) + 1.0)
            .anchors(pa, pb);
        world.insert_joint(rod).unwrap();
        out.clear();
        assert_eq!(joints(&world, marks, None, &mut out), (5, 1));
        let rod: Vec<&Instance> = out.iter().filter(|i| i.material == STRETCHED).collect();
        assert_eq!(rod.len(), 3, "two spheres and a line: {rod:?}");
        assert!(rod[0].position.distance(pa) < 1e-6 && rod[1].position.distance(pb) < 1e-5);
        let Shape::Box { half_extents } = rod[2].shape else { panic!("the line is a box") };
        assert!((half_extents.y * 2.0 - pa.distance(pb)).abs() < 1e-4, "{half_extents}");
        for inst in &out {
            inst.validate(0).unwrap();
        }

        // The joints of a hidden body are left out.
        out.clear();
        assert_eq!(joints(&world, marks, Some(chain.ball), &mut out), (3, 0), "the ball's joint and the rod hidden");
        // Points that are not finite draw nothing.
        out.clear();
        link(Vec3::NAN, Vec3::ZERO, marks, GRAB, &mut out);
        assert!(out.is_empty());
    }

    /// Two bricks stacked on a static block, bonded where they touch.
    fn stacked_bricks() -> (World, [crumble::BodyHandle; 2]) {
        use crumble::scenes::{add_box, BRICK, BRICK_SIZE};
        let mut world = World::new(Default::default()).unwrap();
        let block = world.insert_body(crumble::BodyBuilder::fixed().position(Vec3::new(0.0, -0.1, 0.0))).unwrap();
        let cuboid = crumble::ColliderBuilder::cuboid(0.2, 0.1, 0.1).unwrap().material(BRICK);
        world.insert_collider(cuboid, block).unwrap();
        let h = BRICK_SIZE.y;
        let brick =
            |w: &mut World, y: f32| add_box(w, BRICK_SIZE, Vec3::new(0.0, y, 0.0), Quat::IDENTITY, BRICK, false);
        let bricks = [brick(&mut world, h / 2.0).unwrap(), brick(&mut world, 1.5 * h).unwrap()];
        world.bond_touching(&bricks, crumble::BondSpec::LIME_MORTAR).unwrap();
        (world, bricks)
    }

    #[test]
    fn bonds_are_outlined_on_their_faces_in_their_utilisation_colour() {
        use crumble::scenes::BRICK_SIZE;
        let (mut world, _) = stacked_bricks();
        let mut tracker = Tracker::default();
        for _ in 0..10 {
            tracker.sync(&world);
            world.step(1.0 / 60.0).unwrap();
        }
        let marks = Marks::for_radius(1.0);
        let mut out = Vec::new();
        assert_eq!(bonds(&world, &tracker, marks, &mut out), 2);
        assert_eq!(out.len(), 8, "four sides a bond");
        let mut heights = Vec::new();
        for ((_, bond), sides) in world.bonds().zip(out.chunks(4)) {
            // The bottom bond carries both bricks' weight: some load, far from its strength.
            let u = bond.utilisation();
            assert!(u > 0.0 && u < 0.5, "{u}");
            let want = Material::matte(utilisation_color(u));
            let mut lengths = Vec::new();
            for side in sides {
                assert_eq!(side.material, want);
                let Shape::Box { half_extents } = side.shape else { panic!("a side is a box") };
                assert!((half_extents.x - marks.bond_line()).abs() < 1e-7, "{half_extents}");
                lengths.push(half_extents.y * 2.0);
                side.validate(0).unwrap();
            }
            // Around the brick's bed, 215 × 102.5 mm: a short side, a long
            // one, a short one, a long one (which comes first is the
            // engine's choice of axes).
            let (short, long) = (BRICK_SIZE.z, BRICK_SIZE.x);
            let want = if lengths[0] < lengths[1] { [short, long, short, long] } else { [long, short, long, short] };
            for (got, want) in lengths.iter().zip(want) {
                assert!((got - want).abs() < 1e-4, "{lengths:?}");
            }
            heights.push(sides.iter().map(|s| s.position.y).sum::<f32>() / 4.0);
        }
        // On the bed faces: the block's top (y = 0) and between the bricks
        // (y = one brick), to within the millimetre the bricks settle.
        heights.sort_by(f32::total_cmp);
        assert!(heights[0].abs() < 1e-3 && (heights[1] - BRICK_SIZE.y).abs() < 1e-3, "{heights:?}");
    }

    #[test]
    fn a_break_mark_flashes_then_thins_darkens_and_goes() {
        let (material, thickness) = break_style(1.0);
        assert_eq!((material.color, thickness), (BREAK_FLASH, 3.0));
        assert_eq!(break_style(1.0 - FLASH).0.color, BREAK_MAGENTA);
        let (material, thickness) = break_style(0.0);
        assert_eq!((material.color, thickness), (BREAK_DARK, 0.0));
        // Thinner and darker all the way down from magenta.
        let mut last = break_style(1.0 - FLASH);
        for i in (0..75).rev() {
            let now = break_style(i as f32 / 100.0);
            let brightness = |m: Material| m.color.iter().sum::<f32>();
            assert!(now.1 < last.1 && brightness(now.0) < brightness(last.0), "{i}: {now:?} after {last:?}");
            last = now;
        }

        // A mark in a unit square: four sides and two diagonals, three
        // bond lines thick at the break, half that at half its time, gone
        // after a second.
        let mut list = BreakMarks::default();
        // (The anchors at the square's kern: a third of the way out.)
        let corners = [Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO];
        let middle = Vec3::new(0.5, 0.0, 0.5);
        let anchors = corners.map(|p| middle + (p - middle) / 3.0);
        list.push(anchors, 2.0);
        let marks = Marks::for_radius(1.0);
        let mut out = Vec::new();
        let half_thickness = |out: &[Instance]| {
            let Shape::Box { half_extents } = out[0].shape else { panic!("a box") };
            half_extents.x
        };
        assert_eq!(breaks(&list, 2.0, marks, &mut out), 1);
        assert_eq!(out.len(), 6);
        assert!((half_thickness(&out) - 3.0 * marks.bond_line()).abs() < 1e-7);
        let lengths: Vec<f32> = out.iter().map(|i| i.position.distance(Vec3::new(0.5, 0.0, 0.5))).collect();
        assert!(lengths[..4].iter().all(|d| (d - 0.5).abs() < 1e-6), "sides' middles half a side from the centre");
        assert!(lengths[4..].iter().all(|d| d.abs() < 1e-6), "diagonals cross at the centre");
        out.clear();
        assert_eq!(breaks(&list, 2.5, marks, &mut out), 1);
        assert!((half_thickness(&out) - 1.5 * marks.bond_line()).abs() < 1e-6);
        out.clear();
        assert_eq!(breaks(&list, 3.0, marks, &mut out), 0);
        assert!(out.is_empty());
    }
}
