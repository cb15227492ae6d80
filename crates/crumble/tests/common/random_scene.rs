//! Seeded random scenes and the rules every step of them must keep: no
//! fault, no speed above the cap, no energy from nowhere (issue 46).
//!
//! [`Scene::generate`] draws the kind of scene that found the engine's
//! faults and energy gains in the reliability findings behind issue 46
//! (their section 3): 1–12 boxes and balls spanning grains to boulders,
//! light foam to heavy metal, at rest or fast, with and without ground.
//! [`run`] simulates one and reports the first break of each rule
//! ([`Outcome`]); a failure names the seed, the step, the body and the
//! quantity against its limit, so that it can be replayed alone.
//!
//! Shared by `tests/random_scenes.rs` (seeds 0–999 as an ordinary test)
//! and `examples/random_scenes.rs` (the same with counts, likely causes
//! and shrunk reproducers).

use std::fmt;

use super::Rng;
use crumble::glam::DVec3;
use crumble::{BodyBuilder, BodyHandle, ColliderBuilder, Material, Quat, Shape, Vec3, World, WorldSettings};

/// The step sizes a scene is run at, s.
pub const TIME_STEPS: [f32; 3] = [1.0 / 30.0, 1.0 / 60.0, 1.0 / 120.0];

/// Smallest clearance between two bodies' bounding spheres, and between a
/// bounding sphere and the ground, m. Bodies are created apart, so that
/// the push-out of overlap (which moves bodies without a velocity and may
/// lift them) has nothing to undo at the start; 0.1 mm stays well above
/// the f32 spacing of positions within 100 m of the origin (8 µm).
pub const MIN_GAP: f64 = 1e-4;

/// A collider's shape as the scene describes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShapeSpec {
    /// A ball of this radius, m.
    Ball(f32),
    /// A box of these half extents, m.
    Box(Vec3),
}

impl ShapeSpec {
    /// The engine's shape.
    pub fn shape(&self) -> Shape {
        match *self {
            ShapeSpec::Ball(r) => Shape::ball(r).expect("generated radius is valid"),
            ShapeSpec::Box(h) => Shape::cuboid(h).expect("generated half extents are valid"),
        }
    }

    /// Radius of the smallest ball about the body's origin that holds it, m.
    pub fn bounding_radius(&self) -> f64 {
        match *self {
            ShapeSpec::Ball(r) => r as f64,
            ShapeSpec::Box(h) => h.as_dvec3().length(),
        }
    }
}

/// One body of a scene: a single collider at the body's origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySpec {
    pub shape: ShapeSpec,
    pub material: Material,
    /// Static (never moves) or dynamic.
    pub fixed: bool,
    pub position: Vec3,
    pub rotation: Quat,
    pub linear_velocity: Vec3,
    pub angular_velocity: Vec3,
    pub bullet: bool,
}

impl BodySpec {
    /// Principal moments of inertia (kg·m²) the engine computes for a
    /// dynamic body of this shape and density, or `None` when it finds
    /// none (mass out of f32 range).
    pub fn principal_inertia(&self) -> Option<Vec3> {
        self.shape.shape().mass_properties(self.material.density).ok().map(|m| m.principal_inertia)
    }

    /// Whether the inverse of this body's inertia leaves f32 (finding F2):
    /// `I⁻¹ = adj(I) / det(I)` with `det = I_x I_y I_z` below 1/f32::MAX,
    /// or a cofactor `I_j I_k` above f32::MAX. The findings predicted
    /// every NaN of their random scenes with this rule.
    pub fn inertia_out_of_range(&self) -> bool {
        if self.fixed {
            return false;
        }
        match self.principal_inertia() {
            None => true,
            Some(i) => {
                let i = i.as_dvec3();
                let det = i.x * i.y * i.z;
                let cofactor = (i.x * i.y).max(i.y * i.z).max(i.z * i.x);
                det < 1.0 / f32::MAX as f64 || cofactor > f32::MAX as f64
            }
        }
    }
}

