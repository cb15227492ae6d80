//! The velocity bounds: after the solver and continuous collision, the
//! speed and rotation caps, and the energy bound: no island
//! of awake bodies holds more kinetic energy than it had when the step
//! began plus the work its forces (gravity and applied forces) did over
//! its motion in the step (`Solver::energy_share`).
//!
//! Each part of the step is built not to add energy (the contacts'
//! passes, friction and rolling resistance take it away; restitution
//! gives back at most what the impact took; the gyroscopic step and the
//! caps never add any), but the solver keeps each body's inertia from the
//! step's start. A thin body that turns a third of a radian in a step has
//! a true inertia about the axis of an impulse that can be a thousand
//! times the one the solver used (for a rod, I_max/I_min ≈ 10⁴ and the
//! error grows as θ²·I_max/I_min): a pass that removes energy in the
//! solver's measure adds it in the body's. The same holds of a sweep that
//! moves a body back along its path: its position is put back, the speed
//! it gained falling is not. Here the island's velocities are scaled
//! down together so that its energy is what the step could have given
//! it; the rare island it acts on is counted in `Profile::energy_bounded`.
//!
//! An island pushed by a kinematic body (which may drive energy in), or
//! with an applied torque (whose work is not tracked), is left alone, and
//! so is every island when overlap is pushed out by the soft step's
//! velocities (`split_impulse` false), which is energy the scene asked for.

use crate::arena::Arena;
use crate::awake::AwakeSet;
use crate::body::{Body, BodyType};
use crate::contact::ContactSet;
use crate::solver::Solver;
use crate::world::WorldSettings;

/// Slack on the bound, a fraction of the island's starting kinetic
/// energy: the f32 rounding of the sums (1e-7 a term) with a wide margin.
const RELATIVE_SLACK: f32 = 1e-3;
/// Slack on the bound, as a lift of the island against its forces, m:
/// the solver's own noise in a pile struck and settling (a wall of 105
/// bricks hit by a ball gains up to 8 mJ, 3 µm of its 300 kg, in a step)
/// is not what the bound is for; the random scenes' gains it takes back
/// are larger.
const LIFT_SLACK: f32 = 1e-5;

/// One island's sums: kinetic energy now, what it may hold, slack, and
/// whether it is checked at all.
#[derive(Clone, Copy, Default)]
pub(crate) struct Island {
    now: f32,
    allowed: f32,
    slack: f32,
    unchecked: bool,
}

/// Scales down the velocities of each island that gained energy in the
/// step (see the module). `awake` are the awake bodies, grouped into
/// islands by the step's `find_islands`. Returns how many islands it
/// scaled.
#[allow(clippy::too_many_arguments)]
pub(crate) fn bound_island_energy(
    settings: &WorldSettings,
    awake: &mut AwakeSet,
    bodies: &Arena<Body>,
    contacts: &ContactSet,
    solver: &mut Solver,
    islands: &mut Vec<Island>,
    driving_joints: impl Iterator<Item = (u32, u32)>,
    dt: f32,
) -> usize {
    let n = awake.list().len();
    // The caps hold where the step ends, after the contacts, restitution
    // and the sweeps, which act after each substep's velocity update has
    // capped the velocities: the speed at `max_linear_speed`, the turn at
    // `max_rotation` a substep. Kinematic bodies move as they are told.
    let max_spin = settings.max_rotation * settings.substeps as f32 / dt;
    let check_energy = settings.split_impulse;
    if check_energy {
        islands.clear();
        islands.resize(n, Island::default());
    }
    // One pass over the awake bodies: each dynamic body capped, then its
    // share summed at its island's root (in the awake order: the same sums
    // whatever the threads). Kinematic bodies never sleep, so whether the
    // world has one is whether the awake list does.
    let mut kinematic = false;
    for k in 0..n {
        let b = bodies.at(awake.list()[k]).expect("awake body");
        kinematic |= b.body_type == BodyType::Kinematic;
        if b.body_type != BodyType::Dynamic || b.solver_index == u32::MAX {
            continue;
        }
        let si = b.solver_index as usize;
        solver.cap_velocity(si, settings.max_linear_speed, max_spin);
        if !check_energy {
            continue;
        }
        let root = awake.island_root(k) as usize;
        let island = &mut islands[root];
        match solver.energy_share(si, dt) {
            Some(s) => {
                island.now += s.now;
                island.allowed += s.allowed;
                island.slack += RELATIVE_SLACK * s.start + LIFT_SLACK * s.weight;
            }
            None => island.unchecked = true,
        }
    }
    if !check_energy {
        return 0;
    }
    // Islands a kinematic body touches take the energy it drives in.
    if kinematic {
        for &ci in &contacts.active {
            let c = &contacts.list[ci as usize];
            if c.manifold.is_empty() {
                continue;
            }
            let kind = |x: u32| bodies.at(x).map(|b| b.body_type);
            for (this, other) in [(c.body_a, c.body_b), (c.body_b, c.body_a)] {
                if kind(this) == Some(BodyType::Dynamic) && kind(other) == Some(BodyType::Kinematic) {
                    if let Some(k) = awake.position(this) {
                        let root = awake.island_root(k) as usize;
                        islands[root].unchecked = true;
                    }
                }
            }
        }
    }
    // Islands with a joint that stores or drives energy (a spring, a
    // kinematic body's hold) are not bounded either: a spring's rebound is
    // energy it stored, not energy from nowhere.
    for (a, b) in driving_joints {
        for x in [a, b] {
            if let Some(k) = awake.position(x) {
                let root = awake.island_root(k) as usize;
                islands[root].unchecked = true;
            }
        }
    }
    let mut scaled = 0;
    for k in 0..n {
        let root = awake.island_root(k) as usize;
        let island = islands[root];
        // (A NaN sum passes: the write-back's guard catches the body.)
        let bound = island.allowed.max(0.0) + island.slack;
        let gained = island.now.partial_cmp(&bound) == Some(std::cmp::Ordering::Greater);
        if island.unchecked || !gained {
            continue;
        }
        if root == k {
            scaled += 1;
        }
        let b = bodies.at(awake.list()[k]).expect("awake body");
        if b.body_type != BodyType::Dynamic || b.solver_index == u32::MAX {
            continue;
        }
        // ½ m v² scales as s²: s = √(allowed / now) leaves the island
        // with what it may hold (nothing when that is not positive); `now`
        // is above a positive bound, so s is finite.
        let s = (island.allowed.max(0.0) / island.now).sqrt();
        solver.scale_velocity(b.solver_index as usize, s);
    }
    scaled
}
