//! State files (issue 50, item 3): a simulation saved and resumed continues
//! bit for bit, pieces of broken bricks and projectiles still to launch
//! included; a file cut short, changed, or of another kind, and a state
//! whose fields cannot be right, are refused with the byte and field at
//! fault, never with a panic.

use crumble::{Pose, Quat, Vec3};
use crumble_scene::state::{STATE_HEADER_BYTES, STATE_MAGIC};
use crumble_scene::{build, builtin, parse, RunInfo, SampledFrame, Simulation, StateError};

fn built(text: &str) -> Simulation {
    build(&parse(text, "test.toml").expect("parses")).expect("builds")
}

fn builtin_scene(name: &str) -> Simulation {
    built(builtin::find(name).expect("built in").source)
}

fn stepped(mut sim: Simulation, steps: usize) -> Simulation {
    for _ in 0..steps {
        sim.step().expect("steps");
    }
    sim
}

/// A run info with everything present: a camera and a sampled frame of
/// the first `bodies` bodies.
fn run_info(bodies: usize) -> RunInfo {
    RunInfo {
        scene: "test.toml".into(),
        camera: Some(crumble_scene::CameraSpec { eye: Some([3.0, 2.0, 4.0]), target: None, fov_deg: 40.0 }),
        frame: Some(SampledFrame {
            fps: 30,
            index: 0,
            positions: vec![[0.0, 1.0, 2.0]; bodies],
            rotations: vec![[0.0, 0.0, 0.0, 1.0]; bodies],
        }),
    }
}

/// FNV-1a 64, as the format's checksum.
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3))
}

/// `bytes` with its header's length and checksum made to match its
/// contents again: for changes the checksum would otherwise catch.
fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
    let contents = bytes[STATE_HEADER_BYTES..].to_vec();
    bytes[20..28].copy_from_slice(&(contents.len() as u64).to_le_bytes());
    bytes[28..36].copy_from_slice(&fnv(&contents).to_le_bytes());
    bytes
}

fn refused(bytes: &[u8]) -> StateError {
    match Simulation::resume(bytes) {
        Ok(_) => panic!("a bad state was resumed"),
        Err(e) => e,
    }
}

/// Refused as invalid, at `field` (a part of the message's field), with
/// `problem` in the message.
fn refused_at(bytes: &[u8], field: &str, problem: &str) {
    let e = refused(bytes);
    let StateError::Invalid { field: f, problem: p, offset } = &e else { panic!("{e}: not an invalid field") };
    assert!(f.contains(field) && p.contains(problem), "{e}: expected `{field}` and `{problem}`");
    assert!(*offset >= STATE_HEADER_BYTES && *offset < bytes.len(), "{e}: offset out of the file");
    eprintln!("refused: {e}");
}

/// A simulation changed by `edit`, saved with `run`: its state is refused
/// at `field`, saying `problem`.
fn edited(mut sim: Simulation, run: &RunInfo, edit: impl FnOnce(&mut Simulation), field: &str, problem: &str) {
    edit(&mut sim);
    refused_at(&sim.save_state(run), field, problem);
}

