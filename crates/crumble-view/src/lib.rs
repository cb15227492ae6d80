//! # crumble-view
//!
//! A real-time window on a crumble scene: the scene simulates live at its
//! fixed step (decoupled from the frame rate) and is drawn every frame by
//! [`crumble_render::Renderer`] into a wgpu surface on a winit window.
//!
//! Mouse: left-drag orbits, right-drag or shift-drag pans, the wheel zooms;
//! a left click without dragging (or a middle click, or F) fires a steel
//! ball from the eye along the ray under the mouse; Ctrl + left-drag on a
//! dynamic body grabs it at the point under the mouse and pulls it after
//! the cursor through a soft joint until the button is released
//! ([`grab`]). Keys: see [`KEYS`].
//!
//! Scripted mode for CI ([`ViewOptions::frames`]): runs a number of frames,
//! optionally fires one shot at a given frame, saves a screenshot and
//! prints a summary line (`moved: N bodies > 5 cm, ...`).
//!
//! A side panel on the right (egui, 260 points wide; H or `--no-panel`
//! hides it) shows the body counts (awake, sleeping, static), the contact
//! pairs and points, the bonds and how many broke, the per-stage step
//! timings of [`crumble::World::profile`] averaged over half a second,
//! steps per frame, the frame rate and the time to draw a frame, with
//! buttons, sliders and checkboxes that do what the keys do (see
//! [`panel`]). The scene is drawn into a texture the size of the area left
//! of the panel, which egui shows there; clicks are aimed through that
//! area, and presses, drags and the wheel over the panel are the panel's.
//! A screenshot draws the last frame's scene and panel again offscreen, so
//! it shows what the window showed. The counts and timings also go into
//! the window title (four times a second) and a stdout line (once a
//! second).
//!
//! Bonds (M, or the panel's "bonds" checkbox; on at the start when the
//! scene has bonds, see [`ViewOptions::show_bonds`]) are drawn as the
//! outline of each bond's face, coloured by how near it came to breaking
//! in the last step: green unloaded, yellow at half its strength, red at
//! it. Where a bond breaks, a crossed rectangle flashes white, turns
//! magenta and fades out over a second of simulated time (it stays while
//! paused); see [`bonds`].
//!
//! Boxes of a breakable material split in two as the simulation runs: the
//! box is drawn until it breaks, its pieces from then on, and the pieces
//! flash, lit up in their brick's colour, for half a second of simulated
//! time; the panel counts the splits beside the bonds ([`splits`]).
//!
//! A timeline keeps a moment every second of simulated time ([`timeline`]):
//! Left (or `,`), `.`, Home and End, or the panel's buttons and slider, go
//! to the kept second before or after the present, the oldest or the
//! newest, and pause there. Playing on replays the run from there, the
//! user's shots, grabs and drags included, bit for bit; a shot or a grab
//! in a replay starts a new branch of history and drops the timeline's
//! later seconds. Old seconds are thinned out to stay within 600 moments
//! and 256 MiB.

mod app;
pub mod bonds;
pub mod clock;
pub mod fading;
pub mod grab;
mod gui;
pub mod orbit;
pub mod overlay;
pub mod panel;
pub mod splits;
pub mod timeline;

use std::path::PathBuf;

use glam::Vec3;

pub use app::Summary;
pub use glam;

/// The key bindings, as shown by `crumble view --help` and the README.
pub const KEYS: &str = "\
Mouse:  left-drag orbit, right-drag or shift+left-drag pan, wheel zoom,
        left click (no drag) or middle click: fire a ball at the clicked point,
        ctrl+left-drag on a body: grab it and pull it after the mouse
Space   play / pause            S or Right  single step (pauses)
Left ,  back to the kept second before now (a moment is kept every second)
.       forward to the next kept second   Home End  oldest / newest kept
        (each pauses there; Space replays the run from it, shots and grabs
        included, and a shot or a grab then starts a new branch)
R       restart the scene       F           fire a ball at the mouse
1 2 3   speed 1, 1/2, 1/4       [ ]         slower / faster (1/4 .. 1)
+ -     ball speed up / down    PgUp PgDn   ball radius up / down
C       contact points+normals  B           bounding boxes
J       joints (anchors, lines) Z           tint sleeping bodies
M       bonds, green to red by load; where one broke, magenta for 1 s
H       show / hide the side panel
Esc or Q  quit
The side panel shows counts and step timings, and has buttons, sliders and
checkboxes for the same controls; the mouse over it does not move the camera.";

/// What to show and, for scripted runs, what to do.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// A scene file (.toml) or the name of a built-in scene.
    pub scene: String,
    /// Window inner size, pixels.
    pub size: (u32, u32),
    /// Scripted mode: exit after this many frames.
    pub frames: Option<u64>,
    /// Fire one ball at this frame (1-based) towards [`ViewOptions::shoot_target`].
    pub shoot_at_frame: Option<u64>,
    /// Where the scripted shot aims [default: the centre of the scene's boxes].
    pub shoot_target: Option<Vec3>,
    /// Save the last frame here (PNG) when the viewer exits.
    pub screenshot: Option<PathBuf>,
    /// Initial ball speed, m/s.
    pub ball_speed: f32,
    /// Initial ball radius, metres.
    pub ball_radius: f32,
    /// Keep every body awake.
    pub no_sleep: bool,
    /// Start with contact points and normals shown (C).
    pub show_contacts: bool,
    /// Start with bounding boxes shown (B).
    pub show_aabbs: bool,
    /// Start with joints shown (J).
    pub show_joints: bool,
    /// Start with bonds and the marks of broken bonds shown (M); `None`:
    /// shown when the scene has bonds, whose scene is about its mortar.
    pub show_bonds: Option<bool>,
    /// Start with sleeping bodies tinted (Z).
    pub tint_sleeping: bool,
    /// Start with the side panel shown (H).
    pub show_panel: bool,
}

