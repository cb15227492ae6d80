//! Rendering the headline scene and checking the pictures: not blank, the
//! ball where its centre projects, bricks over the wall's face, the same
//! bytes every time, bad input refused, a broken brick replaced by its
//! pieces. Needs an adapter (a GPU, or Mesa's lavapipe from
//! `mesa-vulkan-drivers`): without one these tests fail with the
//! renderer's message, they do not skip.

use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

use crumble_render::{
    Bounds, Camera, Frame, Instance, Material, RenderError, Renderer, SceneFrames, Shape, BRICK_TONES,
};
use crumble_scene::{BodyShape, Simulation};
use glam::{Quat, Vec2, Vec3};

const W: u32 = 640;
const H: u32 = 360;

/// One rendering test at a time: on a CPU adapter they would otherwise
/// share the cores and slow each other down (and the timing test).
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

fn renderer() -> Renderer {
    Renderer::new().unwrap_or_else(|e| panic!("cannot render: {e}"))
}

fn brick_wall() -> Simulation {
    let s = crumble_scene::builtin::find("brick_wall").unwrap();
    crumble_scene::build(&crumble_scene::parse(s.source, "brick_wall.toml").unwrap()).unwrap()
}

fn run_until(sim: &mut Simulation, t: f64) {
    while sim.time() + 1e-9 < t {
        sim.step().unwrap();
    }
}

fn pixel(img: &[u8], x: u32, y: u32) -> [f32; 3] {
    let i = ((y * W + x) * 4) as usize;
    [img[i] as f32, img[i + 1] as f32, img[i + 2] as f32]
}

/// Red clearly above green and blue: a brick (lit, shaded or at an edge).
fn is_brick(c: [f32; 3]) -> bool {
    c[0] > 1.3 * c[1] && c[0] > 1.3 * c[2] && c[0] > 40.0
}

/// Grey or bluish-grey metal: channels close together, not sky-bright blue.
fn is_steel(c: [f32; 3]) -> bool {
    let (max, min) = (c[0].max(c[1]).max(c[2]), c[0].min(c[1]).min(c[2]));
    !is_brick(c) && max - min < 0.25 * max + 12.0
}

/// The sky's colours: light, blue above red.
fn is_sky(c: [f32; 3]) -> bool {
    c[2] > c[0] + 15.0 && c[2] > 180.0
}

fn ball_index(sim: &Simulation) -> usize {
    sim.bodies.iter().position(|b| b.name == "ball").unwrap()
}

#[test]
fn the_headline_frame_is_not_blank() {
    let _one = serial();
    let sim = brick_wall();
    let frames = SceneFrames::new(&sim.bodies);
    let camera = frames.auto_camera(W as f32 / H as f32, 45.0);
    let img = renderer().render_rgba(&frames.frame_of(&sim).unwrap(), &camera, W, H).unwrap();
    assert_eq!(img.len(), (W * H * 4) as usize);
    let lum: Vec<f64> =
        img.chunks(4).map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64).collect();
    let mean = lum.iter().sum::<f64>() / lum.len() as f64;
    let var = lum.iter().map(|l| (l - mean) * (l - mean)).sum::<f64>() / lum.len() as f64;
    assert!(var > 100.0, "luminance variance {var:.1} (mean {mean:.1}): the image is nearly flat");
    assert!(img.chunks(4).all(|p| p[3] == 255), "opaque");
    let bricks = img.chunks(4).filter(|p| is_brick([p[0] as f32, p[1] as f32, p[2] as f32])).count();
    assert!(bricks > (W * H) as usize / 20, "only {bricks} brick-coloured pixels");
}