#[test]
fn every_truncation_is_refused_as_one() {
    let sim = stepped(builtin_scene("falling_cube"), 5);
    let bytes = sim.save_state(&run_info(2));
    eprintln!("falling_cube after 5 steps: {} bytes", bytes.len());
    assert_eq!(refused(&[]), StateError::Empty);
    for len in 1..bytes.len() {
        let e = refused(&bytes[..len]);
        let right = match len {
            ..STATE_HEADER_BYTES => e == StateError::TruncatedHeader(len),
            _ => matches!(e, StateError::Truncated { found, .. } if found == (len - STATE_HEADER_BYTES) as u64),
        };
        assert!(right, "cut at {len} of {}: {e}", bytes.len());
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert_eq!(refused(&longer), StateError::Trailing(1));
}

#[test]
fn every_changed_byte_is_refused_by_the_part_of_the_header_it_changes() {
    let sim = stepped(builtin_scene("falling_cube"), 5);
    let bytes = sim.save_state(&run_info(2));
    for i in 0..bytes.len() {
        for flip in [0x01u8, 0x80, 0xff] {
            let mut bad = bytes.clone();
            bad[i] ^= flip;
            let e = refused(&bad);
            let right = match i {
                0..16 => matches!(e, StateError::NotState(_)),
                16..20 => matches!(e, StateError::Version(_)),
                20..28 => matches!(e, StateError::Truncated { .. } | StateError::Trailing(_)),
                _ => matches!(e, StateError::Checksum { .. }),
            };
            assert!(right, "byte {i} ^ {flip:#04x}: {e}");
        }
    }
}

#[test]
fn files_of_other_kinds_are_not_state_files_and_say_what_they_look_like() {
    let cases: [(&[u8], &str); 6] = [
        (b"glTF\x02\0\0\0", "glTF"),
        (b"{\"fps\": 30}", "JSON"),
        (b"frame,t,body,x,y,z\n", "CSV"),
        (b"[world]\nseconds = 3.0\n", "text"),
        (b"\x89PNG\r\n\x1a\n", "PNG"),
        (b"\0\x01\x02\x03", ""),
    ];
    for (bytes, like) in cases {
        let e = refused(bytes);
        assert!(matches!(e, StateError::NotState(_)) && e.to_string().contains(like), "{e}");
    }
    // The start of the magic bytes alone is a file cut short.
    assert_eq!(refused(&STATE_MAGIC[..7]), StateError::TruncatedHeader(7));
}

#[test]
fn contents_that_cannot_be_right_are_refused_at_their_field() {
    let cube = || stepped(builtin_scene("falling_cube"), 5);
    let run = run_info(2);
    let nan_pose = Pose::new(Vec3::new(0.0, f32::NAN, 0.0), Quat::IDENTITY);
    edited(cube(), &run, |s| s.bodies[1].parent = Some((1, Pose::IDENTITY)), "body 1 (`cube`): parent", "earlier");
    edited(cube(), &run, |s| s.bodies[1].initial = nan_pose, "body 1 (`cube`): initial pose", "finite");
    let unnormalised = Pose::new(Vec3::ZERO, Quat::from_xyzw(0.0, 0.0, 0.0, 2.0));
    edited(cube(), &run, |s| s.bodies[1].initial = unnormalised, "initial pose", "unit quaternion");
    edited(cube(), &run, |s| s.bodies[1].name = "ground".into(), "body 1: name", "earlier body");
    edited(cube(), &run, |s| s.bodies[1].spawn_time = -1.0, "spawn time", "negative");
    edited(cube(), &run, |s| s.bodies[1].despawn = Some((f64::NAN, Pose::IDENTITY)), "time it broke", "finite");
    let flat = crumble_scene::BodyShape::Box { half_extents: Vec3::new(0.1, 0.0, 0.1) };
    edited(cube(), &run, |s| s.bodies[1].shape = flat, "half extents", "positive");
    let sphere = crumble_scene::BodyShape::Sphere { radius: f32::INFINITY };
    edited(cube(), &run, |s| s.bodies[1].shape = sphere, "radius", "finite");
    edited(cube(), &run, |s| s.dt = 0.0, "step", "positive");
    edited(cube(), &run, |s| s.seconds = f32::NAN, "scene's seconds", "finite");

    let run_with = |edit: &dyn Fn(&mut RunInfo)| {
        let mut r = run_info(2);
        edit(&mut r);
        r
    };
    let bad_fov = run_with(&|r| r.camera.as_mut().expect("a camera").fov_deg = 180.0);
    edited(cube(), &bad_fov, |_| {}, "camera field of view", "1 to 170");
    let too_many = run_with(&|r| {
        let f = r.frame.as_mut().expect("a frame");
        f.positions.push([0.0; 3]);
        f.rotations.push([0.0, 0.0, 0.0, 1.0]);
    });
    edited(cube(), &too_many, |_| {}, "sampled frame's body count", "of 2 in the state");
    let nan = run_with(&|r| r.frame.as_mut().expect("a frame").positions[1][2] = f32::NAN);
    edited(cube(), &nan, |_| {}, "sampled frame, body 1: position", "finite");
    let late = run_with(&|r| r.frame.as_mut().expect("a frame").index = 30);
    edited(cube(), &late, |_| {}, "sampled frame's number", "after the state's time");
    let still = run_with(&|r| r.frame.as_mut().expect("a frame").fps = 0);
    edited(cube(), &still, |_| {}, "sampled frame's rate", "0 frames per second");

    // Bytes the checksum would catch, sealed again: the contents are read
    // field by field whatever the checksum says.
    let bytes = cube().save_state(&run);
    let name_at = STATE_HEADER_BYTES + 4;
    let mut bad = bytes.clone();
    bad[name_at] = 0xff;
    refused_at(&resealed(bad), "scene name", "not UTF-8");
    let camera_at = name_at + run.scene.len();
    let mut bad = bytes.clone();
    bad[camera_at] = 2;
    refused_at(&resealed(bad), "camera", "0 (absent) or 1 (present)");
    let mut bad = bytes.clone();
    bad.push(7);
    refused_at(&resealed(bad), "end", "1 bytes follow the last field");
    let mut bad = bytes.clone();
    bad.truncate(bytes.len() - 3);
    refused_at(&resealed(bad), "sampled frame's body count", "cannot fit");
    // The world's snapshot's length after the camera (a flag, the eye's
    // flag and three floats, the target's flag, the field of view), the
    // time, the step and the scene's seconds; the body count after it.
    let world_len_at = camera_at + 19 + 8 + 4 + 4;
    let world_len = u64::from_le_bytes(bytes[world_len_at..world_len_at + 8].try_into().expect("8 bytes"));
    let count_at = world_len_at + 8 + world_len as usize;
    let mut bad = bytes.clone();
    bad[count_at..count_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    refused_at(&resealed(bad), "body count", "cannot fit");
    let mut bad = bytes.clone();
    bad[world_len_at..world_len_at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
    refused_at(&resealed(bad), "world's snapshot length", "are left");
}

/// The tower (a projectile launched at 1 s) 0.5 s in: its projectile waits.
fn tower_waiting() -> Simulation {
    let sim = stepped(builtin_scene("tower"), 30);
    assert_eq!(sim.pending.len(), 1, "the projectile waits");
    sim
}

#[test]
fn projectiles_that_cannot_be_waiting_are_refused() {
    let run = run_info(0);
    let i = tower_waiting().pending[0].index;
    let name = tower_waiting().bodies[i].name.clone();
    eprintln!("tower: projectile {i} `{name}` waits");
    edited(tower_waiting(), &run, |s| s.pending[0].index = 999, "projectile 0: body", "body 999 of");
    edited(tower_waiting(), &run, |s| s.pending[0].time = f64::INFINITY, "projectile 0: launch time", "finite");
    edited(
        tower_waiting(),
        &run,
        |s| {
            let again = s.pending[0].clone();
            s.pending.push(again);
        },
        "projectile 1: body",
        "not waiting",
    );
    edited(
        tower_waiting(),
        &run,
        |s| {
            let mut earlier = s.pending[0].clone();
            earlier.time = 0.25;
            s.pending.push(earlier);
        },
        "projectile 1: launch time",
        "before the launch before it",
    );
    edited(tower_waiting(), &run, move |s| s.bodies[i].despawn = Some((0.1, Pose::IDENTITY)), "body", "not waiting");
}

/// `brick_wall` with its wall of the built-in breakable brick and its ball
/// launched at 0.3 s: the ball splits the bricks it strikes.
fn late_ball_breaking_wall() -> Simulation {
    let text = builtin::find("brick_wall").expect("built in").source;
    let text = text
        .replace("material = \"clay\"\n\n[[projectile]]", "material = \"brick\"\n\n[[projectile]]")
        .replace("at = 0.0", "at = 0.3");
    assert!(text.contains("material = \"brick\"") && text.contains("at = 0.3"), "the scene changed");
    built(&text)
}

/// Everything a simulation is, as text with every float's bits: the
/// bodies' records (a handle as its slot, when the world holds it), their
/// poses, speeds and sleep, the schedule, and every body of the world
/// with its velocities.
fn everything(sim: &Simulation) -> String {
    use std::fmt::Write;
    let bits = |p: Pose| (p.position.to_array().map(f32::to_bits), p.rotation.to_array().map(f32::to_bits));
    let mut s = format!("time {:x}, dt {:x}\n", sim.time().to_bits(), sim.dt.to_bits());
    for (i, b) in sim.bodies.iter().enumerate() {
        let handle = b.handle.filter(|&h| sim.world.body(h).is_some()).map(|h| h.index());
        let parent = b.parent.map(|(p, pose)| (p, bits(pose)));
        let despawn = b.despawn.map(|(t, pose)| (t.to_bits(), bits(pose)));
        writeln!(
            s,
            "{} {:?} {} {} {} {:?} {handle:?} {:x} {parent:?} {despawn:?} {:?} {:x} {}",
            b.name,
            b.shape,
            b.is_static,
            b.metal,
            b.source,
            bits(b.initial),
            b.spawn_time.to_bits(),
            bits(sim.pose(i)),
            sim.speed(i).to_bits(),
            sim.is_sleeping(i)
        )
        .expect("writes");
    }
    writeln!(s, "pending {:?}", sim.pending).expect("writes");
    for (h, b) in sim.world.bodies() {
        let (v, w) = (b.linear_velocity().to_array(), b.angular_velocity().to_array());
        writeln!(
            s,
            "{h:?} {:?} {:?} {:?} {}",
            bits(b.pose()),
            v.map(f32::to_bits),
            w.map(f32::to_bits),
            b.is_sleeping()
        )
        .expect("writes");
    }
    s
}

/// Saved after `save` steps and resumed, `sim` goes on for `more` steps as
/// it does uninterrupted; its state saved again then is the same bytes.
fn continues_bit_for_bit(name: &str, make: fn() -> Simulation, save: usize, more: usize) -> (Simulation, Simulation) {
    let saved = stepped(make(), save);
    let run = run_info(saved.bodies.len());
    let bytes = saved.save_state(&run);
    let (resumed, info) = match Simulation::resume(&bytes) {
        Ok(r) => r,
        Err(e) => panic!("{name}: resuming after {save} steps: {e}"),
    };
    assert_eq!(info, run, "{name}: the run info comes back");
    assert_eq!(everything(&resumed), everything(&saved), "{name}: resumed as saved");
    assert_eq!(resumed.save_state(&run), bytes, "{name}: saved again, the same bytes");
    let (mut a, mut b) = (saved, resumed);
    for step in 1..=more {
        a.step().expect("steps");
        b.step().expect("steps");
        assert_eq!(everything(&a), everything(&b), "{name}: step {step} after the save");
    }
    (a, b)
}

#[test]
fn a_resumed_simulation_continues_bit_for_bit_through_launches_and_breaks() {
    // Saved at 0.2 s: the ball launches at 0.3 s and splits bricks.
    let (a, _) = continues_bit_for_bit("ball launched later", late_ball_breaking_wall, 12, 48);
    let pieces = a.bodies.iter().filter(|b| b.parent.is_some()).count();
    eprintln!("ball launched later: {pieces} pieces by 1 s");
    assert!(a.pending.is_empty() && pieces > 0, "launched, and bricks broke after the save");
    // Saved at 0.8 s, after the splits: the pieces are in the state.
    let (a, _) = continues_bit_for_bit("pieces saved", late_ball_breaking_wall, 48, 30);
    assert!(a.bodies.iter().any(|b| b.despawn.is_some()), "bricks broke before the save");
    // Saved right after the step in which the first brick split.
    let mut probe = late_ball_breaking_wall();
    let split = (1..=60).find(|_| {
        probe.step().expect("steps");
        !probe.world.fracture_events().is_empty()
    });
    let split = split.expect("a brick splits within 1 s");
    eprintln!("ball launched later: the first split in step {split}");
    continues_bit_for_bit("saved at a split", late_ball_breaking_wall, split, 20);
    // Joints and mortar: the wrecking ball into its wall, saved mid-swing.
    continues_bit_for_bit("demolition", || builtin_scene("demolition"), 30, 30);
}

#[test]
fn handles_the_restored_world_does_not_hold_as_listed_are_refused() {
    let run = run_info(0);
    let cube = || stepped(builtin_scene("falling_cube"), 5);
    edited(cube(), &run, |s| s.bodies[1].handle = s.bodies[0].handle, "body 1 (`cube`): handle", "body 0's too");
    let broke = |s: &mut Simulation| s.bodies[1].despawn = Some((0.05, Pose::IDENTITY));
    edited(cube(), &run, broke, "body 1 (`cube`): handle", "the body broke");
    let e = {
        let mut s = cube();
        s.bodies[1].handle = None;
        refused(&s.save_state(&run))
    };
    assert!(matches!(&e, StateError::World { message, .. } if message.contains("holds 2 bodies")), "{e}");
}

#[test]
fn every_changed_byte_sealed_again_is_refused_or_read_without_a_panic() {
    // The checksum made to match again: every field is read and checked
    // (the world's snapshot by the world, with its own checksum).
    let sim = stepped(builtin_scene("falling_cube"), 5);
    let bytes = sim.save_state(&run_info(2));
    let (mut refused, mut world) = (0, 0);
    for i in STATE_HEADER_BYTES..bytes.len() {
        let mut bad = bytes.clone();
        bad[i] ^= 0x41;
        match Simulation::resume(&resealed(bad)) {
            Ok(_) => {}
            Err(StateError::World { .. }) => world += 1,
            Err(_) => refused += 1,
        }
    }
    let n = bytes.len() - STATE_HEADER_BYTES;
    eprintln!("{n} bytes changed: {refused} refused by the state's checks, {world} by the world's");
    // The world's snapshot is more than half the contents here, and every
    // change to it is caught by its own checksum.
    assert!(world > n / 2 && refused > 0, "{refused} and {world} of {n}");
}
