//! `crumble run` on a scene whose bricks break (issue 49): the JSON lists
//! every piece with its parent and the time it appears, the broken brick
//! with the time it disappears; before it appears a piece moves as a part
//! of its parent (its parent's pose field), after it breaks a brick stays
//! where it broke; the CSV carries the same three columns.

use assert_cmd::Command;
use crumble_scene::builtin;
use serde_json::Value;

/// `brick_wall` with its wall in the built-in breakable `brick`: the ball
/// splits the three bricks it strikes in steps 7 and 8.
fn scene() -> String {
    let text = builtin::find("brick_wall")
        .expect("built in")
        .source
        .replace("material = \"clay\"\n\n[[projectile]]", "material = \"brick\"\n\n[[projectile]]");
    assert!(text.contains("material = \"brick\"\n\n[[projectile]]"), "the wall's material replaced");
    text
}

fn v3(v: &Value) -> [f64; 3] {
    [0, 1, 2].map(|k| v[k].as_f64().expect("a number"))
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// `v` turned by the unit quaternion `q` = `[x, y, z, w]`, or by its
/// inverse when `inverse`.
fn rotate(q: &Value, v: [f64; 3], inverse: bool) -> [f64; 3] {
    let [x, y, z, w] = [0, 1, 2, 3].map(|k| q[k].as_f64().expect("a number"));
    let (x, y, z) = if inverse { (-x, -y, -z) } else { (x, y, z) };
    // v + 2 w (u × v) + 2 u × (u × v), u the vector part.
    let c = [y * v[2] - z * v[1], z * v[0] - x * v[2], x * v[1] - y * v[0]];
    let cc = [y * c[2] - z * c[1], z * c[0] - x * c[2], x * c[1] - y * c[0]];
    [0, 1, 2].map(|k| v[k] + 2.0 * w * c[k] + 2.0 * cc[k])
}

/// A brick of a weak chalk thrown spinning at a static post: it turns
/// three radians in flight and splits when it strikes.
const THROWN: &str = "[world]\nseconds = 0.8\n\n[world.ground]\n\n\
[materials.chalk]\ndensity = 2000.0\ntensile_strength = 2e4\nshear_strength = 6e4\n\n\
[[body]]\nname = \"brick\"\nshape = \"box\"\nsize = [0.215, 0.065, 0.1025]\nposition = [0.0, 1.5, 0.0]\n\
velocity = [8.0, 0.0, 0.0]\nangular_velocity = [0.0, 2.0, 8.0]\nmaterial = \"chalk\"\n\n\
[[body]]\nname = \"post\"\nshape = \"box\"\nsize = [0.2, 3.0, 2.0]\nposition = [3.2, 1.5, 0.0]\nstatic = true\n";

#[test]
fn pieces_appear_at_their_split_in_the_json_and_the_csv_moving_as_a_part_of_their_parent_before() {
    // Measured: the wall's three struck bricks break (6 pieces); the
    // thrown brick, which turned about three radians in flight, breaks in
    // two when it strikes the post.
    for (name, text) in [("wall", scene()), ("thrown", THROWN.to_owned())] {
        let pieces = check(&text);
        eprintln!("{name}: {pieces} pieces");
        assert!(pieces >= 2, "{name}: nothing broke");
    }
}

/// Runs `text` to JSON and CSV and checks every piece (see the module
/// docs); returns how many pieces there were.
fn check(text: &str) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("scene.toml");
    std::fs::write(&file, text).unwrap();
    let (json, csv) = (dir.path().join("out.json"), dir.path().join("out.csv"));
    let out = Command::cargo_bin("crumble")
        .unwrap()
        .args(["run", file.to_str().unwrap(), "--seconds", "0.5", "--fps", "60", "--quiet", "--out"])
        .arg(&json)
        .arg("--out")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let summary = String::from_utf8_lossy(&out.stdout).into_owned();
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let bodies = doc["bodies"].as_array().unwrap();
    let frames = doc["frames"].as_array().unwrap();
    let index = |name: &str| bodies.iter().position(|b| b["name"] == name).unwrap_or_else(|| panic!("{name}"));
    let pieces: Vec<usize> = (0..bodies.len()).filter(|&i| bodies[i].get("parent").is_some()).collect();
    let broken: Vec<usize> = (0..bodies.len()).filter(|&i| bodies[i].get("disappears").is_some()).collect();
    assert!(!broken.is_empty(), "no brick broke");
    assert_eq!(pieces.len(), 2 * broken.len(), "two pieces a broken brick");
    // The summary counts the bodies in the world, and says what broke.
    let line = format!("broken:     {} bodies split into {} pieces", broken.len(), pieces.len());
    assert!(summary.contains(&line), "`{line}` not in:\n{summary}");
    let in_world = format!("bodies:     {}\n", bodies.len() - broken.len());
    assert!(summary.contains(&in_world), "`{in_world}` not in:\n{summary}");
    let frame_of = |t: f64| frames.iter().position(|f| f["t"].as_f64().unwrap() >= t - 1e-9).unwrap();
    for &i in &pieces {
        let b = &bodies[i];
        let p = index(b["parent"].as_str().unwrap());
        let appears = b["appears"].as_f64().expect("a piece appears");
        assert_eq!(bodies[p]["disappears"].as_f64(), Some(appears), "{} appears as its parent goes", b["name"]);
        // Before it appears the piece is a rigid part of its parent: its
        // offset from the parent's centre, in the parent's frame, is the
        // same in every frame, and inside the parent's box.
        let first = frame_of(appears);
        assert!(first > 2, "the split comes after a few frames");
        let local = |f: &Value| {
            let d = v3(&f["positions"][i]);
            let c = v3(&f["positions"][p]);
            rotate(&f["rotations"][p], [d[0] - c[0], d[1] - c[1], d[2] - c[2]], true)
        };
        let at_split = local(&frames[first - 1]);
        let half = v3(&bodies[p]["half_extents"]);
        assert!((0..3).all(|k| at_split[k].abs() <= half[k] + 1e-6), "{}: {at_split:?} outside {half:?}", b["name"]);
        for f in &frames[..first] {
            assert!(dist(local(f), at_split) < 1e-5, "{} at t {}: {:?} vs {at_split:?}", b["name"], f["t"], local(f));
        }
        // After it breaks the parent stays where it broke.
        let last = v3(&frames[frames.len() - 1]["positions"][p]);
        assert_eq!(v3(&frames[first]["positions"][p]), last, "{} moved after it broke", bodies[p]["name"]);
    }
    // The CSV: the same three columns on every row of a body.
    let text = std::fs::read_to_string(&csv).unwrap();
    for line in text.lines().skip(1) {
        let row: Vec<&str> = line.split(',').collect();
        let b = &bodies[index(row[2])];
        let field = |k: &str| b.get(k).map_or(String::new(), |v| v.as_str().map_or(v.to_string(), str::to_owned));
        assert_eq!(row[10..13], [field("parent"), field("appears"), field("disappears")], "{line}");
    }
    pieces.len()
}
