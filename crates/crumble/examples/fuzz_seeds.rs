//! Writes the seed payloads of the snapshot fuzz target
//! (`fuzz/corpus/snapshot/`): small worlds mid-impact, each saved by
//! `World::snapshot` and stripped of the header and checksum that the
//! target seals every input with (`fuzz/fuzz_targets/snapshot.rs`). Run it
//! again whenever a saved field changes, since payloads of another layout
//! no longer restore and the fuzzer would start from nothing:
//!
//! ```text
//! cargo run --release -p crumble-physics --example fuzz_seeds -- fuzz/corpus/snapshot
//! ```
//!
//! The worlds: an empty one; three boxes in a pyramid, settling; a 3 × 3
//! wall hit by a ball, dry, mortared and breakable (its bricks split in
//! the second step); two boxes hanging on spherical joints.

use crumble::scenes::{add_ball, add_box, add_ground, add_wall, WallSpec, BRICK, STEEL};
use crumble::snapshot::seal;
use crumble::{BondSpec, JointBody, JointBuilder, Quat, Strength, Vec3, World, WorldSettings};

fn world() -> World {
    World::new(WorldSettings { threads: 1, ..WorldSettings::default() }).unwrap()
}

fn wall(kind: &str) -> World {
    let mut w = world();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let mut spec = WallSpec { rows: 3, bricks_per_row: 3, ..WallSpec::default() };
    if kind == "breakable" {
        spec.material.strength = Some(Strength { tensile: 2e4, shear: 2e4 });
    }
    let bricks = add_wall(&mut w, &spec).unwrap();
    if kind == "mortar" {
        let mortar = BondSpec { tensile_strength: 2e5, shear_strength: 4e5, friction: 0.6, user_data: 0 };
        w.bond_touching(&bricks, mortar).unwrap();
    }
    let mid = spec.rows as f32 * spec.brick.y * 0.5;
    add_ball(&mut w, 0.075, Vec3::new(0.0, mid, 0.4), Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
    w
}

fn main() {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).expect("usage: fuzz_seeds DIR"));
    let mut cases: Vec<(&str, World, usize)> = Vec::new();
    cases.push(("empty", world(), 1));
    let mut p = world();
    add_ground(&mut p, 0.0, BRICK).unwrap();
    let s = Vec3::splat(0.2);
    for (x, y) in [(-0.11, 0.1), (0.11, 0.1), (0.0, 0.3)] {
        add_box(&mut p, s, Vec3::new(x, y, 0.0), Quat::IDENTITY, BRICK, false).unwrap();
    }
    cases.push(("pyramid_2", p, 10));
    for k in ["ball", "mortar", "breakable"] {
        let name: &'static str = match k {
            "ball" => "wall_3x3_ball",
            "mortar" => "wall_3x3_mortar",
            _ => "wall_3x3_breakable",
        };
        cases.push((name, wall(k), 2));
    }
    let mut j = world();
    let a = add_box(&mut j, Vec3::splat(0.1), Vec3::new(0.3, 1.0, 0.0), Quat::IDENTITY, STEEL, false).unwrap();
    let b = add_box(&mut j, Vec3::splat(0.1), Vec3::new(0.6, 1.0, 0.0), Quat::IDENTITY, STEEL, false).unwrap();
    j.insert_joint(JointBuilder::spherical(JointBody::World, a).anchor(Vec3::new(0.0, 1.0, 0.0))).unwrap();
    j.insert_joint(JointBuilder::spherical(a, b).anchor(Vec3::new(0.45, 1.0, 0.0))).unwrap();
    cases.push(("joints", j, 5));
    for (name, mut w, steps) in cases {
        for _ in 0..steps {
            w.step(1.0 / 60.0).unwrap();
        }
        let bytes = w.snapshot();
        // Magic (8 bytes), version (4), layout hash (8), payload length (8);
        // the checksum (8) last.
        let payload = &bytes[28..bytes.len() - 8];
        assert!(seal(payload) == bytes, "{name}: the header is not 28 bytes");
        let back = World::restore(&seal(payload)).unwrap();
        println!("{name}: {} bytes, {} bodies, {} contacts", payload.len(), back.body_count(), w.profile().pairs);
        std::fs::write(dir.join(name), payload).unwrap();
    }
}
