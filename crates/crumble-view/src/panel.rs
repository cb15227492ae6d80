//! The side panel: live body and contact counts, the step's per-stage
//! timings, the timeline, and buttons, sliders and checkboxes that do what
//! the keys do.
//!
//! The layout ([`Viewport::layout`]), the counts ([`Counts`]) and the
//! smoothing of the timings ([`Smoother`]) are plain code, tested here; the
//! egui drawing is [`show`].

use std::time::{Duration, Instant};

use crumble::{BodyHandle, BodyType, Profile, World};
use crumble_render::Camera;
use glam::{Vec2, Vec3};

use crate::orbit::mouse_ray;
use crate::overlay::STRETCH_TOLERANCE;
use crate::timeline::Seek;

/// Width of the panel, points (pixels at a scale factor of 1).
pub const PANEL_WIDTH: f32 = 260.0;
/// Narrowest scene view kept beside the panel, pixels: a narrower window
/// shows the scene alone.
pub const MIN_SCENE_WIDTH: u32 = 160;
/// Real time over which the step timings, steps per frame and frame rate
/// are averaged: long enough for the numbers to stay still and be read.
pub const SMOOTHING: Duration = Duration::from_millis(500);
/// Simulation speeds of keys 1, 2, 3 and of the panel's speed buttons.
pub const SPEEDS: [f64; 3] = [1.0, 0.5, 0.25];
/// Labels of [`SPEEDS`].
const SPEED_LABELS: [&str; 3] = ["1", "1/2", "1/4"];
/// Ball speed range, m/s (keys + and -, the slider, `--ball-speed`).
pub const BALL_SPEEDS: std::ops::RangeInclusive<f32> = 0.5..=1000.0;
/// Ball radius range, metres (PgUp and PgDn, the slider, `--ball-radius`).
pub const BALL_RADII: std::ops::RangeInclusive<f32> = 0.005..=10.0;

/// Where the scene is drawn in the window, pixels (x right, y down, from
/// the top-left corner).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Viewport {
    /// Left edge.
    pub x: u32,
    /// Top edge.
    pub y: u32,
    /// Width, at least 1.
    pub width: u32,
    /// Height, at least 1.
    pub height: u32,
}

impl Viewport {
    /// The whole of a `width` × `height` window.
    pub fn full(width: u32, height: u32) -> Self {
        Self { x: 0, y: 0, width: width.max(1), height: height.max(1) }
    }

    /// Splits a window of `window` pixels at `pixels_per_point`: the scene
    /// on the left and, when `panel` is asked for and the window is wide
    /// enough, the panel on the right. Returns the scene's viewport and the
    /// panel's width in pixels (0 when there is no panel).
    pub fn layout(window: (u32, u32), pixels_per_point: f32, panel: bool) -> (Self, u32) {
        let full = Self::full(window.0, window.1);
        let ppp = if pixels_per_point.is_finite() && pixels_per_point > 0.0 { pixels_per_point } else { 1.0 };
        // `as` saturates: an absurd scale factor gives a panel that cannot fit.
        let panel_px = (PANEL_WIDTH * ppp).round() as u32;
        if panel && full.width >= panel_px.saturating_add(MIN_SCENE_WIDTH) {
            (Self { width: full.width - panel_px, ..full }, panel_px)
        } else {
            (full, 0)
        }
    }

    /// Width over height.
    pub fn aspect(&self) -> f32 {
        self.width.max(1) as f32 / self.height.max(1) as f32
    }

    /// Width and height as a vector.
    pub fn size(&self) -> Vec2 {
        Vec2::new(self.width as f32, self.height as f32)
    }

    /// True when window pixel `p` lies in the viewport.
    pub fn contains(&self, p: Vec2) -> bool {
        let (x, y) = (self.x as f32, self.y as f32);
        p.x >= x && p.y >= y && p.x < x + self.width as f32 && p.y < y + self.height as f32
    }

    /// The ray under window pixel `pixel` for the scene drawn in this
    /// viewport by `camera`: the eye and a unit direction.
    pub fn ray(&self, camera: &Camera, pixel: Vec2) -> Option<(Vec3, Vec3)> {
        mouse_ray(camera, pixel - Vec2::new(self.x as f32, self.y as f32), self.size())
    }
}

