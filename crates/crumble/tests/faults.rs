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
