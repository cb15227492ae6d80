//! From a checked [`Scene`] to a [`World`]: every body is first planned
//! (shape, pose, material), the joints' bodies are found by name, the plan
//! is checked for overlaps, and only then is the world built. Projectiles
//! wait in a schedule until their time.

use std::collections::{HashMap, HashSet, VecDeque};

use crumble::scenes::{self, BREAKABLE_BRICK, STEEL};
use crumble::{
    BodyBuilder, BodyHandle, ColliderBuilder, JointBody, JointBuilder, Material, Pose, Quat, Shape, Vec3, World,
    WorldError, WorldSettings,
};

use crate::error::{at_path, KeyPath, SceneError};
use crate::overlap::{check_overlaps, Joined, Placed};
use crate::parse::WORLD;
use crate::spec::{BondSpec, JointKindSpec, JointSpec, Scene, ShapeKind};

/// A body's shape as the outputs draw it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BodyShape {
    /// A box with these half extents, metres.
    Box {
        /// Half edge lengths.
        half_extents: Vec3,
    },
    /// A sphere.
    Sphere {
        /// Radius, metres.
        radius: f32,
    },
    /// The ground: the plane y = height (solid below).
    Plane {
        /// Height, metres.
        height: f32,
    },
}

/// What a body is, for colouring it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BodyKind {
    /// A box (brick).
    Brick = 0,
    /// Steel: a sphere (ball), or a box as dense as a metal (a chain's
    /// link, see [`BodyInfo::metal`]).
    Ball = 1,
    /// The ground plane.
    Ground = 2,
}

/// One body of a built scene, in output order.
#[derive(Clone, Debug)]
pub struct BodyInfo {
    /// Unique name.
    pub name: String,
    /// Shape.
    pub shape: BodyShape,
    /// Never moves.
    pub is_static: bool,
    /// Key path of the scene entry that made it, e.g. `wall[0]`.
    pub source: String,
    /// Pose at creation (projectiles: at launch).
    pub initial: Pose,
    /// Handle in the world; `None` for a projectile not launched yet.
    pub handle: Option<BodyHandle>,
    /// When it enters the world, seconds (0 for everything but projectiles).
    pub spawn_time: f64,
    /// Drawn as metal: its material is as dense as a metal (4,500 kg/m³ or
    /// more: steel is 7,800, fired clay and stone at most 3,000), as the
    /// wrecking ball's links are.
    pub metal: bool,
    /// For a piece of a box that broke (`docs/fracture.md`): the body it
    /// broke from (an index into `Simulation::bodies`) and its pose in
    /// that body's frame, so that before `spawn_time` it moves as a part
    /// of its parent. `None` for a body the scene made.
    pub parent: Option<(usize, Pose)>,
    /// For a body that broke: when it left the world (seconds) and its
    /// pose then. `None` while it is in the world.
    pub despawn: Option<(f64, Pose)>,
}

impl BodyInfo {
    /// Colour class.
    pub fn kind(&self) -> BodyKind {
        match self.shape {
            BodyShape::Plane { .. } => BodyKind::Ground,
            BodyShape::Box { .. } if self.metal => BodyKind::Ball,
            BodyShape::Box { .. } => BodyKind::Brick,
            BodyShape::Sphere { .. } => BodyKind::Ball,
        }
    }
}

/// A body planned but not yet in the world.
#[derive(Clone, Debug)]
struct Planned {
    body: BodyBuilder,
    is_static: bool,
    shape: Shape,
    material: Material,
    pose: Pose,
    path: KeyPath,
    /// Put in the world by the engine's generator of its table
    /// (`[[wrecking_ball]]`), not on its own.
    generated: bool,
}

/// A wrecking ball to make with the engine's generator when the plan's
/// body `first` (its first link) is reached.
struct PlannedWreckingBall {
    first: usize,
    spec: scenes::WreckingBallSpec,
}

/// One side of a planned joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    /// The world.
    World,
    /// The ground.
    Ground,
    /// The plan's body of this index.
    Planned(usize),
}

/// A `[[joint]]` whose bodies are found.
struct PlannedJoint<'a> {
    spec: &'a JointSpec,
    a: Side,
    b: Side,
    path: KeyPath,
}

/// A `[[bond]]` whose bodies are found.
struct PlannedBond<'a> {
    spec: &'a crate::spec::BondPairSpec,
    a: Side,
    b: Side,
    path: KeyPath,
}

/// A projectile waiting for its launch time.
#[derive(Clone, Debug)]
pub struct ScheduledSpawn {
    /// Launch time, seconds.
    pub time: f64,
    /// Index into [`Simulation::bodies`].
    pub index: usize,
    pub(crate) launch: Launch,
}

/// How a projectile enters the world: a dynamic bullet of one collider,
/// kept as its parts (rather than as builders) so that a state file can
/// carry it (`state.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Launch {
    /// Its pose at launch.
    pub pose: Pose,
    /// Its velocity at launch, m/s.
    pub velocity: Vec3,
    /// Its collider's shape (a box or a ball).
    pub shape: Shape,
    /// Its collider's material.
    pub material: Material,
}