/// What the keys and the panel's controls set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Controls {
    /// The simulation is paused (Space).
    pub paused: bool,
    /// Simulated seconds per real second, one of [`SPEEDS`].
    pub speed: f64,
    /// Speed of fired balls, m/s, in [`BALL_SPEEDS`].
    pub ball_speed: f32,
    /// Radius of fired balls, metres, in [`BALL_RADII`].
    pub ball_radius: f32,
    /// Draw contact points and normals (C).
    pub show_contacts: bool,
    /// Draw bounding boxes (B).
    pub show_aabbs: bool,
    /// Draw joints (J).
    pub show_joints: bool,
    /// Draw bonds and the marks of broken bonds (M).
    pub show_bonds: bool,
    /// Tint sleeping bodies (Z).
    pub tint_sleeping: bool,
    /// Show this panel (H).
    pub show_panel: bool,
}

impl Controls {
    /// Does what character key `key` (any case) does to the controls: the
    /// overlay toggles C, B, J, M, Z, the panel's H, the speeds `1`, `2`,
    /// `3`, `[` and `]`, the ball speed `+` and `-`. False for a key that
    /// is not one of these (S, R, F, Q act on the viewer, not on the
    /// controls).
    pub fn key(&mut self, key: &str) -> bool {
        match key.to_lowercase().as_str() {
            "c" => self.show_contacts = !self.show_contacts,
            "b" => self.show_aabbs = !self.show_aabbs,
            "j" => self.show_joints = !self.show_joints,
            "m" => self.show_bonds = !self.show_bonds,
            "z" => self.tint_sleeping = !self.tint_sleeping,
            "h" => self.show_panel = !self.show_panel,
            "1" => self.speed = SPEEDS[0],
            "2" => self.speed = SPEEDS[1],
            "3" => self.speed = SPEEDS[2],
            "[" => self.speed = (self.speed * 0.5).max(SPEEDS[2]),
            "]" => self.speed = (self.speed * 2.0).min(SPEEDS[0]),
            // `=` is `+` without shift on most layouts.
            "+" | "=" => self.ball_speed = (self.ball_speed * 1.25).min(*BALL_SPEEDS.end()),
            "-" | "_" => self.ball_speed = (self.ball_speed / 1.25).max(*BALL_SPEEDS.start()),
            _ => return false,
        }
        true
    }
}

/// What a click on the panel asks for beyond [`Controls`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Requests {
    /// Play or pause (Space).
    pub play_pause: bool,
    /// One step, pausing (S).
    pub step: bool,
    /// Restart the scene (R).
    pub restart: bool,
    /// Go to a moment of the timeline, pausing (Home, Left, `.`, End).
    pub seek: Option<Seek>,
}

/// Viewer keys that move on the timeline ([`crate::timeline`]): `,` or
/// `<` back to the moment before the present, `.` or `>` forward to the
/// one after it (the arrow Left, Home and End are named keys, not
/// characters). `None` for any other key.
pub fn seek_key(key: &str) -> Option<Seek> {
    match key {
        "," | "<" => Some(Seek::Back),
        "." | ">" => Some(Seek::Forward),
        _ => None,
    }
}

/// What the panel shows of the timeline.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimelineInfo {
    /// Simulated time of each moment kept, seconds, oldest first.
    pub times: Vec<f64>,
    /// The moment at or last before the present, and whether the present
    /// is that moment.
    pub position: Option<(usize, bool)>,
    /// In a replay, the simulated time the run replayed went to, seconds.
    pub replay_until: Option<f64>,
    /// Bytes kept.
    pub bytes: usize,
    /// Most bytes kept.
    pub budget: usize,
    /// Moments thinned out to stay within the budget.
    pub thinned: usize,
    /// Why the last move on the timeline failed, if it did.
    pub error: Option<String>,
}

impl TimelineInfo {
    /// Whether there is a moment before the present.
    pub fn can_go_back(&self) -> bool {
        self.position.is_some_and(|(i, exact)| i > 0 || !exact)
    }

    /// Whether there is a moment after the present.
    pub fn can_go_forward(&self) -> bool {
        self.position.map_or(!self.times.is_empty(), |(i, _)| i + 1 < self.times.len())
    }
}

