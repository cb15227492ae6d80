//! The window, its event handling and the frame loop.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crumble::{BodyHandle, BondEvent, World};
use crumble_render::{wgpu, Camera, Frame, Instance, RenderTarget, Renderer, RendererOptions, SceneFrames, Shape};
use crumble_scene::{BodyShape, Scene, Simulation};
use glam::{Vec2, Vec3};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::bonds::{BreakMark, BreakMarks, Tracker};
use crate::clock::FixedStepper;
use crate::grab::{self, Grab};
use crate::gui::{Gui, SCENE_FORMAT};
use crate::orbit::Orbit;
use crate::overlay::{self, Marks};
use crate::panel::{
    self, Controls, Counts, Info, Requests, Smoother, TimelineInfo, Viewport, BALL_RADII, BALL_SPEEDS, SPEEDS,
};
use crate::splits::{self, Flash, Splits};
use crate::timeline::{Budget, Footprint, Seek, SimMoment, Timeline};
use crate::{load_scene, ViewError, ViewOptions};

/// A body "moved" when it is this far from where it started, metres.
const MOVED: f32 = 0.05;
/// A mouse press that travels less than this is a click, not a drag, pixels.
const CLICK_SLOP: f32 = 4.0;
/// Most steps simulated in one frame: after a stall the viewer slows down
/// instead of freezing while it catches up.
const MAX_STEPS_PER_FRAME: u32 = 10;

/// What a run did, printed as one line at the end.
#[derive(Clone, Debug, Default)]
pub struct Summary {
    /// Scene bodies (projectiles of the scene included, shots not) more
    /// than 5 cm from their start.
    pub moved: usize,
    /// Balls fired from the viewer.
    pub shots: usize,
    /// Of those, how many touched a dynamic body.
    pub hits: usize,
    /// Bodies that broke in two.
    pub splits: usize,
    /// Frames drawn.
    pub frames: u64,
    /// Frames per second over the run.
    pub fps: f64,
    /// Simulated seconds.
    pub simulated: f64,
    /// Window size, pixels.
    pub size: (u32, u32),
    /// The adapter that drew.
    pub adapter: String,
    /// The screenshot written, if any.
    pub screenshot: Option<PathBuf>,
    /// The camera at the end.
    pub camera: Option<Camera>,
}

impl Summary {
    /// The camera at the end as a scene file's `[camera]` keys (to keep a
    /// view), e.g. `camera: eye = [3.000, 2.000, 5.000], target = [0.000,
    /// 0.500, 0.000], fov_deg = 45`.
    pub fn camera_line(&self) -> Option<String> {
        let c = self.camera?;
        let v = |p: Vec3| format!("[{:.3}, {:.3}, {:.3}]", p.x, p.y, p.z);
        Some(format!("camera: eye = {}, target = {}, fov_deg = {}", v(c.eye), v(c.target), c.fov_y_deg))
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "moved: {} bodies > 5 cm, shots: {} fired, {} hit, splits: {}, frames: {} at {}x{}, fps: {:.1}, simulated: {:.3} s, adapter: {}",
            self.moved,
            self.shots,
            self.hits,
            self.splits,
            self.frames,
            self.size.0,
            self.size.1,
            self.fps,
            self.simulated,
            self.adapter
        )?;
        if let Some(p) = &self.screenshot {
            write!(f, ", screenshot: {}", p.display())?;
        }
        Ok(())
    }
}

/// A ball fired from the viewer (not one of the scene's bodies).
#[derive(Clone, Copy, Debug)]
struct Shot {
    body: BodyHandle,
    radius: f32,
    hit: bool,
}

/// A user's input that changes the world, as the timeline records it to
/// replay ([`Live::apply`] does it).
#[derive(Clone, Copy, Debug)]
enum Input {
    /// A ball fired from `from` at `velocity`.
    Fire { from: Vec3, velocity: Vec3, radius: f32 },
    /// A grab of the body the ray from `eye` along `dir` enters first,
    /// dragged on the plane facing `forward`; lets go of a body held before.
    Grab { eye: Vec3, dir: Vec3, forward: Vec3 },
    /// The held body's target moved to the ray from `eye` along `dir`.
    Drag { eye: Vec3, dir: Vec3 },
    /// The held body let go.
    Release,
}

/// What the timeline keeps of [`Live`] at a moment: the simulation, the
/// fired balls, the body held (its helper and joint are in the world's
/// snapshot), and the fading marks of broken bonds and split bricks with
/// their counts. What follows from the simulation alone (how each body is
/// drawn, the bonds' anchors) is made again on the way back.
#[derive(Clone, Debug)]
struct Moment {
    sim: SimMoment,
    shots: Vec<Shot>,
    grab: Option<Grab>,
    breaks: BreakMarks,
    splits: Splits,
}

impl Footprint for Moment {
    fn footprint(&self) -> usize {
        use std::mem::size_of;
        self.sim.footprint()
            + self.shots.capacity() * size_of::<Shot>()
            + self.breaks.len() * size_of::<BreakMark>()
            + self.splits.len() * size_of::<Flash>()
    }
}

/// The simulation and what is needed to draw and restart it. A body held
/// by the mouse is held in this world: a restart, which makes a new one,
/// lets go of it with the old world, helper body and joint included, and
/// the marks of the bonds broken in it.
///
/// The simulation's bodies grow as boxes break (their pieces are
/// appended): what is kept per body follows them after every step
/// ([`Live::step`]), and the frame asks `frames` which bodies are in the
/// world now.
///
/// The user's inputs (a shot, a grab, a drag, a release) go through the
/// timeline ([`Live::act`]): recorded to be replayed, and, in a replay,
/// starting a new branch of history. A drag is applied before the next
/// step, once however many frames moved the cursor before it, so that a
/// replay can apply it before the same step.
struct Live {
    sim: Simulation,
    /// How each body is drawn, and when; follows `sim.bodies`.
    frames: SceneFrames,
    shots: Vec<Shot>,
    grab: Option<Grab>,
    /// The user's last drag of the held body since the last step.
    drag: Option<(Vec3, Vec3)>,
    /// The bonds' anchors in their bodies' frames, to draw them and to
    /// place those that break.
    bonds: Tracker,
    /// Where bonds broke in the last second of simulated time.
    breaks: BreakMarks,
    /// Bodies that broke, and their pieces' flashes.
    splits: Splits,
    /// Steps taken since the start.
    steps: u64,
    /// A moment every second, and the inputs to replay from them.
    timeline: Timeline<Moment, Input>,
}

impl Live {
    fn new(scene: &Scene) -> Result<Self, ViewError> {
        let sim = crumble_scene::build(scene).map_err(|e| ViewError::Scene(e.to_string()))?;
        let frames = SceneFrames::new(&sim.bodies);
        let mut bonds = Tracker::default();
        bonds.sync(&sim.world);
        let mut live = Self {
            sim,
            frames,
            shots: Vec::new(),
            grab: None,
            drag: None,
            bonds,
            breaks: BreakMarks::default(),
            splits: Splits::default(),
            steps: 0,
            timeline: Timeline::new(Budget::default()),
        };
        let start = live.moment();
        live.timeline.keep(0, live.sim.time(), start);
        Ok(live)
    }

    /// The moment the simulation is at, for the timeline.
    fn moment(&self) -> Moment {
        Moment {
            sim: SimMoment::capture(&self.sim),
            shots: self.shots.clone(),
            grab: self.grab.clone(),
            breaks: self.breaks.clone(),
            splits: self.splits.clone(),
        }
    }

    /// Does the user's `input` and records it. In a replay (before the end
    /// of the run replayed), a new branch of history starts here first:
    /// the timeline's later moments and the inputs not yet replayed go,
    /// and a body the replay held is let go. Whether the input did
    /// anything ([`Live::apply`]).
    fn act(&mut self, input: Input) -> Result<bool, ViewError> {
        if self.timeline.has_future(self.steps) {
            self.timeline.branch(self.steps);
            if self.grab.is_some() {
                self.apply(Input::Release)?;
                self.timeline.record(self.steps, Input::Release);
            }
        }
        let done = self.apply(input)?;
        self.timeline.record(self.steps, input);
        Ok(done)
    }