impl ViewOptions {
    /// Options for `scene` with the defaults: 1280×720, interactive.
    pub fn new(scene: impl Into<String>) -> Self {
        Self {
            scene: scene.into(),
            size: (1280, 720),
            frames: None,
            shoot_at_frame: None,
            shoot_target: None,
            screenshot: None,
            ball_speed: 20.0,
            ball_radius: 0.1,
            no_sleep: false,
            show_contacts: false,
            show_aabbs: false,
            show_joints: false,
            show_bonds: None,
            tint_sleeping: false,
            show_panel: true,
        }
    }
}

/// Why the viewer could not run.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// No window can be opened.
    #[error("no display: run under a desktop or `xvfb-run crumble view ...` ({0})")]
    NoDisplay(String),
    /// The scene could not be loaded or built.
    #[error("{0}")]
    Scene(String),
    /// An option has an impossible value.
    #[error("{0}")]
    BadOption(String),
    /// The graphics device or the renderer failed.
    #[error("graphics: {0}")]
    Graphics(String),
    /// The simulation failed.
    #[error("simulation: {0}")]
    Simulation(String),
    /// Writing the screenshot failed.
    #[error("{0}")]
    Io(String),
}

/// Parses `WxH` (e.g. `1280x720`).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("size `{s}` must be WIDTHxHEIGHT, e.g. 1280x720"))?;
    let side = |t: &str| -> Result<u32, String> {
        match t.trim().parse::<u32>() {
            Ok(v) if (16..=8192).contains(&v) => Ok(v),
            _ => Err(format!("size `{s}`: each side must be a whole number from 16 to 8192")),
        }
    };
    Ok((side(w)?, side(h)?))
}

/// Parses `x,y,z` (metres).
pub fn parse_point(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(format!("point `{s}` must be x,y,z, e.g. 0,0.3,0"));
    }
    let mut v = [0.0f32; 3];
    for (out, p) in v.iter_mut().zip(&parts) {
        *out = p
            .trim()
            .parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("point `{s}`: `{}` is not a finite number", p.trim()))?;
    }
    Ok(Vec3::from_array(v))
}

/// The scene's text and the name to use in messages: a file if one exists
/// at `arg`, else a built-in scene.
pub fn load_scene(arg: &str) -> Result<crumble_scene::Scene, ViewError> {
    let path = std::path::Path::new(arg);
    let (text, name) = if path.is_file() {
        let bytes = std::fs::read(path).map_err(|e| ViewError::Scene(format!("{arg}: {e}")))?;
        // A file that is not UTF-8 is refused at its first bad byte's line.
        (crumble_scene::decode(bytes, arg).map_err(|e| ViewError::Scene(e.to_string()))?, arg.to_string())
    } else if let Some(s) = crumble_scene::builtin::find(arg) {
        (s.source.to_string(), format!("scenes/{} (built-in)", s.file_name()))
    } else {
        let names: Vec<&str> = crumble_scene::builtin::BUILTIN.iter().map(|s| s.name).collect();
        return Err(ViewError::Scene(format!(
            "{arg}: no such file, and no built-in scene of that name (built-in: {})",
            names.join(", ")
        )));
    };
    crumble_scene::parse(&text, &name).map_err(|e| ViewError::Scene(e.to_string()))
}

/// Opens the window and runs until it is closed (or, scripted, until the
/// last frame). Prints the summary line on stdout at the end, and the
/// camera's `[camera]` keys on the next line.
pub fn run(opts: ViewOptions) -> Result<(), ViewError> {
    let summary = app::run(opts)?;
    println!("{summary}");
    if let Some(line) = summary.camera_line() {
        println!("{line}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_and_points_parse_or_say_what_is_wrong() {
        assert_eq!(parse_size("640x360"), Ok((640, 360)));
        assert!(parse_size("640").unwrap_err().contains("WIDTHxHEIGHT"));
        assert!(parse_size("0x10").unwrap_err().contains("16 to 8192"));
        assert_eq!(parse_point("0, 0.5,-1"), Ok(Vec3::new(0.0, 0.5, -1.0)));
        assert!(parse_point("1,2").is_err());
        assert!(parse_point("1,nan,2").unwrap_err().contains("`nan`"));
    }

    #[test]
    fn unknown_scenes_are_named() {
        let e = load_scene("no_such_scene").unwrap_err().to_string();
        assert!(e.contains("no_such_scene") && e.contains("brick_wall"), "{e}");
        assert!(load_scene("brick_wall").is_ok());
    }

    /// Regression: the viewer read scene files with `read_to_string`, so a
    /// file that is not UTF-8 was refused with no line (issue 46, F15);
    /// it now names the line and column of the first bad byte, as `crumble
    /// run` does.
    #[test]
    fn a_scene_that_is_not_utf8_is_located() {
        let path = std::env::temp_dir().join(format!("crumble-view-latin1-{}.toml", std::process::id()));
        std::fs::write(&path, b"[world]\ndt = 0.01 # caf\xe9\n").unwrap();
        let e = load_scene(path.to_str().unwrap()).unwrap_err().to_string();
        std::fs::remove_file(&path).unwrap();
        assert!(e.contains(":2:") && e.contains("not UTF-8"), "{e}");
    }
}