/// Bodies and contacts of the world now.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// All bodies, fired balls included.
    pub bodies: usize,
    /// Dynamic and kinematic bodies not asleep.
    pub awake: usize,
    /// Dynamic and kinematic bodies asleep.
    pub sleeping: usize,
    /// Static bodies.
    pub fixed: usize,
    /// Broad-phase pairs of the last step (touching or not).
    pub pairs: usize,
    /// Pairs touching now (sleeping ones included).
    pub touching: usize,
    /// Contact points of the touching pairs (sleeping ones included).
    pub points: usize,
    /// Contacts the last step worked on (at least one awake body).
    pub active_contacts: usize,
    /// Contact points the last step handed to the solver.
    pub solver_points: usize,
    /// Islands of awake bodies in the last step.
    pub islands: usize,
    /// Joints.
    pub joints: usize,
    /// Of those, how many are further than [`STRETCH_TOLERANCE`] from
    /// holding (drawn red).
    pub stretched: usize,
    /// Bonds holding.
    pub bonds: usize,
}

impl Counts {
    /// Counts the world's bodies by state, its contacts, joints and bonds;
    /// what the last step worked on comes from its profile. `hidden` (the
    /// mouse's helper body while a body is dragged) and its joint are not
    /// counted.
    pub fn of(world: &World, hidden: Option<BodyHandle>) -> Self {
        let mut c = Self::default();
        for (h, body) in world.bodies() {
            if Some(h) == hidden {
                continue;
            }
            c.bodies += 1;
            if body.body_type() == BodyType::Static {
                c.fixed += 1;
            } else if body.is_sleeping() {
                c.sleeping += 1;
            } else {
                c.awake += 1;
            }
        }
        for (_, _, manifold) in world.contacts() {
            c.touching += 1;
            c.points += manifold.len();
        }
        for (_, joint) in world.joints() {
            let (a, b) = joint.bodies();
            if hidden.is_some() && (a == hidden || b == hidden) {
                continue;
            }
            c.joints += 1;
            c.stretched += usize::from(joint.separation() > STRETCH_TOLERANCE);
        }
        c.bonds = world.bond_count();
        let p = world.profile();
        c.pairs = p.pairs;
        c.active_contacts = p.active_contacts;
        c.solver_points = p.contact_points;
        c.islands = p.islands_count;
        c
    }
}

/// Names of the step's stages, in the order of [`stage_times`].
pub const STAGES: [&str; 8] =
    ["broad phase", "narrow phase", "islands", "solver", "integration", "continuous", "write-back", "sleep"];

/// The step's stage times, in the order of [`STAGES`].
pub fn stage_times(p: &Profile) -> [Duration; 8] {
    [p.broad_phase, p.narrow_phase, p.islands, p.solver, p.integration, p.continuous, p.write_back, p.sleep]
}

/// What the panel shows of the timings: means over the last [`SMOOTHING`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Averages {
    /// Mean time per step of each stage, ms, in the order of [`STAGES`].
    pub stage_ms: [f64; 8],
    /// Mean time per step, ms.
    pub step_ms: f64,
    /// Steps taken per frame.
    pub steps_per_frame: f64,
    /// Frames per second.
    pub fps: f64,
    /// Mean time to encode, submit and present a frame (scene and panel), ms.
    pub render_ms: f64,
}

/// Averages step timings and frame numbers over windows of [`SMOOTHING`]
/// of real time; the last finished window is what is shown. A window
/// without steps (paused) keeps the step timings of the one before.
#[derive(Clone, Debug, Default)]
pub struct Smoother {
    start: Option<Instant>,
    stage_s: [f64; 8],
    step_s: f64,
    steps: u32,
    frames: u32,
    render_s: f64,
    shown: Averages,
}

impl Smoother {
    /// Counts one step with the world's profile after it.
    pub fn step(&mut self, p: &Profile) {
        for (sum, d) in self.stage_s.iter_mut().zip(stage_times(p)) {
            *sum += d.as_secs_f64();
        }
        self.step_s += p.total.as_secs_f64();
        self.steps += 1;
    }