impl fmt::Display for BodySpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.shape {
            ShapeSpec::Ball(r) => write!(f, "ball r={r:.3e}")?,
            ShapeSpec::Box(h) => write!(f, "box size=[{:.3e}, {:.3e}, {:.3e}]", 2.0 * h.x, 2.0 * h.y, 2.0 * h.z)?,
        }
        let m = self.material;
        write!(f, " ρ={:.3e} μ={:.2} e={:.2} rr={:.3}", m.density, m.friction, m.restitution, m.rolling_resistance)?;
        if self.fixed {
            return write!(f, " static");
        }
        if let Some(i) = self.principal_inertia() {
            write!(f, " I=[{:.1e}, {:.1e}, {:.1e}]", i.x, i.y, i.z)?;
        }
        write!(f, " |v|={:.3} |ω|={:.3}", self.linear_velocity.length(), self.angular_velocity.length())?;
        if self.bullet {
            write!(f, " bullet")?;
        }
        Ok(())
    }
}

/// A scene: its bodies, an optional ground (the half-space y < 0) with its
/// material, and how it is stepped.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub seed: u64,
    pub bodies: Vec<BodySpec>,
    pub ground: Option<Material>,
    pub dt: f32,
    pub substeps: u32,
    pub steps: u32,
    /// `WorldSettings::continuous` (always on in generated scenes; off to
    /// tell what continuous collision does in one).
    pub continuous: bool,
}

/// A random material: friction 0–1.5, restitution 0–1, and in 30 % of
/// cases rolling resistance 0–0.1 (the rest none).
fn material(rng: &mut Rng, density: f32) -> Material {
    let friction = rng.range(0.0, 1.5) as f32;
    let restitution = rng.range(0.0, 1.0) as f32;
    let rolling_resistance = if rng.unit() < 0.3 { rng.range(0.0, 0.1) as f32 } else { 0.0 };
    Material { density, friction, restitution, rolling_resistance, strength: None }
}