impl Launch {
    /// The body and collider to insert.
    fn builders(&self) -> (BodyBuilder, ColliderBuilder) {
        let body = BodyBuilder::dynamic().pose(self.pose).linear_velocity(self.velocity).bullet(true);
        (body, ColliderBuilder::new(self.shape).material(self.material))
    }
}

/// A built scene: the world, its bodies in output order, and the projectiles
/// still to launch.
pub struct Simulation {
    /// The world.
    pub world: World,
    /// Every body, ground first if there is one; projectiles included.
    pub bodies: Vec<BodyInfo>,
    /// Projectiles not launched yet, earliest first.
    pub pending: Vec<ScheduledSpawn>,
    /// Step size, seconds.
    pub dt: f32,
    /// The scene's default run length, seconds.
    pub seconds: f32,
}

impl Simulation {
    /// Launches the projectiles that are due, then advances one step.
    pub fn step(&mut self) -> Result<(), crumble::WorldError> {
        let now = self.world.time() + 0.5 * self.dt as f64;
        while self.pending.first().is_some_and(|s| s.time <= now) {
            let s = self.pending.remove(0);
            let (body, collider) = s.launch.builders();
            let h = self.world.insert_body(body)?;
            self.world.insert_collider(collider, h)?;
            self.bodies[s.index].handle = Some(h);
        }
        self.world.step(self.dt)?;
        self.take_pieces();
        Ok(())
    }

    /// Replaces each body that broke in the last step by its pieces
    /// (`World::fracture_events`): the body stays in `bodies`, with the
    /// time and pose it left at, and the pieces join at the end, named
    /// after it (`NAME.0` on the negative side of the cut, `NAME.1` on the
    /// positive one).
    fn take_pieces(&mut self) {
        let events = self.world.fracture_events();
        if events.is_empty() {
            return;
        }
        let now = self.world.time();
        for e in events {
            let crumble::FractureEvent::Split { parent, pieces, .. } = *e;
            let Some(i) = self.bodies.iter().rposition(|b| b.handle == Some(parent) && b.despawn.is_none()) else {
                continue;
            };
            // The parent's pose when it broke: its collider's pieces tile
            // it, so it is found from them (both have its rotation).
            let poses: Vec<Pose> = pieces.iter().filter_map(|&h| self.world.body(h)).map(|b| b.pose()).collect();
            let Some(&first) = poses.first() else { continue };
            let centre = poses
                .iter()
                .zip(pieces)
                .fold(Vec3::ZERO, |acc, (p, h)| acc + p.position * self.world.body(h).map_or(0.0, |b| b.mass()))
                / pieces.iter().filter_map(|&h| self.world.body(h)).map(|b| b.mass()).sum::<f32>();
            let at = Pose::new(centre, first.rotation);
            self.bodies[i].despawn = Some((now, at));
            for (k, &h) in pieces.iter().enumerate() {
                let Some(body) = self.world.body(h) else { continue };
                let pose = body.pose();
                let half = self
                    .world
                    .body_colliders(h)
                    .first()
                    .and_then(|&c| self.world.collider(c))
                    .and_then(|c| match c.shape() {
                        Shape::Cuboid(b) => Some(b.half_extents()),
                        _ => None,
                    })
                    .unwrap_or(Vec3::ZERO);
                let parent_info = &self.bodies[i];
                let mut name = format!("{}.{k}", parent_info.name);
                while self.bodies.iter().any(|b| b.name == name) {
                    name.push('\'');
                }
                let local = Pose::new(at.inverse_transform_point(pose.position), at.rotation.inverse() * pose.rotation);
                let info = BodyInfo {
                    name,
                    shape: BodyShape::Box { half_extents: half },
                    is_static: false,
                    source: parent_info.source.clone(),
                    initial: pose,
                    handle: Some(h),
                    spawn_time: now,
                    metal: parent_info.metal,
                    parent: Some((i, local)),
                    despawn: None,
                };
                self.bodies.push(info);
            }
        }
    }

    /// Simulated time, seconds.
    pub fn time(&self) -> f64 {
        self.world.time()
    }

    /// Current pose of body `i` (its launch pose while it waits, its pose
    /// when it broke once it has).
    pub fn pose(&self, i: usize) -> Pose {
        let info = &self.bodies[i];
        if let Some((_, pose)) = info.despawn {
            return pose;
        }
        info.handle.and_then(|h| self.world.body(h)).map_or(info.initial, |b| b.pose())
    }

    /// Current speed of body `i`, m/s (0 while it waits).
    pub fn speed(&self, i: usize) -> f32 {
        self.bodies[i].handle.and_then(|h| self.world.body(h)).map_or(0.0, |b| b.linear_velocity().length())
    }

