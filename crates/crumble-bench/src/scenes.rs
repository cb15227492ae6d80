//! The benchmark scenes, built in crumble with its own generators. The Rapier
//! copy is made from the crumble world afterwards (`rapier_side.rs`), body by
//! body, so that both engines start from exactly the same sizes, poses,
//! velocities and materials.

use crumble::scenes::{
    add_box, add_ground, add_pyramid, add_wall, add_wrecking_ball, Bond, WallSpec, WreckingBallSpec, BREAKABLE_BRICK,
    BRICK, STEEL,
};
use crumble::{BodyHandle, BondSpec, Material, Quat, Vec3, World, WorldError, WorldSettings};

/// The mortar of the mortared scenes: lime, the weaker of crumble's two
/// (0.1 MPa in tension, 0.2 MPa in shear), so that the ball's hit breaks
/// joints while the walls at rest load theirs to a fraction of it.
pub const MORTAR: BondSpec = BondSpec::LIME_MORTAR;

/// The mortar of `demolition`, the built-in scene's: cement (0.3 MPa in
/// tension and in shear).
pub const DEMOLITION_MORTAR: BondSpec = BondSpec::CEMENT_MORTAR;

/// Time step of every scene (s).
pub const DT: f32 = 1.0 / 60.0;

/// Unit cubes of the pyramid scenes: 100 kg/m³ (as in Rapier's and Box2D's
/// pyramid benchmarks), friction 0.6, no bounce.
pub const CUBE: Material =
    Material { density: 100.0, friction: 0.6, restitution: 0.0, rolling_resistance: 0.0, strength: None };

/// One scene: its name, what it is, how many steps it runs by default, and
/// the engine-neutral settings both sides use.
#[derive(Clone, Copy, Debug)]
pub struct SceneDef {
    pub name: &'static str,
    pub about: &'static str,
    pub steps: usize,
    /// Whether resting islands may sleep (both engines).
    pub sleep: bool,
    pub gravity: Vec3,
    /// A mortared scene's dry twin: the scene whose bricks it bonds with
    /// [`MORTAR`] ([`build`] builds the twin, then bonds it). crumble steps
    /// the twin beside the mortared scene, in the same blocks, so that the
    /// bonds' cost is a ratio taken in one run; Rapier, which has no bonds,
    /// runs the twin's bodies dry.
    pub dry: Option<&'static str>,
}

const G: Vec3 = Vec3::new(0.0, -9.81, 0.0);

pub const SCENES: &[SceneDef] = &[
    SceneDef {
        name: "wall100",
        about: "the seed's 10 x 10 running-bond brick wall at rest",
        steps: 600,
        sleep: false,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "wall_10k",
        about: "10 walls of 25 rows x 40 bricks at rest, 1 m apart",
        steps: 300,
        sleep: false,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "wall_10k_mortar",
        about: "wall_10k with lime mortar in every joint and under the bottom rows (29,470 bonds); Rapier runs it dry",
        steps: 300,
        sleep: false,
        gravity: G,
        dry: Some("wall_10k"),
    },
    SceneDef {
        name: "large_pyramid",
        about: "planar pyramid, base 100, 5,050 unit cubes of 100 kg/m3",
        steps: 300,
        sleep: false,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "many_pyramids",
        about: "14 x 14 planar pyramids of base 10 (10,780 unit cubes)",
        steps: 300,
        sleep: false,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "smash",
        about: "100 x 100 brick wall created asleep, zero gravity, hit by a 1 m steel box at 40 m/s",
        steps: 300,
        sleep: true,
        gravity: Vec3::ZERO,
        dry: None,
    },
    SceneDef {
        name: "brick_wall",
        about: "the headline: seed wall hit at mid-height by a 0.15 m steel ball at 15 m/s from 2 m",
        steps: 180,
        sleep: false,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "brick_wall_mortar",
        about: "brick_wall with lime mortar in every joint and under the bottom row (285 bonds); Rapier runs it dry",
        steps: 180,
        sleep: false,
        gravity: G,
        dry: Some("brick_wall"),
    },
    SceneDef {
        name: "chain",
        about: "the wrecking ball alone: 20 steel links and a 110 kg ball on spherical joints, swinging from 10 deg",
        steps: 600,
        sleep: false,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "wrecking_ball",
        about: "the wrecking ball released from 60 deg into the seed wall at mid-height, at 5 m/s",
        steps: 600,
        sleep: false,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "demolition",
        about: "the wrecking ball from 90 deg at 7.1 m/s into a 16 x 16 wall of breakable bricks in cement mortar \
(744 bonds, no jitter); Rapier runs it dry and unbreakable",
        steps: 240,
        sleep: false,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "collapse_3k",
        about: "smash.toml's 40 x 80 wall (3,220 bricks) created asleep, hit by three 0.3 m steel balls at 25 m/s",
        steps: 240,
        sleep: true,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "collapse_10k",
        about: "a 100 x 100 wall (10,050 bricks) created asleep, hit by collapse_3k's balls at 2.5 times their heights",
        steps: 240,
        sleep: true,
        gravity: G,
        dry: None,
    },
    SceneDef {
        name: "topple",
        about: "the 40 x 80 wall (3,220 bricks) tilted 4 deg about its front base edge: the whole wall falls",
        steps: 300,
        sleep: true,
        gravity: G,
        dry: None,
    },
];

