//! Scene files: every built-in scene loads and runs; bad files are refused
//! with the file, line and key.

mod common;
use common::err;
use crumble_scene::builtin::{self, BUILTIN};
use crumble_scene::{build, parse, BodyShape};

fn scenes_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

#[test]
fn every_file_in_scenes_is_built_in_and_runs() {
    let mut files: Vec<String> = std::fs::read_dir(scenes_dir())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    files.sort();
    let mut names: Vec<String> = BUILTIN.iter().map(|s| s.file_name()).collect();
    names.sort();
    assert_eq!(files, names, "scenes/ and the built-in list differ");
    for name in files {
        let text = std::fs::read_to_string(scenes_dir().join(&name)).unwrap();
        let builtin = builtin::find(&name).unwrap();
        assert_eq!(builtin.source, text, "{name}: embedded copy is stale");
        assert!(!builtin.description().is_empty(), "{name}: no top comment");
        let scene = parse(&text, &name).unwrap_or_else(|e| panic!("{e}"));
        let mut sim = build(&scene).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.body_count(), sim.bodies.len() as u64, "{name}: body_count");
        let steps = if sim.bodies.len() > 1000 { 2 } else { 12 };
        for _ in 0..steps {
            sim.step().unwrap();
        }
        for i in 0..sim.bodies.len() {
            assert!(sim.pose(i).is_finite(), "{name}: body {i} not finite");
        }
    }
}

#[test]
fn headline_scene_matches_the_issue() {
    let s = builtin::find("brick_wall").unwrap();
    let sim = build(&parse(s.source, "brick_wall.toml").unwrap()).unwrap();
    let bricks = sim.bodies.iter().filter(|b| b.source == "wall[0]").count();
    assert_eq!(bricks, 105, "5 full rows of 10, 5 offset rows of 9 + 2 halves");
    let ball = sim.bodies.iter().find(|b| b.name == "ball").unwrap();
    assert_eq!(ball.shape, BodyShape::Sphere { radius: 0.075 });
    // Running bond: both ends of every row are flush.
    let mut ends: Vec<(f32, f32)> = vec![(f32::MAX, f32::MIN); 10];
    for b in sim.bodies.iter().filter(|b| b.source == "wall[0]") {
        let BodyShape::Box { half_extents } = b.shape else { panic!() };
        let row = ((b.initial.position.y - 0.0325) / 0.065).round() as usize;
        ends[row].0 = ends[row].0.min(b.initial.position.x - half_extents.x);
        ends[row].1 = ends[row].1.max(b.initial.position.x + half_extents.x);
    }
    for (lo, hi) in ends {
        assert!((lo + 1.075).abs() < 1e-5 && (hi - 1.075).abs() < 1e-5, "{lo} {hi}");
    }
}

const CUBE: &str = "[world.ground]\n\n[[body]]\nshape = \"box\"\nsize = [1, 1, 1]\nposition = [0, 2, 0]\n";

#[test]
fn a_minimal_scene_builds() {
    let sim = build(&parse(CUBE, "cube.toml").unwrap()).unwrap();
    assert_eq!(sim.bodies.len(), 2);
}

#[test]
fn unknown_key_names_line_and_key() {
    let e = err(&format!("{CUBE}colour = \"red\"\n"));
    assert_eq!((e.file.as_str(), e.line, e.key.as_str()), ("bad.toml", 7, "body[0].colour"), "{e}");
    assert!(e.message.contains("unknown field"), "{e}");
    let e = err("[world]\ngravty = [0, -9.81, 0]\n");
    assert_eq!((e.line, e.key.as_str()), (2, "world.gravty"), "{e}");
}

#[test]
fn wrong_type_names_line_and_key() {
    let e = err("[world]\ndt = \"fast\"\n");
    assert_eq!((e.line, e.key.as_str()), (2, "world.dt"), "{e}");
    let e = err("[[wall]]\nrows = -3\nbricks_per_row = 4\n");
    assert_eq!((e.line, e.key.as_str()), (2, "wall[0].rows"), "{e}");
}

#[test]
fn nan_is_refused() {
    let e = err("[[body]]\nshape = \"sphere\"\nradius = 0.5\nposition = [0, nan, 0]\n");
    assert_eq!((e.line, e.key.as_str()), (4, "body[0].position"), "{e}");
    assert!(e.message.contains("finite"), "{e}");
}