    /// Whether body `i` is asleep.
    pub fn is_sleeping(&self, i: usize) -> bool {
        self.bodies[i].handle.and_then(|h| self.world.body(h)).is_some_and(|b| b.is_sleeping())
    }
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

/// Builds the world of a parsed scene. Fails, before anything is simulated,
/// when generated bodies overlap.
pub fn build(scene: &Scene) -> Result<Simulation, SceneError> {
    let w = &scene.world;
    let settings = WorldSettings {
        gravity: v3(w.gravity),
        substeps: w.substeps,
        sleep_enabled: w.sleep,
        min_piece: w.min_piece,
        max_new_pieces: w.max_new_pieces,
        ..WorldSettings::default()
    };
    let mut world = World::new(settings).map_err(|e| scene.err(&KeyPath::key("world"), e.to_string()))?;
    let mut plan = Plan {
        scene,
        names: HashSet::new(),
        planned: Vec::new(),
        names_of: Vec::new(),
        wrecking_balls: Vec::new(),
        walls: Vec::new(),
    };
    let mut bodies: Vec<BodyInfo> = Vec::new();
    let ground = plan.ground(&mut world, &mut bodies)?;
    plan.bodies()?;
    plan.walls()?;
    plan.pyramids()?;
    plan.stacks()?;
    plan.wrecking_balls()?;
    let first_projectile = plan.planned.len();
    let launches = plan.projectiles()?;
    let joints = plan.joints(first_projectile)?;
    let bonds = plan.bonds(first_projectile)?;
    let walls = plan.walls.clone();
    let mut joined = Joined::default();
    for j in joints.iter().filter(|j| !j.spec.collide_connected) {
        match (j.a, j.b) {
            (Side::Planned(x), Side::Planned(y)) => _ = joined.pairs.insert((x.min(y), x.max(y))),
            (Side::Planned(x), Side::Ground) | (Side::Ground, Side::Planned(x)) => _ = joined.to_ground.insert(x),
            _ => {}
        }
    }
    let placed: Vec<Placed> = (plan.planned.iter().zip(&plan.names_of))
        .map(|(p, name)| Placed { shape: &p.shape, pose: &p.pose, name, path: &p.path })
        .collect();
    check_overlaps(scene, &placed, ground.as_ref(), &joined)?;
    let first_planned = bodies.len();
    let pending = plan.insert(&mut world, &mut bodies, first_projectile, &launches)?;
    for j in &joints {
        let side = |s: Side| match s {
            Side::World => Some(JointBody::World),
            Side::Ground => bodies.first().and_then(|b| b.handle).map(JointBody::Body),
            Side::Planned(k) => bodies.get(first_planned + k).and_then(|b| b.handle).map(JointBody::Body),
        };
        let (Some(a), Some(b)) = (side(j.a), side(j.b)) else {
            return Err(scene.err(&j.path, "a body of the joint is not in the world".into()));
        };
        world.insert_joint(joint_builder(j.spec, a, b)).map_err(|e| joint_error(scene, &j.path, j.spec, e))?;
    }
    // Mortar: each mortared wall's bricks bonded where they touch (each
    // other, the ground, static bodies), then the `[[bond]]` pairs.
    let handle = |k: usize| bodies[first_planned + k].handle.expect("a wall's brick is in the world");
    for (i, (wl, range)) in scene.wall.iter().zip(walls).enumerate() {
        let Some(mortar) = &wl.mortar else { continue };
        let path = KeyPath::item("wall", i);
        let spec = scene.mortar(mortar);
        let bricks: Vec<BodyHandle> = range.map(handle).collect();
        let (jitter, seed) = (wl.strength_jitter, wl.seed);
        // Keyed by the bricks' numbers in the wall (a body that is not one
        // of them, the ground, by `u32::MAX`): the same seed gives the same
        // wall wherever it is in the file.
        let number: HashMap<BodyHandle, u64> = bricks.iter().enumerate().map(|(k, &h)| (h, k as u64)).collect();
        let key = |h: BodyHandle| number.get(&h).copied().unwrap_or(u64::from(u32::MAX));
        world
            .bond_touching_with(&bricks, |a, b| {
                let f = 1.0 + jitter * unit_jitter(seed ^ 0xB0D5, key(a) << 32 | key(b));
                crumble::BondSpec {
                    tensile_strength: spec.tensile_strength * f,
                    shear_strength: spec.shear_strength * f,
                    ..spec
                }
            })
            .map_err(|e| scene.err(&path.join("mortar"), format!("the engine refuses the mortar: {e}")))?;
    }
    for b in &bonds {
        let side = |s: Side| match s {
            Side::World => None,
            Side::Ground => bodies.first().and_then(|b| b.handle),
            Side::Planned(k) => bodies.get(first_planned + k).and_then(|b| b.handle),
        };
        let (Some(x), Some(y)) = (side(b.a), side(b.b)) else {
            return Err(scene.err(&b.path, "a body of the bond is not in the world".into()));
        };
        world
            .insert_bond(x, y, scene.mortar(&b.spec.mortar))
            .map_err(|e| scene.err(&b.path, format!("the engine refuses the bond: {e}")))?;
    }
    Ok(Simulation { world, bodies, pending, dt: w.dt, seconds: w.seconds })
}

/// A number in `[-1, 1)` from `seed` and `key`, the same on every machine:
/// the jitter of a wall's bricks and bonds (SplitMix64's finaliser of the
/// two).
fn unit_jitter(seed: u64, key: u64) -> f32 {
    let mut z = seed.wrapping_add(key.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    // The top 24 bits, as a fraction of 2^24, mapped to [-1, 1).
    (z >> 40) as f32 / (1u32 << 23) as f32 - 1.0
}

/// The engine's joint of a checked `[[joint]]` between `a` and `b`.
fn joint_builder(j: &JointSpec, a: JointBody, b: JointBody) -> JointBuilder {
    let length = j.length.unwrap_or(0.0);
    let mut builder = match j.kind {
        JointKindSpec::Spherical => JointBuilder::spherical(a, b),
        JointKindSpec::Revolute => JointBuilder::revolute(a, b, v3(j.axis.unwrap_or([0.0, 0.0, 1.0]))),
        JointKindSpec::Fixed => JointBuilder::fixed(a, b),
        JointKindSpec::Distance => JointBuilder::distance(a, b, length),
        JointKindSpec::Rope => JointBuilder::rope(a, b, length),
    };
    if let Some(p) = j.anchor {
        builder = builder.anchor(v3(p));
    }
    if let Some([pa, pb]) = j.anchors {
        builder = builder.anchors(v3(pa), v3(pb));
    }
    if let Some([la, lb]) = j.local_anchors {
        builder = builder.local_anchors(v3(la), v3(lb));
    }
    if let Some([lo, hi]) = j.limits_deg {
        // ±180° in radians rounds to within an ulp of ±π, on either side.
        let pi = std::f32::consts::PI;
        builder = builder.limits(lo.to_radians().clamp(-pi, pi), hi.to_radians().clamp(-pi, pi));
    }
    if let Some(s) = j.spring {
        builder = builder.spring(s.hertz, s.damping_ratio);
    }
    builder
        .break_force(j.break_force.unwrap_or(f32::INFINITY))
        .break_torque(j.break_torque.unwrap_or(f32::INFINITY))
        .collide_connected(j.collide_connected)
}

/// The engine's refusal of the joint at `path`, at the key it is about
/// when the reason names one (the checks of `parse` refuse most bad joints
/// first, at their keys), else at the table.
fn joint_error(scene: &Scene, path: &KeyPath, j: &JointSpec, e: WorldError) -> SceneError {
    let WorldError::InvalidJoint(why) = e else { return scene.err(path, format!("the joint cannot be made: {e}")) };
    let anchor_key = [("anchor", j.anchor.is_some()), ("anchors", j.anchors.is_some())]
        .into_iter()
        .find(|(_, given)| *given)
        .map_or("local_anchors", |(k, _)| k);
    let keys: [(&str, &str, bool); 6] = [
        ("anchor", anchor_key, j.anchor.is_some() || j.anchors.is_some() || j.local_anchors.is_some()),
        ("axis", "axis", j.axis.is_some()),
        ("length", "length", j.length.is_some()),
        ("limits", "limits_deg", j.limits_deg.is_some()),
        ("spring", "spring", j.spring.is_some()),
        ("break", if j.break_force.is_some() { "break_force" } else { "break_torque" }, true),
    ];
    let at = keys.iter().find(|(word, _, given)| *given && why.contains(word)).map_or(path.clone(), |k| path.join(k.1));
    scene.err(&at, format!("the engine refuses the joint: {why}"))
}

impl Scene {
    /// An error at `path` of this scene's file.
    fn err(&self, path: &KeyPath, msg: String) -> SceneError {
        at_path(&self.file, &self.source, path, msg)
    }

    /// An error about `path` found outside the scene crate (by the
    /// command's checks of its flags against the scene), located in the
    /// scene's file.
    pub fn error_at(&self, path: &KeyPath, msg: impl Into<String>) -> SceneError {
        at_path(&self.file, &self.source, path, msg)
    }

    /// The mortar called `name` (validated): the scene's own, else a
    /// built-in one.
    fn mortar(&self, name: &str) -> crumble::BondSpec {
        if let Some(m) = self.mortars.get(name) {
            return crumble::BondSpec::new(m.tensile_strength, m.shear_strength).friction(m.friction);
        }
        match name {
            "cement" => crumble::BondSpec::CEMENT_MORTAR,
            _ => crumble::BondSpec::LIME_MORTAR,
        }
    }

    /// The material called `name`: the scene's own, else a built-in one,
    /// else the default.
    fn material(&self, name: &str) -> Material {
        if let Some(m) = self.materials.get(name) {
            let mut out =
                Material::new(m.density, m.friction, m.restitution).with_rolling_resistance(m.rolling_resistance);
            if let (Some(t), Some(s)) = (m.tensile_strength, m.shear_strength) {
                out = out.with_strength(t, s);
            }
            return out;
        }
        match name {
            "brick" => BREAKABLE_BRICK,
            "steel" => STEEL,
            _ => Material::default(),
        }
    }
}

/// The bodies planned so far, in the order they enter the world.
struct Plan<'a> {
    scene: &'a Scene,
    /// Every name taken, the ground's too.
    names: HashSet<String>,
    planned: Vec<Planned>,
    /// Per planned body: its name.
    names_of: Vec<String>,
    /// The wrecking balls, in the plan's order.
    wrecking_balls: Vec<PlannedWreckingBall>,
    /// Per `[[wall]]`: the plan's indices of its bricks.
    walls: Vec<std::ops::Range<usize>>,
}

fn dynamic(asleep: bool) -> BodyBuilder {
    BodyBuilder::dynamic().sleeping(asleep)
}

fn cuboid(size: Vec3) -> Shape {
    Shape::cuboid(size * 0.5).expect("validated size")
}

impl<'a> Plan<'a> {
    /// Takes `name`, or fails when it is taken.
    fn name(&mut self, name: String, path: &KeyPath) -> Result<String, SceneError> {
        if name == WORLD {
            let msg = format!("no body may be named `{WORLD}`: in a `[[joint]]` the name stands for the world");
            return Err(self.scene.err(path, msg));
        }
        if !self.names.insert(name.clone()) {
            return Err(self.scene.err(path, format!("the name `{name}` is used twice")));
        }
        Ok(name)
    }

