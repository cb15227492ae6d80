//! Joints (issue 47): chains that do not stretch under heavy ends, hinges
//! that swing with the analytic period and pump no energy, limits and
//! welds that hold, joints that break at their force at any step, and the
//! same bits on any thread count. Every limit is written beside the
//! measured value and where the expected number comes from. dt 1/60, 4
//! substeps and the default settings unless a test says otherwise.

use crumble::scenes::{add_ball, add_box, add_ground, add_wall, add_wrecking_ball, WallSpec, WreckingBallSpec, STEEL};
use crumble::{
    BodyHandle, JointBody, JointBuilder, JointEvent, JointHandle, Material, Quat, Vec3, World, WorldError,
    WorldSettings,
};

const DT: f32 = 1.0 / 60.0;
const G: f64 = 9.81;

/// Kinetic plus potential energy (above `y = 0`) of every body, J, in
/// `f64`.
fn energy(w: &World) -> f64 {
    w.bodies()
        .map(|(_, b)| {
            let m = b.mass() as f64;
            let (v, om) = (b.linear_velocity(), b.angular_velocity());
            0.5 * m * v.length_squared() as f64
                + 0.5 * om.dot(b.world_inertia() * om) as f64
                + m * G * b.center_of_mass().y as f64
        })
        .sum()
}

/// The largest separation of any joint now, metres.
fn max_separation(w: &World) -> f32 {
    w.joints().map(|(_, j)| j.separation()).fold(0.0, f32::max)
}

fn world_with(f: impl FnOnce(&mut WorldSettings)) -> World {
    let mut s = WorldSettings::default();
    f(&mut s);
    World::new(s).expect("settings")
}

/// A wrecking ball hanging straight and left alone stays where it hangs.
/// The joints are solved exactly along the chain (solver/joints.rs), so
/// nothing stretches: measured, the anchor-to-ball distance stays at its
/// 2.55 m to the last bit of `f32` for a minute and no joint opens at all.
/// Limits from the issue: 1 mm and 0.5 mm. With sleep on it sleeps after
/// `time_to_sleep` (measured 0.5 s, 30 steps; the issue asks for 3 s).
#[test]
fn the_wrecking_ball_hangs_still_for_a_minute() {
    let spec = WreckingBallSpec { release_angle: 0.0, ..WreckingBallSpec::default() };
    for sleep in [false, true] {
        let mut world = world_with(|s| s.sleep_enabled = sleep);
        let wb = add_wrecking_ball(&mut world, &spec).unwrap();
        let (mut worst_length, mut worst_sep, mut asleep_at) = (0.0f32, 0.0f32, None);
        for step in 0..3600 {
            world.step(DT).unwrap();
            let ball = world.body(wb.ball).unwrap();
            let length = (ball.center_of_mass() - spec.anchor).length();
            worst_length = worst_length.max((length - spec.length()).abs());
            worst_sep = worst_sep.max(max_separation(&world));
            if asleep_at.is_none() && ball.is_sleeping() {
                asleep_at = Some(step + 1);
            }
        }
        eprintln!(
            "hanging, sleep {sleep}: length off by {worst_length} m, joints open {worst_sep} m, asleep {asleep_at:?}"
        );
        assert!(worst_length < 1e-3, "sleep {sleep}: the ball moved {worst_length} m from 2.55 m");
        assert!(worst_sep < 0.5e-3, "sleep {sleep}: a joint opened {worst_sep} m");
        if sleep {
            let at = asleep_at.expect("the chain falls asleep");
            assert!(at <= 180, "asleep after {at} steps (limit 3 s)");
            assert!(wb.links.iter().all(|&l| world.body(l).unwrap().is_sleeping()), "the chain sleeps as one");
        } else {
            assert_eq!(asleep_at, None);
        }
    }
}