impl Scene {
    /// The scene of `seed`. The draws, in order:
    ///
    /// - 70 % of scenes have a ground (a random material, density unused).
    /// - 1–12 bodies; 40 % balls of diameter, else boxes of edges, each
    ///   log-uniform in 1 mm – 10 m; densities log-uniform in 1 – 20,000
    ///   kg/m³; uniformly random orientations; materials as [`material`].
    /// - 15 % static. Of the dynamic ones 30 % start at rest; the others
    ///   move at 0.1 – 200 m/s (log-uniform), half of them aimed at the
    ///   cluster's centre and half in a random direction, and half of those
    ///   spin at 0.1 – 50 rad/s about a random axis. 20 % of the dynamic
    ///   bodies are bullets.
    /// - Placement near-touching and never overlapping: each body after
    ///   the first is put against a random earlier one, its bounding sphere
    ///   at a clearance of 0.1 mm plus up to 5 % of the smaller radius, and
    ///   is kept only if its bounding sphere clears every other one and the
    ///   ground by [`MIN_GAP`]; after 64 refused tries it goes on top of
    ///   the pile. With a ground, the first body sits its clearance above
    ///   it, or up to 5 m higher in half the scenes.
    /// - dt of 1/30, 1/60 or 1/120 s, 1–8 substeps, 60–300 steps.
    pub fn generate(seed: u64) -> Scene {
        let mut rng = Rng::new(seed);
        let ground = if rng.unit() < 0.7 { Some(material(&mut rng, 1000.0)) } else { None };
        let n = 1 + (rng.next_u64() % 12) as usize;
        let mut bodies = Vec::with_capacity(n);
        for _ in 0..n {
            let shape = if rng.unit() < 0.4 {
                ShapeSpec::Ball((0.5 * rng.log_range(1e-3, 10.0)) as f32)
            } else {
                let mut edge = || (0.5 * rng.log_range(1e-3, 10.0)) as f32;
                ShapeSpec::Box(Vec3::new(edge(), edge(), edge()))
            };
            let density = rng.log_range(1.0, 20_000.0) as f32;
            let material = material(&mut rng, density);
            let fixed = rng.unit() < 0.15;
            bodies.push(BodySpec {
                shape,
                material,
                fixed,
                position: Vec3::ZERO,
                rotation: rng.rotation(),
                linear_velocity: Vec3::ZERO,
                angular_velocity: Vec3::ZERO,
                bullet: false,
            });
        }
        // Placement, in f64; positions are rounded to f32 once, far inside
        // the clearance.
        let mut centres: Vec<DVec3> = Vec::with_capacity(n);
        for i in 0..n {
            let r = bodies[i].shape.bounding_radius();
            let clear = |c: DVec3, centres: &[DVec3]| {
                let above_ground = ground.is_none() || c.y - r >= MIN_GAP;
                above_ground
                    && centres
                        .iter()
                        .zip(&bodies)
                        .all(|(&o, b)| (c - o).length() >= r + b.shape.bounding_radius() + MIN_GAP)
            };
            let mut at = None;
            if i == 0 {
                let lift = if rng.unit() < 0.5 { 0.0 } else { rng.range(0.0, 5.0) };
                let y = if ground.is_some() { r + MIN_GAP + rng.range(0.0, 1e-3) + lift } else { rng.range(-5.0, 5.0) };
                at = Some(DVec3::new(0.0, y, 0.0));
            } else {
                for _ in 0..64 {
                    let j = (rng.next_u64() % i as u64) as usize;
                    let rj = bodies[j].shape.bounding_radius();
                    let gap = MIN_GAP + rng.range(0.0, 0.05) * r.min(rj);
                    let c = centres[j] + rng.unit_vector().as_dvec3() * (r + rj + gap);
                    if clear(c, &centres) {
                        at = Some(c);
                        break;
                    }
                }
            }
            let c = at.unwrap_or_else(|| {
                let top = centres.iter().zip(&bodies).map(|(c, b)| c.y + b.shape.bounding_radius()).fold(0.0, f64::max);
                DVec3::new(0.0, top + r + 2.0 * MIN_GAP, 0.0)
            });
            centres.push(c);
        }
        let centre = centres.iter().sum::<DVec3>() / n as f64;
        for (b, &c) in bodies.iter_mut().zip(&centres) {
            b.position = c.as_vec3();
            if b.fixed {
                continue;
            }
            b.bullet = rng.unit() < 0.2;
            if rng.unit() < 0.3 {
                continue; // at rest
            }
            let speed = rng.log_range(0.1, 200.0);
            let towards = centre - c;
            let dir = if rng.unit() < 0.5 && towards.length() > 1e-9 {
                towards.normalize()
            } else {
                rng.unit_vector().as_dvec3()
            };
            b.linear_velocity = (dir * speed).as_vec3();
            if rng.unit() < 0.5 {
                b.angular_velocity = rng.unit_vector() * rng.log_range(0.1, 50.0) as f32;
            }
        }
        let dt = TIME_STEPS[(rng.next_u64() % 3) as usize];
        let substeps = 1 + (rng.next_u64() % 8) as u32;
        let steps = 60 + (rng.next_u64() % 241) as u32;
        Scene { seed, bodies, ground, dt, substeps, steps, continuous: true }
    }

    /// The world settings the scene runs with: the defaults, its
    /// substeps, and one thread (each scene is small; the results are the
    /// same bits whatever the threads).
    pub fn settings(&self) -> WorldSettings {
        WorldSettings { substeps: self.substeps, continuous: self.continuous, threads: 1, ..WorldSettings::default() }
    }