pub fn find(name: &str) -> Option<&'static SceneDef> {
    SCENES.iter().find(|s| s.name == name)
}

/// A scene built in crumble: the world, and the bodies whose drift from
/// their initial pose is the quality measure (bricks and cubes, not
/// projectiles, and none in `chain`, where every body swings).
pub struct Built {
    pub world: World,
    pub tracked: Vec<BodyHandle>,
    /// The wrecking ball's, in the scenes that have one.
    pub pendulum: Option<Pendulum>,
    /// The lines of flight of what the scene throws at its bodies (the
    /// ball, the box, the wrecking ball), for [`untouched`].
    pub paths: Vec<Path>,
}

/// A projectile's line of flight: the line through `point` along
/// `direction`.
#[derive(Clone, Copy, Debug)]
pub struct Path {
    pub point: Vec3,
    pub direction: Vec3,
}

/// How far, horizontally, a body must start from every projectile's line
/// of flight to count as untouched ([`untouched`]), m.
pub const UNTOUCHED: f32 = 2.0;

/// Which of the bodies starting at `start` nothing in the scene is aimed
/// at: those whose centre starts more than [`UNTOUCHED`] from every line
/// of `paths`, measured horizontally (in the x–z plane, so that what
/// falls from above or below a struck region counts as touched). With no
/// path every body is untouched. Both engines' outcomes are measured on
/// the same bodies (the copy starts from crumble's poses).
pub fn untouched(start: &[Vec3], paths: &[Path]) -> Vec<bool> {
    let flat = |v: Vec3| Vec3::new(v.x, 0.0, v.z);
    start
        .iter()
        .map(|&p| {
            paths.iter().all(|path| {
                let (d, r) = (flat(path.direction), flat(p - path.point));
                let off = if d.length_squared() > 0.0 { r - d * (r.dot(d) / d.length_squared()) } else { r };
                off.length() > UNTOUCHED
            })
        })
        .collect()
}

/// A ball hanging from a fixed point: the chain's stretch is the ball
/// centre's distance from `anchor` beyond `length`.
#[derive(Clone, Copy, Debug)]
pub struct Pendulum {
    pub anchor: Vec3,
    pub ball: BodyHandle,
    /// The anchor-to-ball-centre distance of the straight chain, m.
    pub length: f32,
    /// Horizontal direction of the swing.
    pub direction: Vec3,
}

impl Pendulum {
    /// The wrecking ball's line of flight: through the bottom of its
    /// swing (where it strikes), along the swing.
    pub fn path(&self) -> Path {
        Path { point: self.anchor - Vec3::Y * self.length, direction: self.direction }
    }
}

/// Release angle of `chain` (rad): a swing of 10 degrees, so that the load
/// on the joints changes every step, as a wrecking ball's does. Hanging
/// still, the chain would start in the equilibrium that crumble's joints
/// hold exactly, and time a solver with nothing to correct.
pub const CHAIN_RELEASE: f32 = 10.0 * std::f32::consts::PI / 180.0;