#[test]
fn negative_size_is_refused() {
    let e = err("[world.ground]\n\n[[stack]]\ncount = 3\nsize = [0.5, -0.5, 0.5]\n");
    assert_eq!((e.line, e.key.as_str()), (5, "stack[0].size"), "{e}");
    assert!(e.message.contains("positive"), "{e}");
}

#[test]
fn overlapping_generated_bodies_are_refused() {
    let text =
        "[world.ground]\n\n[[wall]]\nrows = 2\nbricks_per_row = 4\n\n[[stack]]\ncount = 2\nsize = [0.3, 0.3, 0.3]\n";
    let e = err(text);
    assert_eq!((e.line, e.key.as_str()), (7, "stack[0]"), "{e}");
    assert!(e.message.contains("overlap") && e.message.contains("wall[0]"), "{e}");
    let e = err("[world.ground]\n[[body]]\nshape = \"sphere\"\nradius = 1\nposition = [0, 0.5, 0]\n");
    assert!(e.message.contains("ground"), "{e}");
}

#[test]
fn touching_and_rotated_bricks_are_not_overlapping() {
    for facing in ["[0, 0, 1]", "[1, 0, 1]", "[0.3, 0, -1]"] {
        for bond in ["stack", "running"] {
            let text = format!(
                "[world.ground]\n[[wall]]\nrows = 6\nbricks_per_row = 7\ngap = 0\nbond = \"{bond}\"\nfacing = {facing}\n"
            );
            build(&parse(&text, "ok.toml").unwrap()).unwrap_or_else(|e| panic!("{e}"));
        }
    }
}

#[test]
fn other_mistakes_are_named() {
    let e = err("[[body]]\nshape = \"box\"\nsize = [1, 1, 1]\nmaterial = \"jelly\"\n");
    assert_eq!((e.line, e.key.as_str()), (4, "body[0].material"), "{e}");
    let e = err("[[projectile]]\nradius = 0.1\nfrom = [0, 1, 0]\n");
    assert_eq!((e.line, e.key.as_str()), (1, "projectile[0]"), "{e}");
    let e = err("[[body]]\nshape = \"cone\"\n");
    assert_eq!((e.line, e.key.as_str()), (2, "body[0].shape"), "{e}");
    let e = err("[world\n");
    assert_eq!(e.line, 1, "{e}");
    let e = err("[[body]]\nshape = \"box\"\nsize = [1, 1, 1]\naxis_angle = { axis = [0, 1, 0], degrees = 10 }\nquaternion = [0, 0, 0, 1]\n");
    assert_eq!((e.line, e.key.as_str()), (5, "body[0].quaternion"), "{e}");
}

#[test]
fn aimed_projectile_reaches_its_target() {
    let g = crumble::Vec3::new(0.0, -9.81, 0.0);
    let (from, target) = (crumble::Vec3::new(0.0, 1.0, 3.0), crumble::Vec3::new(0.0, 1.5, 0.0));
    let v = crumble_scene::aim(from, target, 10.0, g);
    let t = (target - from).length() / 10.0;
    let p = from + v * t + 0.5 * g * t * t;
    assert!((p - target).length() < 1e-4, "{p}");
}

#[test]
fn projectiles_wait_for_their_time() {
    let text = "[[projectile]]\nradius = 0.1\nfrom = [0, 1, 0]\nvelocity = [1, 0, 0]\nat = 0.1\n";
    let mut sim = build(&parse(text, "p.toml").unwrap()).unwrap();
    assert!(sim.bodies[0].handle.is_none());
    for _ in 0..6 {
        sim.step().unwrap();
    }
    assert!(sim.bodies[0].handle.is_none());
    sim.step().unwrap();
    assert!(sim.bodies[0].handle.is_some());
}

/// The TOML examples of the format doc, each with the heading of its
/// section.
fn doc_examples() -> Vec<(String, String)> {
    let doc = std::fs::read_to_string(scenes_dir().join("../docs/scene-format.md")).unwrap();
    let mut out = Vec::new();
    for section in doc.split("\n## ").skip(1) {
        let heading = section.lines().next().unwrap_or_default().to_string();
        for block in section.split("```toml\n").skip(1) {
            out.push((heading.clone(), block.split("```").next().unwrap().to_string()));
        }
    }
    out
}

