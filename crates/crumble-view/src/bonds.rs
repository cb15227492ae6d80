//! Bonds in the viewer (key M): where each bond's four anchors are, from
//! its two bodies' poses alone; the colour of how near it came to breaking
//! ([`utilisation_color`]); and the marks left where bonds broke
//! ([`BreakMarks`]), which fade out over a second of simulated time.
//!
//! A bond that breaks is gone from the world by the time its event is
//! read, anchors included. So the viewer keeps each bond's anchors fixed
//! in its two bodies' frames ([`Tracker`]): with the bodies' poses after
//! the step, they say where the bond was when it broke.

use crate::fading::{Fading, Stamped};

use crumble::{BodyHandle, Bond, BondHandle, Pose, Quat, Vec3, World};

/// The colour of an unloaded bond (utilisation 0): green.
pub const UNLOADED: [f32; 3] = [0.1, 0.75, 0.2];
/// The colour of a bond at half its strength: yellow.
pub const HALF_LOADED: [f32; 3] = [1.0, 0.8, 0.1];
/// The colour of a bond at its strength (it breaks at 0.99): red.
pub const AT_LIMIT: [f32; 3] = [1.0, 0.1, 0.1];

/// The colour of a bond of utilisation `u` ([`Bond::utilisation`]): green
/// at 0 through yellow at 0.5 to red at 1 and beyond, linearly between.
/// A utilisation that is not a number shows red: a bond whose forces went
/// wrong is one to look at.
pub fn utilisation_color(u: f32) -> [f32; 3] {
    let u = if u.is_nan() { 1.0 } else { u.clamp(0.0, 1.0) };
    let (from, to, t) = if u < 0.5 { (UNLOADED, HALF_LOADED, u * 2.0) } else { (HALF_LOADED, AT_LIMIT, u * 2.0 - 1.0) };
    mix(from, to, t)
}

/// `a` moved towards `b` by `t` (0 to 1).
fn mix(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t)
}

/// The corners of a bond's face from its anchors: the anchors sit at the
/// kern of the face's rectangle, a third of the way from its centre to its
/// sides (`crumble::bond`), so the corners are three times as far out.
pub fn face_corners(a: &[Vec3; 4]) -> [Vec3; 4] {
    let c = centre(a);
    a.map(|p| c + (p - c) * 3.0)
}

/// The four sides of a bond's face, from its anchors in the order
/// [`Bond::anchors`] gives them, `(+u, +v)`, `(+u, −v)`, `(−u, +v)`,
/// `(−u, −v)` (see [`face_corners`]): the perimeter runs 0, 1, 3, 2 (0 to
/// 3 and 1 to 2 are the diagonals).
pub fn outline(anchors: &[Vec3; 4]) -> [(Vec3, Vec3); 4] {
    let a = face_corners(anchors);
    [(a[0], a[1]), (a[1], a[3]), (a[3], a[2]), (a[2], a[0])]
}

/// The two diagonals of a bond's face (see [`outline`]).
pub fn diagonals(anchors: &[Vec3; 4]) -> [(Vec3, Vec3); 2] {
    let a = face_corners(anchors);
    [(a[0], a[3]), (a[1], a[2])]
}

/// The mean of the four anchors: the centre of the bond's face.
pub fn centre(a: &[Vec3; 4]) -> Vec3 {
    (a[0] + a[1] + a[2] + a[3]) * 0.25
}

/// A bond's anchors fixed in each of its two bodies' frames.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Tracked {
    bond: BondHandle,
    bodies: (BodyHandle, BodyHandle),
    in_a: [Vec3; 4],
    in_b: [Vec3; 4],
}

