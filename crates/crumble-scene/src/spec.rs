//! The scene file's types, exactly as they appear in TOML. Every table
//! rejects keys it does not know; every default is written next to its field
//! and repeated in `docs/scene-format.md`.

use std::collections::BTreeMap;

use serde::Deserialize;

/// A whole scene file.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// `[world]`: gravity, step, sleep, ground, default run length.
    #[serde(default)]
    pub world: WorldSpec,
    /// `[materials.NAME]`: named materials, added to the built-in
    /// `default`, `brick` and `steel` (a name given here replaces those).
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    /// `[[body]]`: single bodies.
    #[serde(default)]
    pub body: Vec<BodySpec>,
    /// `[[wall]]`: brick walls.
    #[serde(default)]
    pub wall: Vec<WallSpec>,
    /// `[[pyramid]]`: planar pyramids of boxes.
    #[serde(default)]
    pub pyramid: Vec<PyramidSpec>,
    /// `[[stack]]`: vertical stacks of boxes.
    #[serde(default)]
    pub stack: Vec<StackSpec>,
    /// `[[projectile]]`: balls or boxes launched at a given time.
    #[serde(default)]
    pub projectile: Vec<ProjectileSpec>,
    /// `[[wrecking_ball]]`: balls hanging on chains, released at an angle.
    #[serde(default)]
    pub wrecking_ball: Vec<WreckingBallSpec>,
    /// `[[joint]]`: joints between named bodies, or a body and the world.
    #[serde(default)]
    pub joint: Vec<JointSpec>,
    /// `[mortars.NAME]`: named mortars, added to the built-in `lime` and
    /// `cement` (a name given here replaces those).
    #[serde(default)]
    pub mortars: BTreeMap<String, MortarSpec>,
    /// `[[bond]]`: bonds between named bodies that touch face to face.
    #[serde(default)]
    pub bond: Vec<BondPairSpec>,
    /// `[camera]`: where rendered images and videos look from (automatic
    /// framing when absent).
    pub camera: Option<CameraSpec>,
    /// Name of the file the scene came from (for error messages).
    #[serde(skip)]
    pub file: String,
    /// The file's text, kept to point errors found after parsing at a line.
    #[serde(skip)]
    pub source: String,
}

impl Scene {
    /// Bodies the scene makes, the ground included, in the order of the
    /// outputs (saturating at `u64::MAX`; a validated scene makes at most
    /// [`MAX_BODIES`](crate::MAX_BODIES) besides the ground).
    pub fn body_count(&self) -> u64 {
        let tables = [
            self.world.ground.is_some() as u64,
            self.body.len() as u64,
            self.wall.iter().fold(0u64, |n, w| n.saturating_add(w.brick_count())),
            self.pyramid.iter().fold(0u64, |n, p| n.saturating_add(p.box_count())),
            self.stack.iter().fold(0u64, |n, s| n.saturating_add(s.count as u64)),
            self.projectile.len() as u64,
            self.wrecking_ball.iter().fold(0u64, |n, w| n.saturating_add(w.body_count())),
        ];
        tables.iter().fold(0u64, |n, &t| n.saturating_add(t))
    }
}

/// `[world]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WorldSpec {
    /// m/s², default `[0, -9.81, 0]` (y is up).
    pub gravity: [f32; 3],
    /// Step size, seconds (default 1/60).
    pub dt: f32,
    /// Solver substeps per step (default 6, the engine's; 1 to 64).
    pub substeps: u32,
    /// Whether resting bodies fall asleep (default true).
    pub sleep: bool,
    /// How long `crumble run` simulates when `--seconds` is not given (default 3).
    pub seconds: f32,
    /// `[world.ground]`: a static ground plane; none when absent.
    pub ground: Option<GroundSpec>,
    /// The smallest piece a breaking box may leave, metres (default 0.025,
    /// > 0): see `docs/fracture.md`.
    pub min_piece: f32,
    /// Most new bodies breaking boxes may add in one step (default 64, at
    /// most 4096).
    pub max_new_pieces: u32,
}

