//! `crumble-bench reference`: where each engine's collapse lands against a
//! converged run of the same scene (issue 52, item 2).
//!
//! The reference is crumble with [`REFERENCE_SUBSTEPS`] substeps (a
//! quarter of the default substep) and relax and settling tolerances a
//! tenth of the defaults' (`--substeps N`, `--tolerance T` change them).
//! Beside it run, on the same scene built afresh each time: crumble at its
//! defaults, crumble at Rapier's passes (`--matched`'s settings), Rapier
//! at its defaults, and Rapier with as many substeps as the reference
//! (its `num_solver_iterations`), a second engine's converged run.
//!
//! Each run's outcome, on the tracked bodies (the bricks; never the
//! balls):
//! - **knocked out**: bodies that ended more than 0.5 m from their start;
//! - **debris centre**: the mean end position of those bodies (the bricks
//!   weigh the same, so it is their centre of mass);
//! - **mean shift**: the mean displacement of all tracked bodies, which
//!   every brick moves, the unstruck ones by their sag.
//!
//! and its distance from the reference: the difference of the knocked-out
//! counts as a fraction of the reference's, and the distance between the
//! debris centres. No step is timed against another engine's here: the
//! mean ms per step is given for scale only.

use std::time::Instant;

use serde_json::{json, Value};

use crumble::{Vec3, WorldSettings};

use crate::rapier_side::{self, Joints};
use crate::scenes::{build, crumble_settings, matched_passes, SceneDef, DT};
use crate::DISPLACED;

/// The reference's substeps: a quarter of the default substep.
pub const REFERENCE_SUBSTEPS: u32 = 16;
/// The reference's relax tolerance, m/s: a tenth of the default's; its
/// settling tolerance is a tenth of the default's too.
pub const REFERENCE_TOLERANCE: f32 = 1e-4;

/// Most substeps `--substeps` takes.
pub const MAX_SUBSTEPS: u32 = 64;

/// The reference's settings beyond the scene's: its substeps and relax
/// tolerance (`--substeps`, `--tolerance`).
#[derive(Clone, Copy, Debug)]
pub struct Reference {
    pub substeps: u32,
    pub tolerance: f32,
}

/// The scenes the mode runs without `--scene`.
pub const SCENES: &[&str] = &["collapse_3k", "topple", "collapse_10k"];

/// One run's outcome on the tracked bodies.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Outcome {
    pub(crate) knocked: usize,
    pub(crate) debris: Option<Vec3>,
    pub(crate) mean_shift: Vec3,
    pub(crate) ms: f64,
}

impl Outcome {
    /// From each tracked body's start and end, `None` at the end for a body
    /// that is gone (a brick that split: it counts as knocked out, and its
    /// pieces are not tracked, so it is left out of the centre and the
    /// shift, as the table's outcome leaves it out of the drift). A body
    /// whose end is not finite counts as knocked out too, and is left out
    /// of both in the same way (the table counts its drift as infinite).
    pub(crate) fn new(start: &[Vec3], end: &[Option<Vec3>], ms: f64) -> Outcome {
        let (mut debris, mut centred) = (Vec3::ZERO, 0usize);
        let mut knocked = 0;
        let (mut shift, mut shifted) = (Vec3::ZERO, 0usize);
        for (s, e) in start.iter().zip(end) {
            let Some(e) = e.filter(|e| e.is_finite()) else {
                knocked += 1;
                continue;
            };
            shift += e - *s;
            shifted += 1;
            if (e - *s).length() > DISPLACED {
                knocked += 1;
                debris += e;
                centred += 1;
            }
        }
        Outcome {
            knocked,
            debris: (centred > 0).then(|| debris / centred as f32),
            mean_shift: shift / shifted.max(1) as f32,
            ms,
        }
    }

    /// The knocked-out count's difference from `r`'s, as a fraction of
    /// `r`'s (of 1 when `r` knocked none out), and the distance between
    /// the debris centres (`None` when either has no debris).
    fn distance(&self, r: &Outcome) -> (f32, Option<f32>) {
        let count = (self.knocked as f32 - r.knocked as f32) / r.knocked.max(1) as f32;
        let centre = self.debris.zip(r.debris).map(|(a, b)| (a - b).length());
        (count, centre)
    }
}

