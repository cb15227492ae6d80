//! Fracture (issue 49): a box of a breakable material splits in two along
//! one of its own axis planes when the step's impulses stress that plane
//! beyond the material's strength. Every limit is written beside the
//! measured value and where the expected number comes from.

use crumble::scenes::{add_ball, add_ground, add_wall, WallSpec, BRICK, BRICK_SIZE, STEEL};
use crumble::{
    BodyBuilder, BodyHandle, ColliderBuilder, FractureEvent, MaterialError, Vec3, World, WorldError, WorldSettings,
};

mod rigs;
use rigs::{static_box, world_with};

/// The breakable brick's strengths (`scenes::BREAKABLE_BRICK`, sourced in
/// `docs/fracture.md`), Pa.
const TENSILE: f32 = 1.0e6;
const SHEAR: f32 = 3.0e6;

/// Three-point bending: a brick of tensile strength `tensile` on two
/// narrow static supports `span` apart, a steel ball of mass `load / g`
/// set on the middle of its top face, at rest. Runs `steps` steps and
/// returns the splits.
fn three_point(tensile: f32, load: f32, steps: usize) -> Vec<FractureEvent> {
    let mut w = world_with(|s| s.sleep_enabled = false);
    let h = BRICK_SIZE.y;
    let span = SPAN;
    let support = Vec3::new(0.004, 0.1, 0.2);
    static_box(&mut w, support, Vec3::new(-span / 2.0, 0.05, 0.0));
    static_box(&mut w, support, Vec3::new(span / 2.0, 0.05, 0.0));
    let brick = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 0.1 + h / 2.0, 0.0))).unwrap();
    let half = BRICK_SIZE / 2.0;
    w.insert_collider(
        ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap().material(BRICK.with_strength(tensile, SHEAR)),
        brick,
    )
    .unwrap();
    // A ball of the load's mass, resting on the brick's middle.
    let mass = load / 9.81;
    let radius = (mass / (STEEL.density * 4.0 / 3.0 * std::f32::consts::PI)).cbrt();
    let ball = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 0.1 + h + radius, 0.0))).unwrap();
    w.insert_collider(ColliderBuilder::ball(radius).unwrap().material(STEEL), ball).unwrap();
    let mut splits = Vec::new();
    for _ in 0..steps {
        w.step(1.0 / 60.0).unwrap();
        splits.extend_from_slice(w.fracture_events());
    }
    splits
}

/// The supports' centres are this far apart, m.
const SPAN: f32 = 0.19;

/// The load at mid-span that brings the brick's bottom edge to `tensile`:
/// σ = M / Z with M = W s / 4 + m g (s / 4 − L / 8) (the load, and the
/// brick's own weight spread over its length L on supports s apart) and
/// Z = b h² / 6.
fn analytic_load(tensile: f32) -> f32 {
    let (l, h, b) = (BRICK_SIZE.x, BRICK_SIZE.y, BRICK_SIZE.z);
    let m = BRICK.density * l * h * b;
    let z = b * h * h / 6.0;
    let self_moment = m * 9.81 * (SPAN / 4.0 - l / 8.0);
    (tensile * z - self_moment) * 4.0 / SPAN
}

#[test]
fn a_brick_in_three_point_bending_splits_at_mid_span_at_its_analytic_load() {
    // A weak brick (0.05 MPa) so that the load is a ball of a few kg.
    let tensile = 5e4;
    let load = analytic_load(tensile);
    // The smallest load, in steps of 2% of the analytic one, under which
    // the brick splits within a second.
    let mut first = None;
    for k in 0..=15 {
        let factor = 0.8 + 0.02 * k as f32;
        let splits = three_point(tensile, factor * load, 60);
        if let Some(&FractureEvent::Split { axis, offset, ratio, .. }) = splits.first() {
            eprintln!(
                "analytic load {load:.1} N; split at {factor:.2} x: axis {axis}, offset {offset}, ratio {ratio:.3}"
            );
            assert_eq!(axis, 0, "the cut is across the brick's length");
            assert_eq!(offset, 0.0, "at mid-span");
            first = Some(factor);
            break;
        }
    }
    // Measured: 1.04 x (the supports, 4 mm wide, carry the brick at their
    // inner edges, 4 mm inside the span the formula takes).
    let factor = first.expect("no split up to 1.1 x the analytic load");
    assert!((0.9..=1.1).contains(&factor), "split at {factor} x the analytic load");
}