/// The wrecking ball of `chain`, `wrecking_ball` and `demolition`:
/// `WreckingBallSpec`'s defaults (20 links of 0.03 x 0.12 x 0.03 m, ball
/// of radius 0.15 m, 2.55 m from the anchor to the ball's centre,
/// swinging along +z), hung so that at the bottom of its swing the ball's
/// centre is at `wall`'s mid-height and the ball just touches the wall's
/// near face (z < 0). Released from 60 degrees it strikes at
/// sqrt(2 g L (1 - cos 60)) = 5.0 m/s, from 90 degrees at
/// sqrt(2 g L) = 7.1 m/s.
pub fn wrecking_ball_spec(wall: &WallSpec, release_angle: f32) -> WreckingBallSpec {
    let ball = WreckingBallSpec::default();
    let mid = wall.rows as f32 * wall.brick.y * 0.5;
    let touch = wall.origin.z - wall.brick.z * 0.5 - ball.ball_radius;
    let anchor = Vec3::new(wall.origin.x, mid + ball.length(), touch);
    WreckingBallSpec { anchor, release_angle, ..ball }
}

/// Adds [`wrecking_ball_spec`]'s wrecking ball for `wall`, released from
/// `angle`.
fn add_pendulum(world: &mut World, wall: &WallSpec, angle: f32) -> Result<Pendulum, WorldError> {
    let spec = wrecking_ball_spec(wall, angle);
    let made = add_wrecking_ball(world, &spec)?;
    Ok(Pendulum { anchor: spec.anchor, ball: made.ball, length: spec.length(), direction: spec.direction })
}

/// The wall of `demolition`: the built-in scene's (`scenes/demolition.toml`),
/// 16 rows of 16 breakable bricks in running bond.
pub fn demolition_wall() -> WallSpec {
    WallSpec { rows: 16, bricks_per_row: 16, material: BREAKABLE_BRICK, ..WallSpec::default() }
}

/// Release angle of `demolition`'s wrecking ball (rad), the built-in
/// scene's.
pub const DEMOLITION_RELEASE: f32 = std::f32::consts::FRAC_PI_2;

/// The wall of `collapse_3k` and `topple`: `scenes/smash.toml`'s, 40 rows
/// of 80 bricks in running bond (3,220 bricks).
pub fn collapse_wall(sleeping: bool) -> WallSpec {
    WallSpec { rows: 40, bricks_per_row: 80, sleeping, ..WallSpec::default() }
}

/// The balls of the collapse scenes: `scenes/smash.toml`'s three, of
/// radius 0.3 m, each leaving from (x, y, 4) towards (x, y, 0) (the wall's
/// middle plane) at [`COLLAPSE_SPEED`]; (x, y) per ball.
pub const COLLAPSE_BALLS: [(f32, f32); 3] = [(-4.0, 1.3), (0.0, 2.0), (4.0, 0.8)];

/// Radius of the collapse scenes' balls, m.
pub const COLLAPSE_BALL_RADIUS: f32 = 0.3;

/// Launch speed of the collapse scenes' balls, m/s. The scene file
/// launches the centre ball at 30 m/s at 0.2 s and the right one at 0.4 s;
/// the harness has no launch hook, so all three leave at once at the
/// others' 25 m/s.
pub const COLLAPSE_SPEED: f32 = 25.0;

/// Launch velocity from `from` that reaches `target` under `gravity` after
/// the time a straight flight at `speed` takes (`crumble_scene::aim`, the
/// scene files' aim).
pub fn aim(from: Vec3, target: Vec3, speed: f32, gravity: Vec3) -> Vec3 {
    let d = target - from;
    let t = d.length() / speed;
    d / t - gravity * (0.5 * t)
}

/// Adds the collapse scenes' three steel balls (bullets, as in
/// `brick_wall`), their heights scaled by `heights`, aimed under `gravity`.
fn add_collapse_balls(world: &mut World, heights: f32, gravity: Vec3) -> Result<Vec<Path>, WorldError> {
    let mut paths = Vec::new();
    for (x, y) in COLLAPSE_BALLS {
        let (from, target) = (Vec3::new(x, y * heights, 4.0), Vec3::new(x, y * heights, 0.0));
        let v = aim(from, target, COLLAPSE_SPEED, gravity);
        crumble::scenes::add_ball(world, COLLAPSE_BALL_RADIUS, from, v, STEEL, true)?;
        paths.push(Path { point: from, direction: target - from });
    }
    Ok(paths)
}

/// How far `topple`'s wall is tilted, rad: its centre of mass (1.3 m up, on
/// a base 102.5 mm deep) passes its front base edge at 2.3 degrees.
pub const TOPPLE_TILT: f32 = 4.0 * std::f32::consts::PI / 180.0;