    fn push(&mut self, name: String, p: Planned) {
        self.names_of.push(name);
        self.planned.push(p);
    }

    /// Plans a dynamic box named `name` of `size` at `pose`.
    fn brick(&mut self, name: String, asleep: bool, size: Vec3, material: &str, pose: Pose, path: &KeyPath) {
        let p = Planned {
            body: dynamic(asleep).pose(pose),
            is_static: false,
            shape: cuboid(size),
            material: self.scene.material(material),
            pose,
            path: path.clone(),
            generated: false,
        };
        self.push(name, p);
    }

    /// Puts the ground, if any, in the world at once (it is first in the
    /// outputs); returns its height and key path for the overlap check.
    fn ground(&mut self, world: &mut World, bodies: &mut Vec<BodyInfo>) -> Result<Option<(f32, KeyPath)>, SceneError> {
        let scene = self.scene;
        let Some(g) = &scene.world.ground else { return Ok(None) };
        let path = KeyPath::key("world").join("ground");
        let err = |e: crumble::WorldError| scene.err(&path, e.to_string());
        let h = world.insert_body(BodyBuilder::fixed()).map_err(err)?;
        let c = ColliderBuilder::ground(g.height).map_err(|e| scene.err(&path, e.to_string()))?;
        world.insert_collider(c.material(scene.material(&g.material)), h).map_err(err)?;
        bodies.push(BodyInfo {
            name: self.name("ground".into(), &path)?,
            shape: BodyShape::Plane { height: g.height },
            is_static: true,
            source: path.to_string(),
            initial: Pose::from_translation(Vec3::new(0.0, g.height, 0.0)),
            handle: Some(h),
            spawn_time: 0.0,
            metal: false,
            parent: None,
            despawn: None,
        });
        Ok(Some((g.height, path)))
    }