/// The reference's settings: `def`'s, with `substeps` and the relax and
/// settling tolerances at `tolerance` and a tenth of it.
pub fn reference_settings(def: &SceneDef, substeps: u32, tolerance: f32) -> WorldSettings {
    let d = crumble_settings(def, false);
    WorldSettings { substeps, relax_tolerance: tolerance, settle_tolerance: tolerance * 0.1, ..d }
}

fn run_crumble(
    def: &'static SceneDef,
    steps: usize,
    threads: usize,
    settings: WorldSettings,
) -> Result<Outcome, String> {
    let mut built = build(def, threads, false).map_err(|e| format!("{}: {e}", def.name))?;
    built.world.set_settings(WorldSettings { threads, ..settings }).map_err(|e| e.to_string())?;
    let pos = |w: &crumble::World| -> Vec<Option<Vec3>> {
        built.tracked.iter().map(|&h| w.body(h).map(|b| b.position())).collect()
    };
    let start: Vec<Vec3> = pos(&built.world).into_iter().map(|p| p.expect("a tracked body at the start")).collect();
    let t = Instant::now();
    for _ in 0..steps {
        built.world.step(DT).map_err(|e| e.to_string())?;
    }
    let ms = t.elapsed().as_secs_f64() * 1e3 / steps.max(1) as f64;
    Ok(Outcome::new(&start, &pos(&built.world), ms))
}

fn run_rapier(def: &'static SceneDef, steps: usize, substeps: usize) -> Result<Outcome, String> {
    let built = build(def, 1, false).map_err(|e| format!("{}: {e}", def.name))?;
    let mut rs =
        rapier_side::mirror(def, &built.world, &built.tracked, built.pendulum.as_ref(), Joints::Impulse, substeps)
            .map_err(|e| format!("Rapier's copy: {e}"))?;
    let pos = |rs: &rapier_side::RapierScene| -> Vec<Option<Vec3>> {
        rs.tracked.iter().map(|&h| Some(rapier_side::position(&rs.world, h))).collect()
    };
    let start: Vec<Vec3> = pos(&rs).into_iter().flatten().collect();
    let t = Instant::now();
    for _ in 0..steps {
        rs.world.step();
    }
    let ms = t.elapsed().as_secs_f64() * 1e3 / steps.max(1) as f64;
    Ok(Outcome::new(&start, &pos(&rs), ms))
}