/// Turns every brick of `bricks` by `angle` about the x axis through
/// `pivot` (positive: the top towards +z), as one rigid wall.
fn tilt(world: &mut World, bricks: &[BodyHandle], pivot: Vec3, angle: f32) -> Result<(), WorldError> {
    let q = Quat::from_rotation_x(angle);
    for &b in bricks {
        let pose = world.body(b).expect("a brick just added").pose();
        let pose = crumble::Pose::new(pivot + q * (pose.position - pivot), q * pose.rotation);
        world.set_pose(b, pose)?;
    }
    Ok(())
}

/// crumble's settings for a scene: the defaults (6 substeps at dt 1/60),
/// with the scene's gravity and sleep switch. With `matched`, crumble's
/// passes per substep are Rapier's (see [`matched_passes`]).
pub fn crumble_settings(def: &SceneDef, matched: bool) -> WorldSettings {
    passes(WorldSettings { gravity: def.gravity, sleep_enabled: def.sleep, ..WorldSettings::default() }, matched)
}

/// `settings` with Rapier's passes when `matched` (see [`matched_passes`]).
fn passes(settings: WorldSettings, matched: bool) -> WorldSettings {
    if matched {
        matched_passes(settings)
    } else {
        settings
    }
}

/// The same work per step as Rapier's defaults (`--matched`): Rapier's
/// substeps (`rapier_side::default_substeps`, 4), each with one biased
/// pass and one relax pass, like its one PGS iteration and one
/// stabilisation iteration, however deep the stack and whatever the
/// residual. crumble's defaults instead relax until converged, with at
/// least one pass per layer of the deepest stack (`relax_per_layer`): that
/// is their quality, and the drift columns show what it buys. Settling
/// (`WorldSettings::settle_steps`) is left on, as for any user: a unit of
/// mostly new contacts relaxes further for its first steps, which the
/// timed steps include (the mean and p90 show them; Rapier given more
/// passes over its first steps drifted as much: `docs/solver.md`,
/// "Settling").
pub fn matched_passes(settings: WorldSettings) -> WorldSettings {
    let substeps = crate::rapier_side::default_substeps() as u32;
    WorldSettings { substeps, relax_iterations: 1, max_relax_iterations: 1, relax_per_layer: 0.0, ..settings }
}

/// `walls` walls of `rows` x `per_row` bricks (running bond), laid out on a
/// grid: `columns` walls side by side along x, the others behind along z.
pub fn add_walls(
    world: &mut World,
    walls: u32,
    columns: u32,
    rows: u32,
    per_row: u32,
) -> Result<Vec<BodyHandle>, WorldError> {
    let spec = WallSpec { rows, bricks_per_row: per_row, ..WallSpec::default() };
    let x_pitch = per_row as f32 * spec.brick.x + 2.0;
    let z_pitch = 1.0;
    let mut out = Vec::new();
    for w in 0..walls {
        let (cx, cz) = ((w % columns) as f32, (w / columns) as f32);
        let origin = Vec3::new((cx - (columns - 1) as f32 * 0.5) * x_pitch, 0.0, cz * z_pitch);
        out.extend(add_wall(world, &WallSpec { origin, ..spec })?);
    }
    Ok(out)
}