    /// Counts a frame that ended at `now` and took `render` to draw; the
    /// first call only starts the clock.
    pub fn frame(&mut self, now: Instant, render: Duration) {
        let Some(start) = self.start else {
            *self = Self { start: Some(now), shown: self.shown, ..Self::default() };
            return;
        };
        self.frames += 1;
        self.render_s += render.as_secs_f64();
        let elapsed = now.saturating_duration_since(start);
        if elapsed < SMOOTHING {
            return;
        }
        let mut shown = Averages {
            steps_per_frame: self.steps as f64 / self.frames as f64,
            fps: self.frames as f64 / elapsed.as_secs_f64(),
            render_ms: self.render_s * 1e3 / self.frames as f64,
            ..self.shown
        };
        if self.steps > 0 {
            let per_step = |s: f64| s * 1e3 / self.steps as f64;
            shown.stage_ms = self.stage_s.map(per_step);
            shown.step_ms = per_step(self.step_s);
        }
        *self = Self { start: Some(now), shown, ..Self::default() };
    }

    /// The numbers to show.
    pub fn shown(&self) -> &Averages {
        &self.shown
    }
}

/// Everything the panel shows that it does not change.
#[derive(Clone, Debug)]
pub struct Info<'a> {
    /// The scene's name as given.
    pub scene: &'a str,
    /// Simulated seconds.
    pub time: f64,
    /// Bodies and contacts.
    pub counts: Counts,
    /// Timings.
    pub timings: Averages,
    /// Balls fired and how many hit a body.
    pub shots: (usize, usize),
    /// Bonds broken since the scene (re)started.
    pub bonds_broken: usize,
    /// Bodies split in two since the scene (re)started.
    pub splits: usize,
    /// Pieces of split bodies in the world now.
    pub pieces: usize,
    /// The timeline.
    pub timeline: TimelineInfo,
}

/// Bar colour of the stage timings.
const BAR: egui::Color32 = egui::Color32::from_rgb(90, 150, 230);

/// Draws the panel's contents into `ui`; the controls change `controls`
/// directly, and the buttons come back as [`Requests`].
pub fn show(ui: &mut egui::Ui, info: &Info<'_>, controls: &mut Controls) -> Requests {
    let mut req = Requests::default();
    ui.horizontal(|ui| {
        ui.strong("crumble view");
        ui.label(info.scene);
    });
    let state = if controls.paused {
        "paused".to_string()
    } else {
        let i = SPEEDS.iter().position(|&s| s == controls.speed).unwrap_or(0);
        format!("running ×{}", SPEED_LABELS[i])
    };
    ui.label(format!("t = {:.2} s, {state}", info.time));

    ui.separator();
    ui.horizontal(|ui| {
        let label = if controls.paused { "Play" } else { "Pause" };
        req.play_pause = ui.button(label).on_hover_text("Space").clicked();
        req.step = ui.button("Step").on_hover_text("S or Right: one step, pauses").clicked();
        req.restart = ui.button("Restart").on_hover_text("R: the scene as loaded, fired balls gone").clicked();
    });
    ui.horizontal(|ui| {
        ui.label("speed").on_hover_text("1 2 3, [ ]");
        for (speed, label) in SPEEDS.into_iter().zip(SPEED_LABELS) {
            ui.selectable_value(&mut controls.speed, speed, label);
        }
    });
    ui.spacing_mut().slider_width = 110.0;
    ui.add(egui::Slider::new(&mut controls.ball_speed, BALL_SPEEDS).logarithmic(true).text("ball m/s"))
        .on_hover_text("+ -: speed of fired balls");
    ui.add(egui::Slider::new(&mut controls.ball_radius, BALL_RADII).logarithmic(true).text("radius m"))
        .on_hover_text("PgUp PgDn: radius of fired balls");
    ui.checkbox(&mut controls.show_contacts, "contact points, normals (C)");
    ui.checkbox(&mut controls.show_aabbs, "bounding boxes (B)");
    ui.checkbox(&mut controls.show_joints, "joints (J)");
    ui.checkbox(&mut controls.show_bonds, "bonds (M)")
        .on_hover_text("each bond's face outlined, green unloaded to red at its strength; where one broke, a crossed magenta rectangle for 1 s");
    ui.checkbox(&mut controls.tint_sleeping, "tint sleeping bodies (Z)");

    timeline(ui, &info.timeline, &mut req);

    ui.separator();
    let c = &info.counts;
    let pairs = [
        ("bodies", c.bodies, "awake", c.awake),
        ("sleeping", c.sleeping, "static", c.fixed),
        ("contact pairs", c.pairs, "touching", c.touching),
        ("contact points", c.points, "solved", c.solver_points),
        ("active contacts", c.active_contacts, "islands", c.islands),
        ("joints", c.joints, "stretched", c.stretched),
        ("bonds", c.bonds, "broken", info.bonds_broken),
        ("bricks split", info.splits, "pieces", info.pieces),
        ("balls fired", info.shots.0, "hit", info.shots.1),
    ];
    egui::Grid::new("counts").num_columns(4).spacing([6.0, 2.0]).show(ui, |ui| {
        for (a, x, b, y) in pairs {
            ui.label(a);
            ui.monospace(format!("{x:>6}"));
            ui.label(b);
            ui.monospace(format!("{y:>5}"));
            ui.end_row();
        }
    });

    ui.separator();
    let t = &info.timings;
    ui.label(format!("ms per step, mean over {:.1} s", SMOOTHING.as_secs_f64()));
    egui::Grid::new("timings").num_columns(3).spacing([8.0, 2.0]).show(ui, |ui| {
        let scale = t.step_ms.max(1e-9);
        for (name, ms) in STAGES.iter().zip(t.stage_ms) {
            ui.label(*name);
            ui.monospace(format!("{ms:8.3}"));
            bar(ui, (ms / scale) as f32);
            ui.end_row();
        }
        ui.strong("whole step");
        ui.monospace(format!("{:8.3}", t.step_ms));
        ui.end_row();
    });

    ui.separator();
    egui::Grid::new("frame").num_columns(4).spacing([6.0, 2.0]).show(ui, |ui| {
        ui.label("fps");
        ui.monospace(format!("{:6.1}", t.fps));
        ui.label("steps/frame");
        ui.monospace(format!("{:5.2}", t.steps_per_frame));
        ui.end_row();
        ui.label("render").on_hover_text("ms per frame to draw the scene and this panel and present them");
        ui.monospace(format!("{:6.1}", t.render_ms));
        ui.label("ms");
        ui.end_row();
    });
    ui.separator();
    ui.weak("Ctrl + drag pulls a body; H hides this panel");
    req
}