    /// The world of this scene, its bodies' handles in scene order.
    pub fn build(&self) -> Result<(World, Vec<BodyHandle>), String> {
        let mut world = World::new(self.settings()).map_err(|e| format!("settings: {e}"))?;
        if let Some(m) = self.ground {
            let g = world.insert_body(BodyBuilder::fixed()).map_err(|e| format!("ground: {e}"))?;
            let c = ColliderBuilder::ground(0.0).map_err(|e| format!("ground: {e}"))?;
            world.insert_collider(c.material(m), g).map_err(|e| format!("ground: {e}"))?;
        }
        let mut handles = Vec::with_capacity(self.bodies.len());
        for (i, b) in self.bodies.iter().enumerate() {
            let builder = if b.fixed { BodyBuilder::fixed() } else { BodyBuilder::dynamic() };
            let builder = builder
                .position(b.position)
                .rotation(b.rotation)
                .linear_velocity(b.linear_velocity)
                .angular_velocity(b.angular_velocity)
                .bullet(b.bullet);
            let h = world.insert_body(builder).map_err(|e| format!("body {i} ({b}): {e}"))?;
            world
                .insert_collider(ColliderBuilder::new(b.shape.shape()).material(b.material), h)
                .map_err(|e| format!("body {i} ({b}): {e}"))?;
            handles.push(h);
        }
        Ok((world, handles))
    }

    /// The scene as Rust code that builds it with the public API (f32
    /// values printed so that they read back to the same bits), for a
    /// reproducer.
    pub fn to_rust(&self) -> String {
        let v = |v: Vec3| format!("Vec3::new({:?}, {:?}, {:?})", v.x, v.y, v.z);
        let q = |q: Quat| format!("Quat::from_xyzw({:?}, {:?}, {:?}, {:?})", q.x, q.y, q.z, q.w);
        let m = |m: Material| {
            format!(
                "Material {{ density: {:?}, friction: {:?}, restitution: {:?}, rolling_resistance: {:?}, strength: None }}",
                m.density, m.friction, m.restitution, m.rolling_resistance
            )
        };
        let mut s = String::new();
        let continuous = if self.continuous { "" } else { "continuous: false, " };
        s += &format!(
            "// seed {}: dt {:?}, {} steps\nlet mut w = World::new(WorldSettings {{ substeps: {}, {continuous}..WorldSettings::default() }}).unwrap();\n",
            self.seed, self.dt, self.steps, self.substeps
        );
        if let Some(g) = self.ground {
            s += "let g = w.insert_body(BodyBuilder::fixed()).unwrap();\n";
            s += &format!("w.insert_collider(ColliderBuilder::ground(0.0).unwrap().material({}), g).unwrap();\n", m(g));
        }
        for (i, b) in self.bodies.iter().enumerate() {
            let kind = if b.fixed { "fixed" } else { "dynamic" };
            let mut builder = format!("BodyBuilder::{kind}().position({}).rotation({})", v(b.position), q(b.rotation));
            if b.linear_velocity != Vec3::ZERO {
                builder += &format!(".linear_velocity({})", v(b.linear_velocity));
            }
            if b.angular_velocity != Vec3::ZERO {
                builder += &format!(".angular_velocity({})", v(b.angular_velocity));
            }
            if b.bullet {
                builder += ".bullet(true)";
            }
            let shape = match b.shape {
                ShapeSpec::Ball(r) => format!("ColliderBuilder::ball({r:?})"),
                ShapeSpec::Box(h) => format!("ColliderBuilder::cuboid({:?}, {:?}, {:?})", h.x, h.y, h.z),
            };
            s += &format!("let b{i} = w.insert_body({builder}).unwrap();\n");
            s += &format!("w.insert_collider({shape}.unwrap().material({}), b{i}).unwrap();\n", m(b.material));
        }
        s
    }
}

impl fmt::Display for Scene {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "seed {}: {} bodies, {}, dt 1/{:.0}, {} substeps, {} steps",
            self.seed,
            self.bodies.len(),
            if self.ground.is_some() { "ground" } else { "no ground" },
            1.0 / self.dt,
            self.substeps,
            self.steps
        )
    }
}

/// A rule broken at a step (1 = after the first step).
#[derive(Clone, Debug, PartialEq)]
pub enum Violation {
    /// The scene could not be built (a body refused).
    Build(String),
    /// `World::step` returned an error.
    Step { step: u32, error: String },
    /// A body was reported faulted or holds a non-finite pose or velocity.
    Fault { step: u32, body: usize, what: String },
    /// A dynamic body faster than `WorldSettings::max_linear_speed`.
    Speed { step: u32, body: usize, speed: f64, cap: f64 },
    /// Total energy above its start plus the tolerance; `in_play` is the
    /// energy the relative part of the tolerance is taken of, `body` the
    /// body whose own energy rose the most since the start; `spin_gain`
    /// and `ccd_gain` are [`Outcome::spin_gain`] and
    /// [`Outcome::ccd_gain`] up to this step.
    Energy {
        step: u32,
        body: usize,
        energy: f64,
        start: f64,
        tolerance: f64,
        in_play: f64,
        body_gain: f64,
        spin_gain: f64,
        ccd_gain: f64,
    },
}