impl Tracked {
    /// The anchors where the bodies are now: half-way between the two
    /// bodies' own anchor points, as [`Bond::anchors_at`] places them.
    /// `None` when a body is gone or its pose is not finite.
    fn anchors(&self, world: &World) -> Option<[Vec3; 4]> {
        let pa = world.body(self.bodies.0)?.pose();
        let pb = world.body(self.bodies.1)?.pose();
        let a: [Vec3; 4] =
            std::array::from_fn(|k| 0.5 * (pa.transform_point(self.in_a[k]) + pb.transform_point(self.in_b[k])));
        a.iter().all(|p| p.is_finite()).then_some(a)
    }
}

/// Each side's anchors in its collider's frame, read off
/// [`Bond::anchors_at`]: it is the mean of the two sides' anchors, each
/// carried by its own pose, so turning one side's pose half a turn about
/// an axis (the other kept at the identity) moves the mean by that side's
/// anchor across the axis. About x, `(x, y, z)` goes to `(x, −y, −z)` and
/// the mean moves by `(0, y, z)`; about y, by `(x, 0, z)`.
fn collider_frame_sides(bond: &Bond) -> ([Vec3; 4], [Vec3; 4]) {
    const ID: Pose = Pose::IDENTITY;
    // Exact half turns: unit quaternions with no rounding in them.
    const TURN_X: Pose = Pose::new(Vec3::ZERO, Quat::from_xyzw(1.0, 0.0, 0.0, 0.0));
    const TURN_Y: Pose = Pose::new(Vec3::ZERO, Quat::from_xyzw(0.0, 1.0, 0.0, 0.0));
    let base = bond.anchors_at(&ID, &ID);
    let side = |about_x: [Vec3; 4], about_y: [Vec3; 4]| -> [Vec3; 4] {
        std::array::from_fn(|k| {
            let (dx, dy) = (base[k] - about_x[k], base[k] - about_y[k]);
            Vec3::new(dy.x, dx.y, dx.z)
        })
    };
    (
        side(bond.anchors_at(&TURN_X, &ID), bond.anchors_at(&TURN_Y, &ID)),
        side(bond.anchors_at(&ID, &TURN_X), bond.anchors_at(&ID, &TURN_Y)),
    )
}

/// Bond `h`'s anchors in its bodies' frames. A bond joins one collider of
/// each body; of a body with several, it is the pair whose two sides'
/// anchors meet (a holding bond keeps them together), so that the anchors
/// are right for compound bodies too. `None` when a body has no collider.
fn track(world: &World, h: BondHandle, bond: &Bond) -> Option<Tracked> {
    let (ha, hb) = bond.bodies();
    let (sa, sb) = collider_frame_sides(bond);
    let colliders = |b| world.body_colliders(b).into_iter().filter_map(|c| world.collider(c)).collect::<Vec<_>>();
    let (ca, cb) = (colliders(ha), colliders(hb));
    let mut best: Option<(f32, Pose, Pose)> = None;
    for a in &ca {
        for b in &cb {
            let (pa, pb) = (a.world_pose(), b.world_pose());
            let apart: f32 =
                (0..4).map(|k| pa.transform_point(sa[k]).distance_squared(pb.transform_point(sb[k]))).sum();
            if best.is_none_or(|(d, ..)| apart < d) {
                best = Some((apart, a.local_pose(), b.local_pose()));
            }
        }
    }
    // A collider's world pose is its body's pose times its local pose.
    let (_, la, lb) = best?;
    Some(Tracked {
        bond: h,
        bodies: (ha, hb),
        in_a: sa.map(|p| la.transform_point(p)),
        in_b: sb.map(|p| lb.transform_point(p)),
    })
}

/// Every bond's anchors in its bodies' frames, by bond slot: learnt once
/// per bond ([`Tracker::sync`]), read each frame from the bodies' poses
/// ([`Tracker::anchors`]), and read once more for a bond that broke
/// ([`Tracker::take_broken`]).
#[derive(Clone, Debug, Default)]
pub struct Tracker {
    slots: Vec<Option<Tracked>>,
}