/// A rod hinged at its top, 5° from the vertical: a compound pendulum of
/// period `2π √(I / (m g d))`, `I = m (l² + w²)/12 + m d²` about the
/// pivot (`d = l/2`): 1.6400 s for a 1 m × 0.1 m rod; measured 1.6410 s
/// (0.06 %) as the mean of the periods between downward crossings of the
/// vertical over 30 s. Limit: 0.5 % (the issue).
///
/// Energy: the joints must not pump it. The swing's energy, measured at
/// each crossing of the vertical (the same phase of each period, so that
/// the integrator's oscillation within a period, about `h ω` of it, does
/// not count), never rises above its first value by more than 0.1 % (the
/// issue's limit); measured: it only falls, by 0.4 % in 30 s.
#[test]
fn a_hinged_rod_swings_with_the_compound_pendulum_period() {
    let mut world = World::default();
    let (l, w) = (1.0f32, 0.1f32);
    let amplitude = 5f32.to_radians();
    let pivot = Vec3::new(0.0, 2.0, 0.0);
    let q = Quat::from_rotation_z(amplitude);
    let rod = add_box(&mut world, Vec3::new(w, l, w), pivot + q * Vec3::new(0.0, -l / 2.0, 0.0), q, STEEL, false);
    let rod = rod.unwrap();
    let hinge = world.insert_joint(JointBuilder::revolute(JointBody::World, rod, Vec3::Z).anchor(pivot)).unwrap();
    let mass = world.body(rod).unwrap().mass() as f64;
    let rest = mass * G * (pivot.y - l / 2.0) as f64;
    let (mut crossings, mut swing) = (Vec::new(), Vec::new());
    let mut last_x = world.body(rod).unwrap().center_of_mass().x;
    for step in 0..1800 {
        world.step(DT).unwrap();
        let x = world.body(rod).unwrap().center_of_mass().x;
        if last_x > 0.0 && x <= 0.0 {
            crossings.push((step as f32 + last_x / (last_x - x)) * DT);
            swing.push(energy(&world) - rest);
        }
        last_x = x;
        assert!(world.joint(hinge).unwrap().separation() < 1e-5, "the hinge holds");
    }
    let i = mass as f32 * (l * l + w * w) / 12.0 + mass as f32 * (l / 2.0).powi(2);
    let analytic = 2.0 * std::f32::consts::PI * (i / (mass as f32 * 9.81 * l / 2.0)).sqrt();
    let measured = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f32;
    assert!((measured / analytic - 1.0).abs() < 0.005, "period {measured} s, analytic {analytic} s");
    let first = swing[0];
    let (lo, hi) = swing.iter().fold((f64::MAX, f64::MIN), |(a, b), &e| (a.min(e), b.max(e)));
    eprintln!(
        "pendulum: period {measured} s (analytic {analytic}), swing energy {} to {} of the first",
        lo / first,
        hi / first
    );
    for (k, e) in swing.iter().enumerate() {
        assert!(*e <= first * 1.001, "period {k}: swing energy {e} J from {first} J");
    }
}

/// The wrecking ball released from 60°: the chain whips as it swings, and
/// its joints hold. Measured over 10 s: no joint opened more than 0.005 mm
/// (limit 2 mm, the issue's); the energy (kinetic plus potential) never
/// rose above its start (the solver's projections only take energy: 6 %
/// of the 1.45 kJ in 10 s); the ball passes the bottom at 5.07 m/s
/// (`√(2 g L (1 − cos 60°))` = 5.0 m/s for a point on a 2.55 m string;
/// the chain's mass falling with it adds speed; limit 3 %).
#[test]
fn the_chain_released_from_60_degrees_holds_and_gains_no_energy() {
    let spec = WreckingBallSpec::default();
    let mut world = World::default();
    let wb = add_wrecking_ball(&mut world, &spec).unwrap();
    let start = energy(&world);
    let (mut worst_sep, mut top_speed, mut most) = (0.0f32, 0.0f32, f64::NEG_INFINITY);
    for _ in 0..600 {
        world.step(DT).unwrap();
        worst_sep = worst_sep.max(max_separation(&world));
        top_speed = top_speed.max(world.body(wb.ball).unwrap().linear_velocity().length());
        most = most.max(energy(&world) - start);
    }
    eprintln!("worst separation {worst_sep} m, top speed {top_speed} m/s, most energy above start {most} J");
    assert!(worst_sep < 2e-3, "a joint opened {worst_sep} m");
    assert!(most <= 0.0, "the energy rose {most} J above its start {start} J");
    let analytic = (2.0 * 9.81 * spec.length() * (1.0 - spec.release_angle.cos())).sqrt();
    assert!((top_speed / analytic - 1.0).abs() < 0.03, "ball at {top_speed} m/s, pendulum {analytic} m/s");
}

/// The wrecking ball scene built from the generators: the seed's 10 × 10
/// wall on the ground and the ball hung so that it meets the wall's face
/// at the bottom of its swing, at the wall's middle height.
fn wrecking_ball_world(threads: usize) -> (World, Vec<BodyHandle>, BodyHandle) {
    let mut world = world_with(|s| s.threads = threads);
    add_ground(&mut world, 0.0, crumble::scenes::BRICK).unwrap();
    let wall = WallSpec::default();
    let bricks = add_wall(&mut world, &wall).unwrap();
    let mid = 0.5 * wall.rows as f32 * wall.brick.y;
    let spec = WreckingBallSpec::default();
    let face = -0.5 * wall.brick.z;
    let anchor = Vec3::new(0.0, mid + spec.length(), face - spec.ball_radius);
    let wb = add_wrecking_ball(&mut world, &WreckingBallSpec { anchor, ..spec }).unwrap();
    (world, bricks, wb.ball)
}

