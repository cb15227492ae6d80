//! A step that would leave a body non-finite puts it back where the step
//! began, stops it, and reports it (`World::faulted_bodies`), in the same
//! order whatever the threads; no NaN reaches a pose.

use crumble::scenes::{add_box, add_ground, BRICK};
use crumble::{BodyHandle, Quat, Vec3, World, WorldSettings};

/// 2,500 boxes resting apart on the ground (enough for the step's per-body
/// loops to run on the threads), two of them pushed by a force that
/// overflows `f32` within the step.
fn faults(threads: usize) -> (Vec<BodyHandle>, Vec<BodyHandle>, bool) {
    let mut w = World::new(WorldSettings { threads, sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let mut boxes = Vec::new();
    for i in 0..50 {
        for j in 0..50 {
            let at = Vec3::new(0.3 * i as f32, 0.05, 0.3 * j as f32);
            // 1 g boxes: `f32::MAX` newtons overflow their acceleration.
            let light = crumble::Material { density: 1.0, ..BRICK };
            boxes.push(add_box(&mut w, Vec3::splat(0.1), at, Quat::IDENTITY, light, false).unwrap());
        }
    }
    let pushed = vec![boxes[2100], boxes[17]];
    for &b in &pushed {
        w.apply_force(b, Vec3::new(f32::MAX, 0.0, 0.0)).unwrap();
    }
    let before: Vec<_> = pushed.iter().map(|&b| w.body(b).unwrap().pose()).collect();
    w.step(1.0 / 60.0).unwrap();
    let all_finite = boxes.iter().all(|&b| w.body(b).unwrap().pose().is_finite());
    let restored = pushed.iter().zip(&before).all(|(&b, p)| {
        let body = w.body(b).unwrap();
        body.pose() == *p && body.linear_velocity() == Vec3::ZERO && body.is_faulted()
    });
    (w.faulted_bodies().to_vec(), pushed, all_finite && restored)
}

#[test]
fn a_body_whose_step_overflows_is_put_back_and_reported_in_order() {
    let (serial, pushed, ok) = faults(1);
    eprintln!("faulted: {serial:?}");
    assert!(ok, "a pose went non-finite, or a faulted body was not put back and stopped");
    // Reported in the awake order: creation order here.
    assert_eq!(serial, vec![pushed[1], pushed[0]]);
    let (threaded, _, ok) = faults(2);
    assert!(ok);
    assert_eq!(threaded, serial, "faults reported in another order on two threads");
}

/// A box pushed once by `f32::MAX` newtons while another rests on it: the
/// step faults both (their contact's impulses go NaN) and puts them back.
/// The fault ends with its step: the contact keeps none of the NaN (which
/// would warm-start every later step and fault both boxes in each), the
/// next steps are ordinary ones, the boxes are no longer marked faulted,
/// the top one rests on the bottom one again, and the world's snapshot
/// restores and continues with the same bits.
#[test]
fn a_fault_does_not_outlive_its_step_through_a_contact() {
    let settings = WorldSettings { threads: 1, sleep_enabled: false, ..WorldSettings::default() };
    let mut w = World::new(settings).unwrap();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let light = crumble::Material { density: 1.0, ..BRICK };
    let bottom = add_box(&mut w, Vec3::splat(0.1), Vec3::new(0.0, 0.05, 0.0), Quat::IDENTITY, light, false).unwrap();
    let top = add_box(&mut w, Vec3::splat(0.1), Vec3::new(0.0, 0.15, 0.0), Quat::IDENTITY, light, false).unwrap();
    for _ in 0..10 {
        w.step(1.0 / 60.0).unwrap();
    }
    w.apply_force(bottom, Vec3::new(f32::MAX, 0.0, 0.0)).unwrap();
    w.step(1.0 / 60.0).unwrap();
    assert!(w.faulted_bodies().contains(&bottom), "the push faults the box it pushes");
    let mut copy = World::restore(&w.snapshot()).expect("a world after a fault restores");
    for step in 0..30 {
        w.step(1.0 / 60.0).unwrap();
        copy.step(1.0 / 60.0).unwrap();
        assert!(w.faulted_bodies().is_empty(), "step {step} after the fault: {:?} faulted", w.faulted_bodies());
        assert!(w.snapshot() == copy.snapshot(), "step {step}: the restored copy went its own way");
    }
    let (b, t) = (w.body(bottom).unwrap(), w.body(top).unwrap());
    assert!(!b.is_faulted() && !t.is_faulted(), "a sound step clears the mark");
    // Resting face on face: the faces overlap by at most the solver's
    // linear slop (what it leaves unpushed; measured 1.0e-6 m), and the
    // top box moves slower than the sleep threshold's speed (measured
    // 2.4e-9 m/s).
    let overlap = 0.1 - (t.position().y - b.position().y);
    assert!(overlap.abs() <= settings.linear_slop, "the faces overlap by {overlap} m");
    assert!(t.linear_velocity().length() < settings.sleep_threshold, "top at {}", t.linear_velocity());
}

/// The same through a joint: the step that faults a jointed body leaves
/// the joint's impulses NaN; the joint keeps none of them, reports no
/// force (a NaN would never break it), and the next step starts it cold.
#[test]
fn a_fault_does_not_outlive_its_step_through_a_joint() {
    let mut w = World::new(WorldSettings { threads: 1, sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    let light = crumble::Material { density: 1.0, ..BRICK };
    let a = add_box(&mut w, Vec3::splat(0.1), Vec3::new(0.0, 1.0, 0.0), Quat::IDENTITY, light, false).unwrap();
    let b = add_box(&mut w, Vec3::splat(0.1), Vec3::new(0.2, 1.0, 0.0), Quat::IDENTITY, light, false).unwrap();
    let joint = w.insert_joint(crumble::JointBuilder::spherical(a, b).anchor(Vec3::new(0.1, 1.0, 0.0))).unwrap();
    for _ in 0..3 {
        w.step(1.0 / 60.0).unwrap();
    }
    w.apply_force(a, Vec3::new(f32::MAX, 0.0, 0.0)).unwrap();
    w.step(1.0 / 60.0).unwrap();
    assert!(w.faulted_bodies().contains(&a));
    let j = w.joint(joint).unwrap();
    assert!(j.force().is_finite() && j.torque().is_finite(), "force {} torque {}", j.force(), j.torque());
    World::restore(&w.snapshot()).expect("a world after a fault restores");
    w.step(1.0 / 60.0).unwrap();
    assert!(w.faulted_bodies().is_empty(), "{:?}", w.faulted_bodies());
    assert!(!w.body(a).unwrap().is_faulted());
}