    /// Does `input` to the world, whether the user's or a replayed one.
    /// A grab is true when it holds a body, a drag and a release when
    /// there was one to move or let go, a shot always.
    fn apply(&mut self, input: Input) -> Result<bool, ViewError> {
        match input {
            Input::Fire { from, velocity, radius } => {
                let body = crumble::scenes::add_ball(
                    &mut self.sim.world,
                    radius,
                    from,
                    velocity,
                    crumble::scenes::STEEL,
                    true,
                )
                .map_err(|e| ViewError::Simulation(format!("could not fire a ball: {e}")))?;
                self.shots.push(Shot { body, radius, hit: false });
                Ok(true)
            }
            Input::Grab { eye, dir, forward } => {
                self.let_go()?;
                let world = &mut self.sim.world;
                let Some(hit) = grab::pick(world, eye, dir) else { return Ok(false) };
                let grabbed = Grab::start(world, &hit, forward)
                    .map_err(|e| ViewError::Simulation(format!("could not grab a body: {e}")))?;
                self.grab = grabbed;
                Ok(self.grab.is_some())
            }
            Input::Drag { eye, dir } => {
                let Some(grab) = &mut self.grab else { return Ok(false) };
                let holds = grab
                    .drag(&mut self.sim.world, eye, dir)
                    .map_err(|e| ViewError::Simulation(format!("could not drag the body: {e}")))?;
                if !holds {
                    self.let_go()?;
                }
                Ok(true)
            }
            Input::Release => Ok(self.let_go()?),
        }
    }

    /// Takes the held body's joint and helper out of the world; true when
    /// a body was held.
    fn let_go(&mut self) -> Result<bool, ViewError> {
        match self.grab.take() {
            Some(grab) => grab
                .release(&mut self.sim.world)
                .map(|()| true)
                .map_err(|e| ViewError::Simulation(format!("could not let go of the body: {e}"))),
            None => Ok(false),
        }
    }

    /// Grabs the dynamic body that the ray from `eye` along `dir` enters
    /// first, to drag it on the plane through the grabbed point facing
    /// `forward` (the view direction); lets go of any body held before.
    /// False, with nothing done, when the ray enters no dynamic body
    /// first.
    fn grab(&mut self, eye: Vec3, dir: Vec3, forward: Vec3) -> Result<bool, ViewError> {
        let world = &self.sim.world;
        if !grab::pick(world, eye, dir).is_some_and(|hit| world.body(hit.body).is_some_and(|b| b.is_dynamic())) {
            return Ok(false);
        }
        self.drag = None;
        self.act(Input::Grab { eye, dir, forward })
    }

    /// Moves the held body's target to the ray from `eye` along `dir` (the
    /// ray under the cursor) before the next step; there it lets go when
    /// the grab no longer holds.
    fn drag(&mut self, eye: Vec3, dir: Vec3) {
        if self.grab.is_some() {
            self.drag = Some((eye, dir));
        }
    }

    /// Lets go of the held body, if any: its joint and the helper body leave
    /// the world.
    fn release(&mut self) -> Result<(), ViewError> {
        self.drag = None;
        if self.grab.is_some() {
            self.act(Input::Release)?;
        }
        Ok(())
    }

    fn fire(&mut self, from: Vec3, velocity: Vec3, radius: f32) -> Result<(), ViewError> {
        self.act(Input::Fire { from, velocity, radius }).map(|_| ())
    }

    /// The helper body of the grab, left out of the counts and of the
    /// joint overlay.
    fn helper(&self) -> Option<BodyHandle> {
        self.grab.as_ref().map(Grab::helper)
    }

    /// One fixed step, after the inputs the timeline replays before it and
    /// the user's drag; notes which shots touched a dynamic body, marks
    /// where bonds broke (marked whether or not bonds are shown, so that
    /// turning them on shows the last second's breaks too), learns the
    /// pieces of the bodies that broke, and keeps a moment when a new
    /// second of history ends.
    fn step(&mut self) -> Result<(), ViewError> {
        while let Some(input) = self.timeline.next_due(self.steps) {
            self.apply(input)?;
        }
        if let Some((eye, dir)) = self.drag.take() {
            if self.grab.is_some() {
                self.act(Input::Drag { eye, dir })?;
            }
        }
        // Bonds made since the last step are learnt before this one can
        // break them.
        self.bonds.sync(&self.sim.world);
        let before = self.sim.time();
        self.sim.step().map_err(|e| ViewError::Simulation(e.to_string()))?;
        self.steps += 1;
        self.mark_breaks();
        let new = self.frames.follow(&self.sim.bodies);
        self.splits.take(&self.sim.bodies, new, self.sim.time());
        if let Some(&h) = self.sim.world.faulted_bodies().first() {
            let name = self.sim.bodies.iter().find(|b| b.handle == Some(h)).map_or("a fired ball", |b| b.name.as_str());
            return Err(ViewError::Simulation(format!("body `{name}` went non-finite")));
        }
        let world = &self.sim.world;
        for e in world.contact_events() {
            for shot in self.shots.iter_mut().filter(|s| !s.hit) {
                let other = if e.body_a == shot.body {
                    e.body_b
                } else if e.body_b == shot.body {
                    e.body_a
                } else {
                    continue;
                };
                shot.hit |= world.body(other).is_some_and(|b| b.is_dynamic());
            }
        }
        if self.timeline.advance(self.steps, before, self.sim.time()) {
            let moment = self.moment();
            self.timeline.keep(self.steps, self.sim.time(), moment);
        }
        Ok(())
    }

    /// Goes to the moment of the timeline `seek` asks for: the simulation
    /// and the viewer's state as they were then, the inputs recorded from
    /// there to be replayed. False, with nothing changed, when there is no
    /// such moment; an error, with nothing changed, when its world cannot
    /// be restored.
    fn seek(&mut self, seek: Seek) -> Result<bool, ViewError> {
        let Some(i) = self.timeline.resolve(seek, self.steps) else { return Ok(false) };
        let Some((step, _, m)) = self.timeline.moment(i) else { return Ok(false) };
        let sim = m.sim.restore(self.sim.world.settings().threads)?;
        let (shots, grab, breaks, splits) = (m.shots.clone(), m.grab.clone(), m.breaks.clone(), m.splits.clone());
        self.frames = SceneFrames::new(&sim.bodies);
        self.bonds = Tracker::default();
        self.bonds.sync(&sim.world);
        self.sim = sim;
        (self.shots, self.grab, self.breaks, self.splits) = (shots, grab, breaks, splits);
        self.drag = None;
        self.steps = step;
        self.timeline.seek(i);
        Ok(true)
    }

    /// What the panel shows of the timeline.
    fn timeline_info(&self) -> TimelineInfo {
        let t = &self.timeline;
        let ahead = t.frontier().saturating_sub(self.steps);
        TimelineInfo {
            times: t.moments().map(|(_, time)| time).collect(),
            position: t.position(self.steps),
            replay_until: t.has_future(self.steps).then(|| self.sim.time() + ahead as f64 * f64::from(self.sim.dt)),
            bytes: t.bytes(),
            budget: t.budget().bytes,
            thinned: t.thinned(),
            error: None,
        }
    }

    /// Marks each bond the last step broke, where its bodies carried it.
    fn mark_breaks(&mut self) {
        let world = &self.sim.world;
        let now = world.time();
        for e in world.bond_events() {
            let BondEvent::Broken { bond, .. } = *e;
            match self.bonds.take_broken(world, bond) {
                Some(anchors) => self.breaks.push(anchors, now),
                None => self.breaks.count_unplaced(),
            }
        }
        self.breaks.expire(now);
    }

    /// Bodies in the world (not the ground, not fired balls) more than
    /// [`MOVED`] from where they were at the start: a piece of a brick
    /// that broke from where it was in that brick, and the brick itself
    /// not counted (its pieces are).
    fn moved(&self) -> usize {
        let bodies = &self.sim.bodies;
        (0..bodies.len())
            .filter(|&i| {
                let b = &bodies[i];
                !b.is_static
                    && b.handle.is_some()
                    && b.despawn.is_none()
                    && self.sim.pose(i).position.distance(start_pose(bodies, i).position) > MOVED
            })
            .count()
    }

