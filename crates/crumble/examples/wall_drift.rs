//! A resting running-bond wall, sleep off: prints once per simulated second
//! the largest drift of any brick from where it was created (and its x, y,
//! z parts), the step time and the relax passes per step. It is the tool
//! for studying resting stability (`docs/solver.md`, "Relax passes and stack depth").
//!
//! Run: `cargo run --release -p crumble-physics --example wall_drift -- [COLS ROWS SECONDS]`
//! (default: the 40 × 25 wall of issue 3 for 10 s).
//!
//! Solver settings can be varied without rebuilding through environment
//! variables: `RELAX_MIN`, `RELAX_MAX`, `RELAX_TOL`, `PER_LAYER` (relax
//! passes per layer of the stack), `SUBSTEPS`, `BETA` (position-correction
//! rate) and `SLOP`; `SPLIT`, `HZ_RATIO`, `ZETA` (split impulse or soft
//! contacts); `SETTLE`, `SETTLE_TOL`, `SETTLE_MAX` (settling, see
//! `WorldSettings::settle_steps`); `THREADS`; the bricks' `ROLL`,
//! `FRICTION`, `RESTITUTION`; `TIGHT_SECS` with `TIGHT_TOL` and
//! `TIGHT_MAX` (relax to that tolerance for the first seconds).

use crumble::scenes::{add_ground, add_wall, WallSpec, BRICK};
use crumble::{SolverExperiments, World, WorldSettings};

fn var<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name).ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |k: usize, d: f32| -> Result<f32, String> {
        args.get(k).map_or(Ok(d), |s| s.parse().map_err(|_| format!("argument {}: not a number: {s}", k + 1)))
    };
    let (cols, rows, seconds) = (arg(0, 40.0)? as u32, arg(1, 25.0)? as u32, arg(2, 10.0)?);
    let d = WorldSettings::default();
    let settings = WorldSettings {
        sleep_enabled: false,
        relax_iterations: var("RELAX_MIN", d.relax_iterations),
        max_relax_iterations: var("RELAX_MAX", d.max_relax_iterations),
        relax_tolerance: var("RELAX_TOL", d.relax_tolerance),
        relax_per_layer: var("PER_LAYER", d.relax_per_layer),
        substeps: var("SUBSTEPS", d.substeps),
        position_correction_rate: var("BETA", d.position_correction_rate),
        linear_slop: var("SLOP", d.linear_slop),
        experimental: SolverExperiments {
            skip_idle: var("SKIP_IDLE", u8::from(d.experimental.skip_idle)) == 1,
            ordered_relax: var("ORDERED", u8::from(d.experimental.ordered_relax)) == 1,
        },
        split_impulse: var("SPLIT", u8::from(d.split_impulse)) == 1,
        contact_hertz_ratio: var("HZ_RATIO", d.contact_hertz_ratio),
        contact_damping_ratio: var("ZETA", d.contact_damping_ratio),
        threads: var("THREADS", d.threads),
        settle_steps: var("SETTLE", d.settle_steps),
        settle_tolerance: var("SETTLE_TOL", d.settle_tolerance),
        max_settle_iterations: var("SETTLE_MAX", d.max_settle_iterations),
        ..d
    };
    let mut world = World::new(settings)?;
    add_ground(&mut world, 0.0, BRICK)?;
    let bond = if var("STACK_BOND", 0) == 1 { crumble::scenes::Bond::Stack } else { crumble::scenes::Bond::Running };
    let material = crumble::Material {
        rolling_resistance: var("ROLL", BRICK.rolling_resistance),
        friction: var("FRICTION", BRICK.friction),
        restitution: var("RESTITUTION", BRICK.restitution),
        ..BRICK
    };
    let spec = WallSpec { rows, bricks_per_row: cols, gap: var("GAP", 0.0), bond, material, ..WallSpec::default() };
    let bricks = add_wall(&mut world, &spec)?;
    let start: Vec<_> = bricks.iter().map(|&b| world.body(b).map(|b| b.pose())).collect::<Option<_>>().ok_or("body")?;
    println!("{} bricks, {cols} x {rows}, {seconds} s", bricks.len());
    let dt = 1.0 / 60.0;
    let (mut ms, mut passes, mut recycled) = (0.0f64, 0usize, 0usize);
    let tight_until: f32 = var("TIGHT_SECS", 0.0);
    let normal = *world.settings();
    if tight_until > 0.0 {
        world.set_settings(WorldSettings {
            relax_tolerance: var("TIGHT_TOL", 1e-5),
            max_relax_iterations: var("TIGHT_MAX", 300),
            ..normal
        })?;
    }
    for k in 1..=(seconds * 60.0).round() as usize {
        if tight_until > 0.0 && (k as f32 * dt - tight_until).abs() < 0.5 * dt {
            world.set_settings(normal)?;
        }
        world.step(dt)?;
        ms += world.profile().total.as_secs_f64() * 1e3;
        passes += world.profile().relax_passes;
        recycled += world.profile().recycled_manifolds;
        if k % 60 == 0 {
            let (mut worst, mut axes) = (0.0f32, [0.0f32; 3]);
            for (b, p0) in bricks.iter().zip(&start) {
                let moved = world.body(*b).ok_or("body")?.position() - p0.position;
                worst = worst.max(moved.length());
                for (a, m) in axes.iter_mut().zip(moved.to_array()) {
                    *a = a.max(m.abs());
                }
            }
            println!(
                "t {:5.1} s  drift {:.3} mm (x {:.3} y {:.3} z {:.3})  {:.2} ms/step  {:.1} relax passes/step  {:.0} manifolds recycled/step",
                k as f32 * dt,
                worst * 1e3,
                axes[0] * 1e3,
                axes[1] * 1e3,
                axes[2] * 1e3,
                ms / 60.0,
                passes as f64 / 60.0,
                recycled as f64 / 60.0
            );
            (ms, passes, recycled) = (0.0, 0, 0);
        }
    }
    Ok(())
}