impl Tracker {
    /// Learns the bonds of `world` not known yet (new, or in a slot a
    /// removed bond left) and forgets those gone without breaking (a body
    /// that broke takes its bonds with it, and its pieces get new ones).
    /// Call before each step, so that a bond that breaks in it is known.
    pub fn sync(&mut self, world: &World) {
        for slot in &mut self.slots {
            if slot.is_some_and(|t| world.bond(t.bond).is_none()) {
                *slot = None;
            }
        }
        for (h, bond) in world.bonds() {
            let i = h.index() as usize;
            if self.slots.get(i).is_some_and(|t| t.is_some_and(|t| t.bond == h)) {
                continue;
            }
            if self.slots.len() <= i {
                self.slots.resize(i + 1, None);
            }
            self.slots[i] = track(world, h, bond);
        }
    }

    /// Bond `h`'s anchors where its bodies are now (the bond learnt on the
    /// spot if [`Tracker::sync`] has not seen it). `None` when a body is
    /// gone or not finite.
    pub fn anchors(&self, world: &World, h: BondHandle, bond: &Bond) -> Option<[Vec3; 4]> {
        match self.slots.get(h.index() as usize) {
            Some(Some(t)) if t.bond == h => t.anchors(world),
            _ => track(world, h, bond)?.anchors(world),
        }
    }

    /// Where bond `h`, broken in the last step, was at its end: its
    /// anchors carried by its bodies' poses. Forgets the bond. `None` when
    /// the bond was not known before the step or a body is gone.
    pub fn take_broken(&mut self, world: &World, h: BondHandle) -> Option<[Vec3; 4]> {
        let slot = self.slots.get_mut(h.index() as usize)?;
        let t = slot.take_if(|t| t.bond == h)?;
        t.anchors(world)
    }

    /// Bonds known.
    pub fn len(&self) -> usize {
        self.slots.iter().flatten().count()
    }

    /// True when no bond is known.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Simulated seconds a broken bond's mark is shown: long enough to see
/// at full speed, and at a quarter speed or stepping, where it lasts
/// longer in real time, still gone before the next break nearby.
pub const BREAK_MARK_SECONDS: f64 = 1.0;
/// Most marks kept: a wall blown apart can break thousands of bonds in a
/// step, and each mark is drawn as six instances; beyond this many the
/// oldest go first.
pub const MAX_BREAK_MARKS: usize = 4096;

/// Where a bond broke and when.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BreakMark {
    /// The bond's anchors at the end of the step it broke in.
    pub anchors: [Vec3; 4],
    /// Simulated time of the end of that step, seconds.
    pub time: f64,
}

impl Stamped for BreakMark {
    fn time(&self) -> f64 {
        self.time
    }
}

/// The marks of the bonds broken in the last [`BREAK_MARK_SECONDS`] of
/// simulated time, oldest first, at most [`MAX_BREAK_MARKS`]; and how many
/// bonds broke in all.
#[derive(Clone, Debug)]
pub struct BreakMarks {
    marks: Fading<BreakMark>,
    total: usize,
}

impl Default for BreakMarks {
    fn default() -> Self {
        Self { marks: Fading::new(BREAK_MARK_SECONDS, MAX_BREAK_MARKS), total: 0 }
    }
}

impl BreakMarks {
    /// Adds the mark of a bond that broke at `time` (not before the marks
    /// already kept), dropping the oldest mark when there are
    /// [`MAX_BREAK_MARKS`].
    pub fn push(&mut self, anchors: [Vec3; 4], time: f64) {
        self.marks.push(BreakMark { anchors, time });
        self.total += 1;
    }

    /// Counts a bond that broke where the viewer could not tell (it was
    /// made and broke within one step): no mark.
    pub fn count_unplaced(&mut self) {
        self.total += 1;
    }

    /// Drops the marks whose time is over at simulated time `now`.
    pub fn expire(&mut self, now: f64) {
        self.marks.expire(now);
    }

    /// The marks still shown at `now`, each with what is left of its time,
    /// from 1 when it broke to 0 when it goes.
    pub fn visible(&self, now: f64) -> impl Iterator<Item = (&BreakMark, f32)> {
        self.marks.visible(now)
    }