#[test]
fn the_ball_is_drawn_where_its_centre_projects() {
    let _one = serial();
    let mut sim = brick_wall();
    let frames = SceneFrames::new(&sim.bodies);
    let camera = frames.auto_camera(W as f32 / H as f32, 45.0);
    let mut r = renderer();
    let ball = ball_index(&sim);
    // At the start (in the air, ground behind it) and just before it hits
    // the wall (bricks behind it).
    for t in [0.0, 0.1] {
        run_until(&mut sim, t);
        let img = r.render_rgba(&frames.frame_of(&sim).unwrap(), &camera, W, H).unwrap();
        let centre = sim.pose(ball).position;
        let p = camera.project(centre, W, H).expect("ball in front of the camera");
        assert!(p.x > 0.0 && p.y > 0.0 && p.x < W as f32 && p.y < H as f32, "ball off screen at {p}");
        // The ball's radius on screen, from a point on its silhouette.
        let right = camera.project(centre + camera_right(&camera) * 0.075, W, H).unwrap();
        let radius = (right - p).length();
        assert!(radius > 3.0, "ball too small to test: {radius} px");
        for d in [Vec2::ZERO, Vec2::new(0.5, 0.0), Vec2::new(0.0, 0.5), Vec2::new(-0.5, 0.0), Vec2::new(0.0, -0.5)] {
            let q = p + d * radius;
            let c = pixel(&img, q.x as u32, q.y as u32);
            assert!(is_steel(c) && !is_sky(c), "t = {t}: pixel {q} inside the ball is {c:?}, not steel");
        }
    }
}

fn camera_right(c: &Camera) -> Vec3 {
    (c.target - c.eye).cross(Vec3::Y).normalize()
}

#[test]
fn bricks_cover_the_wall_face() {
    let _one = serial();
    let sim = brick_wall();
    let frames = SceneFrames::new(&sim.bodies);
    let camera = frames.auto_camera(W as f32 / H as f32, 45.0);
    let img = renderer().render_rgba(&frames.frame_of(&sim).unwrap(), &camera, W, H).unwrap();
    // The wall's front face, from the bricks' own boxes.
    let mut wall: Option<Bounds> = None;
    for b in sim.bodies.iter().filter(|b| b.source == "wall[0]") {
        let BodyShape::Box { half_extents } = b.shape else { unreachable!() };
        let bb = Bounds::new(b.initial.position - half_extents, b.initial.position + half_extents);
        wall = Some(wall.map_or(bb, |w| w.union(bb)));
    }
    let wall = wall.unwrap();
    let z = wall.max.z;
    let quad: Vec<Vec2> =
        [(wall.min.x, wall.min.y), (wall.max.x, wall.min.y), (wall.max.x, wall.max.y), (wall.min.x, wall.max.y)]
            .iter()
            .map(|&(x, y)| camera.project(Vec3::new(x, y, z), W, H).unwrap())
            .collect();
    let inside = |p: Vec2| {
        (0..4).all(|i| (quad[(i + 1) % 4] - quad[i]).perp_dot(p - quad[i]) <= 0.0)
            || (0..4).all(|i| (quad[(i + 1) % 4] - quad[i]).perp_dot(p - quad[i]) >= 0.0)
    };
    let (mut total, mut brick) = (0, 0);
    for y in 0..H {
        for x in 0..W {
            if inside(Vec2::new(x as f32 + 0.5, y as f32 + 0.5)) {
                total += 1;
                brick += is_brick(pixel(&img, x, y)) as usize;
            }
        }
    }
    assert!(total > 2000, "wall face covers only {total} pixels");
    let share = brick as f64 / total as f64;
    assert!(share > 0.9, "only {:.1} % of the wall's face is brick-coloured", share * 100.0);
    // And outside the wall, below it: ground, not brick.
    let below = camera.project(Vec3::new(0.0, 0.0, z + 0.6), W, H).unwrap();
    assert!(!is_brick(pixel(&img, below.x as u32, below.y as u32)));
}

