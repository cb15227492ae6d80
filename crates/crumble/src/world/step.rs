//! [`World::step`]: the table of contents of a step, one call and one
//! profile line per stage, and the thin calls into each stage's file: the
//! broad phase (`world/proxies.rs`), the narrow phase (`narrow_phase.rs`),
//! islands and sleep (`awake.rs`), the solver and its write-back
//! (`solver/`), continuous collision (`ccd.rs`), the joints and bonds
//! judged on the step's forces (`world/joints.rs`, `world/bonds.rs`) and
//! events (`world/events.rs`).

use std::time::Instant;

use super::proxies::{proxy_aabb, proxy_margin};
use super::{Profile, World, WorldError};
use crate::body::{BodyHandle, BodyType};
use crate::ccd;
use crate::energy;
use crate::math::Vec3;
use crate::narrow_phase;
use crate::solver::StepContext;

impl World {
    /// Advances the world by `dt` seconds in `settings.substeps` substeps.
    ///
    /// The stages, one call and one profile line each: broad phase →
    /// narrow phase → islands (wake, group) → solver (integration inside)
    /// → continuous collision → energy bound → write-back → sleep and
    /// events.
    ///
    /// A body whose state would go non-finite in the step (forces or a
    /// step size too large for `f32`) is put back where the step began and
    /// stopped, never written with a NaN: `Ok` does not mean that none
    /// was. [`World::faulted_bodies`] lists the step's faulted bodies, and
    /// [`Body::is_faulted`](crate::Body::is_faulted) tells of one.
    pub fn step(&mut self, dt: f32) -> Result<(), WorldError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(WorldError::InvalidTimeStep(dt));
        }
        let start = Instant::now();
        self.begin_step();
        let mut p = Profile::default();

        let t = Instant::now();
        self.refresh_awake();
        p.proxies_moved = self.update_broad_phase(dt);
        p.broad_phase = t.elapsed();

        let t = Instant::now();
        p.recycled_manifolds = self.update_contacts(dt);
        p.narrow_phase = t.elapsed();

        let t = Instant::now();
        p.islands_count = self.update_islands();
        p.islands = t.elapsed();

        let t = Instant::now();
        self.begin_fracture();
        p.fracture = t.elapsed();

        let t = Instant::now();
        self.solve(dt, &mut p);
        p.solver = t.elapsed().saturating_sub(p.integration);

        let t = Instant::now();
        p.ccd_hits = self.continuous_collision();
        p.continuous = t.elapsed();

        let t = Instant::now();
        p.energy_bounded = self.bound_energy(dt);
        p.energy = t.elapsed();

        let t = Instant::now();
        self.finish_bodies(dt);
        p.write_back = t.elapsed();

        // Fracture reads the step's impulses of every joint, bond and
        // contact, before the joints and bonds that broke are removed
        // (judging the bonds uses theirs up); the bodies that break split
        // once the step is over (as a caller's removals and insertions
        // between steps would), their bonds and joints passing to their
        // pieces.
        let t = Instant::now();
        self.judge_fractures(dt);
        p.joints_broken = self.finish_joints();
        p.bonds_broken = self.finish_bonds(dt);
        p.fracture += t.elapsed();

        let t = Instant::now();
        self.update_sleep();
        self.report_events();
        p.sleep = t.elapsed();

        let t = Instant::now();
        p.splits = self.apply_fractures();
        p.fracture += t.elapsed();

        p.total = start.elapsed();
        self.end_step(p, dt);
        Ok(())
    }

    /// What every step starts with: the events held back since the last
    /// one, no faults, no visits counted.
    fn begin_step(&mut self) {
        self.events.begin_step();
        self.bonds.events.clear();
        self.fracture.events.clear();
        self.faulted.clear();
        self.scratch.visits = Default::default();
    }

    /// What every step ends with: the counts of what it worked on, and the
    /// clock.
    fn end_step(&mut self, mut p: Profile, dt: f32) {
        p.bodies = self.bodies.len();
        p.pairs = self.contacts.len();
        p.refused_pairs = self.broad_phase.refused_pairs();
        p.bodies_visited = self.scratch.visits.bodies;
        p.contacts_visited = self.scratch.visits.contacts;
        self.profile = p;
        self.time += dt as f64;
    }

    /// The awake set put in order (see `AwakeSet::refresh`); a change of it
    /// may make a solver body stand for another body.
    pub(super) fn refresh_awake(&mut self) {
        if self.awake.refresh(&self.bodies, &mut self.scratch.visits) {
            self.solver.bodies_changed();
        }
    }

    /// The narrow phase (`narrow_phase.rs`); returns the recycled manifolds.
    fn update_contacts(&mut self, dt: f32) -> usize {
        self.scratch.visits.contacts += self.contacts.active.len();
        let pool = self.pool.as_deref();
        narrow_phase::update_contacts(
            &mut self.contacts,
            &self.colliders,
            &self.bodies,
            &self.awake,
            &self.settings,
            pool,
            dt,
        )
    }

    /// Wakes the sleeping islands that awake bodies disturb, then groups
    /// the awake bodies into islands; returns how many.
    fn update_islands(&mut self) -> usize {
        let visits = &mut self.scratch.visits;
        self.awake.wake_touched(&mut self.bodies, &mut self.contacts, &self.settings, visits);
        let joints = self.joints.arena.iter().map(|(_, j)| (j.a, j.b));
        self.awake.wake_jointed(joints, &mut self.bodies, &mut self.contacts, visits);
        self.refresh_awake();
        let joints = self.joints.arena.iter().map(|(_, j)| (j.a, j.b));
        self.awake.find_islands(&self.bodies, &self.contacts, joints, &mut self.scratch.visits)
    }

    /// The solver stage (`solver/step.rs`).
    fn solve(&mut self, dt: f32, p: &mut Profile) {
        let awake = self.awake.list();
        p.awake_bodies = awake.len();
        p.active_contacts = self.contacts.active.len();
        // The solver's set-up loops visit exactly these.
        self.scratch.visits.bodies += awake.len();
        self.scratch.visits.contacts += self.contacts.active.len();
        let pool = self.pool.as_deref();
        let ctx = StepContext::new(&self.settings, pool, dt);
        self.solver.step(&ctx, awake, &mut self.bodies, &mut self.contacts, &mut self.joints.arena, p);
    }

    /// Puts resting islands to sleep (`AwakeSet::update_sleep`); their
    /// proxies take a sleeper's margin (see `proxy_margin`): a wide one is
    /// re-inserted narrow now, a narrow one stays.
    fn update_sleep(&mut self) {
        let visits = &mut self.scratch.visits;
        let asleep = self.awake.update_sleep(&mut self.bodies, &mut self.contacts, &self.settings, visits);
        for &bi in asleep {
            let b = self.bodies.at(bi).expect("asleep");
            for &ci in &b.colliders {
                let c = self.colliders.at(ci).expect("attached");
                let aabb = proxy_aabb(&self.settings, &c.shape, &c.world_pose, Vec3::ZERO, 0.0);
                let margin = proxy_margin(&self.settings, &c.shape, 0.0, true);
                self.broad_phase.update_with_margin(c.proxy, aabb, margin);
            }
        }
    }

    /// Continuous collision (`ccd.rs`); returns the bodies put back.
    fn continuous_collision(&mut self) -> usize {
        ccd::continuous_collision(
            &self.settings,
            self.awake.list(),
            &self.bodies,
            &self.colliders,
            &self.broad_phase,
            &mut self.solver,
            &mut self.scratch.ccd_candidates,
            &mut self.scratch.visits,
        )
    }

    /// The energy bound (`energy.rs`); returns the islands it scaled.
    fn bound_energy(&mut self, dt: f32) -> usize {
        self.scratch.visits.bodies += self.awake.list().len();
        let bodies = &self.bodies;
        let kinematic = |x: u32| bodies.at(x).is_some_and(|b| b.body_type == BodyType::Kinematic);
        let driving = self
            .joints
            .arena
            .iter()
            .filter(|(_, j)| j.options.spring.is_some_and(|(hz, _)| hz > 0.0) || kinematic(j.a) || kinematic(j.b))
            .map(|(_, j)| (j.a, j.b));
        energy::bound_island_energy(
            &self.settings,
            &mut self.awake,
            bodies,
            &self.contacts,
            &mut self.solver,
            &mut self.scratch.islands,
            driving,
            dt,
        )
    }

    /// The write-back (`Solver::finish_bodies`); bodies whose state went
    /// non-finite are listed in `faulted`, in the awake order.
    fn finish_bodies(&mut self, dt: f32) {
        self.scratch.visits.bodies += self.awake.list().len();
        let pool = self.pool.as_deref();
        let ctx = StepContext::new(&self.settings, pool, dt);
        let faults = self.solver.finish_bodies(&ctx, self.awake.list(), &mut self.bodies, &mut self.colliders);
        for k in faults {
            let h = self.bodies.handle_at(self.awake.list()[k]).expect("live");
            self.faulted.push(BodyHandle(h));
        }
    }
}
