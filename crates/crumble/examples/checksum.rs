//! Steps five small scenes and prints one checksum of each: the bits of
//! every body's pose and velocities at the end. Two builds, machines or
//! thread counts that print the same lines simulated the same bits.
//!
//! Run: `cargo run --release -p crumble-physics --example checksum [-- STEPS [THREADS]
//! [--save-half DIR | --resume-half DIR]]` (default 240 steps at 1/60 s,
//! `WorldSettings::threads` 1). `--save-half DIR` also writes each
//! world's snapshot after half the steps to `DIR/<scene>.snapshot`;
//! `--resume-half DIR` restores those instead of building the scenes and
//! runs the other half: the lines must be the same (`docs/snapshot.md`).
//!
//! CI runs it in the default build (batches of eight manifolds) and with
//! `--features lanes4` (batches of four) and compares the lines: the
//! batches' width must not change the results (`src/solver/lanes.rs`);
//! and in the build without AVX (`--cfg crumble_no_avx`), whose passes
//! run the portable code where the default build runs the AVX or AVX-512
//! copy (`crumble::solver_code_path`, which goes to standard error so
//! that the lines to compare stay the same).

use crumble::scenes::{
    add_ball, add_ground, add_pyramid, add_wall, add_wrecking_ball, WallSpec, WreckingBallSpec, BREAKABLE_BRICK, BRICK,
    STEEL,
};
use crumble::{BondSpec, Vec3, World, WorldSettings};

/// Adds a scene's bodies to an empty world.
type Build = fn(&mut World) -> Result<(), crumble::WorldError>;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut half = |flag: &str| -> Result<Option<std::path::PathBuf>, String> {
        let Some(at) = args.iter().position(|a| a == flag) else { return Ok(None) };
        let dir = args.get(at + 1).ok_or(format!("{flag} needs a directory"))?.into();
        args.drain(at..at + 2);
        Ok(Some(dir))
    };
    let (save, resume) = (half("--save-half")?, half("--resume-half")?);
    let mut args = args.into_iter();
    let mut number = |name: &str, default: usize| -> Result<usize, String> {
        args.next().map_or(Ok(default), |s| s.parse().map_err(|e| format!("{name} `{s}`: {e}")))
    };
    let steps = number("STEPS", 240)?;
    let threads = number("THREADS", 1)?;
    let settings = WorldSettings { threads, ..WorldSettings::default() };
    let scenes: [(&str, Build); 6] = [
        ("brick_wall", |w| {
            add_ground(w, 0.0, BRICK)?;
            let spec = WallSpec::default();
            add_wall(w, &spec)?;
            let mid = spec.rows as f32 * spec.brick.y * 0.5;
            add_ball(w, 0.075, Vec3::new(0.0, mid, 2.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true)?;
            Ok(())
        }),
        ("wall_10x10", |w| {
            add_ground(w, 0.0, BRICK)?;
            add_wall(w, &WallSpec::default())?;
            Ok(())
        }),
        ("pyramid_20", |w| {
            add_ground(w, 0.0, BRICK)?;
            add_pyramid(w, 20, 1.0, 0.0, Vec3::ZERO, BRICK)?;
            Ok(())
        }),
        // The joints' trees and loops (solver/joints.rs) meet the contacts
        // at the impact, about step 53.
        ("wrecking_ball", |w| {
            add_ground(w, 0.0, BRICK)?;
            let wall = WallSpec::default();
            add_wall(w, &wall)?;
            let spec = WreckingBallSpec::default();
            let mid = wall.rows as f32 * wall.brick.y * 0.5;
            let anchor = Vec3::new(0.0, mid + spec.length(), -0.5 * wall.brick.z - spec.ball_radius);
            add_wrecking_ball(w, &WreckingBallSpec { anchor, ..spec })?;
            Ok(())
        }),
        // Bonds (solver/contact_wide.rs, "Bonds") in the batches' lanes
        // beside contacts, settling, then breaking at the ball's impact
        // (step 7) into contacts again.
        ("mortar_wall", |w| {
            add_ground(w, 0.0, BRICK)?;
            let spec = WallSpec::default();
            let bricks = add_wall(w, &spec)?;
            w.bond_touching(&bricks, BondSpec::LIME_MORTAR)?;
            let mid = spec.rows as f32 * spec.brick.y * 0.5;
            add_ball(w, 0.075, Vec3::new(0.0, mid, 2.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true)?;
            Ok(())
        }),
        // Fracture (fracture.rs): the struck bricks split into pieces that
        // the step inserts in a fixed order, from step 7 on.
        ("fracture_wall", |w| {
            add_ground(w, 0.0, BRICK)?;
            let spec = WallSpec { material: BREAKABLE_BRICK, ..WallSpec::default() };
            add_wall(w, &spec)?;
            let mid = spec.rows as f32 * spec.brick.y * 0.5;
            add_ball(w, 0.075, Vec3::new(0.0, mid, 2.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true)?;
            Ok(())
        }),
    ];
    eprintln!("solver code path: {}", crumble::solver_code_path());
    for (name, build) in scenes {
        let path = |dir: &std::path::Path| dir.join(format!("{name}.snapshot"));
        let (mut world, start) = match &resume {
            Some(dir) => {
                let mut world = World::restore(&std::fs::read(path(dir))?)?;
                world.set_threads(threads)?;
                (world, steps / 2)
            }
            None => {
                let mut world = World::new(settings)?;
                build(&mut world)?;
                (world, 0)
            }
        };
        for step in start..steps {
            if step == steps / 2 {
                if let Some(dir) = &save {
                    std::fs::write(path(dir), world.snapshot())?;
                }
            }
            world.step(1.0 / 60.0)?;
        }
        println!("{name}: {steps} steps, {} bodies, checksum {:016x}", world.bodies().count(), world.motion_checksum());
    }
    Ok(())
}