    /// Marks kept.
    pub fn len(&self) -> usize {
        self.marks.len()
    }

    /// True when no mark is kept.
    pub fn is_empty(&self) -> bool {
        self.marks.is_empty()
    }

    /// Bonds broken since the marks were made, marked or not.
    pub fn total(&self) -> usize {
        self.total
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crumble::scenes::{add_box, BRICK, BRICK_SIZE};
    use crumble::{BodyBuilder, BondEvent, BondSpec, ColliderBuilder, WorldSettings};

    fn close(a: [f32; 3], b: [f32; 3]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6)
    }

    #[test]
    fn the_colour_runs_from_green_through_yellow_to_red() {
        assert!(close(utilisation_color(0.0), UNLOADED));
        assert!(close(utilisation_color(0.5), HALF_LOADED));
        assert!(close(utilisation_color(1.0), AT_LIMIT));
        assert!(close(utilisation_color(0.25), [0.55, 0.775, 0.15]), "{:?}", utilisation_color(0.25));
        // Out of range: held at the ends; not a number: red.
        assert!(close(utilisation_color(-3.0), UNLOADED));
        assert!(close(utilisation_color(7.0), AT_LIMIT));
        assert!(close(utilisation_color(f32::NAN), AT_LIMIT));
        // Redder (red minus green) at every step up.
        let redness = |u: f32| {
            let c = utilisation_color(u);
            c[0] - c[1]
        };
        for i in 0..100 {
            let (u, v) = (i as f32 / 100.0, (i + 1) as f32 / 100.0);
            assert!(redness(v) > redness(u), "{u} → {v}: {} then {}", redness(u), redness(v));
        }
    }

    #[test]
    fn the_outline_is_the_rectangles_four_sides() {
        // A 2 × 1 face in the anchors' order: (+u, +v), (+u, −v), (−u, +v),
        // (−u, −v); the anchors at its kern, a third of the way out.
        let (u, v) = (Vec3::X, Vec3::Z * 0.5);
        let corners = [u + v, u - v, -u + v, -u - v];
        let a = corners.map(|p| p / 3.0);
        assert!(face_corners(&a).iter().zip(&corners).all(|(p, q)| p.distance(*q) < 1e-6));
        let lengths: Vec<f32> = outline(&a).iter().map(|(p, q)| p.distance(*q)).collect();
        assert!(
            lengths.iter().zip([1.0, 2.0, 1.0, 2.0]).all(|(l, w)| (l - w).abs() < 1e-6),
            "sides, no diagonal: {lengths:?}"
        );
        for p in &face_corners(&a) {
            let ends = outline(&a).iter().filter(|(s, e)| s == p || e == p).count();
            assert_eq!(ends, 2, "every corner ends two sides");
        }
        let diagonal = 5.0f32.sqrt();
        for (p, q) in diagonals(&a) {
            assert!((p.distance(q) - diagonal).abs() < 1e-6);
        }
        assert_eq!(centre(&a), Vec3::ZERO);
    }

    #[test]
    fn marks_fade_over_a_second_and_are_bounded() {
        let mut m = BreakMarks::default();
        let at = |x: f32| [Vec3::splat(x); 4];
        m.push(at(0.0), 10.0);
        m.push(at(1.0), 10.25);
        let left: Vec<f32> = m.visible(10.5).map(|(_, f)| f).collect();
        assert_eq!(left, [0.5, 0.75]);
        m.expire(11.0);
        assert_eq!(m.len(), 1, "the first mark's second is over");
        assert_eq!(m.visible(11.0).map(|(_, f)| f).collect::<Vec<_>>(), [0.25]);
        assert_eq!(m.visible(11.25).count(), 0, "over, even before it is expired");
        m.expire(11.25);
        assert!(m.is_empty());
        assert_eq!(m.total(), 2);

        // A burst of breaks keeps the newest MAX_BREAK_MARKS.
        let burst = MAX_BREAK_MARKS + 904;
        for i in 0..burst {
            m.push(at(i as f32), 20.0);
        }
        m.count_unplaced();
        assert_eq!(m.len(), MAX_BREAK_MARKS);
        assert_eq!(m.visible(20.0).next().unwrap().0.anchors[0].x, 904.0, "the oldest went first");
        assert_eq!(m.total(), 2 + burst + 1);
    }