/// The seed's 10 × 10 wall on the ground, its bricks breakable with the
/// given strengths (Pa); sleep as `sleep` says; `threads` threads.
fn breakable_wall(tensile: f32, shear: f32, sleep: bool, threads: usize) -> (World, Vec<BodyHandle>) {
    let mut w = world_with(|s| {
        s.sleep_enabled = sleep;
        s.threads = threads;
    });
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let spec = WallSpec { material: BRICK.with_strength(tensile, shear), ..WallSpec::default() };
    let bricks = add_wall(&mut w, &spec).unwrap();
    (w, bricks)
}

/// What the seed's ball did to a breakable wall in `seconds`.
struct Hit {
    /// Every split: (step, parent, pieces).
    splits: Vec<(usize, BodyHandle, [BodyHandle; 2])>,
    /// The most bodies the splits added in one step.
    most_new: usize,
    /// The smallest piece's smallest full edge, m.
    smallest: f32,
    /// The parents' distances from the impact point (the wall's face
    /// centre), m, at the split.
    distances: Vec<f32>,
}

fn hit(tensile: f32, shear: f32, threads: usize, seconds: f32) -> Hit {
    let (mut w, _) = breakable_wall(tensile, shear, true, threads);
    // brick_wall's ball: 0.15 m steel at 15 m/s at the face's centre.
    add_ball(&mut w, 0.075, Vec3::new(0.0, 0.325, 2.0), Vec3::new(0.0, 0.0, -15.0), STEEL, false).unwrap();
    let impact = Vec3::new(0.0, 0.325, 0.0);
    let mut out = Hit { splits: Vec::new(), most_new: 0, smallest: f32::INFINITY, distances: Vec::new() };
    let dt = 1.0 / 60.0;
    let mut positions = std::collections::HashMap::new();
    for step in 0..(seconds / dt).round() as usize {
        for (h, b) in w.bodies() {
            positions.insert(h, b.position());
        }
        w.step(dt).unwrap();
        out.most_new = out.most_new.max(2 * w.fracture_events().len());
        for e in w.fracture_events() {
            let FractureEvent::Split { parent, pieces, .. } = *e;
            out.splits.push((step, parent, pieces));
            out.distances.push((positions[&parent] - impact).length());
            for p in pieces {
                let c = w.body_colliders(p)[0];
                if let crumble::Shape::Cuboid(cb) = w.collider(c).unwrap().shape() {
                    out.smallest = out.smallest.min(2.0 * cb.half_extents().min_element());
                }
            }
        }
    }
    out
}

#[test]
fn the_seed_ball_splits_a_few_bricks_where_it_hits_the_same_on_any_thread_count() {
    let hits: Vec<Hit> = [1, 2, 4].into_iter().map(|threads| hit(TENSILE, SHEAR, threads, 1.0)).collect();
    let h = &hits[0];
    let wall_bricks: std::collections::BTreeSet<u32> =
        h.splits.iter().map(|s| s.1.index()).filter(|&i| (1..=100).contains(&i)).collect();
    eprintln!(
        "{} splits of {} bricks {wall_bricks:?} in steps {:?}; most new bodies in a step {}; smallest piece {:.4} m; \
         parents {:?} m from the impact",
        h.splits.len(),
        wall_bricks.len(),
        h.splits.iter().map(|s| s.0).collect::<Vec<_>>(),
        h.most_new,
        h.smallest,
        h.distances
    );
    // Measured: bricks 16, 26 and 47 (the two the ball meets first and
    // one beside them), one split each in steps 7, 7 and 8, 4 new bodies
    // at most in a step, the smallest piece 25.6 mm, every parent within
    // 0.23 m of the impact. The issue asks for 1 to 6 bricks near the impact:
    // "near" here is within two brick lengths (0.43 m).
    assert!((1..=6).contains(&wall_bricks.len()), "{} bricks split", wall_bricks.len());
    assert!(h.distances.iter().all(|&d| d < 2.0 * BRICK_SIZE.x), "a split far from the impact: {:?}", h.distances);
    assert!(h.smallest >= WorldSettings::default().min_piece, "a piece of {} m", h.smallest);
    assert!(h.most_new <= 64, "{} new bodies in one step", h.most_new);
    for (threads, other) in [2, 4].iter().zip(&hits[1..]) {
        assert_eq!(other.splits, h.splits, "{threads} threads split other bodies, or at other steps");
    }
}