impl Default for WorldSpec {
    fn default() -> Self {
        Self {
            gravity: [0.0, -9.81, 0.0],
            dt: 1.0 / 60.0,
            substeps: 6,
            sleep: true,
            seconds: 3.0,
            ground: None,
            min_piece: 0.025,
            max_new_pieces: 64,
        }
    }
}

/// `[world.ground]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundSpec {
    /// Height of the plane y = height, metres (default 0).
    #[serde(default)]
    pub height: f32,
    /// Material name (default `"default"`).
    #[serde(default = "default_material")]
    pub material: String,
}

/// `[camera]`: the viewpoint of rendered images and videos. Whatever is not
/// given is chosen automatically so that the whole scene is in view.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Camera position, metres (default: automatic).
    pub eye: Option<[f32; 3]>,
    /// Point looked at, metres (default: automatic, the scene's centre).
    pub target: Option<[f32; 3]>,
    /// Vertical field of view, degrees, 1 to 170 (default 45).
    #[serde(default = "default_fov")]
    pub fov_deg: f32,
}

/// Default vertical field of view of `[camera]`, degrees.
pub const DEFAULT_FOV_DEG: f32 = 45.0;

/// `[materials.NAME]`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// kg/m³ (required, > 0).
    pub density: f32,
    /// Coulomb friction coefficient (default 0.6, ≥ 0).
    #[serde(default = "default_friction")]
    pub friction: f32,
    /// Coefficient of restitution (default 0, in [0, 1]).
    #[serde(default)]
    pub restitution: f32,
    /// Rolling resistance coefficient (default 0, ≥ 0): slows rolling and
    /// spinning balls (a pair uses the larger).
    #[serde(default)]
    pub rolling_resistance: f32,
    /// Tensile strength, Pa (> 0): a box of this material breaks
    /// (`docs/fracture.md`). Given with `shear_strength`; without both the
    /// material never breaks.
    #[serde(default)]
    pub tensile_strength: Option<f32>,
    /// Shear strength, Pa (> 0), given with `tensile_strength`.
    #[serde(default)]
    pub shear_strength: Option<f32>,
}

/// A body's shape kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ShapeKind {
    /// A box, given by `size` (full edges) or `half_extents`.
    #[serde(rename = "box")]
    Cuboid,
    /// A sphere, given by `radius`.
    #[default]
    Sphere,
}

/// Orientation as an axis and an angle in degrees.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisAngle {
    /// Rotation axis (any non-zero length).
    pub axis: [f32; 3],
    /// Angle, degrees, right-handed about `axis`.
    pub degrees: f32,
}

/// `[[body]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Name in the outputs (default `body<i>`).
    pub name: Option<String>,
    /// `"box"` or `"sphere"` (required).
    pub shape: ShapeKind,
    /// Box: full edge lengths, metres.
    pub size: Option<[f32; 3]>,
    /// Box: half edge lengths, metres (instead of `size`).
    pub half_extents: Option<[f32; 3]>,
    /// Sphere: radius, metres.
    pub radius: Option<f32>,
    /// Centre, metres (default origin).
    #[serde(default)]
    pub position: [f32; 3],
    /// Orientation as axis and degrees (default none).
    pub axis_angle: Option<AxisAngle>,
    /// Orientation as a quaternion `[x, y, z, w]` (normalised on load).
    pub quaternion: Option<[f32; 4]>,
    /// m/s (default zero).
    #[serde(default)]
    pub velocity: [f32; 3],
    /// rad/s (default zero).
    #[serde(default)]
    pub angular_velocity: [f32; 3],
    /// Material name (default `"default"`).
    #[serde(default = "default_material")]
    pub material: String,
    /// Static: never moves (default false).
    #[serde(default, rename = "static")]
    pub is_static: bool,
    /// Created asleep (default false).
    #[serde(default)]
    pub asleep: bool,
    /// Swept against dynamic bodies too, for fast small bodies (default false).
    #[serde(default)]
    pub bullet: bool,
}