/// Builds `def` for crumble; `threads` is `WorldSettings::threads`,
/// `matched` as in [`crumble_settings`]. A mortared scene is its dry twin
/// with every touching pair of the twin's bricks, and each brick on the
/// ground, bonded with [`MORTAR`] (`World::bond_touching`): the same
/// bodies, so that the two differ by the bonds alone.
pub fn build(def: &SceneDef, threads: usize, matched: bool) -> Result<Built, WorldError> {
    if let Some(dry) = def.dry {
        let twin = find(dry).expect("a mortared scene's dry twin is a scene");
        let mut built = build(twin, threads, matched)?;
        built.world.bond_touching(&built.tracked, MORTAR)?;
        return Ok(built);
    }
    let mut world = World::new(WorldSettings { threads, ..crumble_settings(def, matched) })?;
    let mut pendulum = None;
    let mut paths = Vec::new();
    let tracked = match def.name {
        "wall100" => {
            add_ground(&mut world, 0.0, BRICK)?;
            add_wall(&mut world, &WallSpec::default())?
        }
        "wall_10k" => {
            add_ground(&mut world, 0.0, BRICK)?;
            add_walls(&mut world, 10, 1, 25, 40)?
        }
        "large_pyramid" => {
            add_ground(&mut world, 0.0, CUBE)?;
            add_pyramid(&mut world, 100, 1.0, 0.0, Vec3::ZERO, CUBE)?
        }
        "many_pyramids" => {
            add_ground(&mut world, 0.0, CUBE)?;
            let mut out = Vec::new();
            for i in 0..14 {
                for k in 0..14 {
                    let origin = Vec3::new((i as f32 - 6.5) * 12.0, 0.0, (k as f32 - 6.5) * 3.0);
                    out.extend(add_pyramid(&mut world, 10, 1.0, 0.0, origin, CUBE)?);
                }
            }
            out
        }
        "smash" => {
            add_ground(&mut world, 0.0, BRICK)?;
            let spec =
                WallSpec { rows: 100, bricks_per_row: 100, bond: Bond::Running, sleeping: true, ..WallSpec::default() };
            let bricks = add_wall(&mut world, &spec)?;
            let mid = spec.rows as f32 * spec.brick.y * 0.5;
            let from = Vec3::new(0.0, mid, 1.5);
            let box_ = add_box(&mut world, Vec3::ONE, from, Quat::IDENTITY, STEEL, false)?;
            world.set_linear_velocity(box_, Vec3::new(0.0, 0.0, -40.0))?;
            paths.push(Path { point: from, direction: Vec3::NEG_Z });
            bricks
        }
        "brick_wall" => {
            add_ground(&mut world, 0.0, BRICK)?;
            let spec = WallSpec::default();
            let bricks = add_wall(&mut world, &spec)?;
            let mid = spec.rows as f32 * spec.brick.y * 0.5;
            let from = Vec3::new(0.0, mid, 2.0);
            crumble::scenes::add_ball(&mut world, 0.075, from, Vec3::new(0.0, 0.0, -15.0), STEEL, true)?;
            paths.push(Path { point: from, direction: Vec3::NEG_Z });
            bricks
        }
        "chain" => {
            pendulum = Some(add_pendulum(&mut world, &WallSpec::default(), CHAIN_RELEASE)?);
            Vec::new()
        }
        "wrecking_ball" => {
            add_ground(&mut world, 0.0, BRICK)?;
            let bricks = add_wall(&mut world, &WallSpec::default())?;
            pendulum = Some(add_pendulum(&mut world, &WallSpec::default(), 60f32.to_radians())?);
            bricks
        }
        "demolition" => {
            // Without the built-in scene's jitter (each joint's strengths
            // by up to 20%, each brick's density by 5%): every joint and
            // brick alike, as in the mortared scenes, with no seed to keep.
            add_ground(&mut world, 0.0, BRICK)?;
            let wall = demolition_wall();
            let bricks = add_wall(&mut world, &wall)?;
            world.bond_touching(&bricks, DEMOLITION_MORTAR)?;
            pendulum = Some(add_pendulum(&mut world, &wall, DEMOLITION_RELEASE)?);
            bricks
        }
        "collapse_3k" | "collapse_10k" => {
            add_ground(&mut world, 0.0, BRICK)?;
            let (wall, heights) = if def.name == "collapse_3k" {
                (collapse_wall(true), 1.0)
            } else {
                (WallSpec { rows: 100, bricks_per_row: 100, sleeping: true, ..WallSpec::default() }, 2.5)
            };
            let bricks = add_wall(&mut world, &wall)?;
            paths = add_collapse_balls(&mut world, heights, def.gravity)?;
            bricks
        }
        "topple" => {
            add_ground(&mut world, 0.0, BRICK)?;
            let wall = collapse_wall(false);
            let bricks = add_wall(&mut world, &wall)?;
            tilt(&mut world, &bricks, Vec3::new(0.0, 0.0, wall.brick.z * 0.5), TOPPLE_TILT)?;
            bricks
        }
        other => unreachable!("unknown scene {other}"),
    };
    paths.extend(pendulum.map(|p| p.path()));
    Ok(Built { world, tracked, pendulum, paths })
}

