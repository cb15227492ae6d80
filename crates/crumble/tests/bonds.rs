//! Bonds (issue 48): mortar that holds two faces together until the
//! forces across it reach its strength. Every limit is written beside the
//! measured value and where the expected number comes from.

use crumble::scenes::{add_box, add_ground, add_wall, WallSpec, BRICK, BRICK_SIZE};
use crumble::{BodyBuilder, BodyHandle, BondEvent, BondMode, BondSpec, ColliderBuilder, Quat, Vec3, World, WorldError};

mod rigs;
use rigs::{static_box, world_with};

/// A brick on a static block, bonded along its bed face, pulled straight
/// up by a force rising at `rate` (N/s) from zero, gravity off. Returns
/// the force when the bond broke (the force of the step it broke in) over
/// the bond's strength × area, and the event's mode.
fn pull_test(dt: f32, substeps: u32, rate: f32) -> (f32, BondMode) {
    let mut w = world_with(|s| {
        s.substeps = substeps;
        s.gravity = Vec3::ZERO;
        s.sleep_enabled = false;
    });
    static_box(&mut w, Vec3::new(0.4, 0.2, 0.2), Vec3::new(0.0, -0.1, 0.0));
    let brick =
        add_box(&mut w, BRICK_SIZE, Vec3::new(0.0, BRICK_SIZE.y / 2.0, 0.0), Quat::IDENTITY, BRICK, false).unwrap();
    let ground_handle = w.bodies().find(|(_, b)| !b.is_dynamic()).map(|(h, _)| h).unwrap();
    let bond = w.insert_bond(ground_handle, brick, BondSpec::LIME_MORTAR).unwrap();
    let strength = BondSpec::LIME_MORTAR.tensile_strength * w.bond(bond).unwrap().area();
    for step in 1..100_000 {
        let force = rate * (step as f32 * dt);
        w.apply_force(brick, Vec3::new(0.0, force, 0.0)).unwrap();
        w.step(dt).unwrap();
        if let Some(BondEvent::Broken { mode, .. }) = w.bond_events().first() {
            return (force / strength, *mode);
        }
        assert!(force < 3.0 * strength, "no break by 3x the strength");
    }
    unreachable!()
}

#[test]
fn a_pulled_bond_breaks_at_its_tensile_strength_times_its_area() {
    for &dt in &[1.0 / 30.0, 1.0 / 60.0, 1.0 / 120.0, 1.0 / 240.0] {
        for &n in &[1u32, 2, 4, 8] {
            // Measured: 0.9983 at dt 1/30, 0.9907 at the others (the bond
            // breaks within 1% of its limit, `BREAK_AT`, and the force rises
            // by 500 N/s × dt = 1.5% of the 1.1 kN strength per step at 1/30).
            let (ratio, mode) = pull_test(dt, n, 500.0);
            eprintln!("dt 1/{:.0} substeps {n}: broke at {ratio:.4} x strength x area ({mode:?})", 1.0 / dt);
            assert!((0.95..=1.05).contains(&ratio), "dt 1/{:.0}, {n} substeps: broke at {ratio}", 1.0 / dt);
            assert_eq!(mode, BondMode::Tension);
        }
    }
}

/// A row of `n` bricks glued end to end, sticking out along +x from the
/// end face of a static block, under gravity, every joint of tensile
/// strength `tensile` (Pa) and a shear strength far above its load.
/// Returns the world, the bricks and the root bond's analytic edge stress
/// (Pa): σ = M / Z, with M the row's weight times its lever about the
/// root face and Z = b h² / 6 of the brick's end face (b its depth, h its
/// height).
fn cantilever(n: usize, tensile: f32) -> (World, Vec<BodyHandle>, f32) {
    let mut w = world_with(|s| s.sleep_enabled = false);
    let (l, h, b) = (BRICK_SIZE.x, BRICK_SIZE.y, BRICK_SIZE.z);
    let block = static_box(&mut w, Vec3::new(0.4, 0.4, 0.2), Vec3::new(-0.2, 1.0, 0.0));
    let spec = BondSpec::new(tensile, 10e6);
    let mut bricks = Vec::new();
    let mut prev = block;
    for i in 0..n {
        let x = l * (i as f32 + 0.5);
        let brick = add_box(&mut w, BRICK_SIZE, Vec3::new(x, 1.0, 0.0), Quat::IDENTITY, BRICK, false).unwrap();
        w.insert_bond(prev, brick, spec).unwrap();
        bricks.push(brick);
        prev = brick;
    }
    let m = w.body(bricks[0]).unwrap().mass() as f64;
    let moment: f64 = (0..n).map(|i| m * 9.81 * l as f64 * (i as f64 + 0.5)).sum();
    let z = b as f64 * (h as f64).powi(2) / 6.0;
    (w, bricks, (moment / z) as f32)
}