#[test]
fn every_example_in_the_format_doc_builds() {
    let examples = doc_examples();
    assert!(examples.len() >= 10, "found {} examples", examples.len());
    for (i, (heading, text)) in examples.iter().enumerate() {
        let scene = parse(text, &format!("example {i}")).unwrap_or_else(|e| panic!("{heading}: {e}\n{text}"));
        let mut sim = build(&scene).unwrap_or_else(|e| panic!("{heading}: {e}\n{text}"));
        sim.step().unwrap();
    }
}

/// The examples of the `[[wrecking_ball]]` and `[[joint]]` sections make
/// joints, and run for a second without a body going non-finite.
#[test]
fn the_joint_and_wrecking_ball_examples_make_joints_and_run() {
    let examples = doc_examples();
    for section in ["`[[wrecking_ball]]`", "`[[joint]]`"] {
        let texts: Vec<&String> = examples.iter().filter(|(h, _)| h == section).map(|(_, t)| t).collect();
        assert!(!texts.is_empty(), "no example under {section}");
        for text in texts {
            let mut sim = build(&parse(text, "example.toml").unwrap()).unwrap_or_else(|e| panic!("{e}\n{text}"));
            assert!(sim.world.joint_count() > 0, "{section}: no joint\n{text}");
            for _ in 0..60 {
                sim.step().unwrap();
            }
            assert!(sim.world.faulted_bodies().is_empty(), "{section}\n{text}");
            for i in 0..sim.bodies.len() {
                assert!(sim.pose(i).is_finite(), "{section}: body {i} not finite\n{text}");
            }
        }
    }
}

#[test]
fn camera_table_is_read_and_checked() {
    let ok = "[world.ground]\n\n[camera]\neye = [3, 2, 4]\ntarget = [0, 0.5, 0]\nfov_deg = 35\n";
    let cam = parse(ok, "cam.toml").unwrap().camera.unwrap();
    assert_eq!((cam.eye, cam.target, cam.fov_deg), (Some([3.0, 2.0, 4.0]), Some([0.0, 0.5, 0.0]), 35.0));
    let partial = parse("[camera]\ntarget = [0, 1, 0]\n", "cam.toml").unwrap().camera.unwrap();
    assert_eq!((partial.eye, partial.fov_deg), (None, crumble_scene::spec::DEFAULT_FOV_DEG));
    assert!(parse(CUBE, "cube.toml").unwrap().camera.is_none());

    let e = err("[world.ground]\n\n[camera]\neye = [3, 2, 4]\nfov_deg = 200\n");
    assert_eq!((e.line, e.column, e.key.as_str()), (5, 1, "camera.fov_deg"), "{e}");
    assert!(e.message.contains("1 to 170"), "{e}");
    let e = err("[camera]\neye = [1, 1, 1]\ntarget = [1, 1, 1]\n");
    assert_eq!((e.line, e.key.as_str()), (3, "camera.target"), "{e}");
    assert!(e.message.contains("differ"), "{e}");
    let e = err("[camera]\neye = [1, nan, 1]\n");
    assert_eq!((e.line, e.key.as_str()), (2, "camera.eye"), "{e}");
    let e = err("[camera]\nup = [0, 1, 0]\n");
    assert_eq!((e.line, e.key.as_str()), (2, "camera.up"), "{e}");
    assert!(e.message.contains("unknown field"), "{e}");
    let e = err("[camera]\neye = [1, 2]\n");
    assert_eq!((e.line, e.key.as_str()), (2, "camera.eye"), "{e}");
    assert!(e.to_string().starts_with("bad.toml:2:"), "{e}");
}

/// Regression: a box size whose half rounds to zero in `f32` (1e-45, the
/// smallest subnormal) passed the "positive" check and then panicked in
/// the builder (`Shape::cuboid` of the halved size). Now it is an error
/// that names the line and key, for bodies and for every generator.
#[test]
fn a_box_too_small_to_halve_is_an_error_not_a_panic() {
    let cases = [
        ("[[body]]\nshape = \"box\"\nsize = [1, 1e-45, 1]\n", 3, "body[0].size"),
        ("[world.ground]\n\n[[stack]]\ncount = 3\nsize = [1e-45, 0.5, 0.5]\n", 5, "stack[0].size"),
        ("[world.ground]\n\n[[pyramid]]\nbase = 2\nsize = [0.5, 0.5, 1e-45]\n", 5, "pyramid[0].size"),
        ("[world.ground]\n\n[[wall]]\nrows = 1\nbricks_per_row = 1\nbrick = [0.2, 1e-45, 0.1]\n", 6, "wall[0].brick"),
    ];
    for (text, line, key) in cases {
        let e = err(text);
        assert_eq!((e.line, e.key.as_str()), (line, key), "{e}");
        assert!(e.message.contains("too small"), "{e}");
    }
}

