//! # crumble-render
//!
//! An offscreen renderer for crumble scenes on [wgpu]: lit, shadowed,
//! anti-aliased (4× MSAA) images of boxes, spheres and the ground, drawn
//! instanced (one draw call per shape) so that ten thousand bricks take a
//! fraction of a second per frame even on a CPU. It runs on any GPU through
//! Vulkan or GL, and without one on Mesa's software drivers (lavapipe for
//! Vulkan, Debian package `mesa-vulkan-drivers`; llvmpipe for GL).
//!
//! - [`Renderer`] owns the wgpu device, queue, pipelines and buffers.
//!   [`Renderer::render_rgba`] draws a [`Frame`] into an RGBA8 image (sRGB,
//!   rows top to bottom); [`Renderer::encode`] / [`Renderer::render_to_view`]
//!   draw into any [`wgpu::TextureView`] (a window's surface texture), on a
//!   device of the caller's ([`Renderer::from_device`]) or on an adapter
//!   picked for a surface ([`request_adapter`], [`Renderer::on_adapter`]).
//! - [`Frame`]: a list of [`Instance`]s (a [`Shape`] — box half extents,
//!   sphere radius or ground square —, position, rotation and [`Material`]),
//!   plus the region that gets shadows.
//! - [`Camera`]: eye, target and vertical field of view; its matrices, the
//!   projection of a world point to a pixel ([`Camera::project`]) and
//!   automatic framing of a [`Bounds`] ([`Camera::framing`]).
//! - [`SceneFrames`]: crumble-scene bodies ([`crumble_scene::BodyInfo`]) and
//!   their poses to frames, in brick tones (varied per brick by a hash of its
//!   index), steel and light grey, each body only while it is in the world
//!   (the pieces of a brick that broke from then on, the brick until then);
//!   [`SceneFrames::auto_camera`].
//!
//! The same frame renders to the same bytes on the same adapter. Bad input
//! (non-finite poses, zero sizes, an impossible camera or image size) and
//! wgpu errors come back as [`RenderError`]; nothing panics.
//!
//! ```no_run
//! use crumble_render::{Renderer, SceneFrames};
//!
//! let source = crumble_scene::builtin::find("brick_wall").unwrap().source;
//! let sim = crumble_scene::build(&crumble_scene::parse(source, "brick_wall.toml")?)?;
//! let frames = SceneFrames::new(&sim.bodies);
//! let camera = frames.auto_camera(1280.0 / 720.0, 45.0);
//! let mut renderer = Renderer::new()?; // fails clearly without any adapter
//! let rgba: Vec<u8> = renderer.render_rgba(&frames.frame_of(&sim)?, &camera, 1280, 720)?;
//! assert_eq!(rgba.len(), 1280 * 720 * 4);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod camera;
mod frame;
pub mod mesh;
mod renderer;
mod scene;

pub use camera::{Bounds, Camera, AUTO_VIEW_DIRECTION, DEFAULT_FOV_DEG};
pub use frame::{Frame, Instance, Material, Shape};
pub use renderer::{
    request_adapter, srgb_to_linear, Lighting, RenderTarget, Renderer, RendererOptions, NO_ADAPTER_HELP, RGBA_FORMAT,
};
pub use scene::{brick_material, SceneFrames, BRICK_TONES, GROUND, STEEL};
pub use wgpu;

/// What went wrong while setting up or drawing.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RenderError {
    /// No adapter at all: no GPU and no software driver. The message says
    /// what to install.
    #[error("{0}")]
    NoAdapter(String),
    /// The adapter refused to make a device.
    #[error("could not open the graphics device {0}")]
    Device(String),
    /// An image side is zero or larger than the device allows.
    #[error("image size {width}x{height} is not possible: each side must be 1 to {max} pixels")]
    InvalidSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// Largest side the device allows.
        max: u32,
    },
    /// The camera's numbers cannot make a view.
    #[error("bad camera: {0}")]
    InvalidCamera(String),
    /// An instance (or body) with bad numbers.
    #[error("instance {index}: {reason}")]
    InvalidInstance {
        /// Index in the frame (or body index).
        index: usize,
        /// What is wrong.
        reason: String,
    },
    /// wgpu reported an error (validation, out of memory, device lost).
    #[error("graphics error: {0}")]
    Gpu(String),
}