#[test]
fn a_glued_cantilever_holds_below_its_bending_strength_and_breaks_above_it() {
    let (_, _, sigma) = cantilever(4, 1.0);
    // Holds at 0.9 × capacity: strength σ / 0.9.
    let (mut w, bricks, _) = cantilever(4, sigma / 0.9);
    let tip0 = w.body(bricks[3]).unwrap().position();
    let mut broken = 0;
    let mut peak = 0.0f32;
    for _ in 0..600 {
        w.step(1.0 / 60.0).unwrap();
        broken += w.bond_events().len();
        peak = w.bonds().map(|(_, b)| b.utilisation()).fold(peak, f32::max);
    }
    let sag = tip0.y - w.body(bricks[3]).unwrap().position().y;
    let util = w.bonds().map(|(_, b)| b.utilisation()).fold(0.0, f32::max);
    eprintln!(
        "sigma {sigma:.0} Pa; at 0.9: broken {broken}, tip sag {:.3} mm, root at {util:.4} (peak {peak:.4})",
        sag * 1e3
    );
    // Measured: nothing broke, the tip sagged 0.001 mm, the root's
    // utilisation 0.9000 (the analytic 0.9: M / Z over the strength),
    // 0.943 at most (the second step, as the fresh bonds settle).
    assert_eq!(broken, 0, "bonds broke at 0.9 x capacity");
    assert!((util - 0.9).abs() < 0.01, "root utilisation {util}, analytic 0.9");
    assert!(sag < 1e-3, "tip sagged {sag} m (measured 0.001 mm)");
    // Breaks at 1.1 × capacity: strength σ / 1.1.
    let (mut w, _, _) = cantilever(4, sigma / 1.1);
    // Measured: the root is at 0.98 of its limit over the first step (the
    // fresh bond's load builds up over the step's first substep, from no
    // impulse), at its limit from then on, and it breaks at the end of
    // the second step, in tension, alone.
    w.step(1.0 / 60.0).unwrap();
    let first = w.bonds().map(|(_, b)| b.utilisation()).fold(0.0, f32::max);
    assert!(first > 0.95, "root at {first} of its limit in the first step (measured 0.98)");
    w.step(1.0 / 60.0).unwrap();
    let events = w.bond_events();
    assert_eq!(events.len(), 1, "the root bond alone breaks by the second step: {events:?}");
    let BondEvent::Broken { mode, body_a, .. } = events[0];
    assert_eq!(mode, BondMode::Tension);
    assert!(!w.body(body_a).unwrap().is_dynamic(), "the bond that broke is the root's");
}

/// The seed's 10 × 10 wall on the ground, mortared (every touching pair
/// and the bottom row to the ground) with `spec` or dry; sleep off.
fn wall_world(spec: Option<BondSpec>) -> (World, Vec<BodyHandle>) {
    let mut w = world_with(|s| s.sleep_enabled = false);
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let bricks = add_wall(&mut w, &WallSpec::default()).unwrap();
    if let Some(spec) = spec {
        let bonds = w.bond_touching(&bricks, spec).unwrap();
        // 10 rows: 9 or 10 head joints a row (95 in all: odd rows have 11
        // bricks), a bed joint for each overlap of a brick with one of the
        // course above (10 + 11 − 1 = 20 a course boundary, 180 in all),
        // and 10 bricks on the ground: 285.
        assert_eq!(bonds.len(), 95 + 180 + 10, "bonds of the 10 x 10 wall");
    }
    (w, bricks)
}

/// The largest distance any brick moved from where it started, metres.
fn max_drift(w: &World, bricks: &[BodyHandle], start: &[Vec3]) -> f32 {
    bricks.iter().zip(start).map(|(&b, &p)| (w.body(b).unwrap().position() - p).length()).fold(0.0, f32::max)
}

#[test]
fn a_mortared_wall_at_rest_stands_a_minute_without_a_break_and_drifts_no_more_than_a_dry_one() {
    let mut drift = [0.0f32; 2];
    let mut most_loaded = 0.0f32;
    for (k, spec) in [None, Some(BondSpec::LIME_MORTAR)].into_iter().enumerate() {
        let (mut w, bricks) = wall_world(spec);
        let start: Vec<Vec3> = bricks.iter().map(|&b| w.body(b).unwrap().position()).collect();
        let mut broken = 0;
        for _ in 0..3600 {
            w.step(1.0 / 60.0).unwrap();
            broken += w.bond_events().len();
        }
        drift[k] = max_drift(&w, &bricks, &start);
        assert_eq!(broken, 0, "bonds broke in a wall at rest");
        most_loaded = w.bonds().map(|(_, b)| b.utilisation()).fold(most_loaded, f32::max);
    }
    eprintln!(
        "60 s at rest: dry wall drift {:.4} mm, mortared {:.4} mm; most loaded bond at {:.3} of its strength",
        drift[0] * 1e3,
        drift[1] * 1e3,
        most_loaded
    );
    // Measured: dry 0.0115 mm, mortared 0.0002 mm; the most loaded bond
    // at 0.062 of its strength (the forces the settling passes find: see
    // `solver/contact_wide.rs`, "Bonds").
    assert!(drift[1] <= drift[0] && drift[1] < 5e-4, "mortared drift {} m, dry {} m", drift[1], drift[0]);
    assert!(most_loaded < 0.15, "a bond of a wall at rest carries {most_loaded} of its strength (measured 0.062)");
}