/// The scaling scene: `thousands` walls of 1,012 bricks (25 rows x 40,
/// running bond), 8 side by side per row of walls.
pub fn build_scaling(thousands: u32, threads: usize, matched: bool) -> Result<Built, WorldError> {
    let settings = passes(WorldSettings { sleep_enabled: false, threads, ..WorldSettings::default() }, matched);
    let mut world = World::new(settings)?;
    add_ground(&mut world, 0.0, BRICK)?;
    let tracked = add_walls(&mut world, thousands, thousands.min(8), 25, 40)?;
    Ok(Built { world, tracked, pendulum: None, paths: Vec::new() })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At the bottom of its swing the wrecking ball's centre is at the
    /// seed wall's mid-height and the ball touches the wall's near face;
    /// from 60 degrees it gets there at 5 m/s (a point mass's speed).
    #[test]
    fn the_wrecking_ball_strikes_the_wall_at_mid_height() {
        let wall = WallSpec::default();
        let spec = wrecking_ball_spec(&wall, 60f32.to_radians());
        let bottom = spec.anchor - Vec3::Y * spec.length();
        assert!((bottom.y - wall.rows as f32 * wall.brick.y * 0.5).abs() < 1e-6, "{bottom}");
        assert!((bottom.z + spec.ball_radius - (wall.origin.z - wall.brick.z * 0.5)).abs() < 1e-6, "{bottom}");
        let speed = (2.0 * 9.81 * spec.length() * (1.0 - spec.release_angle.cos())).sqrt();
        assert!((speed - 5.0).abs() < 0.01, "{speed} m/s");
        let built = build(find("wrecking_ball").expect("scene"), 1, false).expect("build");
        assert_eq!(built.tracked.len(), 105);
        assert_eq!(built.world.joint_count(), 21);
    }

    /// `demolition` is the built-in scene's wall and ball: 16 rows of 16
    /// breakable bricks (8 rows of 16, 8 of 15 and two halves) in lime
    /// mortar, 744 bonds (8 x 15 + 8 x 16 head joints, 15 x 32 bed
    /// joints, 16 bricks on the ground), and the ball reaching the face
    /// at the wall's mid-height, 0.52 m up, at 7.1 m/s.
    #[test]
    fn demolition_is_the_built_in_wall_and_ball() {
        let wall = demolition_wall();
        let spec = wrecking_ball_spec(&wall, DEMOLITION_RELEASE);
        let bottom = spec.anchor - Vec3::Y * spec.length();
        assert!((bottom.y - 0.52).abs() < 1e-6, "{bottom}");
        assert!((bottom.z + spec.ball_radius - (wall.origin.z - wall.brick.z * 0.5)).abs() < 1e-6, "{bottom}");
        let speed = (2.0 * 9.81 * spec.length() * (1.0 - spec.release_angle.cos())).sqrt();
        assert!((speed - 7.07).abs() < 0.01, "{speed} m/s");
        let built = build(find("demolition").expect("scene"), 1, false).expect("build");
        assert_eq!(built.tracked.len(), 264);
        assert_eq!(built.world.bond_count(), 8 * 15 + 8 * 16 + 15 * 32 + 16);
        assert_eq!(built.world.joint_count(), 21);
        let w = &built.world;
        assert!(built
            .tracked
            .iter()
            .all(|&b| w.collider(w.body_colliders(b)[0]).unwrap().material() == BREAKABLE_BRICK));
    }

    /// The collapse scenes: `smash.toml`'s wall of 3,220 bricks (100 x 100:
    /// 10,050) created asleep and its three balls, which fly through (x, y,
    /// 0) under gravity; `topple`'s wall awake, tilted 4 degrees about its
    /// front base edge, every brick above the ground and the wall's centre
    /// of mass in front of that edge, so that it falls.
    #[test]
    fn the_collapse_scenes_are_smash_toml_s_wall_and_balls() {
        for (name, bricks, heights) in [("collapse_3k", 3220, 1.0), ("collapse_10k", 10050, 2.5)] {
            let def = find(name).expect("scene");
            let built = build(def, 1, false).expect("build");
            let w = &built.world;
            assert_eq!(built.tracked.len(), bricks, "{name}");
            assert!(built.tracked.iter().all(|&b| w.body(b).unwrap().is_sleeping()), "{name}");
            let balls: Vec<_> = w.bodies().filter(|(_, b)| b.is_dynamic() && !b.is_sleeping()).collect();
            assert_eq!(balls.len(), 3, "{name}");
            for ((_, ball), (x, y)) in balls.iter().zip(COLLAPSE_BALLS) {
                assert!(ball.is_bullet());
                let (p, v) = (ball.position(), ball.linear_velocity());
                let t = p.z / -v.z;
                let at = p + v * t + def.gravity * (0.5 * t * t);
                assert!((at - Vec3::new(x, y * heights, 0.0)).length() < 1e-4, "{name}: {at}");
                assert!((v.z + COLLAPSE_SPEED).abs() < 1e-4, "{name}: {v}");
            }
        }
        let built = build(find("topple").expect("scene"), 1, false).expect("build");
        let w = &built.world;
        assert_eq!(built.tracked.len(), 3220);
        let edge = collapse_wall(false).brick.z * 0.5;
        let mut centre = Vec3::ZERO;
        for &b in &built.tracked {
            let body = w.body(b).unwrap();
            assert!(!body.is_sleeping());
            centre += body.position() / built.tracked.len() as f32;
            let pose = body.pose();
            let half = match w.collider(w.body_colliders(b)[0]).unwrap().shape() {
                crumble::Shape::Cuboid(c) => c.half_extents(),
                _ => unreachable!("a brick is a cuboid"),
            };
            for k in 0..8 {
                let sign = |bit: u32| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
                let corner = pose.transform_point(Vec3::new(sign(0) * half.x, sign(1) * half.y, sign(2) * half.z));
                assert!(corner.y > -1e-5, "a brick below the ground: {corner}");
            }
        }
        assert!(centre.z > edge + 0.03, "centre of mass {centre}, edge at z = {edge}");
    }

    /// The untouched bodies ([`untouched`]): in `collapse_3k`, whose balls
    /// fly along z at x = -4, 0 and 4 m, the bricks whose centres are more
    /// than 2 m to the side of every ball, |x| > 6 m, at every height;
    /// every body of a resting scene; none of the seed wall (2.15 m long)
    /// under `brick_wall`'s ball or `wrecking_ball`'s.
    #[test]
    fn untouched_bodies_are_those_far_to_the_side_of_every_path() {
        let built = build(find("collapse_3k").expect("scene"), 1, false).expect("build");
        let start: Vec<Vec3> = built.tracked.iter().map(|&b| built.world.body(b).unwrap().position()).collect();
        assert_eq!(built.paths.len(), 3);
        let far = untouched(&start, &built.paths);
        for (p, &u) in start.iter().zip(&far) {
            assert_eq!(u, p.x.abs() > 6.0, "{p}");
        }
        let n = far.iter().filter(|&&u| u).count();
        assert!((900..1100).contains(&n), "{n} untouched");
        for (name, expect) in
            [("wall100", Some(105)), ("brick_wall", Some(0)), ("wrecking_ball", Some(0)), ("chain", None)]
        {
            let built = build(find(name).expect("scene"), 1, false).expect("build");
            let start: Vec<Vec3> = built.tracked.iter().map(|&b| built.world.body(b).unwrap().position()).collect();
            let n = untouched(&start, &built.paths).iter().filter(|&&u| u).count();
            assert_eq!(Some(n).filter(|_| !start.is_empty()), expect, "{name}");
        }
    }

    /// A mortared scene runs as long as its dry twin, under the same
    /// gravity and sleep switch (Rapier's copy takes them from the
    /// mortared scene's definition), and is built from the twin's bodies:
    /// the seed wall's 105 bricks and the ball, with 285 bonds (95 head
    /// joints, 180 bed joints, 10 bricks on the ground).
    #[test]
    fn a_mortared_scene_is_its_dry_twin_with_bonds() {
        let mortared: Vec<_> = SCENES.iter().filter(|d| d.dry.is_some()).collect();
        assert_eq!(mortared.iter().map(|d| d.name).collect::<Vec<_>>(), ["wall_10k_mortar", "brick_wall_mortar"]);
        for def in mortared {
            let twin = find(def.dry.unwrap()).expect("the twin is a scene");
            assert_eq!(twin.dry, None, "{}: a twin is dry", def.name);
            assert_eq!((def.steps, def.sleep, def.gravity), (twin.steps, twin.sleep, twin.gravity), "{}", def.name);
        }
        let wet = build(find("brick_wall_mortar").unwrap(), 1, false).expect("build");
        let dry = build(find("brick_wall").unwrap(), 1, false).expect("build");
        assert_eq!((wet.world.bond_count(), dry.world.bond_count()), (285, 0));
        assert_eq!(wet.tracked, dry.tracked);
        let poses = |w: &World| w.bodies().map(|(_, b)| (b.position(), b.linear_velocity())).collect::<Vec<_>>();
        assert_eq!(poses(&wet.world), poses(&dry.world));
    }
}