impl Violation {
    /// The step at which it happened (0: before the first).
    pub fn step(&self) -> u32 {
        match *self {
            Violation::Build(_) => 0,
            Violation::Step { step, .. }
            | Violation::Fault { step, .. }
            | Violation::Speed { step, .. }
            | Violation::Energy { step, .. } => step,
        }
    }

    /// The body it names, if any.
    pub fn body(&self) -> Option<usize> {
        match *self {
            Violation::Fault { body, .. } | Violation::Speed { body, .. } | Violation::Energy { body, .. } => {
                Some(body)
            }
            _ => None,
        }
    }
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Violation::Build(e) => write!(f, "build: {e}"),
            Violation::Step { step, error } => write!(f, "step {step}: error {error}"),
            Violation::Fault { step, body, what } => write!(f, "step {step}: body {body} {what}"),
            Violation::Speed { step, body, speed, cap } => {
                write!(f, "step {step}: body {body} at {speed:.6e} m/s, cap {cap} m/s")
            }
            Violation::Energy { step, body, energy, start, tolerance, in_play, body_gain, spin_gain, ccd_gain } => {
                write!(
                    f,
                    "step {step}: energy {energy:.6e} J, start {start:.6e} J + tolerance {tolerance:.3e} J \
                 (gain {:.3e} J: {:.3e}× the tolerance, {:.3e}× the energy in play); body {body} gained most: \
                 {body_gain:.3e} J; spun up with no torque: {spin_gain:.3e} J, in steps with a sweep hit: \
                 {ccd_gain:.3e} J",
                    energy - start,
                    (energy - start) / tolerance,
                    (energy - start) / in_play
                )
            }
        }
    }
}

/// What a run found: the first break of each rule, and the worst energy
/// gain as a multiple of its tolerance (for choosing the tolerance).
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// `Build`, `Step` or `Fault`.
    pub fault: Option<Violation>,
    pub speed: Option<Violation>,
    pub energy: Option<Violation>,
    /// Largest (E − E₀) / tolerance over the steps.
    pub worst_energy_ratio: f64,
    /// Rotational energy the dynamic bodies gained in steps in which the
    /// length of their angular momentum did not grow (beyond 1e-3 of it,
    /// its rounding in f32 at high spin and inertia ratios):
    /// a torque-free body keeps both (the gyroscopic step keeps `|Iω|`,
    /// the rotation cap shrinks it), and a contact that spins a body up
    /// grows it. So a positive sum is energy that the spin made of
    /// itself, not a contact.
    pub spin_gain: f64,
    /// The change of the total energy over the steps in which continuous
    /// collision put a body back (`Profile::ccd_hits`): a body put back
    /// along its path keeps its velocity, so one falling is lifted with
    /// nothing paying for it.
    pub ccd_gain: f64,
}

impl Outcome {
    /// True when no rule broke.
    pub fn clean(&self) -> bool {
        self.fault.is_none() && self.speed.is_none() && self.energy.is_none()
    }

    /// The earliest violation.
    pub fn first(&self) -> Option<&Violation> {
        [&self.fault, &self.speed, &self.energy].into_iter().flatten().min_by_key(|v| v.step())
    }
}

/// Relative part of the energy tolerance: 1e-3 of the energy in play
/// (see [`run`] for why, and how little the counts depend on it).
pub const ENERGY_REL: f64 = 1e-3;

/// Push-out part of the energy tolerance, m: how far a body may be lifted
/// back out of another by the push-out of overlap (see [`run`]). Ten
/// times the default `linear_slop`, the overlap left alone, and above the
/// sinking of a resting contact in a step.
pub const PUSH_OUT_LIFT: f64 = 1e-4;