/// The timeline's part of the panel: where the present is among the
/// seconds kept, buttons and a slider to go to one, and what is kept.
fn timeline(ui: &mut egui::Ui, t: &TimelineInfo, req: &mut Requests) {
    ui.separator();
    let mb = |b: usize| b as f64 / (1 << 20) as f64;
    ui.horizontal(|ui| {
        ui.strong("timeline").on_hover_text(
            "a moment is kept every simulated second; going to one pauses there, Space replays the run from it, \
             and a shot or a grab starts a new branch (the later moments are dropped)",
        );
        let thinned = if t.thinned > 0 { format!(", {} thinned", t.thinned) } else { String::new() };
        ui.weak(format!("{} kept{thinned}, {:.1} of {:.0} MB", t.times.len(), mb(t.bytes), mb(t.budget)));
    });
    ui.horizontal(|ui| {
        let (back, forward) = (t.can_go_back(), t.can_go_forward());
        let mut button = |ui: &mut egui::Ui, on: bool, label: &str, hover: &str, seek: Seek| {
            if ui.add_enabled(on, egui::Button::new(label)).on_hover_text(hover).clicked() {
                req.seek = Some(seek);
            }
        };
        button(ui, back, "Start", "Home: the oldest moment kept", Seek::First);
        button(ui, back, "Back", "Left , <: the moment before now", Seek::Back);
        button(ui, forward, "Next", ". >: the moment after now", Seek::Forward);
        button(ui, forward, "Newest", "End: the newest moment kept", Seek::Last);
    });
    if let Some(last) = t.times.len().checked_sub(1) {
        let (mut i, exact) = t.position.unwrap_or((0, false));
        ui.horizontal(|ui| {
            let slider = egui::Slider::new(&mut i, 0..=last).show_value(false);
            if ui.add(slider).on_hover_text("drag to go to a moment kept").changed() {
                req.seek = Some(Seek::To(i));
            }
            let at = t.times.get(i).copied().unwrap_or(0.0);
            ui.monospace(if exact { format!("{at:.2} s") } else { format!("{at:.2} s +") });
        });
    }
    if let Some(e) = &t.error {
        ui.colored_label(ui.visuals().error_fg_color, e);
    }
    if let Some(end) = t.replay_until {
        ui.label(format!("replaying the run to {end:.2} s"))
            .on_hover_text("a shot or a grab now starts a new branch of history from here");
    }
}