/// The swing into the wall: the ball breaks through and the chain holds.
/// Measured over 3 s: 82 bricks moved more than 5 cm (the issue asks at
/// least 10), no joint opened more than 0.7 mm (limit 5 mm), every pose
/// finite, and the same bits on 1, 2 and 4 threads.
#[test]
fn the_wrecking_ball_breaks_the_wall_with_the_same_bits_on_any_thread_count() {
    let mut runs = Vec::new();
    for threads in [1, 2, 4] {
        let (mut world, bricks, _) = wrecking_ball_world(threads);
        let starts: Vec<Vec3> = bricks.iter().map(|&b| world.body(b).unwrap().position()).collect();
        let mut worst_sep = 0.0f32;
        for _ in 0..180 {
            world.step(DT).unwrap();
            worst_sep = worst_sep.max(max_separation(&world));
        }
        let moved = bricks
            .iter()
            .zip(&starts)
            .filter(|&(&b, &p)| (world.body(b).unwrap().position() - p).length() > 0.05)
            .count();
        eprintln!("threads {threads}: {moved} bricks moved, worst separation {worst_sep} m");
        assert!(moved >= 10, "{moved} bricks moved more than 5 cm");
        assert!(worst_sep < 5e-3, "a joint opened {worst_sep} m");
        let poses: Vec<[u32; 7]> = world
            .bodies()
            .map(|(_, b)| {
                let (p, q) = (b.position(), b.rotation());
                assert!(p.is_finite() && q.is_finite(), "a pose went non-finite");
                [p.x, p.y, p.z, q.x, q.y, q.z, q.w].map(f32::to_bits)
            })
            .collect();
        runs.push(poses);
    }
    assert!(runs[1] == runs[0], "2 threads gave other bits than 1");
    assert!(runs[2] == runs[0], "4 threads gave other bits than 1");
}

/// Rapier's high-mass-ratio chain (`debug_chain_high_mass_ratio3`): 16
/// balls joined centre to centre, the last 1000 times heavier than a
/// link, released horizontally from a fixed point. Its joints' total
/// opening is the chain's stretch: measured at most 0.1 mm of its 4 m
/// (0.0024 %; Rapier needs 16 extra passes for it). Limit: 1 % of the
/// length (the issue's).
#[test]
fn a_chain_under_a_body_1000_times_heavier_stretches_under_one_percent() {
    let mut world = World::default();
    let (n, gap, r) = (16, 0.25f32, 0.05f32);
    let light = Material { density: 1000.0, ..STEEL };
    let heavy = Material { density: 1.0e6, ..STEEL };
    let anchor = Vec3::new(0.0, 5.0, 0.0);
    let mut previous = JointBody::World;
    for i in 0..n {
        let p = anchor + Vec3::X * (gap * (i + 1) as f32);
        let m = if i + 1 == n { heavy } else { light };
        let b = add_ball(&mut world, r, p, Vec3::ZERO, m, false).unwrap();
        world.insert_joint(JointBuilder::spherical(previous, b).anchor(p - Vec3::X * gap)).unwrap();
        previous = JointBody::Body(b);
    }
    let length = gap * n as f32;
    let mut worst = 0.0f32;
    for _ in 0..600 {
        world.step(DT).unwrap();
        worst = worst.max(world.joints().map(|(_, j)| j.separation()).sum());
    }
    eprintln!("chain stretch {worst} m of {length} m");
    assert!(worst < 0.01 * length, "the chain stretched {worst} m of {length} m");
}

/// Rapier's joint stability test (`joint_stability.rs`): a 32 × 32 net of
/// balls joined to their neighbours by spherical joints (1,984 joints, 961
/// of them closing loops), its first row held by the world, falling from
/// horizontal for 4,000 steps. Rapier's bounds: every speed under 100 m/s
/// and every position finite. Measured: the fastest ball at 29.4 m/s, as
/// the free corner whips round (`√(2 g 7.75)` = 12.3 m/s for the 7.75 m
/// net falling as a rigid sheet; a flexible one's corner goes faster), and
/// the largest joint opening at the end 1.36 cm. A net is all loops: its
/// joints are solved one by one by Gauss–Seidel, warm started, as Rapier
/// and Box2D solve theirs, so the loops hold to centimetres, not exactly.
#[test]
fn a_net_of_spherical_joints_stays_bounded_for_4000_steps() {
    let mut world = World::default();
    let (n, gap) = (32usize, 0.25f32);
    let at = |i: usize, k: usize| Vec3::new(gap * i as f32, 10.0, gap * k as f32);
    let mut grid: Vec<BodyHandle> = Vec::new();
    for i in 0..n {
        for k in 0..n {
            grid.push(add_ball(&mut world, 0.05, at(i, k), Vec3::ZERO, STEEL, false).unwrap());
        }
    }
    for i in 0..n {
        for k in 0..n {
            let b = grid[i * n + k];
            let up = if i == 0 { JointBody::World } else { JointBody::Body(grid[(i - 1) * n + k]) };
            world.insert_joint(JointBuilder::spherical(up, b).anchor(at(i, k))).unwrap();
            if k > 0 {
                world.insert_joint(JointBuilder::spherical(grid[i * n + k - 1], b).anchor(at(i, k))).unwrap();
            }
        }
    }
    let mut fastest = 0.0f32;
    for step in 0..4000 {
        world.step(DT).unwrap();
        for (_, b) in world.bodies() {
            assert!(b.position().is_finite(), "step {step}: a position went non-finite");
            fastest = fastest.max(b.linear_velocity().length());
        }
        assert!(fastest < 100.0, "step {step}: a ball at {fastest} m/s");
    }
    let opening = max_separation(&world);
    eprintln!("net: fastest ball {fastest} m/s, largest joint opening {opening} m");
    // About twice the opening measured, as the other limits here.
    assert!(opening < 0.03, "the net's joints opened {opening} m");
    assert!(world.faulted_bodies().is_empty(), "bodies faulted");
}