/// Energy of the dynamic bodies: kinetic (linear `½ m v²` and rotational
/// `½ ωᵀ I ω` with the world inertia) plus gravitational potential
/// `−m g·x` at the centre of mass, in f64. A sleeping body counts at rest.
/// Returns the total, each body's share (0 for static ones), and the
/// total kinetic part.
pub fn energies(world: &World, handles: &[BodyHandle]) -> (f64, Vec<f64>, f64) {
    let g = world.settings().gravity.as_dvec3();
    let mut total = 0.0;
    let mut kinetic = 0.0;
    let mut each = Vec::with_capacity(handles.len());
    for &h in handles {
        let b = world.body(h).expect("scene bodies are never removed");
        if !b.is_dynamic() {
            each.push(0.0);
            continue;
        }
        let m = b.mass() as f64;
        let potential = -m * g.dot(b.center_of_mass().as_dvec3());
        let k = if b.is_sleeping() {
            0.0
        } else {
            let v = b.linear_velocity().as_dvec3();
            let w = b.angular_velocity().as_dvec3();
            let i = b.world_inertia().as_dmat3();
            0.5 * m * v.length_squared() + 0.5 * w.dot(i * w)
        };
        each.push(k + potential);
        total += k + potential;
        kinetic += k;
    }
    (total, each, kinetic)
}

/// Each body's rotational energy `½ ωᵀ I ω` and the length of its angular
/// momentum `|I ω|` about its centre of mass (zeros for static and
/// sleeping bodies).
pub fn spins(world: &World, handles: &[BodyHandle]) -> Vec<(f64, f64)> {
    handles
        .iter()
        .map(|&h| match world.body(h) {
            Some(b) if b.is_dynamic() && !b.is_sleeping() => {
                let w = b.angular_velocity().as_dvec3();
                let l = b.world_inertia().as_dmat3() * w;
                (0.5 * w.dot(l), l.length())
            }
            _ => (0.0, 0.0),
        })
        .collect()
}