    /// The frame of the scene's bodies now, in body order: those in the
    /// world ([`SceneFrames::is_drawn`]), tinted when asleep if
    /// `tint_sleeping`, and the pieces of bodies that just broke flashing
    /// ([`splits::flash`]).
    fn bodies_frame(&self, tint_sleeping: bool) -> Result<Frame, ViewError> {
        let sim = &self.sim;
        let now = sim.time();
        let mut frame = self
            .frames
            .frame_with(now, |i| {
                let p = sim.pose(i);
                (p.position, p.rotation)
            })
            .map_err(|e| ViewError::Graphics(e.to_string()))?;
        // The instances are the drawn bodies in body order: the body of
        // each instance, to tint or flash the right one.
        let drawn: Vec<usize> = (0..self.frames.len()).filter(|&i| self.frames.is_drawn(i, now)).collect();
        debug_assert_eq!(drawn.len(), frame.instances.len());
        if tint_sleeping {
            for (&i, inst) in drawn.iter().zip(&mut frame.instances) {
                if sim.is_sleeping(i) {
                    inst.material = overlay::sleeping(inst.material);
                }
            }
        }
        for (f, left) in self.splits.visible(now) {
            if let Ok(k) = drawn.binary_search(&f.body) {
                let inst = &mut frame.instances[k];
                inst.material = splits::flash(inst.material, left);
            }
        }
        Ok(frame)
    }

    /// Pieces of broken bodies in the world now.
    fn pieces(&self) -> usize {
        self.sim.bodies.iter().filter(|b| b.parent.is_some() && b.despawn.is_none()).count()
    }

    /// Where a scripted shot aims by default: the centre of the scene's boxes
    /// (the wall, pyramid, tower), else of everything.
    fn default_target(&self) -> Option<Vec3> {
        let boxes: Vec<Vec3> = self
            .sim
            .bodies
            .iter()
            .filter(|b| matches!(b.shape, BodyShape::Box { .. }) && b.parent.is_none())
            .map(|b| b.initial.position)
            .collect();
        match crumble_render::Bounds::from_points(boxes) {
            Some(b) => Some(b.center()),
            None => self.frames.bounds().map(|b| b.center()),
        }
    }
}

/// The window, its surface, the renderer drawing the scene and egui
/// drawing the scene's image and the panel.
struct Gpu {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    renderer: Renderer,
    gui: Gui,
}

impl Gpu {
    /// Opens a surface on `window`: Vulkan first, then GL (or the backends
    /// in `WGPU_BACKEND`), on a GPU or a software adapter.
    fn new(window: Arc<Window>, no_vsync: bool) -> Result<Self, ViewError> {
        let order = match wgpu::Backends::from_env() {
            Some(b) => vec![b],
            None => vec![wgpu::Backends::VULKAN, wgpu::Backends::GL],
        };
        let mut why = Vec::new();
        for backends in order {
            let mut desc = wgpu::InstanceDescriptor::new_with_display_handle(Box::new(window.clone()));
            desc.backends = backends;
            desc.flags = wgpu::InstanceFlags::empty().with_env();
            let instance = wgpu::Instance::new(desc);
            let surface = match instance.create_surface(window.clone()) {
                Ok(s) => s,
                Err(e) => {
                    why.push(format!("{backends:?}: no surface: {e}"));
                    continue;
                }
            };
            let adapter = match crumble_render::request_adapter(&instance, Some(&surface)) {
                Ok(a) => a,
                Err(e) => {
                    why.push(format!("{backends:?}: {e}"));
                    continue;
                }
            };
            let caps = surface.get_capabilities(&adapter);
            let Some(&first) = caps.formats.first() else {
                why.push(format!("{backends:?}: the surface offers no format"));
                continue;
            };
            // An sRGB format lets the hardware encode the renderer's linear colours.
            let format = caps.formats.iter().copied().find(|f| f.is_srgb()).unwrap_or(first);
            // Scripted runs measure the frame rate, so they do not wait for vsync.
            let present_mode = if no_vsync {
                [wgpu::PresentMode::Immediate, wgpu::PresentMode::Mailbox]
                    .into_iter()
                    .find(|m| caps.present_modes.contains(m))
                    .unwrap_or(wgpu::PresentMode::Fifo)
            } else {
                wgpu::PresentMode::Fifo
            };
            let size = window.inner_size();
            let Some(mut config) = surface.get_default_config(&adapter, size.width.max(1), size.height.max(1)) else {
                why.push(format!("{backends:?}: the adapter cannot draw to this window"));
                continue;
            };
            config.format = format;
            config.present_mode = present_mode;
            config.usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
            let renderer = Renderer::on_adapter(adapter, RendererOptions::default())
                .map_err(|e| ViewError::Graphics(e.to_string()))?;
            surface.configure(renderer.device(), &config);
            let gui = Gui::new(&window, renderer.device(), config.format);
            return Ok(Self { window, surface, config, renderer, gui });
        }
        Err(ViewError::Graphics(format!("no adapter can draw to the window ({})", why.join("; "))))
    }

    fn resize(&mut self, size: PhysicalSize<u32>) {
        if size.width > 0 && size.height > 0 {
            self.config.width = size.width;
            self.config.height = size.height;
            self.surface.configure(self.renderer.device(), &self.config);
        }
    }

    /// Draws `frame` into the scene's texture (the size of `viewport`) and
    /// egui's output (the scene's image and the panel) into the next surface
    /// texture; skips the frame when the surface is busy, hidden or out of
    /// date (after reconfiguring it).
    fn draw(
        &mut self,
        frame: &Frame,
        camera: &Camera,
        viewport: Viewport,
        ui: egui::FullOutput,
    ) -> Result<(), ViewError> {
        let egui::FullOutput { platform_output, mut textures_delta, shapes, pixels_per_point, .. } = ui;
        self.gui.state.handle_platform_output(&self.window, platform_output);
        // Before anything can skip the frame: egui sends each texture change once.
        self.gui.upload_textures(self.renderer.device(), self.renderer.queue(), &mut textures_delta);
        let screen =
            egui_wgpu::ScreenDescriptor { size_in_pixels: [self.config.width, self.config.height], pixels_per_point };
        let result = self.draw_surface(frame, camera, viewport, shapes, screen);
        self.gui.free_textures(&mut textures_delta);
        result
    }

    fn draw_surface(
        &mut self,
        frame: &Frame,
        camera: &Camera,
        viewport: Viewport,
        shapes: Vec<egui::epaint::ClippedShape>,
        screen: egui_wgpu::ScreenDescriptor,
    ) -> Result<(), ViewError> {
        // Handles to the renderer's device and queue (cheap clones), so that
        // the renderer can be borrowed mutably below.
        let (device, queue) = (&self.renderer.device().clone(), &self.renderer.queue().clone());
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) => t,
            wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
                // Draw this one; the next frame gets a fresh configuration.
                self.surface.configure(device, &self.config);
                t
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => return Ok(()),
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                let size = self.window.inner_size();
                self.resize(size);
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(ViewError::Graphics("the window surface reported a validation error".into()))
            }
        };
        let view = texture.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("crumble view frame") });
        self.gui.scene_texture(device, viewport.width, viewport.height);
        let Some((scene, width, height)) = self.gui.scene_view() else {
            return Err(ViewError::Graphics("the scene's texture is missing".into()));
        };
        let target = RenderTarget { view: scene, format: SCENE_FORMAT, width, height };
        self.renderer.encode(&mut encoder, frame, camera, &target).map_err(|e| ViewError::Graphics(e.to_string()))?;
        let extra = self.gui.encode(device, queue, &mut encoder, &view, shapes, screen);
        queue.submit(extra.into_iter().chain([encoder.finish()]));
        self.window.pre_present_notify();
        queue.present(texture);
        Ok(())
    }
}

/// Mouse state for orbit, pan, grab and click detection.
#[derive(Default)]
struct Mouse {
    position: Vec2,
    /// Where the left button went down, while it is down (not for a grab).
    left_from: Option<Vec2>,
    dragging: bool,
    /// The user holds a body (Ctrl + left press on it, not yet released).
    holding: bool,
    right: bool,
    shift: bool,
    ctrl: bool,
}

struct App {
    opts: ViewOptions,
    scene: Scene,
    live: Live,
    gpu: Option<Gpu>,
    error: Option<ViewError>,
    orbit: Orbit,
    stepper: FixedStepper,
    last_frame: Option<Instant>,
    single_steps: u32,
    controls: Controls,
    /// Where the scene is drawn in the window (left of the panel).
    viewport: Viewport,
    /// The camera was framed for the first frame's viewport.
    framed: bool,
    timings: Smoother,
    mouse: Mouse,
    marks: Marks,
    /// Why the last move on the timeline failed, if it did.
    seek_error: Option<String>,
    frames_drawn: u64,
    first_frame: Option<Instant>,
    last_report: Option<Instant>,
    last_print: Option<Instant>,
    frames_since_report: u64,
    summary: Summary,
    done: bool,
}