/// How the rows of a wall are laid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BondSpec {
    /// Every row straight on the one below.
    Stack,
    /// Odd rows shifted by half a brick, half bricks at their ends.
    #[default]
    Running,
}

/// `[[wall]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// Prefix of the bricks' names (default `wall<i>`).
    pub name: Option<String>,
    /// Number of rows (≥ 1).
    pub rows: u32,
    /// Full bricks per row (≥ 1).
    pub bricks_per_row: u32,
    /// Brick size, full edges (default 0.215 × 0.065 × 0.1025 m).
    #[serde(default = "default_brick")]
    pub brick: [f32; 3],
    /// Gap between neighbouring bricks, metres (default 0).
    #[serde(default)]
    pub gap: f32,
    /// `"running"` (default) or `"stack"`.
    #[serde(default)]
    pub bond: BondSpec,
    /// Centre of the wall's base, metres (default origin).
    #[serde(default)]
    pub position: [f32; 3],
    /// Horizontal direction the wall's face looks along (default `[0, 0, 1]`).
    #[serde(default = "default_facing")]
    pub facing: [f32; 3],
    /// Material name (default `"brick"`).
    #[serde(default = "brick_material")]
    pub material: String,
    /// Create the bricks asleep (default false).
    #[serde(default)]
    pub asleep: bool,
    /// Mortar name: bonds every touching pair of the wall's bricks, and
    /// its bricks to the ground or any static body they rest on (default:
    /// none, a dry wall).
    pub mortar: Option<String>,
    /// Each brick's density varies by up to this fraction either way,
    /// uniformly (default 0; below 1).
    #[serde(default)]
    pub density_jitter: f32,
    /// Each bond's two strengths vary by up to this fraction either way,
    /// uniformly (default 0; at most 1).
    #[serde(default)]
    pub strength_jitter: f32,
    /// Seed of the jitters: the same seed gives the same wall (default 0).
    #[serde(default)]
    pub seed: u64,
}

impl WallSpec {
    /// Bricks the wall makes: `rows × bricks_per_row`, and in a running
    /// bond one more in each odd row (two halves for one full brick).
    /// Below 2^64 for any `u32` counts.
    pub fn brick_count(&self) -> u64 {
        let (rows, per_row) = (self.rows as u64, self.bricks_per_row as u64);
        rows * per_row + if self.bond == BondSpec::Running { rows / 2 } else { 0 }
    }
}

/// `[[pyramid]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PyramidSpec {
    /// Prefix of the boxes' names (default `pyramid<i>`).
    pub name: Option<String>,
    /// Boxes in the bottom row (≥ 1).
    pub base: u32,
    /// Box size, full edges, metres.
    pub size: [f32; 3],
    /// Gap between neighbouring boxes, metres (default 0).
    #[serde(default)]
    pub gap: f32,
    /// Centre of the pyramid's base, metres (default origin).
    #[serde(default)]
    pub position: [f32; 3],
    /// Material name (default `"default"`).
    #[serde(default = "default_material")]
    pub material: String,
    /// Create the boxes asleep (default false).
    #[serde(default)]
    pub asleep: bool,
}

impl PyramidSpec {
    /// Boxes the pyramid makes: `base + (base − 1) + … + 1`.
    pub fn box_count(&self) -> u64 {
        self.base as u64 * (self.base as u64 + 1) / 2
    }
}

/// `[[stack]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StackSpec {
    /// Prefix of the boxes' names (default `stack<i>`).
    pub name: Option<String>,
    /// Number of boxes (≥ 1).
    pub count: u32,
    /// Box size, full edges, metres.
    pub size: [f32; 3],
    /// Horizontal shift `[x, z]` of each level from the one below (default `[0, 0]`).
    #[serde(default)]
    pub offset: [f32; 2],
    /// Centre of the bottom box's base, metres (default origin).
    #[serde(default)]
    pub position: [f32; 3],
    /// Material name (default `"default"`).
    #[serde(default = "default_material")]
    pub material: String,
    /// Create the boxes asleep (default false).
    #[serde(default)]
    pub asleep: bool,
}