/// A small horizontal bar filled to `fraction` (0 to 1).
fn bar(ui: &mut egui::Ui, fraction: f32) {
    let (rect, _) = ui.allocate_exact_size(egui::vec2(60.0, 8.0), egui::Sense::hover());
    let f = if fraction.is_finite() { fraction.clamp(0.0, 1.0) } else { 0.0 };
    let painter = ui.painter();
    painter.rect_filled(rect, 1.0, ui.visuals().extreme_bg_color);
    let mut fill = rect;
    fill.set_width(rect.width() * f);
    painter.rect_filled(fill, 1.0, BAR);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_panel_takes_the_right_edge_when_the_window_is_wide_enough() {
        let (scene, panel) = Viewport::layout((1280, 720), 1.0, true);
        assert_eq!(scene, Viewport { x: 0, y: 0, width: 1020, height: 720 });
        assert_eq!(panel, 260);
        let (scene, panel) = Viewport::layout((1280, 720), 2.0, true);
        assert_eq!((scene.width, panel), (760, 520), "the panel is 260 points");
        assert_eq!(Viewport::layout((1280, 720), 1.0, false), (Viewport::full(1280, 720), 0));
        // Too narrow for both: the scene alone.
        assert_eq!(Viewport::layout((400, 300), 1.0, true), (Viewport::full(400, 300), 0));
        assert_eq!(Viewport::layout((420, 300), 1.0, true).1, 260);
        // Nonsense scale factors do not panic.
        assert_eq!(Viewport::layout((640, 360), f32::NAN, true).1, 260);
        assert_eq!(Viewport::layout((640, 360), 1e30, true).1, 0);
        assert_eq!(Viewport::layout((0, 0), 1.0, true).0, Viewport::full(1, 1));
    }

    #[test]
    fn a_click_at_the_centre_of_the_scene_view_aims_at_the_camera_target() {
        let cam = Camera::look_at(Vec3::new(3.0, 2.0, 5.0), Vec3::new(0.0, 0.5, 0.0), 45.0);
        let forward = (cam.target - cam.eye).normalize();
        for viewport in [
            Viewport::layout((640, 360), 1.0, true).0,
            Viewport::layout((1280, 720), 1.0, true).0,
            // A view that does not start at the corner (a panel on the left).
            Viewport { x: 260, y: 0, width: 380, height: 360 },
        ] {
            let centre = Vec2::new(viewport.x as f32, viewport.y as f32) + viewport.size() / 2.0;
            let (eye, dir) = viewport.ray(&cam, centre).unwrap();
            assert_eq!(eye, cam.eye);
            assert!(dir.dot(forward) > 0.99999, "{viewport:?}: {dir} vs {forward}");
            // The centre of the whole window is not the centre of the view.
            let window_width = if viewport.x == 0 { viewport.width + 260 } else { viewport.x + viewport.width };
            let window_centre = Vec2::new(window_width as f32, viewport.height as f32) / 2.0;
            let (_, off) = viewport.ray(&cam, window_centre).unwrap();
            assert!(off.dot(forward) < 0.999, "{viewport:?}: the offset must matter");
        }
    }

    #[test]
    fn a_click_on_a_point_drawn_in_the_view_aims_at_that_point() {
        // The renderer draws the scene with the view's aspect; the point
        // projected into that image, moved by the view's corner, is where
        // it shows in the window.
        let cam = Camera::look_at(Vec3::new(-2.0, 4.0, 6.0), Vec3::new(1.0, 0.0, 0.0), 60.0);
        let viewport = Viewport { x: 260, y: 40, width: 500, height: 300 };
        for p in [Vec3::new(1.5, 0.3, 0.2), Vec3::new(0.0, 1.0, -1.0)] {
            let in_image = cam.project(p, viewport.width, viewport.height).unwrap();
            let pixel = in_image + Vec2::new(260.0, 40.0);
            assert!(viewport.contains(pixel));
            let (eye, dir) = viewport.ray(&cam, pixel).unwrap();
            assert!(dir.dot((p - eye).normalize()) > 0.99999, "{p}");
        }
        assert!(!viewport.contains(Vec2::new(259.0, 100.0)) && !viewport.contains(Vec2::new(760.0, 100.0)));
        assert!(viewport.contains(Vec2::new(260.0, 40.0)) && !viewport.contains(Vec2::new(300.0, 340.0)));
    }

    fn profile(solver_ms: u64, total_ms: u64) -> Profile {
        Profile {
            solver: Duration::from_millis(solver_ms),
            total: Duration::from_millis(total_ms),
            ..Profile::default()
        }
    }

    #[test]
    fn timings_are_means_over_half_a_second() {
        let t0 = Instant::now();
        let mut s = Smoother::default();
        s.frame(t0, Duration::ZERO);
        // 30 frames at 60 fps, two steps each, alternating 1 and 3 ms of solver.
        for i in 1..=30u32 {
            s.step(&profile(1, 2));
            s.step(&profile(3, 4));
            assert_eq!(s.shown().fps, 0.0, "nothing shown before the window ends");
            s.frame(t0 + Duration::from_secs_f64(i as f64 / 60.0), Duration::from_millis(5));
        }
        let a = *s.shown();
        assert!((a.stage_ms[3] - 2.0).abs() < 1e-9, "solver {a:?}");
        assert!((a.step_ms - 3.0).abs() < 1e-9, "{a:?}");
        assert_eq!(a.stage_ms[0], 0.0);
        assert!((a.steps_per_frame - 2.0).abs() < 1e-9 && (a.fps - 60.0).abs() < 1e-6, "{a:?}");
        assert!((a.render_ms - 5.0).abs() < 1e-9, "{a:?}");

        // Paused: frames go on, no steps; the step timings stay.
        let t1 = t0 + Duration::from_millis(500);
        for i in 1..=10u32 {
            s.frame(t1 + Duration::from_millis(60 * i as u64), Duration::from_millis(1));
        }
        let b = *s.shown();
        assert_eq!((b.stage_ms, b.step_ms), (a.stage_ms, a.step_ms));
        assert_eq!(b.steps_per_frame, 0.0);
        assert!((b.fps - 10.0 / 0.6).abs() < 1e-6, "{b:?}");
    }

    #[test]
    fn counts_split_bodies_by_state() {
        let mut world = World::new(crumble::WorldSettings::default()).unwrap();
        crumble::scenes::add_ground(&mut world, 0.0, crumble::scenes::STEEL).unwrap();
        let ball = Vec3::new(0.0, 0.1, 0.0);
        crumble::scenes::add_ball(&mut world, 0.1, ball, Vec3::ZERO, crumble::scenes::STEEL, false).unwrap();
        let c = Counts::of(&world, None);
        assert_eq!((c.bodies, c.awake, c.sleeping, c.fixed), (2, 1, 0, 1), "{c:?}");
        // A ball resting on the ground falls asleep within a few seconds.
        for _ in 0..600 {
            world.step(1.0 / 60.0).unwrap();
            if Counts::of(&world, None).sleeping == 1 {
                break;
            }
        }
        // The step after it fell asleep no longer solves its contact.
        world.step(1.0 / 60.0).unwrap();
        let c = Counts::of(&world, None);
        assert_eq!((c.bodies, c.awake, c.sleeping, c.fixed), (2, 0, 1, 1), "{c:?}");
        assert!(c.pairs >= 1 && c.touching == 1 && c.points >= 1, "the ball rests on the ground: {c:?}");
        assert_eq!((c.active_contacts, c.solver_points), (0, 0), "asleep, it is not solved: {c:?}");
    }

    fn controls() -> Controls {
        Controls {
            paused: false,
            speed: SPEEDS[0],
            ball_speed: 20.0,
            ball_radius: 0.1,
            show_contacts: false,
            show_aabbs: false,
            show_joints: false,
            show_bonds: false,
            tint_sleeping: false,
            show_panel: true,
        }
    }

    #[test]
    fn j_toggles_the_joints_and_leaves_the_rest() {
        let mut c = controls();
        assert!(c.key("j"));
        assert_eq!(c, Controls { show_joints: true, ..controls() });
        assert!(c.key("J"), "either case");
        assert_eq!(c, controls());
        // The other toggles each flip their own.
        for (key, want) in [
            ("c", Controls { show_contacts: true, ..controls() }),
            ("b", Controls { show_aabbs: true, ..controls() }),
            ("m", Controls { show_bonds: true, ..controls() }),
            ("M", Controls { show_bonds: true, ..controls() }),
            ("z", Controls { tint_sleeping: true, ..controls() }),
            ("h", Controls { show_panel: false, ..controls() }),
            ("3", Controls { speed: SPEEDS[2], ..controls() }),
            ("[", Controls { speed: SPEEDS[1], ..controls() }),
            ("+", Controls { ball_speed: 25.0, ..controls() }),
        ] {
            let mut c = controls();
            assert!(c.key(key), "{key}");
            assert_eq!(c, want, "{key}");
        }
        // Keys of the viewer's own, and unknown ones, change nothing here.
        for key in ["s", "r", "f", "q", "x", "", ",", ".", "<", ">"] {
            let mut c = controls();
            assert!(!c.key(key), "{key}");
            assert_eq!(c, controls(), "{key}");
        }
    }

    #[test]
    fn the_timeline_keys_and_buttons_go_where_there_is_a_moment() {
        assert_eq!((seek_key(","), seek_key("<")), (Some(Seek::Back), Some(Seek::Back)));
        assert_eq!((seek_key("."), seek_key(">")), (Some(Seek::Forward), Some(Seek::Forward)));
        assert_eq!((seek_key("s"), seek_key("")), (None, None));
        let at = |position| TimelineInfo { times: vec![0.0, 1.0, 2.0], position, ..TimelineInfo::default() };
        let ends = |t: TimelineInfo| (t.can_go_back(), t.can_go_forward());
        assert_eq!(ends(at(Some((0, true)))), (false, true), "at the start");
        assert_eq!(ends(at(Some((0, false)))), (true, true), "just after it");
        assert_eq!(ends(at(Some((2, true)))), (true, false), "at the newest");
        assert_eq!(ends(at(Some((2, false)))), (true, false), "after the newest");
        assert_eq!(ends(TimelineInfo::default()), (false, false), "nothing kept");
        assert_eq!(ends(at(None)), (false, true), "before the oldest kept");
    }

    #[test]
    fn counts_show_joints_and_leave_out_the_hidden_body() {
        let mut world = World::new(crumble::WorldSettings::default()).unwrap();
        let spec = crumble::scenes::WreckingBallSpec { links: 2, ..Default::default() };
        let chain = crumble::scenes::add_wrecking_ball(&mut world, &spec).unwrap();
        let c = Counts::of(&world, None);
        assert_eq!((c.bodies, c.joints, c.stretched), (3, 3, 0), "{c:?}");
        // A rope inserted half as long as its ends are apart is stretched.
        let (pa, pb) = (spec.anchor, world.body(chain.ball).unwrap().position());
        let rope =
            crumble::JointBuilder::rope(crumble::JointBody::World, chain.ball, pa.distance(pb) * 0.5).anchors(pa, pb);
        world.insert_joint(rope).unwrap();
        let c = Counts::of(&world, None);
        assert_eq!((c.bodies, c.joints, c.stretched), (3, 4, 1), "{c:?}");
        // Hiding the ball leaves out it and its two joints.
        let c = Counts::of(&world, Some(chain.ball));
        assert_eq!((c.bodies, c.awake, c.joints, c.stretched), (2, 2, 2, 0), "{c:?}");
    }

    #[test]
    fn counts_show_the_bonds_holding() {
        use crumble::scenes::{add_box, add_ground, BRICK, BRICK_SIZE};
        let mut world = World::new(crumble::WorldSettings::default()).unwrap();
        add_ground(&mut world, 0.0, BRICK).unwrap();
        let at = |i: usize| Vec3::new(0.0, BRICK_SIZE.y * (i as f32 + 0.5), 0.0);
        let bricks: Vec<BodyHandle> = (0..3)
            .map(|i| add_box(&mut world, BRICK_SIZE, at(i), glam::Quat::IDENTITY, BRICK, false).unwrap())
            .collect();
        assert_eq!(Counts::of(&world, None).bonds, 0);
        let bonds = world.bond_touching(&bricks, crumble::BondSpec::LIME_MORTAR).unwrap();
        assert_eq!(bonds.len(), 3, "two between the bricks, one to the ground");
        assert_eq!(Counts::of(&world, None).bonds, 3);
        world.remove_bond(bonds[1]).unwrap();
        assert_eq!(Counts::of(&world, None).bonds, 2);
    }
}