/// A door hinged to the world about the vertical, pushed hard each way
/// against limits of ±45°: a torque of 2,000 N·m on a 40 kg door (enough
/// to turn it a full revolution in 0.2 s). Measured: it rests on each
/// limit to within 0.00001°. Limit: 0.5° (the issue's).
#[test]
fn a_hinged_door_pushed_hard_stays_within_its_limits() {
    let limit = 45f32.to_radians();
    for sign in [1.0f32, -1.0] {
        let mut world = world_with(|s| s.gravity = Vec3::ZERO);
        let door =
            add_box(&mut world, Vec3::new(1.0, 2.0, 0.05), Vec3::new(0.5, 1.0, 0.0), Quat::IDENTITY, STEEL, false);
        let door = door.unwrap();
        let hinge = JointBuilder::revolute(JointBody::World, door, Vec3::Y).anchor(Vec3::ZERO).limits(-limit, limit);
        world.insert_joint(hinge).unwrap();
        let (mut worst, mut angle) = (f32::NEG_INFINITY, 0.0f32);
        for _ in 0..240 {
            world.apply_torque(door, Vec3::Y * (2000.0 * sign)).unwrap();
            world.step(DT).unwrap();
            // The door's angle about y from its direction along +x.
            let x = world.body(door).unwrap().rotation() * Vec3::X;
            angle = (-x.z).atan2(x.x);
            worst = worst.max(angle.abs() - limit);
        }
        eprintln!("door {sign}: {}° past the limit at most, ends at {}°", worst.to_degrees(), angle.to_degrees());
        assert!(worst < 0.5f32.to_radians(), "the door went {}° past its limit", worst.to_degrees());
        let off = (angle - sign * limit).abs();
        assert!(off < 0.5f32.to_radians(), "the door rests {}° from its limit", off.to_degrees());
    }
}

/// Two boxes welded side by side, the pair held by one end to the world
/// by a weld and loaded by gravity and a 500 N push at its free end: the
/// welds hold the relative pose. Measured: the boxes turn 2e-9° apart and
/// 3e-9° from the world (the welds are one tree, solved exactly). Limit:
/// 0.1° (the issue's).
#[test]
fn welded_boxes_hold_their_relative_pose_under_load() {
    let mut world = World::default();
    let size = Vec3::new(0.5, 0.2, 0.2);
    let a = add_box(&mut world, size, Vec3::new(0.25, 2.0, 0.0), Quat::IDENTITY, STEEL, false).unwrap();
    let b = add_box(&mut world, size, Vec3::new(0.75, 2.0, 0.0), Quat::IDENTITY, STEEL, false).unwrap();
    world.insert_joint(JointBuilder::fixed(JointBody::World, a).anchor(Vec3::new(0.0, 2.0, 0.0))).unwrap();
    world.insert_joint(JointBuilder::fixed(a, b).anchor(Vec3::new(0.5, 2.0, 0.0))).unwrap();
    let (mut worst, mut sag) = (0.0f32, 0.0f32);
    for _ in 0..300 {
        world.apply_force_at_point(b, Vec3::new(0.0, 0.0, 500.0), Vec3::new(1.0, 2.1, 0.0)).unwrap();
        world.step(DT).unwrap();
        let (qa, qb) = (world.body(a).unwrap().rotation(), world.body(b).unwrap().rotation());
        // Twice the vector part: the angle, without `acos`'s blind spot
        // below 1e-3 rad in `f32`.
        let angle = |q: Quat| 2.0 * q.xyz().length();
        worst = worst.max(angle(qa.inverse() * qb));
        sag = sag.max(angle(qa));
    }
    eprintln!("weld: {}° between the boxes, {}° from the world at most", worst.to_degrees(), sag.to_degrees());
    assert!(worst < 0.1f32.to_radians(), "the welded boxes turned {}° apart", worst.to_degrees());
    assert!(sag < 0.1f32.to_radians(), "the weld to the world gave {}°", sag.to_degrees());
}

/// A body of mass m hanging at rest from a joint that breaks above F:
/// it holds `m g = 0.95 F` and breaks under `m g = 1.05 F`, at 1, 2, 4
/// and 8 substeps and steps of 1/30 to 1/240 s (the force is the step's
/// summed impulse over the step, whatever the substeps). Its event names
/// the joint and gives the force: measured within 0.00002 % of `m g` (one
/// `f32` rounding). Limit: 5 % (the issue's).
#[test]
fn a_joint_breaks_above_its_force_and_holds_below_it_at_any_step() {
    for substeps in [1, 2, 4, 8] {
        for dt in [1.0 / 30.0, 1.0 / 60.0, 1.0 / 120.0, 1.0 / 240.0] {
            for (load, breaks) in [(0.95f32, false), (1.05, true)] {
                let mut world = world_with(|s| s.substeps = substeps);
                let anchor = Vec3::new(0.0, 2.0, 0.0);
                let ball = add_ball(&mut world, 0.1, anchor - Vec3::Y * 0.1, Vec3::ZERO, STEEL, false).unwrap();
                let weight = world.body(ball).unwrap().mass() * 9.81;
                let limit = weight / load;
                let j = JointBuilder::spherical(JointBody::World, ball).anchor(anchor).break_force(limit);
                let j = world.insert_joint(j).unwrap();
                let mut broke = None;
                for _ in 0..((0.5 / dt) as usize) {
                    world.step(dt).unwrap();
                    if let Some(&JointEvent::Broken { joint, force, .. }) = world.joint_events().first() {
                        broke = Some((joint, force));
                        break;
                    }
                }
                let what = format!("{substeps} substeps, dt {dt}, load {load} F");
                match (breaks, broke) {
                    (false, None) => assert!(world.joint(j).is_some(), "{what}: the joint is gone"),
                    (true, Some((joint, force))) => {
                        assert_eq!(joint, j, "{what}: the event names another joint");
                        assert!(world.joint(j).is_none(), "{what}: a broken joint stays");
                        assert!((force / weight - 1.0).abs() < 0.05, "{what}: force {force} N, weight {weight} N");
                    }
                    (false, Some((_, f))) => panic!("{what}: broke at {f} N under a limit of {limit} N"),
                    (true, None) => panic!("{what}: held {weight} N over a limit of {limit} N"),
                }
            }
        }
    }
}