    /// The single bodies (`[[body]]`).
    fn bodies(&mut self) -> Result<(), SceneError> {
        let scene = self.scene;
        for (i, b) in scene.body.iter().enumerate() {
            let path = KeyPath::item("body", i);
            let shape = match b.shape {
                ShapeKind::Cuboid => match (b.size, b.half_extents) {
                    (Some(s), _) => cuboid(v3(s)),
                    (_, Some(h)) => Shape::cuboid(v3(h)).expect("validated"),
                    _ => unreachable!("validated"),
                },
                ShapeKind::Sphere => Shape::ball(b.radius.expect("validated")).expect("validated"),
            };
            let rotation = if let Some(aa) = &b.axis_angle {
                Quat::from_axis_angle(v3(aa.axis).normalize(), aa.degrees.to_radians())
            } else if let Some(q) = b.quaternion {
                Quat::from_array(q).normalize()
            } else {
                Quat::IDENTITY
            };
            let pose = Pose::new(v3(b.position), rotation);
            let builder = if b.is_static { BodyBuilder::fixed() } else { dynamic(b.asleep) }
                .pose(pose)
                .linear_velocity(v3(b.velocity))
                .angular_velocity(v3(b.angular_velocity))
                .bullet(b.bullet);
            let name = self.name(b.name.clone().unwrap_or_else(|| format!("body{i}")), &path)?;
            let material = scene.material(&b.material);
            let p = Planned { body: builder, is_static: b.is_static, shape, material, pose, path, generated: false };
            self.push(name, p);
        }
        Ok(())
    }