#[test]
fn the_same_frame_gives_the_same_bytes() {
    let _one = serial();
    let mut sim = brick_wall();
    run_until(&mut sim, 0.3);
    let frames = SceneFrames::new(&sim.bodies);
    let frame = frames.frame_of(&sim).unwrap();
    let camera = frames.auto_camera(W as f32 / H as f32, 45.0);
    let mut r = renderer();
    let a = r.render_rgba(&frame, &camera, W, H).unwrap();
    let other = r.render_rgba(&Frame::default(), &camera, 320, 200).unwrap();
    let b = r.render_rgba(&frame, &camera, W, H).unwrap();
    let c = renderer().render_rgba(&frame, &camera, W, H).unwrap();
    assert!(a == b, "a second render on the same renderer differs");
    assert!(a == c, "a render on a fresh renderer differs");
    assert_eq!(other.len(), 320 * 200 * 4);
    assert!(other.chunks(4).all(|p| is_sky([p[0] as f32, p[1] as f32, p[2] as f32]) || p[2] > p[0]), "empty frame");
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let _one = serial();
    let mut r = renderer();
    let camera = Camera::look_at(Vec3::new(0.0, 1.0, 5.0), Vec3::ZERO, 45.0);
    let brick = Material { color: BRICK_TONES[0], metalness: 0.0, edge_width: 0.005 };
    let good = Instance {
        shape: Shape::Box { half_extents: Vec3::splat(0.5) },
        position: Vec3::ZERO,
        rotation: Quat::IDENTITY,
        material: brick,
    };
    let frame = |i: Instance| Frame { instances: vec![good, i], shadow_bounds: None };
    let nan = Instance { position: Vec3::new(f32::NAN, 0.0, 0.0), ..good };
    assert!(matches!(r.render_rgba(&frame(nan), &camera, 64, 64), Err(RenderError::InvalidInstance { index: 1, .. })));
    let flat = Instance { shape: Shape::Box { half_extents: Vec3::new(0.5, 0.0, 0.5) }, ..good };
    assert!(matches!(r.render_rgba(&frame(flat), &camera, 64, 64), Err(RenderError::InvalidInstance { .. })));
    let zero_q = Instance { rotation: Quat::from_xyzw(0.0, 0.0, 0.0, 0.0), ..good };
    assert!(r.render_rgba(&frame(zero_q), &camera, 64, 64).is_err());
    let bright = Instance { material: Material { color: [2.0, 0.0, 0.0], ..brick }, ..good };
    assert!(r.render_rgba(&frame(bright), &camera, 64, 64).is_err());
    assert!(matches!(r.render_rgba(&frame(good), &camera, 0, 64), Err(RenderError::InvalidSize { .. })));
    let e = r.render_rgba(&frame(good), &camera, 1 << 20, 64).unwrap_err();
    assert!(e.to_string().contains("1048576x64"), "{e}");
    let same = Camera::look_at(Vec3::ONE, Vec3::ONE, 45.0);
    assert!(matches!(r.render_rgba(&frame(good), &same, 64, 64), Err(RenderError::InvalidCamera(_))));
    // Still usable after all that.
    let img = r.render_rgba(&frame(good), &camera, 64, 64).unwrap();
    assert!(img.chunks(4).any(|p| is_brick([p[0] as f32, p[1] as f32, p[2] as f32])));
}

#[test]
fn ten_thousand_bricks_render_and_fill_the_frame() {
    let _one = serial();
    // 100 x 100 bricks in a wall with a little tumble, as in a big scene.
    let mut instances = Vec::new();
    let half = Vec3::new(0.1075, 0.0325, 0.05125);
    for row in 0..100 {
        for col in 0..100 {
            let i = row * 100 + col;
            let tilt = Quat::from_rotation_z(((i * 37) % 11) as f32 * 0.01);
            instances.push(Instance {
                shape: Shape::Box { half_extents: half },
                position: Vec3::new(-10.75 + col as f32 * 0.215, 0.0325 + row as f32 * 0.065, 0.0),
                rotation: tilt,
                material: crumble_render::brick_material(i, half),
            });
        }
    }
    let frame = Frame { instances, shadow_bounds: None };
    let bounds = frame.object_bounds().unwrap();
    let camera = Camera::framing(&bounds, 16.0 / 9.0, 45.0, crumble_render::AUTO_VIEW_DIRECTION);
    let mut r = renderer();
    r.render_rgba(&frame, &camera, 1280, 720).unwrap(); // pipelines, buffers
                                                        // The time per frame is printed, not asserted: speed targets belong in
                                                        // benchmarks, and shared CI machines make any bound on time flaky (the
                                                        // README quotes 0.26–0.47 s per 1280×720 frame on lavapipe here).
    let start = Instant::now();
    let img = r.render_rgba(&frame, &camera, 1280, 720).unwrap();
    eprintln!("10,000 bricks at 1280x720 on {}: {:.0} ms", r.describe(), start.elapsed().as_secs_f64() * 1e3);
    let bricks = img.chunks(4).filter(|p| is_brick([p[0] as f32, p[1] as f32, p[2] as f32])).count();
    assert!(bricks > 1280 * 720 / 4, "the wall should fill much of the image: {bricks}");
}