/// FNV-1a over the bits of every body's position and rotation, in body
/// order (as Box2D's determinism test hashes its bodies).
fn pose_hash(w: &World) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for (_, b) in w.bodies() {
        let (p, q) = (b.position(), b.rotation());
        for x in [p.x, p.y, p.z, q.x, q.y, q.z, q.w] {
            for byte in x.to_bits().to_le_bytes() {
                h = (h ^ byte as u64).wrapping_mul(0x0100_0000_01b3);
            }
        }
    }
    h
}

/// Falling hinges (after Box2D's `FallingHinges` determinism scene): four
/// chains of 20 boxes hinged end to end with limits of ±30°, each tilted
/// and dropped onto the ground, the whole run until every body sleeps.
/// Returns the step at which all sleep and the hash of the poses then.
fn falling_hinges(threads: usize) -> (usize, u64) {
    let mut world = world_with(|s| s.threads = threads);
    add_ground(&mut world, 0.0, crumble::scenes::BRICK).unwrap();
    let size = Vec3::new(0.25, 0.1, 0.1);
    let limit = 30f32.to_radians();
    for chain in 0..4 {
        let tilt = Quat::from_rotation_z(0.1 * (chain as f32 + 1.0));
        let base = Vec3::new(0.0, 1.0 + 0.5 * chain as f32, 0.4 * chain as f32);
        let mut previous: Option<BodyHandle> = None;
        for k in 0..20 {
            let p = base + tilt * Vec3::new(size.x * (k as f32 + 0.5), 0.0, 0.0);
            let b = add_box(&mut world, size, p, tilt, STEEL, false).unwrap();
            if let Some(a) = previous {
                let hinge = JointBuilder::revolute(a, b, tilt * Vec3::Z)
                    .anchor(base + tilt * Vec3::new(size.x * k as f32, 0.0, 0.0))
                    .limits(-limit, limit);
                world.insert_joint(hinge).unwrap();
            }
            previous = Some(b);
        }
    }
    for step in 1..=2000 {
        world.step(DT).unwrap();
        if world.bodies().all(|(_, b)| b.is_sleeping() || b.mass() == 0.0) {
            return (step, pose_hash(&world));
        }
    }
    panic!("the hinges never all slept");
}

/// The determinism hash: the falling hinges fall asleep at the same step
/// with the same poses on 1, 2 and 4 threads, and at the step and hash
/// pinned here. Changing the physics on purpose changes these on purpose.
#[test]
fn falling_hinges_give_the_pinned_hash_on_any_thread_count() {
    let one = falling_hinges(1);
    eprintln!("falling hinges: asleep at step {}, hash {:#018x}", one.0, one.1);
    assert_eq!(falling_hinges(2), one, "2 threads");
    assert_eq!(falling_hinges(4), one, "4 threads");
    assert_eq!(one, (103, 0x3608_0f55_152f_b714), "the pinned step and hash");
}

/// Regression: a tree whose first joint holds two moving bodies (a chain
/// with no anchor) gave its bodies the tree's place among all nodes as
/// their parent instead of the root's place in the tree, and the factor
/// read past the tree (an index out of bounds) as soon as a world had two
/// such trees.
#[test]
fn two_free_chains_build_their_own_trees() {
    let mut world = world_with(|s| s.gravity = Vec3::new(0.0, -9.81, 0.0));
    for z in [0.0f32, 1.0] {
        let a = add_ball(&mut world, 0.1, Vec3::new(0.0, 2.0, z), Vec3::ZERO, STEEL, false).unwrap();
        let b = add_ball(&mut world, 0.1, Vec3::new(0.5, 2.0, z), Vec3::ZERO, STEEL, false).unwrap();
        world.insert_joint(JointBuilder::distance(a, b, 0.5)).unwrap();
        let c = add_ball(&mut world, 0.1, Vec3::new(1.0, 2.0, z), Vec3::ZERO, STEEL, false).unwrap();
        world.insert_joint(JointBuilder::spherical(b, c).anchor(Vec3::new(0.75, 2.0, z))).unwrap();
    }
    let first = world.bodies().next().unwrap().0;
    world.set_linear_velocity(first, Vec3::new(0.0, 0.0, 3.0)).unwrap();
    for _ in 0..30 {
        world.step(DT).unwrap();
    }
    assert!(max_separation(&world) < 1e-4, "joints opened {} m", max_separation(&world));
}