    /// The walls (`[[wall]]`), row after row from the bottom.
    fn walls(&mut self) -> Result<(), SceneError> {
        let scene = self.scene;
        for (i, wl) in scene.wall.iter().enumerate() {
            let path = KeyPath::item("wall", i);
            let prefix = wl.name.clone().unwrap_or_else(|| format!("wall{i}"));
            let rot = Quat::from_rotation_y(wl.facing[0].atan2(wl.facing[2]));
            let [bw, bh, bd] = wl.brick;
            let pitch = bw + wl.gap;
            let length = wl.bricks_per_row as f32 * pitch - wl.gap;
            let origin = v3(wl.position);
            let first = self.planned.len();
            let mut k = 0;
            for row in 0..wl.rows {
                let y = bh * 0.5 + row as f32 * (bh + wl.gap);
                let left = -length * 0.5;
                let mut row_bricks: Vec<(f32, f32)> = Vec::new();
                if wl.bond == BondSpec::Running && row % 2 == 1 {
                    // Half bricks at both ends keep the ends flush.
                    let half = (bw - wl.gap) * 0.5;
                    row_bricks.push((left + half * 0.5, half));
                    for j in 0..wl.bricks_per_row - 1 {
                        row_bricks.push((left + half + wl.gap + j as f32 * pitch + bw * 0.5, bw));
                    }
                    row_bricks.push((-left - half * 0.5, half));
                } else {
                    for j in 0..wl.bricks_per_row {
                        row_bricks.push((left + j as f32 * pitch + bw * 0.5, bw));
                    }
                }
                for (x, width) in row_bricks {
                    let pose = Pose::new(origin + rot * Vec3::new(x, y, 0.0), rot);
                    let name = self.name(format!("{prefix}/{k}"), &path)?;
                    self.brick(name, wl.asleep, Vec3::new(width, bh, bd), &wl.material, pose, &path);
                    if wl.density_jitter > 0.0 {
                        let p = self.planned.last_mut().expect("just planned");
                        p.material.density *= 1.0 + wl.density_jitter * unit_jitter(wl.seed, k);
                    }
                    k += 1;
                }
            }
            self.walls.push(first..self.planned.len());
        }
        Ok(())
    }

    /// The bonds (`[[bond]]`), their bodies found by name (the ground as
    /// `ground`; see [`side`](Self::side)).
    fn bonds(&self, first_projectile: usize) -> Result<Vec<PlannedBond<'a>>, SceneError> {
        let scene = self.scene;
        if scene.bond.is_empty() {
            return Ok(Vec::new());
        }
        let index = self.name_index();
        let mut out = Vec::new();
        for (i, b) in scene.bond.iter().enumerate() {
            let path = KeyPath::item("bond", i);
            let a = self.side(&index, &b.a, &path.join("a"), "bond", first_projectile)?;
            let c = self.side(&index, &b.b, &path.join("b"), "bond", first_projectile)?;
            if matches!(a, Side::World) || matches!(c, Side::World) {
                return Err(scene.err(&path, format!("a bond joins bodies: `{WORLD}` has no faces")));
            }
            out.push(PlannedBond { spec: b, a, b: c, path });
        }
        Ok(out)
    }

    /// The plan's body of each name.
    fn name_index(&self) -> HashMap<&str, usize> {
        self.names_of.iter().enumerate().map(|(k, n)| (n.as_str(), k)).collect()
    }

    /// The side called `name` of a `[[joint]]` or `[[bond]]` (`what`), at
    /// `key`: the world, the ground (`ground`, when there is one), or a
    /// planned body; the projectiles, from `first_projectile` on, are not
    /// in the world from the start and cannot be joined or bonded.
    fn side(
        &self,
        index: &HashMap<&str, usize>,
        name: &str,
        key: &KeyPath,
        what: &str,
        first_projectile: usize,
    ) -> Result<Side, SceneError> {
        let scene = self.scene;
        match (name, index.get(name)) {
            (WORLD, _) => Ok(Side::World),
            ("ground", _) if scene.world.ground.is_some() => Ok(Side::Ground),
            (_, Some(&k)) if k >= first_projectile => {
                let msg = format!(
                    "`{name}` is a projectile, which enters the world at its launch time: a {what} joins bodies \
                     that are there from the start"
                );
                Err(scene.err(key, msg))
            }
            (_, Some(&k)) => Ok(Side::Planned(k)),
            (_, None) => {
                let msg = format!(
                    "no body is named `{name}` (a side is a body's name, e.g. `wall0/0` for a generated brick, \
                     `ground`, or `{WORLD}` for a joint)"
                );
                Err(scene.err(key, msg))
            }
        }
    }

    /// The pyramids (`[[pyramid]]`), level after level from the bottom.
    fn pyramids(&mut self) -> Result<(), SceneError> {
        let scene = self.scene;
        for (i, py) in scene.pyramid.iter().enumerate() {
            let path = KeyPath::item("pyramid", i);
            let prefix = py.name.clone().unwrap_or_else(|| format!("pyramid{i}"));
            let size = v3(py.size);
            let origin = v3(py.position);
            let mut k = 0;
            for level in 0..py.base {
                let count = py.base - level;
                let pitch = size.x + py.gap;
                let y = size.y * 0.5 + level as f32 * (size.y + py.gap);
                let x0 = -(count as f32 - 1.0) * pitch * 0.5;
                for j in 0..count {
                    let pose = Pose::from_translation(origin + Vec3::new(x0 + j as f32 * pitch, y, 0.0));
                    let name = self.name(format!("{prefix}/{k}"), &path)?;
                    k += 1;
                    self.brick(name, py.asleep, size, &py.material, pose, &path);
                }
            }
        }
        Ok(())
    }