/// Runs the viewer; the summary of the run on success.
pub fn run(opts: ViewOptions) -> Result<Summary, ViewError> {
    validate(&opts)?;
    let mut scene = load_scene(&opts.scene)?;
    if opts.no_sleep {
        scene.world.sleep = false;
    }
    let live = Live::new(&scene)?;
    if std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
        return Err(ViewError::NoDisplay("DISPLAY is not set".into()));
    }
    let event_loop = EventLoop::new().map_err(|e| ViewError::NoDisplay(e.to_string()))?;
    // Framed again for the scene's viewport at the first frame.
    let (w, h) = opts.size;
    let orbit = Orbit::from_camera(&initial_camera(&scene, &live.frames, w as f32 / h as f32));
    let marks = Marks::for_radius(live.frames.bounds().map_or(1.0, |b| b.radius()));
    let stepper = FixedStepper::new(live.sim.dt as f64, MAX_STEPS_PER_FRAME);
    let controls = Controls {
        paused: false,
        speed: SPEEDS[0],
        ball_speed: opts.ball_speed,
        ball_radius: opts.ball_radius,
        show_contacts: opts.show_contacts,
        show_aabbs: opts.show_aabbs,
        show_joints: opts.show_joints,
        show_bonds: opts.show_bonds.unwrap_or(live.sim.world.bond_count() > 0),
        tint_sleeping: opts.tint_sleeping,
        show_panel: opts.show_panel,
    };
    let mut app = App {
        opts,
        scene,
        live,
        gpu: None,
        error: None,
        orbit,
        stepper,
        last_frame: None,
        single_steps: 0,
        controls,
        viewport: Viewport::full(w, h),
        framed: false,
        timings: Smoother::default(),
        mouse: Mouse::default(),
        marks,
        seek_error: None,
        frames_drawn: 0,
        first_frame: None,
        last_report: None,
        last_print: None,
        frames_since_report: 0,
        summary: Summary::default(),
        done: false,
    };
    event_loop.run_app(&mut app).map_err(|e| ViewError::NoDisplay(e.to_string()))?;
    if let Some(e) = app.error {
        return Err(e);
    }
    if app.gpu.is_none() {
        return Err(ViewError::NoDisplay("the window never opened".into()));
    }
    Ok(app.summary)
}

fn validate(opts: &ViewOptions) -> Result<(), ViewError> {
    let bad = |m: String| Err(ViewError::BadOption(m));
    for (what, range, unit, value) in
        [("ball speed", &BALL_SPEEDS, "m/s", opts.ball_speed), ("ball radius", &BALL_RADII, "m", opts.ball_radius)]
    {
        if !range.contains(&value) {
            return bad(format!("{what} must be in [{}, {}] {unit}, got {value}", range.start(), range.end()));
        }
    }
    let (w, h) = opts.size;
    if !(16..=8192).contains(&w) || !(16..=8192).contains(&h) {
        return bad(format!("window size {w}x{h}: each side must be 16 to 8192 pixels"));
    }
    if opts.frames == Some(0) {
        return bad("--frames must be at least 1".into());
    }
    if let (Some(k), Some(n)) = (opts.shoot_at_frame, opts.frames) {
        if k == 0 || k > n {
            return bad(format!("--shoot-at-frame {k} is not within the {n} frames"));
        }
    }
    if let Some(p) = &opts.screenshot {
        if p.extension().is_none_or(|e| !e.eq_ignore_ascii_case("png")) {
            return bad(format!("{}: the screenshot must be a .png file", p.display()));
        }
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        if !dir.is_dir() {
            return bad(format!("{}: directory {} does not exist", p.display(), dir.display()));
        }
    }
    Ok(())
}

/// Where body `i` of `bodies` was at the start: its starting pose, or for
/// a piece of a body that broke, its place in that body at the start
/// (its pose in its parent's frame, carried by the parent's start).
fn start_pose(bodies: &[crumble_scene::BodyInfo], i: usize) -> crumble::Pose {
    match bodies[i].parent {
        Some((p, local)) if p < i => start_pose(bodies, p).mul_pose(&local),
        _ => bodies[i].initial,
    }
}