/// What `insert_joint` refuses, each with nothing changed.
#[test]
fn bad_joints_are_refused_with_a_reason() {
    let mut world = World::default();
    let a = add_ball(&mut world, 0.1, Vec3::Y, Vec3::ZERO, STEEL, false).unwrap();
    let b = add_ball(&mut world, 0.1, Vec3::Y * 2.0, Vec3::ZERO, STEEL, false).unwrap();
    let fixed = world.insert_body(crumble::BodyBuilder::fixed()).unwrap();
    let invalid = |r: Result<JointHandle, WorldError>| matches!(r, Err(WorldError::InvalidJoint(_)));
    assert!(invalid(world.insert_joint(JointBuilder::spherical(a, a))), "a body joined to itself");
    assert!(
        invalid(world.insert_joint(JointBuilder::spherical(JointBody::World, JointBody::World))),
        "the world twice"
    );
    assert!(invalid(world.insert_joint(JointBuilder::spherical(JointBody::World, fixed))), "no dynamic body");
    let nan = Vec3::new(f32::NAN, 0.0, 0.0);
    assert!(invalid(world.insert_joint(JointBuilder::spherical(a, b).anchor(nan))), "a NaN anchor");
    assert!(invalid(world.insert_joint(JointBuilder::revolute(a, b, Vec3::ZERO))), "a zero axis");
    assert!(invalid(world.insert_joint(JointBuilder::revolute(a, b, nan))), "a NaN axis");
    assert!(invalid(world.insert_joint(JointBuilder::distance(a, b, -1.0))), "a negative length");
    assert!(invalid(world.insert_joint(JointBuilder::rope(a, b, 0.0))), "a zero length");
    assert!(invalid(world.insert_joint(JointBuilder::revolute(a, b, Vec3::Z).limits(1.0, -1.0))), "reversed limits");
    assert!(invalid(world.insert_joint(JointBuilder::revolute(a, b, Vec3::Z).limits(-4.0, 0.0))), "limits past π");
    assert!(invalid(world.insert_joint(JointBuilder::spherical(a, b).limits(-1.0, 1.0))), "limits on a ball joint");
    assert!(invalid(world.insert_joint(JointBuilder::spherical(a, b).spring(5.0, 1.0))), "a spring on a ball joint");
    assert!(invalid(world.insert_joint(JointBuilder::distance(a, b, 1.0).spring(-5.0, 1.0))), "a negative spring");
    assert!(
        invalid(world.insert_joint(JointBuilder::distance(a, b, 1.0).spring(1e22, 0.5))),
        "a spring that overflows"
    );
    assert!(invalid(world.insert_joint(JointBuilder::distance(a, b, 1.0).spring(5.0, 3e38))), "damping that overflows");
    assert!(invalid(world.insert_joint(JointBuilder::spherical(a, b).break_force(f32::NAN))), "a NaN threshold");
    assert!(invalid(world.insert_joint(JointBuilder::spherical(a, b).break_torque(0.0))), "a zero threshold");
    world.remove_body(b).unwrap();
    assert_eq!(world.insert_joint(JointBuilder::spherical(a, b)), Err(WorldError::UnknownBody), "a removed body");
    assert_eq!(world.joint_count(), 0, "nothing was inserted");
}

/// Removing a body removes its joints; a removed joint's handle is stale.
#[test]
fn removing_a_body_removes_its_joints() {
    let mut world = World::default();
    let a = add_ball(&mut world, 0.1, Vec3::Y, Vec3::ZERO, STEEL, false).unwrap();
    let b = add_ball(&mut world, 0.1, Vec3::Y * 2.0, Vec3::ZERO, STEEL, false).unwrap();
    let ab = world.insert_joint(JointBuilder::spherical(a, b).anchor(Vec3::Y * 1.5)).unwrap();
    let wa = world.insert_joint(JointBuilder::spherical(JointBody::World, a).anchor(Vec3::ZERO)).unwrap();
    world.remove_body(b).unwrap();
    assert!(world.joint(ab).is_none() && world.joint(wa).is_some());
    assert_eq!(world.remove_joint(ab), Err(WorldError::UnknownJoint));
    world.remove_joint(wa).unwrap();
    assert_eq!(world.joint_count(), 0);
    world.step(DT).unwrap();
}

/// Two overlapping boxes joined by a joint do not collide by default, do
/// with `collide_connected(true)`, and collide again once their joint is
/// removed.
#[test]
fn jointed_bodies_collide_only_when_asked() {
    let touching = |w: &World| w.contacts().next().is_some();
    for collide in [false, true] {
        let mut world = world_with(|s| s.gravity = Vec3::ZERO);
        let a = add_box(&mut world, Vec3::splat(0.2), Vec3::ZERO, Quat::IDENTITY, STEEL, false).unwrap();
        let b = add_box(&mut world, Vec3::splat(0.2), Vec3::X * 0.15, Quat::IDENTITY, STEEL, false).unwrap();
        world.step(DT).unwrap();
        assert!(touching(&world), "the boxes overlap");
        let j = JointBuilder::fixed(a, b).collide_connected(collide);
        let j = world.insert_joint(j).unwrap();
        world.step(DT).unwrap();
        assert_eq!(touching(&world), collide, "collide_connected({collide})");
        world.remove_joint(j).unwrap();
        world.step(DT).unwrap();
        assert!(touching(&world), "collide_connected({collide}): no contact after the joint went");
    }
}