/// Runs the reference and the others on each `(scene, steps)` of `runs`;
/// the Rapier runs only with `rapier` (`--only crumble` leaves them out).
pub fn run(
    runs: &[(&'static SceneDef, usize)],
    threads: usize,
    reference: Reference,
    rapier: bool,
) -> Result<Value, String> {
    let Reference { substeps, tolerance } = reference;
    println!(
        "outcomes against the converged reference: crumble at {substeps} substeps, relax tolerance {tolerance:e} m/s \
(settling {:e}); tracked bodies only",
        tolerance * 0.1
    );
    println!(
        "{:<13} {:<22} {:>9} {:>8} {:>26} {:>9} {:>22} {:>10}",
        "scene",
        "run",
        "knocked",
        "vs ref",
        "debris centre x, y, z (m)",
        "vs ref",
        "mean shift x, y, z (mm)",
        "ms/step"
    );
    let mut out = Vec::new();
    for &(def, steps) in runs {
        let d = crumble_settings(def, false);
        let names = ["crumble reference", "crumble defaults", "crumble matched", "rapier defaults", "rapier substeps"];
        let mut reference = None;
        let mut rows = Vec::new();
        for name in names.into_iter().filter(|n| rapier || n.starts_with("crumble")) {
            let t = Instant::now();
            let o = match name {
                "crumble reference" => run_crumble(def, steps, threads, reference_settings(def, substeps, tolerance)),
                "crumble defaults" => run_crumble(def, steps, threads, d),
                "crumble matched" => run_crumble(def, steps, threads, matched_passes(d)),
                "rapier defaults" => run_rapier(def, steps, rapier_side::default_substeps()),
                _ => run_rapier(def, steps, substeps as usize),
            }?;
            eprintln!("[{}] {name}: {steps} steps in {:.1} s", def.name, t.elapsed().as_secs_f64());
            let r = *reference.get_or_insert(o);
            let (count, centre) = o.distance(&r);
            let debris = o.debris.map_or("-".to_string(), |c| format!("{:.3}, {:.3}, {:.3}", c.x, c.y, c.z));
            let centre_text = centre.map_or("-".to_string(), |c| format!("{c:.3} m"));
            let m = o.mean_shift * 1e3;
            println!(
                "{:<13} {:<22} {:>9} {:>7.1}% {:>26} {:>9} {:>22} {:>10.2}",
                def.name,
                name,
                o.knocked,
                count * 100.0,
                debris,
                centre_text,
                format!("{:.1}, {:.1}, {:.1}", m.x, m.y, m.z),
                o.ms
            );
            rows.push(json!({
                "run": name, "knocked_out": o.knocked, "knocked_vs_reference": count,
                "debris_centre": o.debris.map(|c| [c.x, c.y, c.z]), "debris_vs_reference_m": centre,
                "mean_shift_m": [o.mean_shift.x, o.mean_shift.y, o.mean_shift.z], "ms_per_step": o.ms,
            }));
        }
        out.push(json!({ "scene": def.name, "steps": steps, "runs": rows }));
    }
    Ok(json!({
        "mode": "reference", "reference_substeps": substeps, "reference_tolerance": tolerance, "scenes": out,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The outcome counts the bodies past 0.5 m, centres their end
    /// positions, and measures its distance from another's as the count's
    /// fraction and the centres' distance.
    #[test]
    fn outcomes_count_centre_and_compare_the_knocked_out_bodies() {
        let start = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        // Two knocked out (1 m and 2 m), one sagged 1 cm, one still.
        let end = [Vec3::new(0.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 2.0), Vec3::new(0.0, 0.99, 0.0), Vec3::Z].map(Some);
        let o = Outcome::new(&start, &end, 1.0);
        assert_eq!(o.knocked, 2);
        let centre = o.debris.expect("debris");
        assert!((centre - Vec3::new(0.5, 0.0, 0.5)).length() < 1e-6, "{centre}");
        let shift = Vec3::new(0.0, -0.01, 1.0) / 4.0;
        assert!((o.mean_shift - shift).length() < 1e-6, "{}", o.mean_shift);
        let r = Outcome::new(&start, &[Vec3::new(0.0, 0.0, -1.0), Vec3::X, Vec3::Y, Vec3::Z].map(Some), 1.0);
        let (count, distance) = o.distance(&r);
        assert_eq!(count, 1.0, "two against one: 100% more");
        assert!((distance.expect("both have debris") - (Vec3::new(0.5, 0.0, 1.5)).length()).abs() < 1e-6);
        let none = Outcome::new(&start, &start.map(Some), 1.0);
        assert_eq!(none.knocked, 0);
        assert_eq!(o.distance(&none), (2.0, None), "against none, counted against one");
        // A body that is gone (a brick that split) is knocked out, and left
        // out of the centre and the shift.
        let gone = Outcome::new(&start, &[None, Some(Vec3::new(1.0, 0.0, 2.0)), Some(Vec3::Y), Some(Vec3::Z)], 1.0);
        assert_eq!(gone.knocked, 2);
        assert_eq!(gone.debris, Some(Vec3::new(1.0, 0.0, 2.0)));
        assert!((gone.mean_shift - Vec3::new(0.0, 0.0, 2.0) / 3.0).length() < 1e-6, "{}", gone.mean_shift);
        // So is one whose end is not finite.
        let lost =
            Outcome::new(&start, &[Some(Vec3::NAN), Some(Vec3::new(1.0, 0.0, 2.0)), Some(Vec3::Y), Some(Vec3::Z)], 1.0);
        assert_eq!((lost.knocked, lost.debris), (gone.knocked, gone.debris));
        assert!(lost.mean_shift.is_finite());
    }

    /// The reference's settings: the scene's, with more substeps and
    /// tighter tolerances only.
    #[test]
    fn the_reference_changes_substeps_and_tolerances_only() {
        let def = crate::scenes::find("collapse_3k").expect("scene");
        let r = reference_settings(def, 16, 1e-4);
        let d = crumble_settings(def, false);
        assert_eq!((r.substeps, r.relax_tolerance, r.settle_tolerance), (16, 1e-4, 1e-5));
        let back = WorldSettings {
            substeps: d.substeps,
            relax_tolerance: d.relax_tolerance,
            settle_tolerance: d.settle_tolerance,
            ..r
        };
        assert_eq!(back, d);
    }
}
