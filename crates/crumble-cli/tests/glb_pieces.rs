//! Bricks that break, in the `.glb`: a piece's node is hidden (scale 0)
//! until its split and shown from then on, the brick it broke from is shown
//! until then and hidden after, and bodies that never break have no scale
//! channel at all.

use crumble_cli::glb::to_glb;
use crumble_cli::record::Recording;
use gltf::animation::util::ReadOutputs;
use gltf::animation::{Interpolation, Property};

/// The seed wall of the built-in, breakable `brick` material, hit at
/// mid-height by a 0.075 m steel ball at 15 m/s: three bricks split in two
/// within 0.15 s.
const BREAKING_WALL: &str = r#"
[world]
seconds = 0.4

[world.ground]
material = "brick"

[[wall]]
name = "wall"
rows = 10
bricks_per_row = 10
brick = [0.215, 0.065, 0.1025]
bond = "running"
facing = [0.0, 0.0, 1.0]
material = "brick"

[[projectile]]
name = "ball"
shape = "sphere"
radius = 0.075
from = [0.0, 0.325, 2.0]
velocity = [0.0, 0.0, -15.0]
at = 0.0
material = "steel"
"#;

/// Runs `text` for its `seconds` and records it at `fps` as the `crumble`
/// command does: a frame before the first step, then each frame once the
/// step that reaches its time (within half a step) is done.
fn record(text: &str, fps: u32) -> Recording {
    let scene = crumble_scene::parse(text, "scene.toml").unwrap();
    let mut sim = crumble_scene::build(&scene).unwrap();
    let seconds = sim.seconds as f64;
    let steps = crumble_scene::step_count(seconds, sim.dt);
    let mut rec = Recording::new(&sim, fps);
    rec.capture(&sim);
    for _ in 0..steps {
        sim.step().unwrap();
        let now = sim.time();
        while rec.next_time() <= now + 0.5 * sim.dt as f64 && rec.next_time() <= seconds + 1e-9 {
            rec.capture(&sim);
        }
    }
    rec
}

/// A node's stepped scale channel: its key times and its x scales.
struct ScaleChannel {
    interpolation: Interpolation,
    times: Vec<f32>,
    scales: Vec<[f32; 3]>,
}

impl ScaleChannel {
    /// The x scale at `t` under STEP interpolation: the value of the last
    /// key at or before `t` (the first key's before it).
    fn at(&self, t: f32) -> f32 {
        let k = self.times.iter().rposition(|&key| key <= t).unwrap_or(0);
        self.scales[k][0]
    }
}

/// The `.glb` of `rec`, parsed back: each node's scale channel (if any),
/// each node's own scale, and every frame's time as the file stores it.
fn scale_channels(rec: &Recording) -> (Vec<Option<ScaleChannel>>, Vec<[f32; 3]>) {
    let bytes = to_glb(rec).unwrap();
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = gltf.blob.clone().unwrap();
    assert_eq!(gltf.nodes().count(), rec.bodies.len(), "one node per body, pieces and broken bodies included");
    let node_scales: Vec<[f32; 3]> = gltf.nodes().map(|n| n.transform().decomposed().2).collect();
    let mut channels: Vec<Option<ScaleChannel>> = (0..rec.bodies.len()).map(|_| None).collect();
    let anims: Vec<_> = gltf.animations().collect();
    assert_eq!(anims.len(), 1, "one animation");
    for ch in anims[0].channels().filter(|c| c.target().property() == Property::Scale) {
        let i = ch.target().node().index();
        let reader = ch.reader(|_| Some(&blob));
        let times: Vec<f32> = reader.read_inputs().unwrap().collect();
        let Some(ReadOutputs::Scales(scales)) = reader.read_outputs() else {
            panic!("node {i}: scale channel without scales")
        };
        let scales: Vec<[f32; 3]> = scales.collect();
        let name = &rec.bodies[i].name;
        assert_eq!(times.len(), scales.len(), "{name}: one scale per key time (STEP has no tangents)");
        assert!(times.windows(2).all(|w| w[0] < w[1]), "{name}: key times strictly increase: {times:?}");
        assert!(scales.iter().all(|s| s[0] == s[1] && s[1] == s[2]), "{name}: scales are uniform: {scales:?}");
        let old = channels[i].replace(ScaleChannel { interpolation: ch.sampler().interpolation(), times, scales });
        assert!(old.is_none(), "{name}: one scale channel, not two");
    }
    (channels, node_scales)
}

