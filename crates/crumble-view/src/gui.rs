//! egui on the window: the scene is drawn into a texture that egui shows in
//! the scene's viewport, the panel is drawn beside it, and a screenshot
//! draws the same egui output once more into a texture that can be read.

use std::sync::mpsc;

use crumble_render::wgpu;
use winit::window::Window;

/// Format of the texture the scene is drawn into: egui samples user
/// textures as sRGB-encoded bytes in a non-sRGB format, and the renderer
/// encodes its colours in the shader for such a format.
pub const SCENE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// The scene's texture and the id egui knows it by.
struct SceneTexture {
    view: wgpu::TextureView,
    width: u32,
    height: u32,
}

/// The last frame's tessellated egui output, drawn again for a screenshot.
struct Painted {
    jobs: Vec<egui::ClippedPrimitive>,
    size: [u32; 2],
    pixels_per_point: f32,
}

/// egui's context, its winit input state and its wgpu renderer.
pub struct Gui {
    /// The egui context (cheap to clone).
    pub ctx: egui::Context,
    /// Turns winit events into egui input.
    pub state: egui_winit::State,
    renderer: egui_wgpu::Renderer,
    format: wgpu::TextureFormat,
    scene: Option<SceneTexture>,
    scene_id: Option<egui::TextureId>,
    last: Option<Painted>,
}

impl Gui {
    /// egui for `window`, drawing into textures of the window's `format`.
    pub fn new(window: &Window, device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let ctx = egui::Context::default();
        // Fixed, so that the panel looks the same everywhere (and the
        // screenshot test knows its background).
        ctx.set_theme(egui::Theme::Dark);
        let max_side = device.limits().max_texture_dimension_2d as usize;
        let state = egui_winit::State::new(
            ctx.clone(),
            egui::ViewportId::ROOT,
            window,
            Some(window.scale_factor() as f32),
            None,
            Some(max_side),
        );
        // No dithering: the scene's pixels are copied through unchanged.
        let options = egui_wgpu::RendererOptions { dithering: false, ..Default::default() };
        let renderer = egui_wgpu::Renderer::new(device, format, options);
        Self { ctx, state, renderer, format, scene: None, scene_id: None, last: None }
    }

    /// The egui texture the scene is drawn into, made (again) at `width` ×
    /// `height` pixels when its size changes.
    pub fn scene_texture(&mut self, device: &wgpu::Device, width: u32, height: u32) -> egui::TextureId {
        let same = matches!(&self.scene, Some(s) if s.width == width && s.height == height);
        if let (Some(id), true) = (self.scene_id, same) {
            return id;
        }
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let texture = target_texture(device, "crumble view scene", width, height, SCENE_FORMAT, usage);
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        // Nearest: the texture is shown pixel for pixel.
        let id = match self.scene_id {
            Some(id) => {
                self.renderer.update_egui_texture_from_wgpu_texture(device, &view, wgpu::FilterMode::Nearest, id);
                id
            }
            None => self.renderer.register_native_texture(device, &view, wgpu::FilterMode::Nearest),
        };
        self.scene_id = Some(id);
        self.scene = Some(SceneTexture { view, width, height });
        id
    }

    /// The scene's texture view and size, once [`Gui::scene_texture`] made it.
    pub fn scene_view(&self) -> Option<(&wgpu::TextureView, u32, u32)> {
        self.scene.as_ref().map(|s| (&s.view, s.width, s.height))
    }

    /// Uploads the textures egui added or changed, taking them out of
    /// `delta`. Call for every egui output, drawn or not, so that none of
    /// its texture updates is lost.
    pub fn upload_textures(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, delta: &mut egui::TexturesDelta) {
        for (id, images) in delta.set.drain() {
            for image in &images {
                self.renderer.update_texture(device, queue, id, image);
            }
        }
    }

    /// Frees the textures egui no longer uses (after drawing), taking them
    /// out of `delta`. (egui checks, in debug builds, that both were done.)
    pub fn free_textures(&mut self, delta: &mut egui::TexturesDelta) {
        for id in delta.free.drain() {
            self.renderer.free_texture(&id);
        }
    }

    /// Records the drawing of `shapes` into `target` (the window's texture,
    /// as `screen` describes it) on `encoder`, and keeps them for a
    /// screenshot. Returns command buffers to submit before the encoder's.
    pub fn encode(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        shapes: Vec<egui::epaint::ClippedShape>,
        screen: egui_wgpu::ScreenDescriptor,
    ) -> Vec<wgpu::CommandBuffer> {
        let jobs = self.ctx.tessellate(shapes, screen.pixels_per_point);
        let painted = Painted { jobs, size: screen.size_in_pixels, pixels_per_point: screen.pixels_per_point };
        let extra = self.draw(device, queue, encoder, target, &painted);
        self.last = Some(painted);
        extra
    }

    fn draw(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        painted: &Painted,
    ) -> Vec<wgpu::CommandBuffer> {
        let screen =
            egui_wgpu::ScreenDescriptor { size_in_pixels: painted.size, pixels_per_point: painted.pixels_per_point };
        let extra = self.renderer.update_buffers(device, queue, encoder, &painted.jobs, &screen);
        let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("crumble view egui"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
            })],
            ..Default::default()
        });
        self.renderer.render(&mut pass.forget_lifetime(), &painted.jobs, &screen);
        extra
    }

    /// The last frame drawn again (the scene texture as it was left, egui's
    /// output over it) into a texture that is read back: RGBA, sRGB, rows
    /// top to bottom, with its width and height.
    pub fn screenshot(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<(Vec<u8>, u32, u32), String> {
        let swap_red_blue = match self.format {
            wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Rgba8UnormSrgb => false,
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb => true,
            f => return Err(format!("the window's format {f:?} cannot be saved as a PNG")),
        };
        let Some(painted) = self.last.take() else { return Err("no frame was drawn".into()) };
        let [width, height] = painted.size;
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        let texture = target_texture(device, "crumble view screenshot", width, height, self.format, usage);
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let padded_row = (width * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("crumble view screenshot readback"),
            size: padded_row as u64 * height as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("crumble view screenshot") });
        let extra = self.draw(device, queue, &mut encoder, &view, &painted);
        self.last = Some(painted);
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        queue.submit(extra.into_iter().chain([encoder.finish()]));

        let (tx, rx) = mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| format!("waiting for the screenshot: {e}"))?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(format!("reading the screenshot back: {e}")),
            Err(_) => return Err("reading the screenshot back: no answer from the device".into()),
        }
        let row = width as usize * 4;
        let mut out = Vec::with_capacity(row * height as usize);
        let copied = buffer.get_mapped_range(..).map(|data| {
            for y in 0..height as usize {
                let start = y * padded_row as usize;
                out.extend_from_slice(&data[start..start + row]);
            }
        });
        buffer.unmap();
        copied.map_err(|e| format!("reading the screenshot back: {e}"))?;
        for px in out.chunks_exact_mut(4) {
            if swap_red_blue {
                px.swap(0, 2);
            }
            // The window is opaque, whatever the surface's alpha says.
            px[3] = 255;
        }
        Ok((out, width, height))
    }
}

/// A single-sample 2D texture of `width` × `height` to render into.
fn target_texture(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}