/// Regression (F2, F10): a body or projectile whose mass is out of the
/// range the engine simulates (a 1e-20 m ball: 4e-57 kg) was built with
/// mass 0 and fell through the ground, or went non-finite at its first
/// step with a message naming neither its key nor the cause; a projectile
/// failed only at its launch. Each is refused when the scene is built, at
/// its line and key, naming the mass and the range.
#[test]
fn a_body_too_light_to_simulate_is_refused_at_its_key() {
    let cases = [
        ("[world.ground]\n\n[[body]]\nshape = \"sphere\"\nradius = 1e-20\n", 3, "body[0]"),
        (
            "[world.ground]\n\n[[projectile]]\nshape = \"sphere\"\nradius = 1e-20\nfrom = [0, 1, 2]\n\
             velocity = [0, 0, -1]\nat = 0.5\n",
            3,
            "projectile[0]",
        ),
    ];
    for (text, line, key) in cases {
        let e = err(text);
        assert_eq!((e.line, e.key.as_str()), (line, key), "{e}");
        assert!(e.message.contains("kg is outside the simulated range"), "{e}");
    }
    // A 1 mm grain of sand is in range and builds.
    let grain = "[world.ground]\n\n[[body]]\nshape = \"sphere\"\nradius = 0.0005\nposition = [0, 0.0005, 0]\n";
    build(&parse(grain, "grain.toml").unwrap()).unwrap();
}

/// Regression: the body-count total was summed without a check, so two
/// walls whose counts add up to 2^64 wrapped it to 0, passed `MAX_BODIES`
/// and the builder then aborted allocating gigabytes; a total that did not
/// wrap was refused at `0:0` with no key. Now the table that takes the
/// scene over the limit is refused, with its line and key.
#[test]
fn two_walls_whose_counts_overflow_are_refused() {
    let huge = "[[wall]]\nrows = 4294967295\nbricks_per_row = 4294967295\nbond = \"stack\"\n\n\
                [[wall]]\nrows = 1\nbricks_per_row = 4294967295\nposition = [0.0, 0.0, 5.0]\n";
    let e = parse(huge, "bad.toml").unwrap_err();
    assert_eq!((e.line, e.key.as_str()), (1, "wall[0]"), "{e}");
    assert!(e.message.contains("makes 18446744065119617025 bodies") && e.message.contains("1000000"), "{e}");
    // Within the limit alone, over it together: the second table is blamed.
    let two = "[[wall]]\nrows = 600\nbricks_per_row = 1000\nbond = \"stack\"\n\n\
               [[pyramid]]\nbase = 1000\nsize = [0.2, 0.2, 0.2]\nposition = [0.0, 0.0, 5.0]\n";
    let e = parse(two, "bad.toml").unwrap_err();
    assert_eq!((e.line, e.key.as_str()), (6, "pyramid[0]"), "{e}");
    assert!(e.message.contains("makes 500500 bodies, which brings the scene to 1100500"), "{e}");
}

/// Regression: a dotted key longer than the TOML reader's nesting limit
/// was refused as `bad.toml:0:0: recursion limit` (the reader gives no
/// position). The error now points at the key's line and column.
#[test]
fn a_dotted_key_nested_too_deep_is_located() {
    let deep = vec!["a"; 100_000].join(".");
    let e = parse(&format!("[world]\ndt = 0.01\n{deep} = 1\n"), "bad.toml").unwrap_err();
    assert_eq!((e.line, e.column), (3, 1), "{e}");
    assert!(e.message.contains("100000 parts") && e.message.contains("at most 80"), "{e}");
    // The reader's limit, exactly: 80 parts are read (and refused as an
    // unknown key), 81 are too deep. Inside an inline table too.
    let e = parse(&format!("x = {{ {} = 1 }}\n", vec!["b"; 80].join(".")), "bad.toml").unwrap_err();
    assert!(e.message.contains("unknown field") && e.line == 1, "{e}");
    let e = parse(&format!("[world]\nx = {{ {} = 1 }}\n", vec!["b"; 81].join(".")), "bad.toml").unwrap_err();
    assert_eq!((e.line, e.column), (2, 7), "{e}");
    assert!(e.message.contains("81 parts"), "{e}");
}