    /// The stacks (`[[stack]]`), from the bottom.
    fn stacks(&mut self) -> Result<(), SceneError> {
        let scene = self.scene;
        for (i, st) in scene.stack.iter().enumerate() {
            let path = KeyPath::item("stack", i);
            let prefix = st.name.clone().unwrap_or_else(|| format!("stack{i}"));
            let size = v3(st.size);
            for level in 0..st.count {
                let l = level as f32;
                let offset = Vec3::new(st.offset[0] * l, size.y * (l + 0.5), st.offset[1] * l);
                let pose = Pose::from_translation(v3(st.position) + offset);
                let name = self.name(format!("{prefix}/{level}"), &path)?;
                self.brick(name, st.asleep, size, &st.material, pose, &path);
            }
        }
        Ok(())
    }

    /// The wrecking balls (`[[wrecking_ball]]`): their links from the
    /// anchor down, then the ball, at the poses the engine's generator
    /// gives them ([`scenes::add_wrecking_ball`], which makes them when the
    /// world is built).
    fn wrecking_balls(&mut self) -> Result<(), SceneError> {
        let scene = self.scene;
        for (i, wb) in scene.wrecking_ball.iter().enumerate() {
            let path = KeyPath::item("wrecking_ball", i);
            let [dx, _, dz] = wb.direction;
            let spec = scenes::WreckingBallSpec {
                anchor: v3(wb.anchor),
                links: wb.links,
                link: v3(wb.link),
                link_material: scene.material(&wb.link_material),
                ball_radius: wb.ball_radius,
                ball_material: scene.material(&wb.ball_material),
                release_angle: wb.release_angle_deg.to_radians(),
                direction: Vec3::new(dx, 0.0, dz),
                tether: wb.tether,
            };
            let (ball, chain) = match (&wb.name, i) {
                (Some(name), _) => (format!("{name}/ball"), format!("{name}/chain")),
                (None, 0) => ("ball".to_string(), "chain".to_string()),
                (None, i) => (format!("ball{i}"), format!("chain{i}")),
            };
            // As `add_wrecking_ball` lays them: link k centred (k + ½) link
            // lengths from the anchor along the chain, the ball's centre its
            // radius past the last link's end.
            let d = spec.hanging_direction();
            let along = Quat::from_rotation_arc(Vec3::NEG_Y, d);
            let anchor = spec.anchor;
            // The generator's refusal of a body too light or heavy to
            // simulate would name neither the body nor the key.
            let ball_shape =
                Shape::ball(wb.ball_radius).map_err(|e| scene.err(&path.join("ball_radius"), e.to_string()))?;
            for (key, shape, density) in [
                ("link", &cuboid(spec.link), spec.link_material.density),
                ("ball_radius", &ball_shape, spec.ball_material.density),
            ] {
                crumble::mass::check_shape(shape, density)
                    .map_err(|e| scene.err(&path.join(key), format!("the body cannot be simulated: {e}")))?;
            }
            let first = self.planned.len();
            for k in 0..spec.links {
                let name = self.name(format!("{chain}/{k}"), &path)?;
                let pose = Pose::new(anchor + d * ((k as f32 + 0.5) * spec.link.y), along);
                self.brick(name, false, spec.link, &wb.link_material, pose, &path);
            }
            let name = self.name(ball, &path)?;
            let pose = Pose::from_translation(anchor + d * spec.length());
            let p = Planned {
                body: dynamic(false).pose(pose),
                is_static: false,
                shape: ball_shape,
                material: spec.ball_material,
                pose,
                path: path.clone(),
                generated: false,
            };
            self.push(name, p);
            for p in &mut self.planned[first..] {
                p.generated = true;
            }
            self.wrecking_balls.push(PlannedWreckingBall { first, spec });
        }
        Ok(())
    }

