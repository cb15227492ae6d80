//! `[[joint]]` and `[[wrecking_ball]]`: what they build, and every bad
//! value refused with the file, line and key before anything is simulated.

mod common;
use common::refused;
use crumble::scenes::{add_wrecking_ball, WreckingBallSpec};
use crumble::{JointKind, Vec3, World, WorldSettings};
use crumble_scene::{build, parse, Simulation};

fn built(text: &str) -> Simulation {
    let scene = parse(text, "ok.toml").unwrap_or_else(|e| panic!("{e}\n{text}"));
    build(&scene).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// A ball and a box, both 1 m up, 1 m apart along x; the joint's keys follow.
fn two_bodies(joint: &str) -> String {
    format!(
        "[[body]]\nname = \"ball\"\nshape = \"sphere\"\nradius = 0.1\nposition = [0, 1, 0]\n\n\
         [[body]]\nname = \"box\"\nshape = \"box\"\nsize = [0.2, 0.2, 0.2]\nposition = [1, 1, 0]\n\n\
         [[joint]]\n{joint}"
    )
}

#[test]
fn every_kind_of_joint_is_built_as_written() {
    let text = two_bodies(
        "kind = \"spherical\"\na = \"world\"\nb = \"ball\"\nanchor = [0, 2, 0]\nbreak_force = 5000.0\n\n\
         [[joint]]\nkind = \"revolute\"\na = \"ball\"\nb = \"box\"\nanchor = [0.5, 1, 0]\naxis = [0, 0, 2]\n\
         limits_deg = [-45, 90]\nbreak_torque = 80.0\n\n\
         [[joint]]\nkind = \"fixed\"\na = \"box\"\nb = \"world\"\n\n\
         [[joint]]\nkind = \"distance\"\na = \"ball\"\nb = \"box\"\nanchors = [[0, 1.1, 0], [1, 1.1, 0]]\nlength = 1.0\n\
         spring = { hertz = 2.0, damping_ratio = 0.5 }\ncollide_connected = true\n\n\
         [[joint]]\nkind = \"rope\"\na = \"world\"\nb = \"box\"\nlocal_anchors = [[1, 3, 0], [0, 0.1, 0]]\nlength = 2.5\n",
    );
    let sim = built(&text);
    let joints: Vec<_> = sim.world.joints().map(|(h, j)| (h, j.clone())).collect();
    let kinds: Vec<JointKind> = joints.iter().map(|(_, j)| j.kind()).collect();
    use JointKind::*;
    assert_eq!(kinds, [Spherical, Revolute, Fixed, Distance, Rope]);
    let handle = |name: &str| sim.bodies.iter().find(|b| b.name == name).and_then(|b| b.handle);
    let (ball, boxed) = (handle("ball"), handle("box"));
    let bodies: Vec<_> = joints.iter().map(|(_, j)| j.bodies()).collect();
    assert_eq!(bodies, [(None, ball), (ball, boxed), (boxed, None), (ball, boxed), (None, boxed)]);
    let world_anchors = |k: usize| sim.world.joint_anchors(joints[k].0).unwrap();
    assert_eq!(world_anchors(0), (Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 2.0, 0.0)));
    assert_eq!(world_anchors(1), (Vec3::new(0.5, 1.0, 0.0), Vec3::new(0.5, 1.0, 0.0)));
    assert_eq!(world_anchors(2), (Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)), "default: b's origin");
    assert_eq!(world_anchors(3), (Vec3::new(0.0, 1.1, 0.0), Vec3::new(1.0, 1.1, 0.0)));
    assert_eq!(world_anchors(4), (Vec3::new(1.0, 3.0, 0.0), Vec3::new(1.0, 1.1, 0.0)));
    assert_eq!(joints[0].1.break_thresholds(), (5000.0, f32::INFINITY));
    assert_eq!(joints[1].1.break_thresholds(), (f32::INFINITY, 80.0));
    let (lo, hi) = joints[1].1.limits().unwrap();
    assert!((lo + std::f32::consts::FRAC_PI_4).abs() < 1e-6 && (hi - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    assert_eq!((joints[3].1.length(), joints[4].1.length()), (1.0, 2.5));
    let collide: Vec<bool> = joints.iter().map(|(_, j)| j.collide_connected()).collect();
    assert_eq!(collide, [false, false, false, true, false]);
}

/// A pendulum from a file: a ball on a spherical joint 1 m below a point
/// of the world swings without its anchor drifting.
#[test]
fn a_pendulum_from_a_file_keeps_its_length() {
    let text = "[[body]]\nname = \"bob\"\nshape = \"sphere\"\nradius = 0.1\nposition = [1, 2, 0]\n\n\
                [[joint]]\nkind = \"spherical\"\na = \"world\"\nb = \"bob\"\nanchor = [0, 2, 0]\n";
    let mut sim = built(text);
    let mut lowest = f32::MAX;
    for _ in 0..60 {
        sim.step().unwrap();
        let p = sim.pose(0).position;
        lowest = lowest.min(p.y);
        // The joint holds its 1 m: the anchor is on the ball's centre, so the
        // centre stays 1 m from the world point (1 mm: the joint's drift
        // over a swing, measured under 0.1 mm).
        assert!(((p - Vec3::new(0.0, 2.0, 0.0)).length() - 1.0).abs() < 1e-3, "{p}");
    }
    // Released level, it swings through the bottom (y = 1) within the
    // quarter period of about 0.59 s; the 60 steps cover 1 s.
    assert!(lowest < 1.01, "{lowest}");
}

#[test]
fn limits_of_plus_and_minus_180_degrees_build() {
    let sim = built(&two_bodies(
        "kind = \"revolute\"\na = \"ball\"\nb = \"box\"\naxis = [0, 1, 0]\nlimits_deg = [-180, 180]\n",
    ));
    let (_, j) = sim.world.joints().next().unwrap();
    let pi = std::f32::consts::PI;
    assert_eq!(j.limits(), Some((-pi, pi)));
}

#[test]
fn bodies_joined_without_colliding_may_overlap_at_the_start() {
    let scene = |pair_collides: bool, post_collides: bool| {
        format!(
            "[world.ground]\n\n[[body]]\nname = \"a\"\nshape = \"box\"\nsize = [0.4, 0.2, 0.2]\nposition = [0, 1, 0]\n\n\
             [[body]]\nname = \"b\"\nshape = \"box\"\nsize = [0.4, 0.2, 0.2]\nposition = [0.3, 1, 0]\n\n\
             [[body]]\nname = \"post\"\nshape = \"box\"\nsize = [0.2, 0.4, 0.2]\nposition = [2, 0.1, 0]\n\n\
             [[joint]]\nkind = \"fixed\"\na = \"a\"\nb = \"b\"\ncollide_connected = {pair_collides}\n\n\
             [[joint]]\nkind = \"fixed\"\na = \"ground\"\nb = \"post\"\ncollide_connected = {post_collides}\n"
        )
    };
    // `a` and `b` overlap by 0.1 m, the post is 0.1 m into the ground:
    // the joints keep them from colliding, so the plan is accepted.
    let sim = built(&scene(false, false));
    assert_eq!(sim.world.joint_count(), 2);
    // Colliding, the same bodies are refused as any overlap is.
    refused(&scene(true, false), 9, "body[1]", "overlap by 0.1000 m");
    refused(&scene(false, true), 15, "body[2]", "reaches 0.1000 m into the ground");
}

#[test]
fn generated_bodies_are_joined_by_their_names() {
    let text = "[world.ground]\n\n[[wall]]\nname = \"w\"\nrows = 1\nbricks_per_row = 2\n\n\
                [[joint]]\nkind = \"fixed\"\na = \"w/0\"\nb = \"w/1\"\nanchor = [0, 0.0325, 0]\n";
    let sim = built(text);
    let (_, j) = sim.world.joints().next().unwrap();
    let handle = |name: &str| sim.bodies.iter().find(|b| b.name == name).and_then(|b| b.handle);
    assert_eq!(j.bodies(), (handle("w/0"), handle("w/1")));
}

/// An empty `[[wrecking_ball]]` takes every default from the engine's
/// `WreckingBallSpec::default()`, and the scene's plan of its bodies (the
/// poses in the outputs and the overlap check) is where the engine's
/// generator puts them.
#[test]
fn a_default_wrecking_ball_is_the_engines() {
    let sim = built("[[wrecking_ball]]\n");
    let mut world = World::new(WorldSettings::default()).unwrap();
    let made = add_wrecking_ball(&mut world, &WreckingBallSpec::default()).unwrap();
    let handles: Vec<_> = made.links.iter().chain([&made.ball]).collect();
    assert_eq!(sim.bodies.len(), handles.len());
    assert_eq!(sim.world.joint_count(), made.joints.len());
    for (i, h) in handles.into_iter().enumerate() {
        let engine = world.body(*h).unwrap();
        let scene = sim.world.body(sim.bodies[i].handle.unwrap()).unwrap();
        assert_eq!(scene.pose(), engine.pose(), "{}", sim.bodies[i].name);
        assert_eq!(scene.mass(), engine.mass(), "{}", sim.bodies[i].name);
        let planned = sim.bodies[i].initial;
        // The plan's arithmetic is the generator's, so within rounding
        // (1 µm, 1e-6 in the quaternion).
        assert!((planned.position - engine.pose().position).length() < 1e-6, "{}", sim.bodies[i].name);
        assert!(planned.rotation.abs_diff_eq(engine.pose().rotation, 1e-6), "{}", sim.bodies[i].name);
    }
}

#[test]
fn wrecking_balls_are_named_ball_and_chain_with_the_index_after_the_first() {
    let text = "[[wrecking_ball]]\nlinks = 2\n\n\
                [[wrecking_ball]]\nlinks = 2\nanchor = [5, 3, 0]\n\n\
                [[wrecking_ball]]\nname = \"crane\"\nlinks = 2\nanchor = [10, 3, 0]\n";
    let sim = built(text);
    let names: Vec<&str> = sim.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(
        names,
        ["chain/0", "chain/1", "ball", "chain1/0", "chain1/1", "ball1", "crane/chain/0", "crane/chain/1", "crane/ball"]
    );
    let sources: Vec<&str> = sim.bodies.iter().map(|b| b.source.as_str()).collect();
    assert_eq!(sources[3..6], ["wrecking_ball[1]"; 3]);
    assert_eq!(sim.world.joint_count(), 9);
}

#[test]
fn a_wrecking_ball_with_a_tether_adds_a_rope_as_long_as_the_chain() {
    let sim = built("[[wrecking_ball]]\ntether = true\n");
    let (_, last) = sim.world.joints().last().unwrap();
    assert_eq!((sim.world.joint_count(), last.kind()), (22, JointKind::Rope));
    // 20 links of 0.12 m and the ball's 0.15 m radius.
    assert!((last.length() - 2.55).abs() < 1e-6, "{}", last.length());
}

#[test]
fn a_wrecking_ball_swings_the_way_of_its_direction() {
    let sim = built("[[wrecking_ball]]\nanchor = [0, 3, 0]\ndirection = [1, 7, 0]\nrelease_angle_deg = 90\n");
    // Level at 90°, on the side opposite `direction` (its y ignored):
    // 2.55 m along −x.
    let ball = sim.bodies.iter().find(|b| b.name == "ball").unwrap();
    assert!((ball.initial.position - Vec3::new(-2.55, 3.0, 0.0)).length() < 1e-5, "{}", ball.initial.position);
}

// What is refused, one test each, at its file, line and key.

#[test]
fn a_joint_to_an_unknown_body_is_refused() {
    refused(
        &two_bodies("kind = \"spherical\"\na = \"world\"\nb = \"bal\"\n"),
        16,
        "joint[0].b",
        "no body is named `bal`",
    );
}

#[test]
fn a_body_joined_to_itself_is_refused() {
    refused(&two_bodies("kind = \"fixed\"\na = \"box\"\nb = \"box\"\n"), 16, "joint[0].b", "joins `box` to itself");
}

#[test]
fn the_world_joined_to_the_world_is_refused() {
    refused(
        &two_bodies("kind = \"fixed\"\na = \"world\"\nb = \"world\"\n"),
        16,
        "joint[0].b",
        "both sides are the world",
    );
}

#[test]
fn a_joint_without_a_dynamic_body_is_refused() {
    let text =
        "[world.ground]\n\n[[body]]\nname = \"post\"\nshape = \"box\"\nsize = [0.2, 1, 0.2]\nposition = [0, 0.5, 0]\n\
                static = true\n\n[[joint]]\nkind = \"fixed\"\na = \"ground\"\nb = \"post\"\n";
    refused(text, 10, "joint[0]", "neither `ground` nor `post` is a dynamic body");
}

#[test]
fn a_joint_to_a_projectile_is_refused() {
    let text = "[[projectile]]\nname = \"shot\"\nradius = 0.1\nfrom = [0, 1, 0]\nvelocity = [1, 0, 0]\n\n\
                [[joint]]\nkind = \"spherical\"\na = \"shot\"\nb = \"world\"\n";
    refused(text, 9, "joint[0].a", "`shot` is a projectile");
}

#[test]
fn a_body_named_world_is_refused() {
    refused(
        "[[body]]\nname = \"world\"\nshape = \"sphere\"\nradius = 0.1\n",
        1,
        "body[0]",
        "no body may be named `world`",
    );
}

#[test]
fn an_unknown_joint_kind_is_refused() {
    refused(&two_bodies("kind = \"hinge\"\na = \"world\"\nb = \"ball\"\n"), 14, "joint[0].kind", "unknown variant");
}

#[test]
fn limits_in_radians_under_an_unknown_key_are_refused() {
    let text = two_bodies("kind = \"revolute\"\na = \"world\"\nb = \"ball\"\naxis = [0, 0, 1]\nlimits = [-1, 1]\n");
    refused(&text, 18, "joint[0].limits", "unknown field");
}

#[test]
fn a_nan_anchor_is_refused() {
    refused(
        &two_bodies("kind = \"spherical\"\na = \"world\"\nb = \"ball\"\nanchor = [0, nan, 0]\n"),
        17,
        "joint[0].anchor",
        "finite",
    );
}

#[test]
fn an_infinite_anchor_of_two_is_refused() {
    let text =
        two_bodies("kind = \"distance\"\na = \"ball\"\nb = \"box\"\nanchors = [[0, 1, 0], [inf, 1, 0]]\nlength = 1\n");
    refused(&text, 17, "joint[0].anchors[1]", "finite");
}

#[test]
fn a_nan_local_anchor_is_refused() {
    let text = two_bodies("kind = \"fixed\"\na = \"ball\"\nb = \"box\"\nlocal_anchors = [[nan, 0, 0], [0, 0, 0]]\n");
    refused(&text, 17, "joint[0].local_anchors[0]", "finite");
}

#[test]
fn an_anchor_beyond_the_worlds_bound_is_refused() {
    let text = two_bodies("kind = \"spherical\"\na = \"world\"\nb = \"ball\"\nanchor = [0, 2e6, 0]\n");
    refused(&text, 17, "joint[0].anchor", "the world's bound");
}

#[test]
fn two_ways_of_giving_the_anchors_are_refused() {
    let text =
        two_bodies("kind = \"spherical\"\na = \"world\"\nb = \"ball\"\nanchor = [0, 2, 0]\nlocal_anchors = [[0, 2, 0], [0, 1, 0]]\n");
    refused(&text, 18, "joint[0].local_anchors", "not both `anchor` and `local_anchors`");
}

#[test]
fn a_zero_axis_is_refused() {
    refused(
        &two_bodies("kind = \"revolute\"\na = \"world\"\nb = \"ball\"\naxis = [0, 0, 0]\n"),
        17,
        "joint[0].axis",
        "must not be zero",
    );
}

#[test]
fn a_revolute_joint_without_an_axis_is_refused() {
    refused(&two_bodies("kind = \"revolute\"\na = \"world\"\nb = \"ball\"\n"), 14, "joint[0].kind", "needs `axis`");
}

#[test]
fn an_axis_on_a_spherical_joint_is_refused() {
    let text = two_bodies("kind = \"spherical\"\na = \"world\"\nb = \"ball\"\naxis = [0, 0, 1]\n");
    refused(&text, 17, "joint[0].axis", "a spherical joint has no `axis`");
}

#[test]
fn a_zero_length_is_refused() {
    refused(
        &two_bodies("kind = \"distance\"\na = \"ball\"\nb = \"box\"\nlength = 0\n"),
        17,
        "joint[0].length",
        "positive",
    );
}

#[test]
fn a_negative_rope_length_is_refused() {
    refused(
        &two_bodies("kind = \"rope\"\na = \"ball\"\nb = \"box\"\nlength = -1\n"),
        17,
        "joint[0].length",
        "positive",
    );
}

#[test]
fn a_distance_joint_without_a_length_is_refused() {
    refused(&two_bodies("kind = \"distance\"\na = \"ball\"\nb = \"box\"\n"), 14, "joint[0].kind", "needs `length`");
}

#[test]
fn a_length_on_a_fixed_joint_is_refused() {
    refused(
        &two_bodies("kind = \"fixed\"\na = \"ball\"\nb = \"box\"\nlength = 1\n"),
        17,
        "joint[0].length",
        "a fixed joint has no `length`",
    );
}

#[test]
fn reversed_limits_are_refused() {
    let text =
        two_bodies("kind = \"revolute\"\na = \"world\"\nb = \"ball\"\naxis = [0, 0, 1]\nlimits_deg = [30, -30]\n");
    refused(&text, 18, "joint[0].limits_deg", "reversed");
}

#[test]
fn limits_beyond_180_degrees_are_refused() {
    let text =
        two_bodies("kind = \"revolute\"\na = \"world\"\nb = \"ball\"\naxis = [0, 0, 1]\nlimits_deg = [-90, 270]\n");
    refused(&text, 18, "joint[0].limits_deg", "from -180 to 180 degrees, got 270");
}

#[test]
fn limits_on_a_spherical_joint_are_refused() {
    let text = two_bodies("kind = \"spherical\"\na = \"world\"\nb = \"ball\"\nlimits_deg = [-30, 30]\n");
    refused(&text, 17, "joint[0].limits_deg", "a spherical joint has no limits");
}

#[test]
fn a_spring_on_a_rope_is_refused() {
    let text = two_bodies(
        "kind = \"rope\"\na = \"ball\"\nb = \"box\"\nlength = 1\nspring = { hertz = 2, damping_ratio = 1 }\n",
    );
    refused(&text, 18, "joint[0].spring", "a rope joint has no spring");
}

#[test]
fn a_negative_spring_frequency_is_refused() {
    let text = two_bodies(
        "kind = \"distance\"\na = \"ball\"\nb = \"box\"\nlength = 1\nspring = { hertz = -2, damping_ratio = 1 }\n",
    );
    refused(&text, 18, "joint[0].spring.hertz", "must not be negative");
}

#[test]
fn a_spring_without_a_damping_ratio_is_refused() {
    let text = two_bodies("kind = \"distance\"\na = \"ball\"\nb = \"box\"\nlength = 1\nspring = { hertz = 2 }\n");
    refused(&text, 18, "joint[0].spring", "missing field `damping_ratio`");
}

#[test]
fn a_zero_break_force_is_refused() {
    let text = two_bodies("kind = \"fixed\"\na = \"ball\"\nb = \"box\"\nbreak_force = 0\n");
    refused(&text, 17, "joint[0].break_force", "must be positive");
}

#[test]
fn a_nan_break_torque_is_refused() {
    let text = two_bodies("kind = \"fixed\"\na = \"ball\"\nb = \"box\"\nbreak_torque = nan\n");
    refused(&text, 17, "joint[0].break_torque", "must be positive");
}

/// The engine's own refusal (`WorldError::InvalidJoint`) is located at
/// the key it names: a length over the engine's 1e6 m, which the scene
/// layer leaves to the engine.
#[test]
fn the_engines_refusal_of_a_joint_is_located() {
    let text = two_bodies("kind = \"rope\"\na = \"ball\"\nb = \"box\"\nlength = 2e6\n");
    refused(&text, 17, "joint[0].length", "the engine refuses the joint: length must be positive and finite");
}

#[test]
fn a_wrecking_ball_without_links_is_refused() {
    refused("[[wrecking_ball]]\nlinks = 0\n", 2, "wrecking_ball[0].links", "at least 1");
}

#[test]
fn a_release_angle_beyond_180_degrees_is_refused() {
    refused("[[wrecking_ball]]\nrelease_angle_deg = 200\n", 2, "wrecking_ball[0].release_angle_deg", "0 to 180");
}

#[test]
fn a_vertical_swing_direction_is_refused() {
    refused("[[wrecking_ball]]\ndirection = [0, 1, 0]\n", 2, "wrecking_ball[0].direction", "horizontal");
}

#[test]
fn a_wrecking_ball_of_an_unknown_material_is_refused() {
    refused(
        "[[wrecking_ball]]\nball_material = \"lead\"\n",
        2,
        "wrecking_ball[0].ball_material",
        "unknown material `lead`",
    );
}

#[test]
fn a_wrecking_ball_of_negative_radius_is_refused() {
    refused("[[wrecking_ball]]\nball_radius = -0.1\n", 2, "wrecking_ball[0].ball_radius", "positive");
}

#[test]
fn a_wrecking_ball_with_a_nan_anchor_is_refused() {
    refused("[[wrecking_ball]]\nanchor = [0, nan, 0]\n", 2, "wrecking_ball[0].anchor", "finite");
}

#[test]
fn a_wrecking_ball_hanging_into_the_ground_is_refused() {
    // Hanging straight down 2.55 m from 2 m up.
    let text = "[world.ground]\n\n[[wrecking_ball]]\nanchor = [0, 2, 0]\nrelease_angle_deg = 0\n";
    refused(text, 3, "wrecking_ball[0]", "into the ground");
}

#[test]
fn a_wrecking_ball_overlapping_a_wall_is_refused() {
    let text = "[world.ground]\n\n[[wall]]\nrows = 10\nbricks_per_row = 10\n\n\
                [[wrecking_ball]]\nanchor = [0, 2.875, 0.1]\nrelease_angle_deg = 0\n";
    refused(text, 7, "wrecking_ball[0]", "generated bodies overlap");
}

#[test]
fn a_wrecking_ball_taking_a_used_name_is_refused() {
    let text =
        "[[body]]\nname = \"ball\"\nshape = \"sphere\"\nradius = 0.1\nposition = [5, 1, 0]\n\n[[wrecking_ball]]\n";
    refused(text, 7, "wrecking_ball[0]", "the name `ball` is used twice");
}

#[test]
fn a_wrecking_ball_of_links_too_light_to_simulate_is_refused() {
    // 1 nm steel cubes: 7.8e-24 kg, below the engine's 1e-15 kg.
    refused(
        "[[wrecking_ball]]\nlink = [1e-9, 1e-9, 1e-9]\n",
        2,
        "wrecking_ball[0].link",
        "kg is outside the simulated range",
    );
}