/// `[[projectile]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectileSpec {
    /// Name (default `projectile<i>`).
    pub name: Option<String>,
    /// `"sphere"` (default) or `"box"`.
    #[serde(default)]
    pub shape: ShapeKind,
    /// Sphere radius, metres.
    pub radius: Option<f32>,
    /// Box size, full edges, metres.
    pub size: Option<[f32; 3]>,
    /// Launch point (centre), metres.
    pub from: [f32; 3],
    /// Launch velocity, m/s; or give `target` and `speed`.
    pub velocity: Option<[f32; 3]>,
    /// Point to hit (with `speed`).
    pub target: Option<[f32; 3]>,
    /// Launch speed towards `target`, m/s.
    pub speed: Option<f32>,
    /// Launch time, seconds (default 0).
    #[serde(default)]
    pub at: f32,
    /// Material name (default `"steel"`).
    #[serde(default = "steel_material")]
    pub material: String,
}

/// `[[wrecking_ball]]`: the engine's wrecking ball
/// ([`crumble::scenes::add_wrecking_ball`]), every default taken from
/// [`crumble::scenes::WreckingBallSpec::default`].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WreckingBallSpec {
    /// Prefix of the bodies' names: `<name>/ball`, `<name>/chain/<k>`
    /// (default: none for the first wrecking ball of the file, `ball` and
    /// `chain/<k>`; the index after it for the others, `ball<i>` and
    /// `chain<i>/<k>`).
    pub name: Option<String>,
    /// The fixed point in the world the chain hangs from, metres (default `[0, 3, 0]`).
    #[serde(default = "wrecking_anchor")]
    pub anchor: [f32; 3],
    /// Number of links (default 20, ≥ 1).
    #[serde(default = "wrecking_links")]
    pub links: u32,
    /// A link's full size, its length along the chain second (default
    /// 0.03 × 0.12 × 0.03 m).
    #[serde(default = "wrecking_link")]
    pub link: [f32; 3],
    /// The links' material (default `"steel"`).
    #[serde(default = "steel_material")]
    pub link_material: String,
    /// The ball's radius, metres (default 0.15).
    #[serde(default = "wrecking_ball_radius")]
    pub ball_radius: f32,
    /// The ball's material (default `"steel"`).
    #[serde(default = "steel_material")]
    pub ball_material: String,
    /// The chain's angle from the vertical at the start, degrees, 0 to 180
    /// (default 60).
    #[serde(default = "wrecking_release_angle")]
    pub release_angle_deg: f32,
    /// The horizontal direction the ball swings towards; it starts on the
    /// other side of the anchor (default `[0, 0, 1]`; y is ignored).
    #[serde(default = "wrecking_direction")]
    pub direction: [f32; 3],
    /// A rope from the anchor to the ball, as long as the chain and ball
    /// (default false).
    #[serde(default)]
    pub tether: bool,
}

impl WreckingBallSpec {
    /// Bodies it makes: the links and the ball.
    pub fn body_count(&self) -> u64 {
        self.links as u64 + 1
    }
}

/// `[mortars.NAME]`: a mortar's strengths (see `crumble::BondSpec`).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MortarSpec {
    /// Largest tensile stress across a joint, Pa (required, ≥ 0).
    pub tensile_strength: f32,
    /// Shear stress a joint holds with no compression, Pa (required, ≥ 0).
    pub shear_strength: f32,
    /// Friction coefficient the shear limit grows by with compression
    /// (default 0.4, ≥ 0).
    #[serde(default = "mortar_friction")]
    pub friction: f32,
}

/// `[[bond]]`: a bond between two named bodies that touch face to face.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BondPairSpec {
    /// One body's name (`ground` for the ground) (required).
    pub a: String,
    /// The other body's name (required).
    pub b: String,
    /// Mortar name (default `"lime"`).
    #[serde(default = "lime_mortar")]
    pub mortar: String,
}