    /// The joints (`[[joint]]`), their sides found by name among the
    /// planned bodies (the projectiles, from `first_projectile` on, are
    /// not in the world from the start and cannot be joined).
    fn joints(&self, first_projectile: usize) -> Result<Vec<PlannedJoint<'a>>, SceneError> {
        let scene = self.scene;
        if scene.joint.is_empty() {
            return Ok(Vec::new());
        }
        let index = self.name_index();
        let mut out = Vec::new();
        for (i, j) in scene.joint.iter().enumerate() {
            let path = KeyPath::item("joint", i);
            let sides = [
                self.side(&index, &j.a, &path.join("a"), "joint", first_projectile)?,
                self.side(&index, &j.b, &path.join("b"), "joint", first_projectile)?,
            ];
            let dynamic = |s: Side| matches!(s, Side::Planned(k) if !self.planned[k].is_static);
            if !sides.iter().any(|&s| dynamic(s)) {
                let msg = format!("neither `{}` nor `{}` is a dynamic body: a joint needs one that moves", j.a, j.b);
                return Err(scene.err(&path, msg));
            }
            out.push(PlannedJoint { spec: j, a: sides[0], b: sides[1], path });
        }
        Ok(out)
    }

    /// The projectiles (`[[projectile]]`), planned at their launch poses;
    /// returns their launch times and velocities.
    fn projectiles(&mut self) -> Result<Vec<(f64, Vec3)>, SceneError> {
        let scene = self.scene;
        let gravity = v3(scene.world.gravity);
        let mut launches = Vec::new();
        for (i, pr) in scene.projectile.iter().enumerate() {
            let path = KeyPath::item("projectile", i);
            let shape = match pr.shape {
                ShapeKind::Cuboid => cuboid(v3(pr.size.expect("validated"))),
                ShapeKind::Sphere => Shape::ball(pr.radius.expect("validated")).expect("validated"),
            };
            let from = v3(pr.from);
            let velocity = match (pr.velocity, pr.target, pr.speed) {
                (Some(v), _, _) => v3(v),
                (None, Some(t), Some(speed)) => aim(from, v3(t), speed, gravity),
                _ => unreachable!("validated"),
            };
            if !velocity.is_finite() {
                return Err(scene.err(&path, "the aimed velocity is not finite".into()));
            }
            let pose = Pose::from_translation(from);
            let name = self.name(pr.name.clone().unwrap_or_else(|| format!("projectile{i}")), &path)?;
            let p = Planned {
                // Launched from its `Launch`, made by `insert`.
                body: BodyBuilder::dynamic().pose(pose),
                is_static: false,
                shape,
                material: scene.material(&pr.material),
                pose,
                path,
                generated: false,
            };
            self.push(name, p);
            launches.push((pr.at as f64, velocity));
        }
        Ok(launches)
    }

    /// Puts the planned bodies in the world in their order, and the
    /// projectiles (from `first_projectile` on, launched at the times and
    /// velocities of `launches`) in the schedule; returns the schedule.
    fn insert(
        self,
        world: &mut World,
        bodies: &mut Vec<BodyInfo>,
        first_projectile: usize,
        launches: &[(f64, Vec3)],
    ) -> Result<Vec<ScheduledSpawn>, SceneError> {
        let scene = self.scene;
        let mut pending = Vec::new();
        let mut wrecking_balls = self.wrecking_balls.into_iter().peekable();
        // Bodies made by a generator, waiting for their `BodyInfo`.
        let mut made: VecDeque<BodyHandle> = VecDeque::new();
        for (k, (p, name)) in self.planned.into_iter().zip(self.names_of).enumerate() {
            let shape = match p.shape {
                Shape::Cuboid(c) => BodyShape::Box { half_extents: c.half_extents() },
                Shape::Ball(b) => BodyShape::Sphere { radius: b.radius() },
                Shape::HalfSpace(_) => unreachable!("only the ground is a plane"),
            };
            let is_static = p.is_static;
            let collider = ColliderBuilder::new(p.shape).material(p.material);
            let source = p.path.to_string();
            let metal = p.material.density >= 4500.0;
            let (initial, handle, spawn_time) = (p.pose, None, 0.0);
            let mut info = BodyInfo {
                name,
                shape,
                is_static,
                source,
                initial,
                handle,
                spawn_time,
                metal,
                parent: None,
                despawn: None,
            };
            if k >= first_projectile {
                // Launched mid-run: refused now, at its key, if its mass
                // is out of the simulated range, rather than at its launch.
                crumble::mass::check_shape(&p.shape, p.material.density)
                    .map_err(|e| scene.err(&p.path, format!("the body cannot be simulated: {e}")))?;
                let (time, velocity) = launches[k - first_projectile];
                info.spawn_time = time;
                let launch = Launch { pose: p.pose, velocity, shape: p.shape, material: p.material };
                pending.push(ScheduledSpawn { time, index: bodies.len(), launch });
            } else if p.generated {
                if let Some(wb) = wrecking_balls.next_if(|wb| wb.first == k) {
                    let err = |e: WorldError| scene.err(&p.path, e.to_string());
                    let made_now = scenes::add_wrecking_ball(world, &wb.spec).map_err(err)?;
                    made.extend(made_now.links);
                    made.push_back(made_now.ball);
                }
                let h = made.pop_front().ok_or_else(|| scene.err(&p.path, "made fewer bodies than planned".into()))?;
                info.handle = Some(h);
            } else {
                let h = world.insert_body(p.body).map_err(|e| scene.err(&p.path, e.to_string()))?;
                world.insert_collider(collider, h).map_err(|e| scene.err(&p.path, e.to_string()))?;
                info.handle = Some(h);
            }
            bodies.push(info);
        }
        pending.sort_by(|a, b| a.time.total_cmp(&b.time));
        Ok(pending)
    }
}

/// Launch velocity from `from` that reaches `target` (under `gravity`, no
/// drag) after the time a straight flight at `speed` would take.
pub fn aim(from: Vec3, target: Vec3, speed: f32, gravity: Vec3) -> Vec3 {
    let d = target - from;
    let t = d.length() / speed;
    d / t - gravity * (0.5 * t)
}