/// The mortared seed wall on a narrow static post under its middle, its
/// ends a metre out over nothing: it stands, glued, where the same wall
/// dry loses its ends. Cement mortar: the wall's own weight bends it in
/// its plane (about 0.7 kN·m at the post's edges, a deep beam 0.65 m
/// high).
#[test]
fn a_mortared_wall_on_a_narrow_post_stands_where_a_dry_one_loses_its_ends() {
    let mut fallen = [0usize; 2];
    for (k, mortar) in [None, Some(BondSpec::CEMENT_MORTAR)].into_iter().enumerate() {
        let mut w = world_with(|s| s.sleep_enabled = false);
        add_ground(&mut w, 0.0, BRICK).unwrap();
        // A 0.2 m wide, 0.5 m tall post, as deep as the wall.
        static_box(&mut w, Vec3::new(0.2, 0.5, BRICK_SIZE.z), Vec3::new(0.0, 0.25, 0.0));
        let spec = WallSpec { origin: Vec3::new(0.0, 0.5, 0.0), ..WallSpec::default() };
        let bricks = add_wall(&mut w, &spec).unwrap();
        if let Some(m) = mortar {
            let bonds = w.bond_touching(&bricks, m).unwrap();
            // The wall's 275 bonds between bricks, and the two bricks of
            // the bottom row that stand on the post.
            assert_eq!(bonds.len(), 95 + 180 + 2, "bonds of the wall on its post");
        }
        let start: Vec<Vec3> = bricks.iter().map(|&b| w.body(b).unwrap().position()).collect();
        for _ in 0..300 {
            w.step(1.0 / 60.0).unwrap();
        }
        fallen[k] =
            bricks.iter().zip(&start).filter(|&(&b, p)| (w.body(b).unwrap().position() - *p).length() > 0.05).count();
        let broken = w.bond_count();
        eprintln!(
            "on a post, {}: {} bricks moved more than 5 cm in 5 s, {broken} bonds left",
            if k == 0 { "dry" } else { "mortared" },
            fallen[k]
        );
    }
    // Measured: dry, most of the wall falls off the post; mortared, no
    // brick moves 5 cm.
    assert!(fallen[0] > 50, "the dry wall kept {} of its bricks near their start", 105 - fallen[0]);
    assert_eq!(fallen[1], 0, "bricks of the mortared wall fell");
}

#[test]
fn bonds_between_bodies_that_cannot_be_bonded_are_refused_with_the_reason() {
    let mut w = world_with(|_| {});
    let ground = add_ground(&mut w, 0.0, BRICK).unwrap();
    let a = add_box(&mut w, BRICK_SIZE, Vec3::new(0.0, BRICK_SIZE.y / 2.0, 0.0), Quat::IDENTITY, BRICK, false).unwrap();
    // 2 mm above the ground: farther than a millimetre.
    let floating =
        add_box(&mut w, BRICK_SIZE, Vec3::new(1.0, BRICK_SIZE.y / 2.0 + 2e-3, 0.0), Quat::IDENTITY, BRICK, false)
            .unwrap();
    let ball = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(3.0, 0.1, 0.0))).unwrap();
    w.insert_collider(ColliderBuilder::ball(0.1).unwrap(), ball).unwrap();
    let lime = BondSpec::LIME_MORTAR;
    let refused = |r: Result<_, WorldError>| match r {
        Err(WorldError::InvalidBond(why)) => why,
        other => panic!("accepted or another error: {other:?}"),
    };
    assert_eq!(refused(w.insert_bond(ground, floating, lime)), "the bodies do not touch face to face");
    assert_eq!(refused(w.insert_bond(ground, ball, lime)), "the bodies do not touch face to face");
    assert_eq!(refused(w.insert_bond(a, a, lime)), "a body bonded to itself");
    for bad in [f32::NAN, -1.0, f32::INFINITY] {
        let why = refused(w.insert_bond(ground, a, BondSpec::new(bad, 1e5)));
        assert!(why.contains("tensile strength"), "{why}");
        let why = refused(w.insert_bond(ground, a, BondSpec::new(1e5, bad)));
        assert!(why.contains("shear strength"), "{why}");
        let why = refused(w.insert_bond(ground, a, lime.friction(bad)));
        assert!(why.contains("friction"), "{why}");
    }
    let h = w.insert_bond(ground, a, lime).unwrap();
    assert_eq!(refused(w.insert_bond(a, ground, lime)), "the pair is already bonded");
    assert_eq!(w.bond_count(), 1);
    w.remove_bond(h).unwrap();
    assert!(matches!(w.remove_bond(h), Err(WorldError::UnknownBond)));
    assert_eq!(w.bond_count(), 0);
    // A removed body takes its bonds with it.
    let h = w.insert_bond(ground, a, lime).unwrap();
    w.remove_body(a).unwrap();
    assert!(w.bond(h).is_none() && w.bond_count() == 0);
    w.step(1.0 / 60.0).unwrap();
}