/// The headline wall in the built-in breakable `brick`: its ball splits
/// bricks in its first tenths of a second (measured: three, at 0.133 s and
/// 0.150 s).
fn breaking_wall() -> Simulation {
    let source = crumble_scene::builtin::find("brick_wall").unwrap().source.replace("\"clay\"", "\"brick\"");
    crumble_scene::build(&crumble_scene::parse(&source, "breaking_wall.toml").unwrap()).unwrap()
}

/// Brick-coloured pixels in the square of half side `half` pixels around
/// `centre`.
fn bricks_around(img: &[u8], centre: Vec2, half: f32) -> usize {
    let (x0, x1) = ((centre.x - half).max(0.0) as u32, ((centre.x + half) as u32).min(W - 1));
    let (y0, y1) = ((centre.y - half).max(0.0) as u32, ((centre.y + half) as u32).min(H - 1));
    (y0..=y1).flat_map(|y| (x0..=x1).map(move |x| (x, y))).filter(|&(x, y)| is_brick(pixel(img, x, y))).count()
}

/// A brick that breaks and one of its pieces, each moved to its own patch
/// of sky above the wall, drawn just before the split and at it: the brick
/// shows in its patch only before, the piece in its patch only after. (In
/// place they fill the same space, so where each is drawn could not be
/// told apart.)
#[test]
fn a_broken_brick_gives_way_to_its_pieces_in_the_picture() {
    let _one = serial();
    let mut sim = breaking_wall();
    let before = sim.bodies.len();
    while sim.bodies.len() == before {
        assert!(sim.time() < 1.0, "no brick broke in 1 s");
        sim.step().unwrap();
    }
    let split = sim.time();
    let frames = SceneFrames::new(&sim.bodies);
    let camera = frames.auto_camera(W as f32 / H as f32, 45.0);
    // The larger of the first split's pieces, and its brick.
    let piece = (before..before + 2)
        .max_by(|&a, &b| {
            let size = |i: usize| match sim.bodies[i].shape {
                BodyShape::Box { half_extents } => half_extents.x * half_extents.y * half_extents.z,
                _ => 0.0,
            };
            size(a).total_cmp(&size(b))
        })
        .unwrap();
    let parent = sim.bodies[piece].parent.unwrap().0;

    // Two patches of sky, 0.25 m over the wall's top, left and right of
    // its middle.
    let top = sim.bodies.iter().filter(|b| b.source == "wall[0]").map(|b| b.initial.position.y).fold(0.0, f32::max);
    let (a, b) = (Vec3::new(-0.5, top + 0.25, 0.0), Vec3::new(0.5, top + 0.25, 0.0));
    let pose = |i: usize| match i {
        _ if i == parent => (a, Quat::IDENTITY),
        _ if i == piece => (b, Quat::IDENTITY),
        _ => {
            let p = sim.pose(i);
            (p.position, p.rotation)
        }
    };
    let (pa, pb) = (camera.project(a, W, H).unwrap(), camera.project(b, W, H).unwrap());
    // A square a little larger than a brick's 0.215 m.
    let half = (camera.project(a + camera_right(&camera) * 0.15, W, H).unwrap() - pa).length();
    assert!(half > 5.0, "a brick too small to count: {half} px");
    let mut r = renderer();
    let mut counts = Vec::new();
    for t in [split - 1e-9, split] {
        let img = r.render_rgba(&frames.frame_with(t, pose).unwrap(), &camera, W, H).unwrap();
        counts.push((bricks_around(&img, pa, half), bricks_around(&img, pb, half)));
    }
    eprintln!(
        "brick pixels (brick's patch, piece's patch) before and at the split: {counts:?}, squares of {half:.0} px"
    );
    let [(brick_before, piece_before), (brick_after, piece_after)] = counts[..] else { unreachable!() };
    // Drawn, the brick or its piece covers a few hundred pixels of its
    // square (measured: 360 and 406 in squares 47 px wide); not drawn,
    // the square is sky, with no brick-coloured pixel.
    assert!(brick_before > 100 && piece_before == 0, "before the split: the brick, not its piece");
    assert!(brick_after == 0 && piece_after > 100, "at the split: the piece, not its brick");
}
