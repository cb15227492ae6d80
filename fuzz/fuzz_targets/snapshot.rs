//! Arbitrary bytes as a snapshot: given to `World::restore` as they are
//! (the header's checks), and as a payload sealed with a valid header and
//! checksum (the checks of the world's contents). A world that restores
//! must save the same bytes again, and step a few times.
//!
//! The property: no panic, no hang, no runaway allocation; after each
//! step every body's pose is finite or the body is reported in
//! `World::faulted_bodies`. Refusing the bytes (a `SnapshotError`) is a
//! correct outcome, not a finding.

#![no_main]

use crumble::snapshot::seal;
use crumble::World;
use libfuzzer_sys::fuzz_target;

/// Worlds with more bodies are restored but not stepped (as the scene
/// target's bound, so that each input stays fast).
const MAX_STEPPED_BODIES: usize = 128;

const STEPS: usize = 3;

fuzz_target!(|data: &[u8]| {
    let _ = World::restore(data);
    let Ok(mut world) = World::restore(&seal(data)) else { return };
    let saved = world.snapshot();
    let again = World::restore(&saved).expect("a restored world's snapshot restores");
    assert!(again.snapshot() == saved, "snapshot → restore → snapshot changed the bytes");
    if world.body_count() > MAX_STEPPED_BODIES {
        return;
    }
    world.set_threads(1).expect("one thread");
    for step in 0..STEPS {
        if world.step(1.0 / 60.0).is_err() {
            break;
        }
        let faulted = world.faulted_bodies();
        for (h, body) in world.bodies() {
            assert!(
                body.pose().is_finite() || faulted.contains(&h),
                "step {step}: body {h:?} has a non-finite pose and is not reported as faulted"
            );
        }
    }
});