    /// A static block and, on its top face, a body of two boxes side by
    /// side, bonded to the block by the box on the right: the bond's
    /// anchors belong to that box, 0.3 m from the body's origin.
    #[test]
    fn anchors_follow_the_collider_the_bond_joins_on_a_compound_body() {
        let mut w = World::new(WorldSettings { gravity: Vec3::ZERO, ..Default::default() }).unwrap();
        let block = w.insert_body(BodyBuilder::fixed().position(Vec3::new(0.3, -0.1, 0.0))).unwrap();
        let cube = || ColliderBuilder::cuboid(0.1, 0.1, 0.1).unwrap().material(BRICK);
        w.insert_collider(cube(), block).unwrap();
        let body = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 0.1, 0.0))).unwrap();
        let local = |x: f32| Pose::from_translation(Vec3::new(x, 0.0, 0.0));
        w.insert_collider(cube().local_pose(local(-0.3)), body).unwrap();
        let right = w.insert_collider(cube().local_pose(local(0.3)), body).unwrap();
        let bond = w.insert_bond(block, body, BondSpec::CEMENT_MORTAR).unwrap();
        let mut tracker = Tracker::default();
        tracker.sync(&w);
        assert_eq!(tracker.len(), 1);

        // The body spinning away and up from where it was bonded, the
        // bond still held (nothing judged it yet): the tracker's anchors
        // are where anchors_at puts them from the colliders' poses.
        let turned = Pose::new(Vec3::new(1.0, 2.0, -0.5), Quat::from_euler(glam::EulerRot::XYZ, 0.4, -1.1, 0.7));
        w.set_pose(body, turned).unwrap();
        let b = w.bond(bond).unwrap();
        let block_collider = w.body_colliders(block)[0];
        let pose = |c| w.collider(c).unwrap().world_pose();
        let (pa, pb) = if b.bodies().0 == block {
            (pose(block_collider), pose(right))
        } else {
            (pose(right), pose(block_collider))
        };
        let want = b.anchors_at(&pa, &pb);
        let got = tracker.anchors(&w, bond, b).unwrap();
        for k in 0..4 {
            assert!(got[k].distance(want[k]) < 1e-5, "anchor {k}: {} vs {}", got[k], want[k]);
        }
        // The body's own pose in place of the collider's puts them 0.15 m
        // off (half the right box's 0.3 m offset): the choice matters.
        let body_pose = w.body(body).unwrap().pose();
        let naive = if b.bodies().0 == block { b.anchors_at(&pa, &body_pose) } else { b.anchors_at(&body_pose, &pb) };
        assert!((naive[0].distance(want[0]) - 0.15).abs() < 1e-4, "{}", naive[0].distance(want[0]));
    }

    /// A body that leaves the world (as a brick that breaks does, its
    /// pieces taking new bonds) takes its bonds with it, with no event:
    /// the tracker forgets them at its next sync, so that what it holds
    /// is the bonds in the world.
    #[test]
    fn bonds_gone_with_their_body_are_forgotten() {
        let mut w = World::new(WorldSettings { gravity: Vec3::ZERO, ..Default::default() }).unwrap();
        let cube = |h: f32| ColliderBuilder::cuboid(h, h, h).unwrap().material(BRICK);
        let block = w.insert_body(BodyBuilder::fixed()).unwrap();
        w.insert_collider(cube(0.1), block).unwrap();
        // Two small cubes side by side on the block's top face.
        let on_top = |w: &mut World, x: f32| {
            let b = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(x, 0.15, 0.0))).unwrap();
            w.insert_collider(cube(0.05), b).unwrap();
            w.insert_bond(block, b, BondSpec::CEMENT_MORTAR).unwrap();
            b
        };
        let (a, _) = (on_top(&mut w, -0.05), on_top(&mut w, 0.05));
        let mut tracker = Tracker::default();
        tracker.sync(&w);
        assert_eq!(tracker.len(), 2);
        w.remove_body(a).unwrap();
        assert_eq!(w.bond_count(), 1);
        tracker.sync(&w);
        assert_eq!(tracker.len(), 1, "the removed body's bond forgotten, the other kept");
    }

    /// Four bricks glued end to end from a static block's side face, under
    /// gravity, the joints 10% weaker than the root needs: the root bond
    /// breaks in the first step (as in crumble's own bond tests), and its
    /// mark is on the block's face.
    #[test]
    fn a_broken_bond_is_placed_where_it_was() {
        let mut w = World::new(WorldSettings { sleep_enabled: false, ..Default::default() }).unwrap();
        let (l, h, b) = (BRICK_SIZE.x, BRICK_SIZE.y, BRICK_SIZE.z);
        let block = w.insert_body(BodyBuilder::fixed().position(Vec3::new(-0.2, 1.0, 0.0))).unwrap();
        w.insert_collider(ColliderBuilder::cuboid(0.2, 0.2, 0.1).unwrap().material(BRICK), block).unwrap();
        // The root face's bending stress under the row's own weight: M / Z.
        let mut bricks = Vec::new();
        for i in 0..4 {
            let at = Vec3::new(l * (i as f32 + 0.5), 1.0, 0.0);
            bricks.push(add_box(&mut w, BRICK_SIZE, at, Quat::IDENTITY, BRICK, false).unwrap());
        }
        let m = w.body(bricks[0]).unwrap().mass();
        let moment: f32 = (0..4).map(|i| m * 9.81 * l * (i as f32 + 0.5)).sum();
        let sigma = moment / (b * h * h / 6.0);
        let spec = BondSpec::new(sigma / 1.1, 10e6);
        let mut prev = block;
        let mut root = None;
        for &brick in &bricks {
            let bond = w.insert_bond(prev, brick, spec).unwrap();
            root.get_or_insert(bond);
            prev = brick;
        }
        let root = root.unwrap();
        let area = w.bond(root).unwrap().area();

        let mut tracker = Tracker::default();
        tracker.sync(&w);
        assert_eq!(tracker.len(), 4);
        // The root breaks at the end of the second step (its first holds
        // 0.98 of its limit: crumble's tests/bonds.rs).
        w.step(1.0 / 60.0).unwrap();
        assert!(w.bond_events().is_empty());
        tracker.sync(&w);
        w.step(1.0 / 60.0).unwrap();
        let events = w.bond_events();
        assert_eq!(events.len(), 1, "{events:?}");
        let BondEvent::Broken { bond, .. } = events[0];
        assert_eq!(bond, root);
        assert!(w.bond(root).is_none(), "gone from the world");
        let a = tracker.take_broken(&w, bond).unwrap();
        // On the block's face (x = 0), over the brick's end (h × b about
        // y = 1, z = 0), within the millimetre a step's sag moves it.
        for p in a {
            assert!(p.x.abs() < 1e-3 && (p.y - 1.0).abs() < h / 2.0 + 1e-3 && p.z.abs() < b / 2.0 + 1e-3, "{p}");
        }
        let [s0, s1, ..] = outline(&a).map(|(p, q)| p.distance(q));
        assert!((s0 * s1 - area).abs() < 1e-3 * area, "rectangle {s0} × {s1} vs area {area}");
        assert!(centre(&a).distance(Vec3::new(0.0, 1.0, 0.0)) < 1e-3, "{}", centre(&a));
        assert_eq!(tracker.take_broken(&w, bond), None, "forgotten");
        assert_eq!(tracker.len(), 3);
    }
}