/// Runs `scene` and checks after every step:
///
/// - **No fault**: `World::faulted_bodies` is empty and every body's pose
///   and velocities are finite. (The issue: valid scenes never fault.)
/// - **Speed cap**: every dynamic body's linear speed is at most
///   `max_linear_speed`, plus 1e-3 of it for the rounding of the cap's own
///   `v · cap / |v|`. (The documented cap holds after the contact solve.)
/// - **No energy gain**: the energy of [`energies`] is at most its start
///   plus a tolerance of two parts:
///   - [`ENERGY_REL`] × the energy in play: the start's kinetic energy
///     plus the most potential energy released so far (`max(E_pot,0 −
///     E_pot)` over the steps). Every legitimate transfer (gravity's
///     work, collisions, spin into motion) moves at most that much
///     energy, and rounding and the solver's iteration tolerances make
///     errors in proportion to what is moved. A fraction of the *total*
///     energy would not do: a scene at rest high above the origin has a
///     large potential energy and nothing moving, and would hide any gain.
///   - [`PUSH_OUT_LIFT`] × Σ m |g| over the dynamic bodies: the push-out
///     of overlap moves bodies without a velocity (split impulse), so a
///     body that sank into another and is lifted back gains potential
///     energy that no velocity paid for. The bodies start apart
///     ([`MIN_GAP`]), so there is no start overlap whose removal (at up
///     to `max_push_out_speed`) could lift more than a contact's sinking.
///
///   Gravity's work needs no term of its own: it is the change of the
///   potential energy, which the total includes. Measured on seeds 0–999
///   (`examples/random_scenes.rs`): with restitution, rolling resistance,
///   initial spin and the bodies of finding F2 taken out, 979 scenes never
///   rise above their start energy at all, 7 stay below the bound, and
///   the 14 above it are causes, not noise (the gyroscopic step,
///   continuous collision's put-back, a slender box's contact). The failing counts barely depend on the
///   tolerance: 226, 213 and 186 scenes with 1e-4, 1e-3 and 1e-2 of the
///   energy in play, and 215 or 211 with no push-out term or ten times it;
///   a failing scene's gain is typically a hundred times the tolerance.
///
/// A fault does not stop the run; the outcome keeps the first break of
/// each rule. With `stop_at_first` the run ends at the first break.
pub fn run(scene: &Scene, stop_at_first: bool) -> Outcome {
    let mut out = Outcome::default();
    let (mut world, handles) = match scene.build() {
        Ok(w) => w,
        Err(e) => {
            out.fault = Some(Violation::Build(e));
            return out;
        }
    };
    let cap = world.settings().max_linear_speed as f64;
    let g = world.settings().gravity.as_dvec3().length();
    let (e0, each0, kinetic0) = energies(&world, &handles);
    let potential0 = e0 - kinetic0;
    let weight: f64 =
        handles.iter().filter_map(|&h| world.body(h)).filter(|b| b.is_dynamic()).map(|b| b.mass() as f64).sum::<f64>()
            * g;
    let mut released: f64 = 0.0;
    let mut spin_before = spins(&world, &handles);
    let mut e_previous = e0;
    for step in 1..=scene.steps {
        if let Err(e) = world.step(scene.dt) {
            out.fault.get_or_insert(Violation::Step { step, error: e.to_string() });
            break;
        }
        if out.fault.is_none() {
            let faulted = world.faulted_bodies();
            let all: Vec<usize> = (0..handles.len()).filter(|&i| faulted.contains(&handles[i])).collect();
            let flagged = all.first().map(|&i| (i, format!("faulted (faulted bodies: {all:?})")));
            let non_finite = || {
                handles.iter().enumerate().find_map(|(i, &h)| {
                    let b = world.body(h)?;
                    let finite =
                        b.pose().is_finite() && b.linear_velocity().is_finite() && b.angular_velocity().is_finite();
                    (!finite).then(|| (i, format!("non-finite: pose {:?} v {:?}", b.pose(), b.linear_velocity())))
                })
            };
            if let Some((body, what)) = flagged.or_else(non_finite) {
                out.fault = Some(Violation::Fault { step, body, what });
            }
        }
        if out.speed.is_none() {
            let fastest = handles
                .iter()
                .enumerate()
                .filter_map(|(i, &h)| {
                    world.body(h).filter(|b| b.is_dynamic()).map(|b| (i, b.linear_velocity().as_dvec3().length()))
                })
                .max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((body, speed)) = fastest {
                if speed > cap * (1.0 + 1e-3) {
                    out.speed = Some(Violation::Speed { step, body, speed, cap });
                }
            }
        }
        let (e, each, kinetic) = energies(&world, &handles);
        let spin = spins(&world, &handles);
        for (&(e1, l1), &(e2, l2)) in spin_before.iter().zip(&spin) {
            if l1 > 0.0 && l2 <= l1 * (1.0 + 1e-3) {
                out.spin_gain += e2 - e1;
            }
        }
        spin_before = spin;
        if world.profile().ccd_hits > 0 {
            out.ccd_gain += e - e_previous;
        }
        e_previous = e;
        released = released.max(potential0 - (e - kinetic));
        let in_play = kinetic0 + released;
        let tolerance = ENERGY_REL * in_play + PUSH_OUT_LIFT * weight;
        let ratio = (e - e0) / tolerance;
        if ratio.is_finite() {
            out.worst_energy_ratio = out.worst_energy_ratio.max(ratio);
        }
        if out.energy.is_none() && (e > e0 + tolerance || e.is_nan()) {
            let (body, body_gain) = each
                .iter()
                .zip(&each0)
                .map(|(a, b)| a - b)
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((0, 0.0));
            out.energy = Some(Violation::Energy {
                step,
                body,
                energy: e,
                start: e0,
                tolerance,
                in_play,
                body_gain,
                spin_gain: out.spin_gain,
                ccd_gain: out.ccd_gain,
            });
        }
        if stop_at_first && !out.clean() {
            break;
        }
    }
    out
}