#[test]
fn a_wall_of_breakable_bricks_at_rest_never_splits() {
    let (mut w, bricks) = breakable_wall(TENSILE, SHEAR, false, 1);
    let start: Vec<Vec3> = bricks.iter().map(|&b| w.body(b).unwrap().position()).collect();
    let mut splits = 0;
    for _ in 0..3600 {
        w.step(1.0 / 60.0).unwrap();
        splits += w.fracture_events().len();
    }
    let drift =
        bricks.iter().zip(&start).map(|(&b, &p)| (w.body(b).unwrap().position() - p).length()).fold(0.0, f32::max);
    eprintln!("60 s at rest: {splits} splits, drift {:.4} mm", drift * 1e3);
    // Gravity and the bricks above load the bottom row's to a few
    // kilopascals, a thousandth of the 1 MPa strength: nothing splits.
    assert_eq!(splits, 0);
}

#[test]
fn bad_strengths_and_pieces_are_refused_by_name() {
    let mut w = World::default();
    let b = w.insert_body(BodyBuilder::dynamic()).unwrap();
    for (t, s) in [(-1.0, 1e6), (f32::NAN, 1e6), (1e6, 0.0), (1e6, f32::INFINITY)] {
        let e =
            w.insert_collider(ColliderBuilder::cuboid(0.1, 0.1, 0.1).unwrap().material(BRICK.with_strength(t, s)), b);
        match e {
            Err(WorldError::Material(MaterialError::Strength(_))) => {}
            other => panic!("strengths {t}, {s}: {other:?}"),
        }
    }
    let e = World::new(WorldSettings { max_new_pieces: 5000, ..WorldSettings::default() });
    assert!(matches!(e, Err(WorldError::InvalidSetting { name: "max_new_pieces", .. })), "{:?}", e.err());
    for piece in [0.0, -0.01, f32::NAN] {
        let e = World::new(WorldSettings { min_piece: piece, ..WorldSettings::default() });
        assert!(
            matches!(e, Err(WorldError::InvalidSetting { name: "min_piece", .. })),
            "min_piece {piece}: {:?}",
            e.err()
        );
    }
}

/// A weak brick welded to the world at the middle of its left end face, a
/// cantilever under its own weight: the section a quarter of the way out
/// carries the rest's weight, M = ¾ m g · (3/8) L, σ = M / Z = 23.5 kPa at
/// a tensile strength of 20 kPa (the middle section carries 10.4 kPa), so
/// it breaks there in its first step. The weld passes to the piece that
/// holds its anchor, which stays; the rest falls.
#[test]
fn a_welded_brick_breaks_beside_its_weld_and_the_weld_passes_to_the_piece_that_holds_it() {
    let mut w = world_with(|s| s.sleep_enabled = false);
    let half = BRICK_SIZE / 2.0;
    let centre = Vec3::new(0.0, 1.0, 0.0);
    let brick = w.insert_body(BodyBuilder::dynamic().position(centre)).unwrap();
    w.insert_collider(
        ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap().material(BRICK.with_strength(2.0e4, 1.0e6)),
        brick,
    )
    .unwrap();
    let anchor = centre - Vec3::new(half.x, 0.0, 0.0);
    w.insert_joint(crumble::JointBuilder::fixed(crumble::JointBody::World, brick).anchor(anchor)).unwrap();
    let mut splits = Vec::new();
    for _ in 0..60 {
        w.step(1.0 / 60.0).unwrap();
        splits.extend_from_slice(w.fracture_events());
    }
    eprintln!("{splits:?}");
    // Measured: one split, in the first step, on the quarter plane at
    // x = −L/4 (ratio 1.18, the analytic 23.5 / 20).
    let Some(&FractureEvent::Split { pieces, axis, offset, ratio, .. }) = splits.first() else {
        panic!("the cantilever did not break");
    };
    assert_eq!((axis, offset), (0, -half.x / 2.0), "the cut is a quarter of the way out");
    assert!((ratio - 23.5 / 20.0).abs() < 0.05, "stress over strength {ratio}, analytic 1.175");
    let joints: Vec<_> = w.joints().map(|(_, j)| j.bodies()).collect();
    assert_eq!(joints, vec![(None, Some(pieces[0]))], "the weld holds the inner piece");
    let inner = w.body(pieces[0]).unwrap().position();
    let at = centre - Vec3::new(0.75 * half.x, 0.0, 0.0);
    assert!((inner - at).length() < 1e-3, "the welded piece moved to {inner} from {at}");
    let outer = w.body(pieces[1]).unwrap().position();
    assert!(outer.y < centre.y - 0.5, "the outer piece fell to {outer}");
}