/// A joint's kind, `kind` of `[[joint]]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JointKindSpec {
    /// Ball and socket: the anchors coincide.
    Spherical,
    /// Hinge about `axis`, optionally within `limits_deg`.
    Revolute,
    /// Weld: the relative pose at the start is kept.
    Fixed,
    /// The anchors stay `length` apart, rigidly or on a `spring`.
    Distance,
    /// The anchors stay at most `length` apart.
    Rope,
}

impl JointKindSpec {
    /// The name as written in a file.
    pub fn name(self) -> &'static str {
        match self {
            JointKindSpec::Spherical => "spherical",
            JointKindSpec::Revolute => "revolute",
            JointKindSpec::Fixed => "fixed",
            JointKindSpec::Distance => "distance",
            JointKindSpec::Rope => "rope",
        }
    }
}

/// `[[joint]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// `"spherical"`, `"revolute"`, `"fixed"`, `"distance"` or `"rope"` (required).
    pub kind: JointKindSpec,
    /// One side: a body's name, or `"world"` (required).
    pub a: String,
    /// The other side: a body's name, or `"world"` (required).
    pub b: String,
    /// One world point for both anchors, metres.
    pub anchor: Option<[f32; 3]>,
    /// A world point for each anchor, `[on a, on b]`, metres.
    pub anchors: Option<[[f32; 3]; 2]>,
    /// Each anchor in its body's frame, `[on a, on b]`, metres (a world
    /// point on the world's side).
    pub local_anchors: Option<[[f32; 3]; 2]>,
    /// Revolute: the hinge axis, a world direction at the start (required).
    pub axis: Option<[f32; 3]>,
    /// Revolute: `[lo, hi]`, degrees, −180 ≤ lo ≤ hi ≤ 180 (default: none).
    pub limits_deg: Option<[f32; 2]>,
    /// Distance: the length; rope: the longest length, metres (required for both).
    pub length: Option<f32>,
    /// Distance: a spring instead of a rigid rod (default: none).
    pub spring: Option<SpringSpec>,
    /// Force above which the joint breaks, N (default: never).
    pub break_force: Option<f32>,
    /// Torque above which the joint breaks, N·m (default: never).
    pub break_torque: Option<f32>,
    /// Whether the two bodies collide with each other (default false).
    #[serde(default)]
    pub collide_connected: bool,
}

/// `spring` of a distance `[[joint]]`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringSpec {
    /// Natural frequency, Hz, ≥ 0 (0: rigid).
    pub hertz: f32,
    /// Damping ratio, ≥ 0 (1: critically damped).
    pub damping_ratio: f32,
}

fn default_material() -> String {
    "default".into()
}
fn brick_material() -> String {
    "brick".into()
}
fn steel_material() -> String {
    "steel".into()
}
fn default_fov() -> f32 {
    DEFAULT_FOV_DEG
}
fn default_friction() -> f32 {
    0.6
}
fn mortar_friction() -> f32 {
    crumble::BondSpec::LIME_MORTAR.friction
}
fn lime_mortar() -> String {
    "lime".into()
}
fn default_brick() -> [f32; 3] {
    crumble::scenes::BRICK_SIZE.to_array()
}
fn default_facing() -> [f32; 3] {
    [0.0, 0.0, 1.0]
}
fn wrecking_anchor() -> [f32; 3] {
    crumble::scenes::WreckingBallSpec::default().anchor.to_array()
}
fn wrecking_links() -> u32 {
    crumble::scenes::WreckingBallSpec::default().links
}
fn wrecking_link() -> [f32; 3] {
    crumble::scenes::WreckingBallSpec::default().link.to_array()
}
fn wrecking_ball_radius() -> f32 {
    crumble::scenes::WreckingBallSpec::default().ball_radius
}
fn wrecking_direction() -> [f32; 3] {
    crumble::scenes::WreckingBallSpec::default().direction.to_array()
}
/// 60.000004 (the degrees of the engine's 60° in radians), which turns
/// back into exactly the engine's default.
fn wrecking_release_angle() -> f32 {
    crumble::scenes::WreckingBallSpec::default().release_angle.to_degrees()
}