#[test]
fn a_joint_between_bonded_bodies_takes_the_bond_s_place() {
    let mut w = world_with(|_| {});
    let ground = add_ground(&mut w, 0.0, BRICK).unwrap();
    let a = add_box(&mut w, BRICK_SIZE, Vec3::new(0.0, BRICK_SIZE.y / 2.0, 0.0), Quat::IDENTITY, BRICK, false).unwrap();
    let b = add_box(&mut w, BRICK_SIZE, Vec3::new(0.0, 1.5 * BRICK_SIZE.y, 0.0), Quat::IDENTITY, BRICK, false).unwrap();
    w.bond_touching(&[a, b], BondSpec::LIME_MORTAR).unwrap();
    assert_eq!(w.bond_count(), 2);
    w.step(1.0 / 60.0).unwrap();
    // A hinge that keeps a and b from colliding: their bond goes (it was
    // their contact), the ground's stays.
    let anchor = Vec3::new(0.1075, BRICK_SIZE.y, 0.0);
    let (ja, jb) = (crumble::JointBody::from(a), crumble::JointBody::from(b));
    w.insert_joint(crumble::JointBuilder::revolute(ja, jb, Vec3::Z).anchor(anchor)).unwrap();
    assert_eq!(w.bond_count(), 1, "the bond between the jointed bodies stayed");
    assert!(w.bonds().all(|(_, x)| x.bodies().0 == ground || x.bodies().1 == ground));
    for _ in 0..10 {
        w.step(1.0 / 60.0).unwrap();
    }
    assert_eq!(w.bond_count(), 1);
}

#[test]
fn a_wall_glued_after_it_has_rested_settles_as_a_fresh_one() {
    // Glued after a second at rest (its contacts long past settling), the
    // wall's bonds start from no impulse, as a fresh wall's: they settle
    // regularised, so no cancelling loads are left near a bond's strength.
    let (mut w, bricks) = wall_world(None);
    for _ in 0..60 {
        w.step(1.0 / 60.0).unwrap();
    }
    assert_eq!(w.bond_touching(&bricks, BondSpec::LIME_MORTAR).unwrap().len(), 285);
    let mut broken = 0;
    for _ in 0..120 {
        w.step(1.0 / 60.0).unwrap();
        broken += w.bond_events().len();
    }
    let most = w.bonds().map(|(_, b)| b.utilisation()).fold(0.0, f32::max);
    eprintln!("glued after a second: {broken} broken, most loaded bond at {most:.3} of its strength");
    // Measured: none broken, the most loaded at the fresh wall's 0.06.
    assert_eq!(broken, 0);
    assert!(most < 0.15, "most loaded bond at {most} of its strength");
}

#[test]
fn a_bond_that_pulls_still_touches() {
    // A brick hanging under a block by its bond pulls on it: the pair keeps
    // touching, no `Ended` event.
    let mut w = world_with(|s| s.sleep_enabled = false);
    let block = static_box(&mut w, Vec3::new(0.4, 0.2, 0.2), Vec3::new(0.0, 1.1, 0.0));
    let brick =
        add_box(&mut w, BRICK_SIZE, Vec3::new(0.0, 1.0 - BRICK_SIZE.y / 2.0, 0.0), Quat::IDENTITY, BRICK, false)
            .unwrap();
    w.insert_bond(block, brick, BondSpec::LIME_MORTAR).unwrap();
    let mut ended = 0;
    for _ in 0..120 {
        w.step(1.0 / 60.0).unwrap();
        ended += w.contact_events().iter().filter(|e| e.kind == crumble::ContactEventKind::Ended).count();
        assert!(w.bonds().next().unwrap().1.normal_force() < 0.0, "the bond pulls");
    }
    assert_eq!(ended, 0, "the hanging brick's pair was reported apart");
    assert_eq!(w.bond_count(), 1);
}
