//! The simulation behind a Python `World`, without Python: a scene's
//! [`Simulation`], the map from body handles to output rows, and the
//! events gathered over one `step(n)` call. Everything here is `Send`, so
//! that steps run with the GIL released.

use std::collections::{BTreeMap, HashMap, HashSet, VecDeque};
use std::panic::{catch_unwind, AssertUnwindSafe};

use crumble::scenes::{BREAKABLE_BRICK, STEEL};
use crumble::{
    BodyBuilder, BodyHandle, BondEvent, BondMode, ColliderBuilder, ContactEventKind, FractureEvent, FractureMode,
    JointEvent, Material, Pose, Quat, Vec3,
};
use crumble_scene::spec::Scene;
use crumble_scene::{BodyInfo, BodyShape, SceneError, Simulation};

/// Why a step batch stopped early.
#[derive(Debug)]
pub enum StepFailure {
    /// The engine refused the step (`WorldError`); the message names why.
    Engine(String),
    /// The engine panicked: a bug. The world is left unusable.
    Panic(String),
}

/// A contact that began or ended.
#[derive(Clone, Copy, Debug)]
pub struct ContactRecord {
    pub time: f64,
    pub began: bool,
    pub a: Option<usize>,
    pub b: Option<usize>,
    pub normal_impulse: f32,
}

/// A joint that broke.
#[derive(Clone, Copy, Debug)]
pub struct JointRecord {
    pub time: f64,
    pub a: Option<usize>,
    pub b: Option<usize>,
    pub force: f32,
    pub torque: f32,
}

/// A bond that broke.
#[derive(Clone, Copy, Debug)]
pub struct BondRecord {
    pub time: f64,
    pub a: Option<usize>,
    pub b: Option<usize>,
    pub mode: &'static str,
    pub force: f32,
}

/// A box that split in two.
#[derive(Clone, Copy, Debug)]
pub struct SplitRecord {
    pub time: f64,
    pub parent: Option<usize>,
    pub pieces: [Option<usize>; 2],
    pub axis: usize,
    pub offset: f32,
    pub mode: &'static str,
    pub ratio: f32,
}

/// The events of the steps of the last `step(n)` call.
#[derive(Clone, Debug, Default)]
pub struct Events {
    pub contacts: Vec<ContactRecord>,
    pub joint_breaks: Vec<JointRecord>,
    pub bond_breaks: Vec<BondRecord>,
    pub splits: Vec<SplitRecord>,
}

/// A body to add from Python: already checked (finite, positive sizes,
/// a unit quaternion).
#[derive(Clone, Copy, Debug)]
pub struct NewBody {
    pub shape: BodyShape,
    pub pose: Pose,
    pub velocity: Vec3,
    pub angular_velocity: Vec3,
}

/// A scene's simulation, as `crumble run` steps it.
pub struct Engine {
    pub sim: Simulation,
    /// Index in `sim.bodies` of row 0: 1 when the scene has a ground plane
    /// (the outputs' first body), which has no row.
    pub first: usize,
    /// The scene's `[materials.NAME]`, for bodies added later.
    materials: BTreeMap<String, Material>,
    /// Steps taken since the scene was loaded.
    pub steps: u64,
    /// Events of the last `step(n)` call.
    pub events: Events,
    /// Row of each body handle that has been in the world (stale handles
    /// stay: a handle's generation makes it unique).
    row_of: HashMap<BodyHandle, usize>,
    /// Rows whose body is not in the world yet (projectiles), launch order.
    waiting: VecDeque<usize>,
    /// `sim.bodies.len()` when `row_of` was last brought up to date.
    known: usize,
    /// Every body name, for refusing a duplicate.
    names: HashSet<String>,
    /// Set when the engine panicked: the message, refused from then on.
    pub poisoned: Option<String>,
    /// Test hook: the step count after which the next step panics, so
    /// that the tests see a panic in a step become an exception.
    pub panic_after: Option<u64>,
}

impl Engine {
    /// Builds a parsed scene.
    pub fn build(scene: &Scene) -> Result<Engine, SceneError> {
        let sim = crumble_scene::build(scene)?;
        let materials = scene
            .materials
            .iter()
            .map(|(name, m)| {
                let mut out =
                    Material::new(m.density, m.friction, m.restitution).with_rolling_resistance(m.rolling_resistance);
                if let (Some(t), Some(s)) = (m.tensile_strength, m.shear_strength) {
                    out = out.with_strength(t, s);
                }
                (name.clone(), out)
            })
            .collect();
        let first = usize::from(matches!(sim.bodies.first().map(|b| b.shape), Some(BodyShape::Plane { .. })));
        let waiting = sim.pending.iter().map(|s| s.index).collect();
        let names = sim.bodies.iter().map(|b| b.name.clone()).collect();
        let mut engine = Engine {
            sim,
            first,
            materials,
            steps: 0,
            events: Events::default(),
            row_of: HashMap::new(),
            waiting,
            known: 0,
            names,
            poisoned: None,
            panic_after: None,
        };
        engine.sync_rows();
        Ok(engine)
    }