/// A sleeping chain wakes as one: a push on its ball wakes every link.
#[test]
fn a_sleeping_chain_wakes_as_one() {
    let mut world = World::default();
    let spec = WreckingBallSpec { release_angle: 0.0, ..WreckingBallSpec::default() };
    let wb = add_wrecking_ball(&mut world, &spec).unwrap();
    for _ in 0..60 {
        world.step(DT).unwrap();
    }
    assert!(world.body(wb.links[0]).unwrap().is_sleeping(), "asleep after a second");
    world.apply_impulse(wb.ball, Vec3::new(0.0, 0.0, 50.0)).unwrap();
    world.step(DT).unwrap();
    assert!(wb.links.iter().all(|&l| !world.body(l).unwrap().is_sleeping()), "every link woke");
    world.validate();
}

/// A ball hanging on a distance spring of 1.5 Hz and damping ratio 0.1,
/// released where the spring is at its rest length: it oscillates about
/// the point where the spring carries its weight (`m g / k` below, `k =
/// m (2π f)²`: 0.110 m) with the damped period `1 / (f √(1 − ζ²))` =
/// 0.670 s. Measured: 0.667 s between its first two lowest points (limit
/// 3 %); it swings 0.076 m below the rest point and rebounds 0.052 m above
/// it, 0.68 of the swing (a damped oscillator rebounds
/// `e^(−πζ/√(1−ζ²))` = 0.73 of it, an overdamped one not at all; limit:
/// half of 0.73).
///
/// Regression: the spring's row was solved in every relax pass, after the
/// bodies had moved, which damped the ball into a creep; and the energy
/// bound (`energy.rs`) took the rebound, energy the spring had stored, for
/// energy from nowhere and cut it.
#[test]
fn a_spring_oscillates_at_its_frequency() {
    let mut world = world_with(|s| s.sleep_enabled = false);
    let anchor = Vec3::new(0.0, 3.0, 0.0);
    let ball = add_ball(&mut world, 0.1, anchor - Vec3::Y, Vec3::ZERO, STEEL, false).unwrap();
    let (f, zeta) = (1.5f32, 0.1f32);
    let spring = JointBuilder::distance(JointBody::World, ball, 1.0).anchors(anchor, anchor - Vec3::Y).spring(f, zeta);
    world.insert_joint(spring).unwrap();
    let rest = anchor.y - 1.0 - 9.81 / (2.0 * std::f32::consts::PI * f).powi(2);
    let (mut ys, mut lows) = (Vec::new(), Vec::new());
    for step in 0..120 {
        world.step(DT).unwrap();
        ys.push(world.body(ball).unwrap().position().y);
        let n = ys.len();
        if n >= 3 && ys[n - 2] < ys[n - 3] && ys[n - 2] <= ys[n - 1] {
            lows.push((step - 1) as f32 * DT);
        }
    }
    let period = lows[1] - lows[0];
    let expected = 1.0 / (f * (1.0 - zeta * zeta).sqrt());
    let first_swing = rest - ys.iter().copied().fold(f32::MAX, f32::min);
    let rebound = ys.iter().copied().skip_while(|&y| y > rest).fold(f32::MIN, f32::max) - rest;
    eprintln!("spring: period {period} s (expected {expected}), swing {first_swing} m, rebound {rebound} m");
    assert!((period / expected - 1.0).abs() < 0.03, "period {period} s, expected {expected} s");
    assert!(rebound > 0.5 * first_swing * 0.73, "rebound {rebound} m after a swing of {first_swing} m");
}

/// Regression: the 6 × 6 blocks were inverted through their Schur
/// complement, which trusts their symmetry; a weld's block is symmetric
/// only to `f32`'s rounding of the body's inertia, and with a long arm on
/// a small turned body the complement amplified that into NaN impulses
/// (a 3 cm cube welded to the world 1 m away faulted every step in 45 of 50
/// orientations, and never broke). Gauss–Jordan with pivoting holds.
#[test]
fn a_weld_far_from_a_turned_body_stays_finite() {
    let mut world = World::default();
    let q = Quat::from_xyzw(0.458_957_23, 0.738_576_5, -0.291_240_72, -0.398_800_55).normalize();
    let centre = Vec3::new(0.0, 3.0, 0.0);
    let cube = add_box(&mut world, Vec3::splat(0.03), centre, q, STEEL, false).unwrap();
    let anchor = centre + Vec3::new(-0.626_657_3, -0.567_272_2, 0.534_324_8);
    let weld = world.insert_joint(JointBuilder::fixed(JointBody::World, cube).anchor(anchor).break_force(1e3)).unwrap();
    for step in 0..60 {
        world.step(DT).unwrap();
        assert!(world.faulted_bodies().is_empty(), "step {step}: the cube faulted");
        let j = world.joint(weld).unwrap();
        assert!(j.force().is_finite() && j.torque().is_finite(), "step {step}: {} N", j.force());
        // The weld holds the cube where it was: the weight's moment about a
        // 1 m arm, held exactly.
        assert!(j.separation() < 1e-4, "step {step}: open {} m", j.separation());
    }
}