/// The scene's `[camera]` where given, the renderer's automatic framing for
/// the rest.
fn initial_camera(scene: &Scene, frames: &SceneFrames, aspect: f32) -> Camera {
    let fov = scene.camera.map_or(crumble_render::DEFAULT_FOV_DEG, |c| c.fov_deg);
    let auto = frames.auto_camera(aspect, fov);
    let Some(spec) = scene.camera else { return auto };
    let eye = spec.eye.map_or(auto.eye, Vec3::from_array);
    let target = spec.target.map_or(auto.target, Vec3::from_array);
    let cam = Camera::look_at(eye, target, fov);
    if cam.validate().is_ok() {
        cam
    } else {
        auto
    }
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewError) {
        self.error.get_or_insert(e);
        event_loop.exit();
    }

    /// Fires a ball from the eye along the ray under window pixel `pixel`,
    /// when that pixel shows the scene (not the panel).
    fn fire_at_pixel(&mut self, pixel: Vec2) -> Result<(), ViewError> {
        if !self.viewport.contains(pixel) {
            return Ok(());
        }
        let camera = self.orbit.camera();
        let Some((eye, dir)) = self.viewport.ray(&camera, pixel) else { return Ok(()) };
        // Start just ahead of the eye so the ball is not clipped by the near plane.
        let from = eye + dir * (self.controls.ball_radius * 2.0 + camera.near);
        self.live.fire(from, dir * self.controls.ball_speed, self.controls.ball_radius)?;
        self.summary.shots += 1;
        Ok(())
    }

    /// Grabs the dynamic body under window pixel `pixel` (Ctrl + left
    /// press), when that pixel shows the scene; nothing happens over empty
    /// space, the ground or a kinematic body.
    fn grab_at_pixel(&mut self, pixel: Vec2) -> Result<(), ViewError> {
        if !self.viewport.contains(pixel) {
            return Ok(());
        }
        let camera = self.orbit.camera();
        let Some((eye, dir)) = self.viewport.ray(&camera, pixel) else { return Ok(()) };
        self.mouse.holding = self.live.grab(eye, dir, camera.target - camera.eye)?;
        Ok(())
    }

    /// Moves the body the user holds (not one a replay holds) towards the
    /// cursor: once a frame, so that it follows the camera (wheel,
    /// right-drag) as well as the mouse.
    fn drag_to_cursor(&mut self) {
        if !self.mouse.holding {
            return;
        }
        let camera = self.orbit.camera();
        if let Some((eye, dir)) = self.viewport.ray(&camera, self.mouse.position) {
            self.live.drag(eye, dir);
        }
    }

    /// Lets go of the body the user holds, if any.
    fn release(&mut self) -> Result<(), ViewError> {
        if std::mem::take(&mut self.mouse.holding) {
            self.live.release()?;
        }
        Ok(())
    }

    /// Goes to the moment of the timeline `seek` asks for, letting go of a
    /// body the user holds first, and pauses there. A moment that cannot
    /// be restored leaves the viewer where it was, and the panel says why.
    fn seek(&mut self, seek: Seek) -> Result<(), ViewError> {
        self.release()?;
        match self.live.seek(seek) {
            Ok(moved) => {
                self.seek_error = None;
                if moved {
                    self.controls.paused = true;
                    self.single_steps = 0;
                    self.stepper.reset();
                }
            }
            Err(e) => {
                eprintln!("crumble view: {e}");
                self.seek_error = Some(e.to_string());
            }
        }
        Ok(())
    }

    /// The scripted shot: from the eye, aimed (allowing for gravity) to pass
    /// through the target.
    fn scripted_shot(&mut self) -> Result<(), ViewError> {
        let camera = self.orbit.camera();
        let target = self.opts.shoot_target.or_else(|| self.live.default_target()).unwrap_or(camera.target);
        let dir = (target - camera.eye).try_normalize().unwrap_or(Vec3::NEG_Z);
        let from = camera.eye + dir * (self.controls.ball_radius * 2.0 + camera.near);
        let gravity = self.live.sim.world.settings().gravity;
        let velocity = crumble_scene::aim(from, target, self.controls.ball_speed, gravity);
        self.live.fire(from, velocity, self.controls.ball_radius)?;
        self.summary.shots += 1;
        Ok(())
    }

    fn restart(&mut self) -> Result<(), ViewError> {
        self.live = Live::new(&self.scene)?;
        self.mouse.holding = false;
        self.seek_error = None;
        self.stepper.reset();
        Ok(())
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) -> Result<(), ViewError> {
        match key {
            Key::Named(NamedKey::Space) => self.play_pause(),
            Key::Named(NamedKey::ArrowRight) => self.step_once(),
            Key::Named(NamedKey::ArrowLeft) => self.seek(Seek::Back)?,
            Key::Named(NamedKey::Home) => self.seek(Seek::First)?,
            Key::Named(NamedKey::End) => self.seek(Seek::Last)?,
            Key::Named(NamedKey::PageUp) => {
                self.controls.ball_radius = (self.controls.ball_radius * 1.25).min(*BALL_RADII.end())
            }
            Key::Named(NamedKey::PageDown) => {
                self.controls.ball_radius = (self.controls.ball_radius / 1.25).max(*BALL_RADII.start())
            }
            Key::Named(NamedKey::Escape) => self.finish(event_loop),
            Key::Character(c) => match c.to_lowercase().as_str() {
                "s" => self.step_once(),
                "r" => self.restart()?,
                "f" => self.fire_at_pixel(self.mouse.position)?,
                "q" => self.finish(event_loop),
                other => match panel::seek_key(other) {
                    Some(seek) => self.seek(seek)?,
                    None => {
                        self.controls.key(other);
                    }
                },
            },
            _ => {}
        }
        Ok(())
    }

    /// True when the mouse is over the scene and egui is not using it (a
    /// slider being dragged): clicks, drags and the wheel then move the
    /// camera or fire.
    fn scene_has_pointer(&self) -> bool {
        self.viewport.contains(self.mouse.position)
            && !self.gpu.as_ref().is_some_and(|g| g.gui.ctx.egui_is_using_pointer())
    }

    fn play_pause(&mut self) {
        self.controls.paused = !self.controls.paused;
        self.stepper.reset();
    }

    /// Does what the panel's buttons asked for.
    fn apply(&mut self, req: Requests) -> Result<(), ViewError> {
        if req.play_pause {
            self.play_pause();
        }
        if req.step {
            self.step_once();
        }
        if req.restart {
            self.restart()?;
        }
        if let Some(seek) = req.seek {
            self.seek(seek)?;
        }
        Ok(())
    }

    fn step_once(&mut self) {
        self.controls.paused = true;
        self.single_steps += 1;
    }

    /// Saves the screenshot if asked for, then closes.
    fn finish(&mut self, event_loop: &ActiveEventLoop) {
        if !self.done {
            self.done = true;
            self.summary.moved = self.live.moved();
            self.summary.hits = self.live.shots.iter().filter(|s| s.hit).count();
            self.summary.splits = self.live.splits.total();
            self.summary.frames = self.frames_drawn;
            self.summary.simulated = self.live.sim.time();
            self.summary.camera = Some(self.orbit.camera());
            if let (Some(first), true) = (self.first_frame, self.frames_drawn > 1) {
                // Frames after the first over the time since it was drawn.
                let t = first.elapsed().as_secs_f64();
                self.summary.fps = if t > 0.0 { (self.frames_drawn - 1) as f64 / t } else { 0.0 };
            }
            if let Some(gpu) = &self.gpu {
                self.summary.size = (gpu.config.width, gpu.config.height);
                self.summary.adapter = gpu.renderer.describe();
            }
            // After the frame rate is measured: the offscreen render is not a frame.
            if let Err(e) = self.save_screenshot() {
                self.error.get_or_insert(e);
            }
        }
        event_loop.exit();
    }

    /// The last frame as the window showed it, scene and panel, drawn
    /// again offscreen (the same device, textures and egui output).
    fn save_screenshot(&mut self) -> Result<(), ViewError> {
        let (Some(path), Some(gpu)) = (self.opts.screenshot.clone(), self.gpu.as_mut()) else {
            return Ok(());
        };
        let (rgba, w, h) = gpu
            .gui
            .screenshot(gpu.renderer.device(), gpu.renderer.queue())
            .map_err(|e| ViewError::Graphics(format!("screenshot {}: {e}", path.display())))?;
        write_png(&path, &rgba, w, h)?;
        self.summary.screenshot = Some(path);
        Ok(())
    }

    /// The frame for the current state: bodies (tinted when asleep and
    /// asked for, fresh pieces flashing), fired balls, debug marks.
    fn build_frame(&self) -> Result<Frame, ViewError> {
        let sim = &self.live.sim;
        let mut frame = self.live.bodies_frame(self.controls.tint_sleeping)?;
        for shot in &self.live.shots {
            let Some(body) = sim.world.body(shot.body) else { continue };
            let pose = body.pose();
            if !pose.position.is_finite() {
                continue;
            }
            let material = if self.controls.tint_sleeping && body.is_sleeping() {
                overlay::sleeping(crumble_render::STEEL)
            } else {
                crumble_render::STEEL
            };
            frame.instances.push(Instance {
                shape: Shape::Sphere { radius: shot.radius },
                position: pose.position,
                rotation: pose.rotation,
                material,
            });
        }
        if self.controls.show_contacts {
            overlay::contacts(&sim.world, self.marks, &mut frame.instances);
        }
        if self.controls.show_aabbs {
            overlay::aabbs(&sim.world, self.marks, &mut frame.instances);
        }
        let helper = self.live.helper();
        if self.controls.show_joints {
            overlay::joints(&sim.world, self.marks, helper, &mut frame.instances);
        }
        if self.controls.show_bonds {
            overlay::bonds(&sim.world, &self.live.bonds, self.marks, &mut frame.instances);
            overlay::breaks(&self.live.breaks, sim.time(), self.marks, &mut frame.instances);
        }
        if let Some(grab) = &self.live.grab {
            if let Some((target, point)) = grab.anchors(&sim.world) {
                // Paused, the drag waits for the next step: the line goes
                // to where it will take the target.
                let aim = self.live.drag.and_then(|(eye, dir)| grab.plane_crossing(eye, dir));
                overlay::link(aim.unwrap_or(target), point, self.marks, overlay::GRAB, &mut frame.instances);
            }
        }
        Ok(frame)
    }

    /// One frame: advance the simulation by the real time since the last
    /// frame (× speed) in whole fixed steps, lay out the panel, draw, report.
    fn frame(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewError> {
        let now = Instant::now();
        let real = self.last_frame.map_or(0.0, |t| (now - t).as_secs_f64());
        self.last_frame = Some(now);
        let frame_number = self.frames_drawn + 1;
        if self.opts.shoot_at_frame == Some(frame_number) {
            self.scripted_shot()?;
        }
        self.drag_to_cursor();
        let steps = if self.controls.paused {
            std::mem::take(&mut self.single_steps)
        } else {
            self.stepper.advance(real, self.controls.speed)
        };
        for _ in 0..steps {
            self.live.step()?;
            self.timings.step(self.live.sim.world.profile());
        }
        let Some(mut ui) = self.run_ui()? else { return Ok(()) };
        let frame = match self.build_frame() {
            Ok(f) => f,
            Err(e) => {
                // The viewer stops: egui's texture changes are not needed.
                ui.textures_delta.clear();
                return Err(e);
            }
        };
        let camera = self.orbit.camera();
        let Some(gpu) = self.gpu.as_mut() else { return Ok(()) };
        let drawing = Instant::now();
        gpu.draw(&frame, &camera, self.viewport, ui)?;
        self.timings.frame(Instant::now(), drawing.elapsed());
        self.frames_drawn = frame_number;
        self.frames_since_report += 1;
        self.first_frame.get_or_insert(now);
        self.report(now);
        if self.opts.frames.is_some_and(|n| frame_number >= n) {
            self.finish(event_loop);
        } else if let Some(gpu) = &self.gpu {
            gpu.window.request_redraw();
        }
        Ok(())
    }

    /// Lays out the window (the scene's viewport, the panel beside it),
    /// runs egui on the input since the last frame and does what the panel
    /// asked for. egui's output, to draw; `None` without a window.
    fn run_ui(&mut self) -> Result<Option<egui::FullOutput>, ViewError> {
        let Some(gpu) = self.gpu.as_mut() else { return Ok(None) };
        let ppp = egui_winit::pixels_per_point(&gpu.gui.ctx, &gpu.window);
        let window = (gpu.config.width, gpu.config.height);
        let (viewport, panel_px) = Viewport::layout(window, ppp, self.controls.show_panel);
        self.viewport = viewport;
        if !self.framed {
            // The scene's own framing, for the view it actually has.
            self.orbit = Orbit::from_camera(&initial_camera(&self.scene, &self.live.frames, viewport.aspect()));
            self.framed = true;
        }
        let scene = gpu.gui.scene_texture(gpu.renderer.device(), viewport.width, viewport.height);
        let input = gpu.gui.state.take_egui_input(&gpu.window);
        let info = Info {
            scene: &self.opts.scene,
            time: self.live.sim.time(),
            counts: Counts::of(&self.live.sim.world, self.live.helper()),
            timings: *self.timings.shown(),
            shots: (self.live.shots.len(), self.live.shots.iter().filter(|s| s.hit).count()),
            bonds_broken: self.live.breaks.total(),
            splits: self.live.splits.total(),
            pieces: self.live.pieces(),
            timeline: TimelineInfo { error: self.seek_error.clone(), ..self.live.timeline_info() },
        };
        let controls = &mut self.controls;
        let mut requests = Requests::default();
        let ctx = gpu.gui.ctx.clone();
        let mut output = ctx.run_ui(input, |ui| {
            let points = |px: u32| px as f32 / ppp;
            let rect = egui::Rect::from_min_size(
                egui::pos2(points(viewport.x), points(viewport.y)),
                egui::vec2(points(viewport.width), points(viewport.height)),
            );
            let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
            ui.painter().image(scene, rect, uv, egui::Color32::WHITE);
            if panel_px > 0 {
                egui::Panel::right("crumble panel").resizable(false).exact_size(points(panel_px)).show(ui, |ui| {
                    egui::ScrollArea::vertical().show(ui, |ui| requests = panel::show(ui, &info, controls));
                });
            }
        });
        if let Err(e) = self.apply(requests) {
            // The viewer stops: egui's texture changes are not needed.
            output.textures_delta.clear();
            return Err(e);
        }
        Ok(Some(output))
    }

    /// Counts and step timings in the title (4× a second) and as a stdout
    /// line (once a second), as well as in the panel.
    fn report(&mut self, now: Instant) {
        let since = self.last_report.map_or(Duration::MAX, |t| now - t);
        if since < Duration::from_millis(250) {
            return;
        }
        let fps = if since == Duration::MAX { 0.0 } else { self.frames_since_report as f64 / since.as_secs_f64() };
        let line = self.stats_line(fps);
        if let Some(gpu) = &self.gpu {
            gpu.window.set_title(&format!("crumble view: {line}"));
        }
        if self.last_print.is_none_or(|t| now - t >= Duration::from_secs(1)) {
            println!("{line}");
            self.last_print = Some(now);
        }
        self.last_report = Some(now);
        self.frames_since_report = 0;
    }

    fn stats_line(&self, fps: f64) -> String {
        let world: &World = &self.live.sim.world;
        let p = world.profile();
        // Counted, not the last step's: a world just restored has not
        // stepped yet.
        let counts = Counts::of(world, self.live.helper());
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let state = if self.controls.paused { "paused".to_string() } else { format!("x{}", self.controls.speed) };
        format!(
            "{} t={:.2}s {state} | bodies {} awake {} | contacts {} pts {} pairs | step {:.2} ms: broad {:.2} narrow {:.2} \
             islands {:.2} solver {:.2} integrate {:.2} ccd {:.2} write {:.2} sleep {:.2} | ball {:.0} m/s r {:.3} m | {:.0} fps",
            self.opts.scene,
            self.live.sim.time(),
            counts.bodies,
            counts.awake,
            p.contact_points,
            p.pairs,
            ms(p.total),
            ms(p.broad_phase),
            ms(p.narrow_phase),
            ms(p.islands),
            ms(p.solver),
            ms(p.integration),
            ms(p.continuous),
            ms(p.write_back),
            ms(p.sleep),
            self.controls.ball_speed,
            self.controls.ball_radius,
            fps
        )
    }
}