    /// Rows: every body but the ground plane.
    pub fn rows(&self) -> usize {
        self.sim.bodies.len() - self.first
    }

    /// The body of `row`.
    pub fn info(&self, row: usize) -> &BodyInfo {
        &self.sim.bodies[self.first + row]
    }

    /// The row of a handle; `None` for the ground and unknown handles.
    fn row(&self, h: BodyHandle) -> Option<usize> {
        self.row_of.get(&h).copied()
    }

    /// Brings `row_of` up to date with the bodies that joined (pieces,
    /// added bodies) and the projectiles launched since the last call.
    fn sync_rows(&mut self) {
        for i in self.known..self.sim.bodies.len() {
            if let (Some(h), true) = (self.sim.bodies[i].handle, i >= self.first) {
                self.row_of.insert(h, i - self.first);
            }
        }
        self.known = self.sim.bodies.len();
        while let Some(&i) = self.waiting.front() {
            let Some(h) = self.sim.bodies[i].handle else { break };
            self.row_of.insert(h, i - self.first);
            self.waiting.pop_front();
        }
    }

    /// The material a scene of this world calls `name`: its own
    /// `[materials.NAME]`, else the built-in `default`, `brick` (breakable)
    /// and `steel`, as in scene files.
    pub fn material(&self, name: &str) -> Result<Material, String> {
        if let Some(m) = self.materials.get(name) {
            return Ok(*m);
        }
        match name {
            "default" => Ok(Material::default()),
            "brick" => Ok(BREAKABLE_BRICK),
            "steel" => Ok(STEEL),
            _ => {
                let mut known = vec!["default", "brick", "steel"];
                const BUILT_IN: [&str; 3] = ["default", "brick", "steel"];
                known.extend(self.materials.keys().map(String::as_str).filter(|n| !BUILT_IN.contains(n)));
                Err(format!("unknown material `{name}` (known: {})", known.join(", ")))
            }
        }
    }

    /// Whether a body is called `name` already.
    pub fn has_name(&self, name: &str) -> bool {
        self.names.contains(name)
    }

    /// Adds dynamic bodies of one material, named by `names`, at the end of
    /// the rows; returns the first new row. Stops at the first the engine
    /// refuses, keeping those before it.
    pub fn add(&mut self, bodies: &[NewBody], names: Vec<String>, material: Material) -> Result<usize, String> {
        let first_row = self.rows();
        let now = self.sim.time();
        for (b, name) in bodies.iter().zip(names) {
            let builder =
                BodyBuilder::dynamic().pose(b.pose).linear_velocity(b.velocity).angular_velocity(b.angular_velocity);
            let collider = match b.shape {
                BodyShape::Box { half_extents: e } => ColliderBuilder::cuboid(e.x, e.y, e.z),
                BodyShape::Sphere { radius } => ColliderBuilder::ball(radius),
                BodyShape::Plane { .. } => unreachable!("only boxes and balls are added"),
            }
            .map_err(|e| format!("{name}: {e}"))?;
            let world = &mut self.sim.world;
            let h = world.insert_body(builder).map_err(|e| format!("{name}: {e}"))?;
            if let Err(e) = world.insert_collider(collider.material(material), h) {
                // A body without its collider would have no mass: take it out.
                let _ = world.remove_body(h);
                return Err(format!("{name}: {e}"));
            }
            self.names.insert(name.clone());
            self.sim.bodies.push(BodyInfo {
                name,
                shape: b.shape,
                is_static: false,
                source: "python".into(),
                initial: b.pose,
                handle: Some(h),
                spawn_time: now,
                metal: material.density >= 4500.0,
                parent: None,
                despawn: None,
            });
            self.sync_rows();
        }
        Ok(first_row)
    }