/// A brick on two supports that has fallen asleep is struck by a ball
/// dropped from 0.5 m: the contact that wakes it comes in the impact step,
/// and that step's blow, not the ball's weight afterwards, must be judged.
/// The brick's strength is five times what the ball's weight needs and a
/// fifth of what the blow brings (3.1 m/s stopped in a step: about 19
/// times the weight).
#[test]
fn a_sleeping_brick_woken_by_a_blow_is_judged_on_that_blow() {
    let mut w = world_with(|_| {});
    let h = BRICK_SIZE.y;
    let support = Vec3::new(0.004, 0.1, 0.2);
    static_box(&mut w, support, Vec3::new(-SPAN / 2.0, 0.05, 0.0));
    static_box(&mut w, support, Vec3::new(SPAN / 2.0, 0.05, 0.0));
    let brick = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 0.1 + h / 2.0, 0.0))).unwrap();
    let half = BRICK_SIZE / 2.0;
    let mass = 2.0;
    let tensile = tensile_for_load(5.0 * mass * 9.81);
    w.insert_collider(
        ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap().material(BRICK.with_strength(tensile, 1e9)),
        brick,
    )
    .unwrap();
    for _ in 0..120 {
        w.step(1.0 / 60.0).unwrap();
    }
    assert!(w.body(brick).unwrap().is_sleeping(), "the brick fell asleep on its supports");
    let radius = (mass / (STEEL.density * 4.0 / 3.0 * std::f32::consts::PI)).cbrt();
    add_ball(&mut w, radius, Vec3::new(0.0, 0.1 + h + radius + 0.5, 0.0), Vec3::ZERO, STEEL, false).unwrap();
    let mut split_at = None;
    for step in 0..60 {
        w.step(1.0 / 60.0).unwrap();
        if split_at.is_none() && !w.fracture_events().is_empty() {
            split_at = Some(step);
        }
    }
    // Measured: it splits in the step the ball lands (the 19th).
    let step = split_at.expect("the dropped ball never split the sleeping brick");
    eprintln!("split in step {step}");
    assert!((17..=20).contains(&step), "split in step {step}, the ball lands in about the 19th");
}

/// The tensile strength at which a load `w` (N) at mid-span of a brick on
/// the two supports of `three_point` brings its bottom edge to failure.
fn tensile_for_load(w: f32) -> f32 {
    let (l, h, b) = (BRICK_SIZE.x, BRICK_SIZE.y, BRICK_SIZE.z);
    let m = BRICK.density * l * h * b;
    let z = b * h * h / 6.0;
    (w * SPAN / 4.0 + m * 9.81 * (SPAN / 4.0 - l / 8.0)) / z
}

/// A force and a torque applied to a brick in free fall (no gravity) push
/// and turn every part of it alike, as gravity would, and stress no
/// section: a weak brick (10 kPa) pushed by 400 N and turned by 2 N·m
/// stays whole, where reading them as loads carried across the brick
/// stresses its middle section to about 30 kPa and 14 kPa. (The torque
/// acts for five steps only: the spin it leaves, 14 rad/s, pulls the
/// brick apart by about 2 kPa; a second of it would spin the brick to
/// 170 rad/s and tear it apart, rightly.)
#[test]
fn a_force_and_a_torque_applied_to_a_brick_strain_nothing() {
    let mut w = world_with(|s| s.gravity = Vec3::ZERO);
    let brick = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 1.0, 0.0))).unwrap();
    let half = BRICK_SIZE / 2.0;
    w.insert_collider(
        ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap().material(BRICK.with_strength(1e4, 3e4)),
        brick,
    )
    .unwrap();
    let mut splits = 0;
    for step in 0..30 {
        w.apply_force(brick, Vec3::new(-400.0, 0.0, 0.0)).unwrap();
        if step < 5 {
            w.apply_torque(brick, Vec3::new(0.0, 0.0, 2.0)).unwrap();
        }
        w.step(1.0 / 60.0).unwrap();
        splits += w.fracture_events().len();
    }
    assert_eq!(splits, 0, "an applied force or torque split the brick");
}