#[test]
fn pieces_appear_and_broken_bricks_disappear_when_they_split() {
    // 24 fps at the scene's 60 Hz step: splits fall between frames, where
    // the scale keys are the split times and not frame times.
    let rec = record(BREAKING_WALL, 24);
    let frame_times: Vec<f32> = rec.frames.iter().map(|f| f.t as f32).collect();
    let last = *frame_times.last().unwrap();
    let pieces: Vec<usize> = (0..rec.bodies.len()).filter(|&i| rec.bodies[i].parent.is_some()).collect();
    let broken: Vec<usize> = (0..rec.bodies.len()).filter(|&i| rec.bodies[i].despawn.is_some()).collect();
    assert!(!pieces.is_empty() && !broken.is_empty(), "the ball splits bricks: {} pieces", pieces.len());
    assert!(
        pieces.iter().any(|&i| !frame_times.contains(&(rec.bodies[i].spawn_time as f32))),
        "a split falls between two frames"
    );
    let (channels, node_scales) = scale_channels(&rec);

    for &i in &pieces {
        let body = &rec.bodies[i];
        let appears = body.spawn_time as f32;
        assert!(appears > frame_times[0] && appears < last, "{}: splits within the recording, at {appears}", body.name);
        let ch = channels[i].as_ref().unwrap_or_else(|| panic!("{}: a piece has a scale channel", body.name));
        assert_eq!(ch.interpolation, Interpolation::Step, "{}: the piece's scale steps, never shrinks", body.name);
        for &t in frame_times.iter().chain([&appears]) {
            let want = if t < appears { 0.0 } else { 1.0 };
            assert_eq!(ch.at(t), want, "{}: scale at {t} s, split at {appears} s", body.name);
        }
        assert_eq!(
            node_scales[i], [0.0; 3],
            "{}: the node is hidden at the first frame without the animation too",
            body.name
        );
    }

    for &i in &broken {
        let body = &rec.bodies[i];
        let (gone, _) = body.despawn.unwrap();
        let gone = gone as f32;
        let ch =
            channels[i].as_ref().unwrap_or_else(|| panic!("{}: a brick that broke has a scale channel", body.name));
        assert_eq!(ch.interpolation, Interpolation::Step, "{}: the broken brick's scale steps", body.name);
        for &t in frame_times.iter().chain([&gone]) {
            let want = if t < gone { 1.0 } else { 0.0 };
            assert_eq!(ch.at(t), want, "{}: scale at {t} s, broke at {gone} s", body.name);
        }
        assert_eq!(node_scales[i], [1.0; 3], "{}: the node is shown at the first frame", body.name);
        // Its pieces take over at the instant it goes: never both shown,
        // never neither.
        for &p in pieces.iter().filter(|&&p| rec.bodies[p].parent.unwrap().0 == i) {
            let piece = channels[p].as_ref().unwrap();
            for &t in &frame_times {
                assert_eq!(ch.at(t) + piece.at(t), 1.0, "{} or its piece {} at {t} s", body.name, rec.bodies[p].name);
            }
        }
    }

    for (i, body) in rec.bodies.iter().enumerate().filter(|(_, b)| b.parent.is_none() && b.despawn.is_none()) {
        assert!(channels[i].is_none(), "{}: a body that never breaks has no scale channel", body.name);
        assert_eq!(node_scales[i], [1.0; 3], "{}: a body that never breaks keeps the node scale 1", body.name);
    }
}

#[test]
fn a_scene_without_fracture_has_no_scale() {
    // The same wall of the unbreakable `default` material: nothing splits.
    let text = BREAKING_WALL.replace("material = \"brick\"", "material = \"default\"");
    let rec = record(&text, 30);
    assert!(rec.bodies.iter().all(|b| b.parent.is_none() && b.despawn.is_none()), "nothing breaks");
    let bytes = to_glb(&rec).unwrap();
    let (channels, node_scales) = scale_channels(&rec);
    assert!(channels.iter().all(Option::is_none), "no body has a scale channel");
    assert!(node_scales.iter().all(|s| *s == [1.0; 3]), "every node has scale 1");
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = std::str::from_utf8(&bytes[20..20 + json_len]).unwrap();
    assert!(!json.contains("\"scale\""), "no node or channel names a scale");
}