    /// Takes `n` steps, gathering their events, each as `crumble run` takes
    /// it (projectiles launched when due). A panic of the engine is caught
    /// here: it poisons the engine rather than crossing into Python.
    pub fn step(&mut self, n: u64, mut each: impl FnMut(&Engine)) -> Result<(), StepFailure> {
        if let Some(msg) = &self.poisoned {
            return Err(StepFailure::Panic(msg.clone()));
        }
        self.events = Events::default();
        for _ in 0..n {
            let result = catch_unwind(AssertUnwindSafe(|| self.step_once()));
            match result {
                Ok(Ok(())) => each(self),
                Ok(Err(e)) => return Err(StepFailure::Engine(e)),
                Err(payload) => {
                    let msg = payload
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| payload.downcast_ref::<String>().cloned())
                        .unwrap_or_else(|| "a panic without a message".into());
                    let msg = format!("the engine panicked at step {} (a bug in crumble): {msg}", self.steps + 1);
                    self.poisoned = Some(msg.clone());
                    return Err(StepFailure::Panic(msg));
                }
            }
        }
        Ok(())
    }

    fn step_once(&mut self) -> Result<(), String> {
        if self.panic_after == Some(self.steps) {
            panic!("the test hook's panic after step {}", self.steps);
        }
        self.sim.step().map_err(|e| format!("step {} at t = {} s: {e}", self.steps + 1, self.sim.time()))?;
        self.steps += 1;
        self.sync_rows();
        let time = self.sim.time();
        let world = &self.sim.world;
        for e in world.contact_events() {
            let (a, b) = (self.row(e.body_a), self.row(e.body_b));
            let began = e.kind == ContactEventKind::Began;
            self.events.contacts.push(ContactRecord { time, began, a, b, normal_impulse: e.normal_impulse });
        }
        for e in world.joint_events() {
            let JointEvent::Broken { body_a, body_b, force, torque, .. } = *e;
            let (a, b) = (body_a.and_then(|h| self.row(h)), body_b.and_then(|h| self.row(h)));
            self.events.joint_breaks.push(JointRecord { time, a, b, force, torque });
        }
        for e in world.bond_events() {
            let BondEvent::Broken { body_a, body_b, mode, force, .. } = *e;
            let mode = match mode {
                BondMode::Tension => "tension",
                BondMode::Shear => "shear",
                BondMode::Separated => "separated",
            };
            self.events.bond_breaks.push(BondRecord { time, a: self.row(body_a), b: self.row(body_b), mode, force });
        }
        for e in world.fracture_events() {
            let FractureEvent::Split { parent, pieces, axis, offset, mode, ratio } = *e;
            let mode = match mode {
                FractureMode::Tension => "tension",
                FractureMode::Shear => "shear",
            };
            let pieces = [self.row(pieces[0]), self.row(pieces[1])];
            self.events.splits.push(SplitRecord { time, parent: self.row(parent), pieces, axis, offset, mode, ratio });
        }
        Ok(())
    }

    /// Writes the rows' poses `[x, y, z, qx, qy, qz, qw]` into `out`
    /// (`7 × rows` values): a waiting projectile's launch pose, a broken
    /// body's pose when it broke, as the outputs of `crumble run` give them.
    pub fn poses_into(&self, out: &mut [f32]) {
        for (row, chunk) in out.chunks_exact_mut(7).enumerate() {
            let p = self.sim.pose(self.first + row);
            chunk[..3].copy_from_slice(&p.position.to_array());
            chunk[3..].copy_from_slice(&p.rotation.to_array());
        }
    }

    /// Writes the rows' velocities `[vx, vy, vz, wx, wy, wz]` into `out`
    /// (`6 × rows` values); zeros for a body not in the world (a waiting
    /// projectile, a broken body).
    pub fn velocities_into(&self, out: &mut [f32]) {
        for (row, chunk) in out.chunks_exact_mut(6).enumerate() {
            let body = self.info(row).handle.and_then(|h| self.sim.world.body(h));
            let (v, w) = body.map_or((Vec3::ZERO, Vec3::ZERO), |b| (b.linear_velocity(), b.angular_velocity()));
            chunk[..3].copy_from_slice(&v.to_array());
            chunk[3..].copy_from_slice(&w.to_array());
        }
    }

    /// The checksum of `cargo run -p crumble-physics --example checksum`: FNV-1a
    /// over the bits of every body's position, rotation, linear and
    /// angular velocity, in handle order (the ground included).
    pub fn checksum(&self) -> u64 {
        self.sim.world.motion_checksum()
    }
}

/// The pose of a row in an earlier frame of a recording that did not have
/// it yet: a piece moves as a part of its parent (its pose in the parent's
/// frame), any other body rests at its first pose, as in `crumble run`'s
/// outputs. `parent_pose` is the parent's pose in that frame.
pub fn joining_pose(info: &BodyInfo, parent_pose: Option<Pose>) -> Pose {
    match (info.parent, parent_pose) {
        (Some((_, local)), Some(parent)) => {
            let p = parent.mul_pose(&local);
            Pose::new(p.position, p.rotation.normalize())
        }
        _ => info.initial,
    }
}

/// A quaternion `[x, y, z, w]` made unit, or why it cannot be.
pub fn unit_quat(q: [f32; 4]) -> Result<Quat, String> {
    let q = Quat::from_array(q);
    if !q.is_finite() || q.length_squared() < 1e-12 {
        return Err(format!("must be a finite non-zero quaternion [x, y, z, w], got {:?}", q.to_array()));
    }
    Ok(q.normalize())
}