/// Regression: a joint whose only dynamic body had no mass yet (no
/// collider, or its collider removed) had a zero block, inverted to an
/// infinite impulse: NaN velocities, and a kinematic body at its other end
/// faulted and stopped. Such a joint now has nothing to solve.
#[test]
fn a_joint_to_a_body_without_mass_leaves_everything_finite() {
    let mut world = World::default();
    let k = world.insert_body(crumble::BodyBuilder::kinematic().linear_velocity(Vec3::X)).unwrap();
    world.insert_collider(crumble::ColliderBuilder::ball(0.1).unwrap(), k).unwrap();
    let m = world.insert_body(crumble::BodyBuilder::dynamic().position(Vec3::new(0.0, -1.0, 0.0))).unwrap();
    let j = world.insert_joint(JointBuilder::spherical(k, m).anchor(Vec3::ZERO).break_force(1e3)).unwrap();
    let bob = add_ball(&mut world, 0.1, Vec3::new(5.0, 1.0, 0.0), Vec3::ZERO, STEEL, false).unwrap();
    let pendulum = JointBuilder::spherical(JointBody::World, bob).anchor(Vec3::new(5.0, 2.0, 0.0));
    let p = world.insert_joint(pendulum).unwrap();
    world.step(DT).unwrap();
    let collider = world.body_colliders(bob)[0];
    world.remove_collider(collider).unwrap();
    for step in 0..30 {
        world.step(DT).unwrap();
        assert!(world.faulted_bodies().is_empty(), "step {step}: faulted {:?}", world.faulted_bodies());
        for h in [j, p] {
            assert!(world.joint(h).unwrap().force().is_finite(), "step {step}");
        }
    }
    assert_eq!(world.body(k).unwrap().linear_velocity(), Vec3::X, "the kinematic body keeps its velocity");
}

/// Regression: with `ordered_relax` (every contact in one serial group) and
/// no contact at all, each joint alone made a unit of its own, keyed by its
/// body, so that ropes sharing a body were solved in units that each
/// integrated it: a chain of eight balls on ropes stretched 1.45 m in 2 s.
#[test]
fn ropes_hold_with_ordered_relax_and_no_contacts() {
    let mut world = world_with(|s| s.experimental.ordered_relax = true);
    let mut previous = JointBody::World;
    let mut at = Vec3::new(0.0, 5.0, 0.0);
    for _ in 0..8 {
        let next = at + Vec3::new(0.3, 0.0, 0.0);
        let b = add_ball(&mut world, 0.05, next, Vec3::ZERO, STEEL, false).unwrap();
        world.insert_joint(JointBuilder::rope(previous, b, 0.3).anchors(at, next)).unwrap();
        (previous, at) = (JointBody::Body(b), next);
    }
    let mut worst = 0.0f32;
    for _ in 0..120 {
        world.step(DT).unwrap();
        worst = worst.max(max_separation(&world));
    }
    eprintln!("ropes with ordered_relax: {worst} m");
    // Measured 3.9 mm (1.5 mm without `ordered_relax`: ropes are
    // Gauss–Seidel rows). Limit 1 cm.
    assert!(worst < 0.01, "a rope stretched {worst} m");
}

/// Regression: moving a body by hand (`set_pose`) woke what touched it but
/// not what hung from it: a ball asleep on a rope stayed asleep 2 m from
/// its moved anchor.
#[test]
fn moving_an_anchor_wakes_what_hangs_from_it() {
    let mut world = World::default();
    let hook = world.insert_body(crumble::BodyBuilder::kinematic().position(Vec3::new(0.0, 3.0, 0.0))).unwrap();
    let ball = add_ball(&mut world, 0.1, Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, STEEL, false).unwrap();
    world.insert_joint(JointBuilder::spherical(hook, ball).anchor(Vec3::new(0.0, 3.0, 0.0))).unwrap();
    for _ in 0..60 {
        world.step(DT).unwrap();
    }
    assert!(world.body(ball).unwrap().is_sleeping(), "asleep");
    world.set_pose(hook, crumble::Pose::from_translation(Vec3::new(2.0, 3.0, 0.0))).unwrap();
    assert!(!world.body(ball).unwrap().is_sleeping(), "woken by the move");
    // The joint pulls the ball back to its anchor at the push-out's speed
    // cap (3 m/s, `max_push_out_speed`): the 2.2 m gap closes in about a
    // second. Measured after 2 s: closed entirely (limit 5 cm).
    for _ in 0..120 {
        world.step(DT).unwrap();
    }
    eprintln!("moved anchor: open {} m after 2 s", max_separation(&world));
    assert!(max_separation(&world) < 0.05, "the joint pulled the ball along: {} m", max_separation(&world));
}