fn write_png(path: &Path, rgba: &[u8], w: u32, h: u32) -> Result<(), ViewError> {
    let io = |e: String| ViewError::Io(format!("{}: {e}", path.display()));
    let file = std::fs::File::create(path).map_err(|e| io(e.to_string()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(|e| io(e.to_string()))?;
    writer.write_image_data(rgba).map_err(|e| io(e.to_string()))?;
    writer.finish().map_err(|e| io(e.to_string()))
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gpu.is_some() {
            return;
        }
        let (w, h) = self.opts.size;
        let attrs = Window::default_attributes()
            .with_title(format!("crumble view: {}", self.opts.scene))
            .with_inner_size(PhysicalSize::new(w, h));
        let window = match event_loop.create_window(attrs) {
            Ok(w) => Arc::new(w),
            Err(e) => return self.fail(event_loop, ViewError::NoDisplay(format!("could not open a window: {e}"))),
        };
        match Gpu::new(window, self.opts.frames.is_some()) {
            Ok(gpu) => {
                gpu.window.request_redraw();
                self.gpu = Some(gpu);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if self.done {
            return;
        }
        // egui sees every event but key presses, which are the viewer's
        // unless a text field of the panel (a slider's number) is being edited.
        let editing = self.gpu.as_ref().is_some_and(|g| g.gui.ctx.text_edit_focused());
        if let Some(gpu) = &mut self.gpu {
            let key_press =
                matches!(&event, WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed);
            if editing || !key_press {
                let _ = gpu.gui.state.on_window_event(&gpu.window, &event);
            }
        }
        let result = match event {
            WindowEvent::CloseRequested => {
                self.finish(event_loop);
                Ok(())
            }
            WindowEvent::Resized(size) => {
                if let Some(gpu) = &mut self.gpu {
                    gpu.resize(size);
                }
                Ok(())
            }
            WindowEvent::RedrawRequested => self.frame(event_loop),
            WindowEvent::ModifiersChanged(m) => {
                self.mouse.shift = m.state().shift_key();
                self.mouse.ctrl = m.state().control_key();
                Ok(())
            }
            // A button released while another window has the focus may
            // never be reported: let go of a held body now.
            WindowEvent::Focused(false) => self.release(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed && !editing => {
                self.key(event_loop, &event.logical_key)
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = Vec2::new(position.x as f32, position.y as f32);
                let d = p - self.mouse.position;
                self.mouse.position = p;
                if let Some(from) = self.mouse.left_from {
                    self.mouse.dragging |= p.distance(from) > CLICK_SLOP;
                    if self.mouse.dragging {
                        if self.mouse.shift {
                            self.orbit.pan(d.x, d.y, self.viewport.size().y);
                        } else {
                            self.orbit.rotate(d.x, d.y);
                        }
                    }
                } else if self.mouse.right {
                    self.orbit.pan(d.x, d.y, self.viewport.size().y);
                }
                Ok(())
            }
            WindowEvent::MouseInput { state, button, .. } => match (button, state) {
                // Presses over the panel are egui's: no orbit, pan, grab or shot.
                (MouseButton::Left, ElementState::Pressed) if self.mouse.ctrl => {
                    self.mouse.left_from = None;
                    self.mouse.dragging = false;
                    if self.scene_has_pointer() {
                        self.grab_at_pixel(self.mouse.position)
                    } else {
                        Ok(())
                    }
                }
                (MouseButton::Left, ElementState::Pressed) => {
                    self.mouse.left_from = self.scene_has_pointer().then_some(self.mouse.position);
                    self.mouse.dragging = false;
                    Ok(())
                }
                (MouseButton::Left, ElementState::Released) => {
                    let released = self.release();
                    let click = self.mouse.left_from.take().is_some() && !self.mouse.dragging;
                    self.mouse.dragging = false;
                    if click && released.is_ok() {
                        self.fire_at_pixel(self.mouse.position)
                    } else {
                        released
                    }
                }
                (MouseButton::Right, s) => {
                    self.mouse.right = s == ElementState::Pressed && self.scene_has_pointer();
                    Ok(())
                }
                (MouseButton::Middle, ElementState::Pressed) if self.scene_has_pointer() => {
                    self.fire_at_pixel(self.mouse.position)
                }
                _ => Ok(()),
            },
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                // Over the panel the wheel scrolls it (egui has the event).
                if steps.is_finite() && self.scene_has_pointer() {
                    self.orbit.zoom(steps);
                }
                Ok(())
            }
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.fail(event_loop, e);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The brick wall without a window: the live simulation, the camera the
    /// viewer starts with for a 640 × 360 view, and that view.
    fn wall() -> (Live, Camera, Viewport) {
        let scene = load_scene("brick_wall").unwrap();
        let live = Live::new(&scene).unwrap();
        let viewport = Viewport::full(640, 360);
        let camera = initial_camera(&scene, &live.frames, viewport.aspect());
        (live, camera, viewport)
    }

    /// The scene's top-row brick nearest the wall's middle: the ball flies
    /// at mid-height, so nothing stands between it and the eye.
    fn top_brick(live: &Live) -> (BodyHandle, Vec3) {
        let bricks = live.sim.bodies.iter().filter(|b| matches!(b.shape, BodyShape::Box { .. }));
        let top = bricks.clone().map(|b| b.initial.position.y).fold(f32::MIN, f32::max);
        let b = bricks
            .filter(|b| b.initial.position.y > top - 1e-3)
            .min_by(|a, b| a.initial.position.x.abs().total_cmp(&b.initial.position.x.abs()))
            .unwrap();
        (b.handle.unwrap(), b.initial.position)
    }

    #[test]
    fn a_grab_through_the_view_holds_the_brick_drawn_there_until_released() {
        let (mut live, camera, viewport) = wall();
        let (brick, centre) = top_brick(&live);
        let forward = camera.target - camera.eye;
        // The first step launches the scene's ball.
        live.step().unwrap();
        let world = &live.sim.world;
        let (bodies, joints) = (world.body_count(), world.joint_count());

        // The pixel where the brick's centre is drawn: the ray through it
        // enters that brick, on its face towards the eye.
        let pixel = camera.project(centre, viewport.width, viewport.height).unwrap();
        let (eye, dir) = viewport.ray(&camera, pixel).unwrap();
        let hit = grab::pick(world, eye, dir).unwrap();
        assert_eq!(hit.body, brick);
        assert!(hit.point.distance(centre) < 0.15 && hit.point.distance(eye) < centre.distance(eye), "{hit:?}");

        assert!(live.grab(eye, dir, forward).unwrap());
        let grab = live.grab.as_ref().unwrap();
        assert_eq!(grab.body(), brick);
        let helper = grab.helper();
        assert_eq!(live.helper(), Some(helper));
        let world = &live.sim.world;
        assert_eq!((world.body_count(), world.joint_count()), (bodies + 1, joints + 1), "one helper, one joint");
        let counts = Counts::of(world, live.helper());
        assert_eq!((counts.bodies, counts.joints), (bodies, joints), "the panel leaves the grab out");

        // The cursor 20 cm higher on the screen's plane: the brick rises.
        let above = viewport.ray(&camera, camera.project(hit.point + Vec3::Y * 0.2, 640, 360).unwrap()).unwrap();
        for _ in 0..30 {
            live.drag(above.0, above.1);
            live.step().unwrap();
        }
        let y = live.sim.world.body(brick).unwrap().position().y;
        assert!(y > centre.y + 0.1, "the brick was lifted: {y} from {}", centre.y);

        live.release().unwrap();
        let world = &live.sim.world;
        assert!(live.grab.is_none() && world.body(helper).is_none());
        assert_eq!((world.body_count(), world.joint_count()), (bodies, joints), "helper and joint gone");
        live.release().unwrap();
    }

    #[test]
    fn a_grab_of_the_sky_or_the_ground_holds_nothing() {
        let (mut live, camera, viewport) = wall();
        let forward = camera.target - camera.eye;
        let bodies = live.sim.world.body_count();
        // The top corners show the sky, the bottom corners the ground.
        for pixel in [Vec2::new(1.0, 1.0), Vec2::new(638.0, 1.0), Vec2::new(1.0, 358.0), Vec2::new(638.0, 358.0)] {
            let (eye, dir) = viewport.ray(&camera, pixel).unwrap();
            assert!(!live.grab(eye, dir, forward).unwrap(), "{pixel}");
            assert!(live.grab.is_none() && live.helper().is_none());
            assert_eq!(live.sim.world.body_count(), bodies);
        }
        assert_eq!(live.timeline.inputs(), 0, "nothing done, nothing recorded");
        // A new grab lets go of the one before: never two helpers.
        let (_, centre) = top_brick(&live);
        let (eye, dir) = viewport.ray(&camera, camera.project(centre, 640, 360).unwrap()).unwrap();
        assert!(live.grab(eye, dir, forward).unwrap());
        let first = live.helper().unwrap();
        assert!(live.grab(eye, dir, forward).unwrap());
        assert!(live.sim.world.body(first).is_none());
        assert_eq!(live.sim.world.body_count(), bodies + 1);
    }

    /// The brick wall in the built-in breakable `brick`: the scene's ball
    /// splits bricks in its first tenths of a second (measured: three,
    /// two at 0.133 s and one at 0.150 s).
    fn breaking_wall() -> Live {
        let source = crumble_scene::builtin::find("brick_wall").unwrap().source.replace("\"clay\"", "\"brick\"");
        Live::new(&crumble_scene::parse(&source, "breaking_wall.toml").unwrap()).unwrap()
    }

    /// The bodies grow as bricks break: after every step the viewer knows
    /// every body, draws each brick until it breaks and its pieces from
    /// then on (one instance fewer than bodies per broken brick), flashes
    /// the new pieces where they are, counts each split once, and stops
    /// the flash after half a second.
    #[test]
    fn bricks_that_break_give_way_to_their_flashing_pieces() {
        let mut live = breaking_wall();
        let start = live.sim.bodies.len();
        let mut first_split = None;
        while live.sim.time() < 0.3 {
            live.step().unwrap();
            let (sim, frames) = (&live.sim, &live.frames);
            assert_eq!(frames.len(), sim.bodies.len(), "every body known after the step");
            let broken = sim.bodies.iter().filter(|b| b.despawn.is_some()).count();
            let pieces = live.pieces();
            assert_eq!(pieces, sim.bodies.len() - start, "pieces in the world (none broke again)");
            assert_eq!(live.splits.total(), broken, "one split per brick that broke");
            assert_eq!(pieces, 2 * broken, "two pieces a split");
            let frame = live.bodies_frame(true).unwrap();
            assert_eq!(frame.instances.len(), sim.bodies.len() - broken, "the broken bricks not drawn");
            if broken > 0 && first_split.is_none() {
                first_split = Some(sim.time());
                // Each fresh piece drawn where it is, lit up from its
                // brick's colour; the brick gone from its place.
                let now = sim.time();
                for (flash, left) in live.splits.visible(now) {
                    assert_eq!(left, 1.0);
                    let p = sim.pose(flash.body);
                    let inst = frame.instances.iter().find(|i| i.position == p.position).expect("the piece is drawn");
                    let parent = sim.bodies[flash.body].parent.unwrap().0;
                    let half = match sim.bodies[flash.body].shape {
                        BodyShape::Box { half_extents } => half_extents,
                        _ => unreachable!("a piece is a box"),
                    };
                    let brick = crumble_render::brick_material(parent, half);
                    assert_eq!(inst.material, splits::flash(brick, 1.0));
                    let gone = sim.pose(parent).position;
                    assert!(frame.instances.iter().all(|i| i.position != gone), "brick {parent} drawn after it broke");
                }
            }
        }
        let first = first_split.expect("a brick broke within 0.3 s");
        eprintln!("{} bricks split, the first at {first:.3} s", live.splits.total());
        // Past half a second of simulated time the flashes are over:
        // every piece is drawn in its brick's own colour.
        while live.sim.time() < first + splits::SPLIT_FLASH_SECONDS + 0.05 {
            live.step().unwrap();
        }
        assert_eq!(live.splits.visible(live.sim.time()).count(), 0);
        let frame = live.bodies_frame(false).unwrap();
        let now = live.sim.time();
        let drawn: Vec<usize> = (0..live.frames.len()).filter(|&i| live.frames.is_drawn(i, now)).collect();
        for (&i, inst) in drawn.iter().zip(&frame.instances) {
            let b = &live.sim.bodies[i];
            if let (Some((parent, _)), BodyShape::Box { half_extents }) = (b.parent, b.shape) {
                assert_eq!(inst.material, crumble_render::brick_material(parent, half_extents), "piece {i}");
            }
        }
    }

    /// Every body's pose in the world, as bits.
    fn poses(live: &Live) -> Vec<[u32; 7]> {
        crate::timeline::tests::poses(&live.sim)
    }

    /// The user's part of the first run of [`first_run`], by step: a grab
    /// of the top brick after 40 steps, dragged up 6 mm a step until 90 and
    /// released there, and a ball fired at the wall after 100.
    fn user(live: &mut Live, camera: &Camera, viewport: Viewport) {
        let (_, centre) = top_brick(live);
        let forward = camera.target - camera.eye;
        match live.steps {
            40 => {
                let (eye, dir) = viewport.ray(camera, camera.project(centre, 640, 360).unwrap()).unwrap();
                assert!(live.grab(eye, dir, forward).unwrap(), "the top brick is held");
            }
            41..90 => {
                let rise = 0.006 * (live.steps - 40) as f32;
                let above = camera.project(centre + Vec3::Y * rise, 640, 360).unwrap();
                let (eye, dir) = viewport.ray(camera, above).unwrap();
                live.drag(eye, dir);
            }
            90 => live.release().unwrap(),
            100 => {
                let target = live.default_target().unwrap();
                let from = camera.eye + (target - camera.eye).normalize() * 0.5;
                let gravity = live.sim.world.settings().gravity;
                live.fire(from, crumble_scene::aim(from, target, 20.0, gravity), 0.1).unwrap();
            }
            _ => {}
        }
    }

    /// The breaking wall for 180 steps (3 s) with the user's inputs of
    /// [`user`]; each step's poses.
    fn first_run() -> (Live, Vec<Vec<[u32; 7]>>) {
        let mut live = breaking_wall();
        let viewport = Viewport::full(640, 360);
        let camera = initial_camera(&load_scene("brick_wall").unwrap(), &live.frames, viewport.aspect());
        let mut poses_by_step = vec![poses(&live)];
        while live.steps < 180 {
            user(&mut live, &camera, viewport);
            live.step().unwrap();
            poses_by_step.push(poses(&live));
        }
        (live, poses_by_step)
    }

    /// Back at a kept second the viewer replays the first run bit for bit:
    /// the body held at that second (restored with it), its drags and its
    /// release, and the ball fired later, all before the same steps.
    #[test]
    fn a_replay_from_a_kept_second_repeats_the_grab_and_the_shot_bit_for_bit() {
        let (mut live, first) = first_run();
        assert!(live.splits.total() > 0 && live.shots.len() == 1, "bricks broke, a ball was fired");
        assert!(live.timeline.moments().map(|m| m.0).eq([0, 60, 120, 180]));
        let inputs = live.timeline.inputs();
        assert_eq!(inputs, 1 + 49 + 1 + 1, "a grab, a drag a step, a release, a shot");
        let end = (live.shots[0].hit, live.splits.total(), live.breaks.total(), live.sim.bodies.len());

        // Back to 1 s, where the brick was held, then to the start.
        for (seek, from) in [(Seek::To(1), 60), (Seek::First, 0)] {
            assert!(live.seek(seek).unwrap());
            assert_eq!(live.steps, from);
            assert_eq!(poses(&live), first[from as usize], "the moment is the first run's");
            assert_eq!(live.grab.is_some(), from == 60, "the body held then is held again");
            assert!(live.timeline.has_future(from));
            while live.steps < 180 {
                live.step().unwrap();
                assert!(poses(&live) == first[live.steps as usize], "step {} replayed", live.steps);
            }
            assert!(live.grab.is_none() && live.shots.len() == 1);
            let again = (live.shots[0].hit, live.splits.total(), live.breaks.total(), live.sim.bodies.len());
            assert_eq!(again, end);
            assert!(!live.timeline.has_future(180));
            assert_eq!((live.timeline.len(), live.timeline.inputs()), (4, inputs), "a replay keeps nothing new");
        }
    }

    /// A moment whose world does not restore leaves everything as it was.
    #[test]
    fn a_moment_that_does_not_restore_changes_nothing() {
        let mut live = breaking_wall();
        while live.steps < 90 {
            live.step().unwrap();
        }
        live.timeline.state_mut(1).unwrap().sim.spoil();
        let (before, bodies) = (poses(&live), live.sim.bodies.len());
        let e = live.seek(Seek::Back).unwrap_err().to_string();
        assert!(e.contains("could not restore a moment of the timeline"), "{e}");
        assert_eq!((live.steps, poses(&live), live.sim.bodies.len()), (90, before, bodies));
        assert!(!live.timeline.has_future(90), "the present is where it was");
        assert!(live.seek(Seek::First).unwrap(), "the other moments still restore");
        assert_eq!(live.steps, 0);
    }

    /// A shot in a replay starts a new branch: the body the replay held is
    /// let go, the later moments and inputs go, and the new history is
    /// kept and replayed in its turn.
    #[test]
    fn a_shot_after_going_back_starts_a_new_branch() {
        let (mut live, first) = first_run();
        assert!(live.seek(Seek::To(1)).unwrap());
        while live.steps < 70 {
            live.step().unwrap();
        }
        assert!(live.grab.is_some(), "the replay holds the brick");
        let bodies = live.sim.world.body_count();
        live.fire(Vec3::new(0.0, 0.3, 3.0), Vec3::new(0.0, 0.0, -30.0), 0.15).unwrap();
        assert!(live.grab.is_none(), "let go where the branch starts");
        assert_eq!(live.sim.world.body_count(), bodies, "the helper out, the new ball in");
        assert!(live.timeline.moments().map(|m| m.0).eq([0, 60]), "the later moments are gone");
        assert_eq!(live.timeline.inputs(), 1 + 29 + 2, "the grab, its drags to 70, the release and the shot");
        assert!(!live.timeline.has_future(70));

        let mut second = vec![poses(&live)];
        while live.steps < 180 {
            live.step().unwrap();
            second.push(poses(&live));
        }
        assert_ne!(poses(&live), first[180], "history changed");
        assert!(live.timeline.moments().map(|m| m.0).eq([0, 60, 120, 180]), "the new branch is kept");
        assert_eq!((live.shots.len(), live.grab.is_none()), (1, true), "the first run's shot is not in this one");
        // The new branch replays as it ran: from 2 s, and from 1 s through
        // the grab and the new shot.
        for (seek, from) in [(Seek::Back, 120), (Seek::To(1), 60)] {
            assert!(live.seek(seek).unwrap());
            while live.steps < 180 {
                live.step().unwrap();
                // The release and the shot at 70 are replayed before the next step.
                if live.steps > 70 {
                    assert!(poses(&live) == second[live.steps as usize - 70], "from {from}: step {}", live.steps);
                }
            }
        }
    }

    /// The brick wall mortared with lime: the scene's ball breaks bonds
    /// (measured: 245 of the 285 in the step it hits, 274 by half a
    /// second), and each break is marked on the face its bricks met at.
    #[test]
    fn bonds_the_ball_breaks_are_marked_on_the_faces_they_held() {
        let (mut live, _, _) = wall();
        // Each brick's half extents (the running bond's odd rows end in
        // half bricks).
        let half: std::collections::HashMap<BodyHandle, Vec3> = live
            .sim
            .bodies
            .iter()
            .filter_map(|b| match (b.shape, b.handle) {
                (BodyShape::Box { half_extents }, Some(h)) => Some((h, half_extents)),
                _ => None,
            })
            .collect();
        let bricks: Vec<BodyHandle> = half.keys().copied().collect();
        let made = live.sim.world.bond_touching(&bricks, crumble::BondSpec::LIME_MORTAR).unwrap().len();
        assert!(made > 200, "the 10 x 10 wall's joints (measured 285): {made}");

        let (mut broken, mut checked) = (0, 0);
        for _ in 0..30 {
            live.step().unwrap();
            let world = &live.sim.world;
            let now = world.time();
            let events = world.bond_events();
            broken += events.len();
            let new: Vec<_> = live.breaks.visible(now).filter(|(m, _)| m.time == now).collect();
            assert_eq!(new.len(), events.len(), "every break placed");
            for (e, (mark, left)) in events.iter().zip(new) {
                assert_eq!(left, 1.0, "a fresh mark has all its time left");
                let BondEvent::Broken { body_a, body_b, .. } = *e;
                let centre = crate::bonds::centre(&mark.anchors);
                // On a face of each brick: the mark is half-way between
                // the two bricks' anchors, so outside each by half what
                // the breaking step moved them apart (a few millimetres),
                // and inside it nowhere deeper.
                for body in [body_a, body_b] {
                    let b = world.body(body).unwrap();
                    if !b.is_dynamic() {
                        continue;
                    }
                    let (local, half) = (b.pose().inverse_transform_point(centre), half[&body]);
                    let off = (local.abs() - half).max_element();
                    assert!(off.abs() < 5e-3, "{off} m off the brick's surface: {local} in a box of {half}");
                    checked += 1;
                }
            }
            assert!(live.breaks.visible(now).all(|(m, _)| now - m.time < crate::bonds::BREAK_MARK_SECONDS));
        }
        assert!(broken > 0, "the ball broke no bond");
        assert!(checked >= broken, "each break has a brick on at least one side");
        assert_eq!(live.breaks.total(), broken);
        assert_eq!(live.bonds.len(), made - broken, "the broken ones forgotten");
        eprintln!("{made} bonds, {broken} broken by the ball in 30 steps");
    }
}