/// Regression: the overlap check swept along x only, so the boxes of a
/// column were all compared with each other (O(n²): 200,000 boxes took
/// 46 s, a million about 20 minutes, before the first step), and a column
/// of 0.2 m boxes was refused from box 10,241 on (2048 m up), where `f32`
/// rounding of their heights exceeds 0.1 mm. A column of 200,000 builds,
/// and an overlap high up in it is still found.
#[test]
fn a_column_of_200k_boxes_is_checked_for_overlaps() {
    let column = "[[stack]]\ncount = 200000\nsize = [0.2, 0.2, 0.2]\n";
    let sim = build(&parse(column, "tall.toml").unwrap()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(sim.bodies.len(), 200_000);
    // Box 150,000 is centred at 30,000.1 m; this one overlaps it by 0.1 m
    // (0.0996 m after rounding to `f32`).
    let text = format!("[[body]]\nname = \"intruder\"\nshape = \"box\"\nsize = [0.2, 0.2, 0.2]\nposition = [0, 30000.2, 0]\n\n{column}");
    let e = err(&text);
    assert_eq!((e.line, e.key.as_str()), (7, "stack[0]"), "{e}");
    assert!(
        e.message.contains("overlap by 0.0996 m (more than the 0.0072 m")
            && e.message.contains("`intruder`")
            && e.message.contains("`stack0/150000`"),
        "{e}"
    );
}

/// Regression: a wall 100 km from the origin and a stack of 10,242 boxes
/// of 0.2 m were refused as overlapping by 7.8 mm and 0.2 mm: there the
/// `f32` spacing of positions exceeds the 0.1 mm tolerance. The tolerance
/// follows the coordinates' rounding (`overlap_tolerance`), and a real
/// overlap far out is still refused.
#[test]
fn a_wall_far_from_the_origin_and_a_tall_stack_are_not_overlapping() {
    let far = [
        "[world.ground]\n[[wall]]\nrows = 2\nbricks_per_row = 10\nposition = [100000.0, 0.0, 0.0]\n",
        "[world.ground]\n[[wall]]\nrows = 20\nbricks_per_row = 10\nposition = [100000.0, 0.0, 3000.0]\nfacing = [1, 0, 0.3]\n",
        "[world.ground]\n[[stack]]\ncount = 10242\nsize = [0.2, 0.2, 0.2]\n",
    ];
    for text in far {
        build(&parse(text, "far.toml").unwrap()).unwrap_or_else(|e| panic!("{e}\n{text}"));
    }
    assert_eq!(crumble_scene::overlap_tolerance(100_000.0), 2.0 * f32::EPSILON * 100_000.0);
    assert_eq!(crumble_scene::overlap_tolerance(1.0), crumble_scene::OVERLAP_TOLERANCE);
    // Two bricks 100 km out overlapping by 5 cm (the tolerance there is 2.4 cm).
    let e = err("[[body]]\nshape = \"box\"\nsize = [0.2, 0.2, 0.2]\nposition = [100000, 0, 0]\n\n\
                 [[body]]\nshape = \"box\"\nsize = [0.2, 0.2, 0.2]\nposition = [100000.15, 0, 0]\n");
    assert_eq!((e.line, e.key.as_str()), (6, "body[1]"), "{e}");
    assert!(e.message.contains("overlap by 0.05"), "{e}");
}

/// The documented tolerance near the origin: two boxes overlapping by
/// 0.05 mm are accepted, by 0.2 mm refused.
#[test]
fn the_overlap_tolerance_near_the_origin_is_a_tenth_of_a_millimetre() {
    let pair = |x: f32| {
        format!(
            "[[body]]\nshape = \"box\"\nsize = [0.2, 0.2, 0.2]\n\n\
             [[body]]\nshape = \"box\"\nsize = [0.2, 0.2, 0.2]\nposition = [{x}, 0, 0]\n"
        )
    };
    build(&parse(&pair(0.2 - 0.00005), "ok.toml").unwrap()).unwrap_or_else(|e| panic!("{e}"));
    let e = err(&pair(0.2 - 0.0002));
    assert_eq!((e.line, e.key.as_str()), (5, "body[1]"), "{e}");
    assert!(e.message.contains("overlap by 0.0002 m (more than the 0.0001 m tolerated there)"), "{e}");
}
