//! The [`Renderer`]: a wgpu device, its pipelines and buffers, drawing
//! [`Frame`]s into an RGBA8 image or into any texture view.

use std::sync::{mpsc, Arc, Mutex};

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

use crate::camera::{basis, Bounds, Camera};
use crate::frame::{Frame, Shape};
use crate::mesh::{self, Vertex};
use crate::RenderError;

/// The sun, the sky and the haze.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    /// Direction towards the sun (any length but zero).
    pub sun_direction: Vec3,
    /// Sunlight, linear RGB; about 1.3 keeps a light ground below white.
    pub sun_color: [f32; 3],
    /// Sky straight up, sRGB.
    pub sky_zenith: [f32; 3],
    /// Sky at the horizon, sRGB; distant things fade into it.
    pub sky_horizon: [f32; 3],
    /// Light bounced up from the ground onto downward faces, sRGB.
    pub ground_bounce: [f32; 3],
    /// Distance at which the haze hides about two thirds of a colour, as a
    /// multiple of the camera's distance to its target (0: no haze).
    pub haze: f32,
}

impl Default for Lighting {
    fn default() -> Self {
        Self {
            sun_direction: Vec3::new(-0.45, 1.0, 0.65),
            sun_color: [1.35, 1.3, 1.2],
            sky_zenith: [0.42, 0.60, 0.86],
            sky_horizon: [0.80, 0.86, 0.93],
            ground_bounce: [0.55, 0.53, 0.50],
            haze: 14.0,
        }
    }
}

/// Settings fixed when the renderer is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RendererOptions {
    /// Multisample anti-aliasing: 4 (default) or 1 (off). Falls back to 1
    /// for a target format that cannot be multisampled 4×.
    pub msaa_samples: u32,
    /// Side of the square shadow map, texels (default 2048).
    pub shadow_map_size: u32,
}

impl Default for RendererOptions {
    fn default() -> Self {
        Self { msaa_samples: 4, shadow_map_size: 2048 }
    }
}

/// A texture view to draw into, as for a window's surface texture.
#[derive(Clone, Copy, Debug)]
pub struct RenderTarget<'a> {
    /// The view; its texture needs `RENDER_ATTACHMENT` usage and one sample.
    pub view: &'a wgpu::TextureView,
    /// The view's format. sRGB formats get linear colours encoded by the
    /// hardware; other 8-bit formats get them encoded by the shader.
    pub format: wgpu::TextureFormat,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
}

/// Per-instance data as the shader reads it (`InstanceData` in shader.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuInstance {
    position_metal: [f32; 4],
    rotation: [f32; 4],
    scale_edge: [f32; 4],
    color: [f32; 4],
}

/// Uniforms (`Globals` in shader.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    light_view_proj: [[f32; 4]; 4],
    inv_view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    sun_dir: [f32; 4],
    sun_color: [f32; 4],
    sky_zenith: [f32; 4],
    sky_horizon: [f32; 4],
    ground_bounce: [f32; 4],
}

const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Format of the images [`Renderer::render_rgba`] returns.
pub const RGBA_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

struct Mesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

struct ColorPipelines {
    format: wgpu::TextureFormat,
    samples: u32,
    lit: wgpu::RenderPipeline,
    sky: wgpu::RenderPipeline,
}

/// Multisampled colour and depth attachments for one target size and format.
struct Attachments {
    format: wgpu::TextureFormat,
    samples: u32,
    width: u32,
    height: u32,
    msaa: Option<wgpu::TextureView>,
    depth: wgpu::TextureView,
}

/// The texture and buffer that [`Renderer::render_rgba`] reads back through.
struct Readback {
    width: u32,
    height: u32,
    padded_row: u32,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    buffer: wgpu::Buffer,
}

/// Draws [`Frame`]s with wgpu: a shadow-map pass from the sun, then one
/// instanced draw per shape (boxes, spheres, ground planes) lit by the sun
/// and the sky, multisampled and resolved into the target, with the sky
/// behind. See the crate documentation for an example.
///
/// Owns the device, queue, pipelines and buffers; buffers grow to the
/// largest frame seen. Nothing here panics on bad input or on a wgpu error:
/// both come back as [`RenderError`].
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter: Option<wgpu::Adapter>,
    info: wgpu::AdapterInfo,
    errors: Arc<Mutex<Vec<String>>>,
    options: RendererOptions,
    /// The sun, sky and haze used by the next frames.
    pub lighting: Lighting,
    shader: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    shadow_pipeline: wgpu::RenderPipeline,
    color_pipelines: Vec<ColorPipelines>,
    globals: wgpu::Buffer,
    globals_group: wgpu::BindGroup,
    shadow_group: wgpu::BindGroup,
    shadow_view: wgpu::TextureView,
    meshes: [Mesh; 3],
    instances: wgpu::Buffer,
    instance_capacity: u64,
    staging: Vec<GpuInstance>,
    attachments: Option<Attachments>,
    readback: Option<Readback>,
}

/// The message for a machine without any usable adapter.
pub const NO_ADAPTER_HELP: &str = "no GPU or software Vulkan/GL adapter found; install mesa-vulkan-drivers \
     (Debian/Ubuntu: apt-get install mesa-vulkan-drivers libvulkan1) — see scripts/install-deps.sh";

/// An instance for `backends`; `None` when none of them is compiled in for
/// this platform (where `wgpu::Instance::new` would panic).
fn instance_for(backends: wgpu::Backends) -> Option<wgpu::Instance> {
    if (wgpu::Instance::enabled_backend_features() & backends).is_empty() {
        return None;
    }
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    // No validation layers or debug labels unless asked for through WGPU_* variables.
    desc.flags = wgpu::InstanceFlags::empty().with_env();
    Some(wgpu::Instance::new(desc))
}

/// Picks an adapter of `instance`: the best GPU if there is one (compatible
/// with `compatible_surface` when given), else a software adapter (Mesa's
/// lavapipe on Vulkan, llvmpipe on GL). Fails with [`NO_ADAPTER_HELP`].
pub fn request_adapter(
    instance: &wgpu::Instance,
    compatible_surface: Option<&wgpu::Surface<'_>>,
) -> Result<wgpu::Adapter, RenderError> {
    for force_fallback_adapter in [false, true] {
        let options = wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter,
            compatible_surface,
            apply_limit_buckets: false,
        };
        if let Ok(adapter) = pollster::block_on(instance.request_adapter(&options)) {
            return Ok(adapter);
        }
    }
    Err(RenderError::NoAdapter(NO_ADAPTER_HELP.to_string()))
}

impl Renderer {
    /// A renderer on the best adapter found (see [`request_adapter`]), for
    /// offscreen images, with default options.
    pub fn new() -> Result<Self, RenderError> {
        Self::with_options(RendererOptions::default())
    }

    /// [`Renderer::new`] with other options.
    ///
    /// Vulkan is tried first, then GL (which is only started when Vulkan has
    /// no adapter); `WGPU_BACKEND` (e.g. `vulkan`, `gl`) replaces that list.
    pub fn with_options(options: RendererOptions) -> Result<Self, RenderError> {
        let order = match wgpu::Backends::from_env() {
            Some(b) => vec![b],
            None => vec![wgpu::Backends::VULKAN, wgpu::Backends::GL],
        };
        for backends in order {
            let Some(instance) = instance_for(backends) else { continue };
            if let Ok(adapter) = request_adapter(&instance, None) {
                return Self::on_adapter(adapter, options);
            }
        }
        Err(RenderError::NoAdapter(NO_ADAPTER_HELP.to_string()))
    }

    /// A renderer on `adapter` (for a window, pick it with
    /// [`request_adapter`] and the window's surface): requests a device
    /// with the adapter's limits.
    pub fn on_adapter(adapter: wgpu::Adapter, options: RendererOptions) -> Result<Self, RenderError> {
        let desc =
            wgpu::DeviceDescriptor { label: Some("crumble"), required_limits: adapter.limits(), ..Default::default() };
        let (device, queue) = pollster::block_on(adapter.request_device(&desc))
            .map_err(|e| RenderError::Device(format!("{}: {e}", adapter.get_info().name)))?;
        let info = adapter.get_info();
        Self::build(device, queue, Some(adapter), info, options)
    }

    /// A renderer on a device the caller already has (a viewer that shares
    /// its device with other drawing). `info` is only reported back by
    /// [`Renderer::adapter_info`]. Installs an uncaptured-error handler on
    /// the device that turns wgpu errors into [`RenderError::Gpu`].
    pub fn from_device(
        device: wgpu::Device,
        queue: wgpu::Queue,
        info: wgpu::AdapterInfo,
        options: RendererOptions,
    ) -> Result<Self, RenderError> {
        Self::build(device, queue, None, info, options)
    }

    fn build(
        device: wgpu::Device,
        queue: wgpu::Queue,
        adapter: Option<wgpu::Adapter>,
        info: wgpu::AdapterInfo,
        options: RendererOptions,
    ) -> Result<Self, RenderError> {
        let errors: Arc<Mutex<Vec<String>>> = Arc::default();
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let lost = errors.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut v) = lost.lock() {
                v.push(format!("device lost ({reason:?}): {message}"));
            }
        });
        let max = device.limits().max_texture_dimension_2d;
        let shadow_size = options.shadow_map_size.clamp(64, max);
        let options = RendererOptions { msaa_samples: if options.msaa_samples >= 4 { 4 } else { 1 }, ..options };

        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("crumble shader"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shader.wgsl").into()),
        });
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("crumble globals"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(size_of::<Globals>() as u64),
                },
                count: None,
            }],
        });
        let shadow_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("crumble shadow map"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                    count: None,
                },
            ],
        });
        let shadow_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("crumble shadow"),
            bind_group_layouts: &[Some(&globals_layout)],
            immediate_size: 0,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("crumble lit"),
            bind_group_layouts: &[Some(&globals_layout), Some(&shadow_layout)],
            immediate_size: 0,
        });
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("crumble globals"),
            size: size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let shadow = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("crumble shadow map"),
            size: wgpu::Extent3d { width: shadow_size, height: shadow_size, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let shadow_view = shadow.create_view(&wgpu::TextureViewDescriptor::default());
        let shadow_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("crumble shadow sampler"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            address_mode_w: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let globals_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("crumble globals"),
            layout: &globals_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: globals.as_entire_binding() }],
        });
        let shadow_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("crumble shadow map"),
            layout: &shadow_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&shadow_view) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&shadow_sampler) },
            ],
        });
        let shadow_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("crumble shadow"),
            layout: Some(&shadow_pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_shadow"),
                compilation_options: Default::default(),
                buffers: &vertex_layouts(),
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::LessEqual),
                stencil: Default::default(),
                bias: wgpu::DepthBiasState { constant: 2, slope_scale: 2.0, clamp: 0.0 },
            }),
            multisample: Default::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });
        let upload = |label: &str, data: &[u8], usage: wgpu::BufferUsages| {
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (data.len() as u64).max(4).next_multiple_of(4),
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            queue.write_buffer(&buffer, 0, data);
            buffer
        };
        let make_mesh = |(vertices, indices): (Vec<Vertex>, Vec<u16>)| {
            let mut idx = indices.clone();
            if idx.len() % 2 == 1 {
                idx.push(0); // pad to 4 bytes; never drawn
            }
            Mesh {
                vertices: upload("crumble mesh", bytemuck::cast_slice(&vertices), wgpu::BufferUsages::VERTEX),
                indices: upload("crumble mesh", bytemuck::cast_slice(&idx), wgpu::BufferUsages::INDEX),
                index_count: indices.len() as u32,
            }
        };
        let meshes = [make_mesh(mesh::cube()), make_mesh(mesh::sphere(48, 24)), make_mesh(mesh::plane())];
        let instance_capacity = 1024;
        let instances = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("crumble instances"),
            size: instance_capacity * size_of::<GpuInstance>() as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let renderer = Self {
            device,
            queue,
            adapter,
            info,
            errors,
            options: RendererOptions { shadow_map_size: shadow_size, ..options },
            lighting: Lighting::default(),
            shader,
            pipeline_layout,
            shadow_pipeline,
            color_pipelines: Vec::new(),
            globals,
            globals_group,
            shadow_group,
            shadow_view,
            meshes,
            instances,
            instance_capacity,
            staging: Vec::new(),
            attachments: None,
            readback: None,
        };
        renderer.check_errors()?;
        Ok(renderer)
    }

    /// The device, e.g. to configure a window surface.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The queue that frames are submitted on.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// The adapter's name, backend and type (e.g. `llvmpipe (LLVM 15.0.6,
    /// 256 bits)`, Vulkan, Cpu).
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// One line naming the adapter and its backend, for messages.
    pub fn describe(&self) -> String {
        format!("{} ({:?}, {:?})", self.info.name, self.info.backend, self.info.device_type)
    }

    /// The options in force (the shadow map size clamped to the device).
    pub fn options(&self) -> RendererOptions {
        self.options
    }

    /// The largest image side the device allows, pixels.
    pub fn max_image_side(&self) -> u32 {
        self.device.limits().max_texture_dimension_2d
    }

    /// Fails with the first wgpu error reported since the last check.
    fn check_errors(&self) -> Result<(), RenderError> {
        let mut errors = self.errors.lock().map_err(|_| RenderError::Gpu("error log poisoned".into()))?;
        if errors.is_empty() {
            return Ok(());
        }
        let all = std::mem::take(&mut *errors);
        Err(RenderError::Gpu(all.join("; ")))
    }

    fn samples_for(&self, format: wgpu::TextureFormat) -> u32 {
        if self.options.msaa_samples < 4 {
            return 1;
        }
        match &self.adapter {
            Some(a) => {
                let f = a.get_texture_format_features(format).flags;
                let d = a.get_texture_format_features(DEPTH_FORMAT).flags;
                if f.sample_count_supported(4) && d.sample_count_supported(4) {
                    4
                } else {
                    1
                }
            }
            None => 4,
        }
    }

    fn color_pipelines(&mut self, format: wgpu::TextureFormat) -> usize {
        if let Some(i) = self.color_pipelines.iter().position(|p| p.format == format) {
            return i;
        }
        let samples = self.samples_for(format);
        let multisample = wgpu::MultisampleState { count: samples, ..Default::default() };
        let targets = [Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })];
        let lit = self.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("crumble lit"),
            layout: Some(&self.pipeline_layout),
            vertex: wgpu::VertexState {
                module: &self.shader,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &vertex_layouts(),
            },
            primitive: wgpu::PrimitiveState {
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: Some(wgpu::Face::Back),
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample,
            fragment: Some(wgpu::FragmentState {
                module: &self.shader,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        });
        let sky = self.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("crumble sky"),
            layout: Some(&self.pipeline_layout),
            vertex: wgpu::VertexState {
                module: &self.shader,
                entry_point: Some("vs_sky"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            // Drawn last, at depth 0: only where nothing else was drawn.
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample,
            fragment: Some(wgpu::FragmentState {
                module: &self.shader,
                entry_point: Some("fs_sky"),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        });
        self.color_pipelines.push(ColorPipelines { format, samples, lit, sky });
        self.color_pipelines.len() - 1
    }

    fn attachments(&mut self, format: wgpu::TextureFormat, samples: u32, width: u32, height: u32) {
        if let Some(a) = &self.attachments {
            if a.format == format && a.samples == samples && a.width == width && a.height == height {
                return;
            }
        }
        let size = wgpu::Extent3d { width, height, depth_or_array_layers: 1 };
        let texture = |label: &str, format: wgpu::TextureFormat| {
            self.device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size,
                    mip_level_count: 1,
                    sample_count: samples,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&wgpu::TextureViewDescriptor::default())
        };
        let msaa = (samples > 1).then(|| texture("crumble msaa colour", format));
        let depth = texture("crumble depth", DEPTH_FORMAT);
        self.attachments = Some(Attachments { format, samples, width, height, msaa, depth });
    }

    fn check_size(&self, width: u32, height: u32) -> Result<(), RenderError> {
        let max = self.max_image_side();
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::InvalidSize { width, height, max });
        }
        Ok(())
    }

    /// Records the passes that draw `frame` seen by `camera` into `target`
    /// on `encoder`, after uploading the frame's instances and uniforms with
    /// [`wgpu::Queue::write_buffer`]. Submit the encoder before encoding the
    /// next frame (the uploads of the next call replace this one's). For a
    /// window: get the surface texture, make a view, call this, submit,
    /// present.
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &Frame,
        camera: &Camera,
        target: &RenderTarget<'_>,
    ) -> Result<(), RenderError> {
        self.check_size(target.width, target.height)?;
        camera.validate()?;
        for (i, inst) in frame.instances.iter().enumerate() {
            inst.validate(i)?;
        }
        if let Some(b) = &frame.shadow_bounds {
            if !b.is_finite() {
                return Err(RenderError::InvalidInstance { index: 0, reason: "shadow bounds are not finite".into() });
            }
        }

        // Instances grouped by mesh: boxes, spheres, planes.
        let mut staging = std::mem::take(&mut self.staging);
        staging.clear();
        let mut counts = [0u32; 3];
        for (mesh, want) in [(0usize, 0u8), (1, 1), (2, 2)] {
            for inst in &frame.instances {
                let (kind, scale) = match inst.shape {
                    Shape::Box { half_extents } => (0u8, half_extents),
                    Shape::Sphere { radius } => (1, Vec3::splat(radius)),
                    Shape::Plane { half_size } => (2, Vec3::new(half_size, 1.0, half_size)),
                };
                if kind != want {
                    continue;
                }
                let m = &inst.material;
                let q = inst.rotation.normalize();
                let c = m.color.map(srgb_to_linear);
                staging.push(GpuInstance {
                    position_metal: inst.position.extend(m.metalness).to_array(),
                    rotation: q.to_array(),
                    scale_edge: scale.extend(if kind == 0 { m.edge_width } else { 0.0 }).to_array(),
                    color: [c[0], c[1], c[2], 1.0],
                });
                counts[mesh] += 1;
            }
        }
        let needed = staging.len() as u64;
        if needed > self.instance_capacity {
            self.instance_capacity = needed.next_power_of_two();
            self.instances = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("crumble instances"),
                size: self.instance_capacity * size_of::<GpuInstance>() as u64,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
        }
        if !staging.is_empty() {
            self.queue.write_buffer(&self.instances, 0, bytemuck::cast_slice(&staging));
        }
        self.staging = staging;

        let globals = self.globals_for(frame, camera, target);
        self.queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));

        let p = self.color_pipelines(target.format);
        let samples = self.color_pipelines[p].samples;
        self.attachments(target.format, samples, target.width, target.height);
        let Some(att) = &self.attachments else { return Err(RenderError::Gpu("no attachments".into())) };
        let pipes = &self.color_pipelines[p];
        let stride = size_of::<GpuInstance>() as u64;
        let first = [0u32, counts[0], counts[0] + counts[1]];

        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("crumble shadow"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.shadow_view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            pass.set_pipeline(&self.shadow_pipeline);
            pass.set_bind_group(0, &self.globals_group, &[]);
            // Planes receive shadows but cast none.
            for mesh in 0..2 {
                self.draw_mesh(&mut pass, mesh, first[mesh], counts[mesh], stride);
            }
        }
        {
            let clear = wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store };
            let color = match &att.msaa {
                Some(msaa) => wgpu::RenderPassColorAttachment {
                    view: msaa,
                    depth_slice: None,
                    resolve_target: Some(target.view),
                    ops: wgpu::Operations { store: wgpu::StoreOp::Discard, ..clear },
                },
                None => wgpu::RenderPassColorAttachment {
                    view: target.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: clear,
                },
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("crumble lit"),
                color_attachments: &[Some(color)],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &att.depth,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            pass.set_bind_group(0, &self.globals_group, &[]);
            pass.set_bind_group(1, &self.shadow_group, &[]);
            pass.set_pipeline(&pipes.lit);
            for mesh in [1, 0, 2] {
                self.draw_mesh(&mut pass, mesh, first[mesh], counts[mesh], stride);
            }
            pass.set_pipeline(&pipes.sky);
            pass.draw(0..3, 0..1);
        }
        self.check_errors()
    }

    fn draw_mesh(&self, pass: &mut wgpu::RenderPass<'_>, mesh: usize, first: u32, count: u32, stride: u64) {
        if count == 0 {
            return;
        }
        let m = &self.meshes[mesh];
        let start = first as u64 * stride;
        pass.set_vertex_buffer(0, m.vertices.slice(..));
        pass.set_vertex_buffer(1, self.instances.slice(start..start + count as u64 * stride));
        pass.set_index_buffer(m.indices.slice(..), wgpu::IndexFormat::Uint16);
        pass.draw_indexed(0..m.index_count, 0, 0..count);
    }

    fn globals_for(&self, frame: &Frame, camera: &Camera, target: &RenderTarget<'_>) -> Globals {
        let aspect = target.width as f32 / target.height as f32;
        let view_proj = camera.view_projection(aspect);
        let light = &self.lighting;
        let to_sun = light.sun_direction.try_normalize().unwrap_or(Vec3::Y);
        let bounds = frame
            .shadow_bounds
            .or_else(|| frame.object_bounds())
            .filter(Bounds::is_finite)
            .unwrap_or(Bounds::new(Vec3::splat(-1.0), Vec3::splat(1.0)));
        let center = bounds.center();
        let r = bounds.radius().max(0.05);
        let (_, up, _) = basis(-to_sun);
        let light_view = Mat4::look_at_rh(center + to_sun * (2.0 * r), center, up);
        let light_proj = Mat4::orthographic_rh(-r, r, -r, r, 0.5 * r, 3.5 * r);
        let size = self.options.shadow_map_size as f32;
        let dist = camera.eye.distance(camera.target);
        let fog = if light.haze > 0.0 { 1.0 / (light.haze * dist) } else { 0.0 };
        let lin = |c: [f32; 3], w: f32| {
            let l = c.map(srgb_to_linear);
            [l[0], l[1], l[2], w]
        };
        Globals {
            view_proj: view_proj.to_cols_array_2d(),
            light_view_proj: (light_proj * light_view).to_cols_array_2d(),
            inv_view_proj: view_proj.inverse().to_cols_array_2d(),
            eye: camera.eye.extend(fog).to_array(),
            sun_dir: to_sun.extend(1.0 / size).to_array(),
            sun_color: [light.sun_color[0], light.sun_color[1], light.sun_color[2], 2.0 * r / size],
            sky_zenith: lin(light.sky_zenith, 0.0),
            sky_horizon: lin(light.sky_horizon, if target.format.is_srgb() { 0.0 } else { 1.0 }),
            ground_bounce: lin(light.ground_bounce, 0.0),
        }
    }

    /// Draws `frame` seen by `camera` into `target` and submits the work.
    pub fn render_to_view(
        &mut self,
        frame: &Frame,
        camera: &Camera,
        target: &RenderTarget<'_>,
    ) -> Result<(), RenderError> {
        let mut encoder =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("crumble frame") });
        self.encode(&mut encoder, frame, camera, target)?;
        self.queue.submit([encoder.finish()]);
        self.check_errors()
    }

    /// Draws `frame` seen by `camera` into a `width` × `height` image and
    /// reads it back: `width * height * 4` bytes, RGBA, sRGB, rows top to
    /// bottom. The same frame gives the same bytes on the same adapter.
    pub fn render_rgba(
        &mut self,
        frame: &Frame,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> Result<Vec<u8>, RenderError> {
        self.check_size(width, height)?;
        let fresh = !matches!(&self.readback, Some(r) if r.width == width && r.height == height);
        if fresh {
            let texture = self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("crumble image"),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: RGBA_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            });
            let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let padded_row = (width * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
            let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("crumble readback"),
                size: padded_row as u64 * height as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            self.readback = Some(Readback { width, height, padded_row, texture, view, buffer });
        }
        let Some(rb) = self.readback.take() else { return Err(RenderError::Gpu("no readback buffer".into())) };
        let result = self.render_and_read(frame, camera, &rb);
        self.readback = Some(rb);
        result
    }

    fn render_and_read(&mut self, frame: &Frame, camera: &Camera, rb: &Readback) -> Result<Vec<u8>, RenderError> {
        let (width, height) = (rb.width, rb.height);
        let mut encoder =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("crumble image") });
        let target = RenderTarget { view: &rb.view, format: RGBA_FORMAT, width, height };
        self.encode(&mut encoder, frame, camera, &target)?;
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &rb.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &rb.buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(rb.padded_row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        self.queue.submit([encoder.finish()]);
        self.check_errors()?;

        let (tx, rx) = mpsc::channel();
        rb.buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RenderError::Gpu(format!("waiting for the frame: {e}")))?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(RenderError::Gpu(format!("reading the frame back: {e}"))),
            Err(_) => return Err(RenderError::Gpu("reading the frame back: no answer from the device".into())),
        }
        let row = width as usize * 4;
        let mut out = Vec::with_capacity(row * height as usize);
        let copied = rb.buffer.get_mapped_range(..).map(|data| {
            for y in 0..height as usize {
                let start = y * rb.padded_row as usize;
                out.extend_from_slice(&data[start..start + row]);
            }
        });
        // Unmapped whatever happened, so that the next frame can map it again.
        rb.buffer.unmap();
        copied.map_err(|e| RenderError::Gpu(format!("reading the frame back: {e}")))?;
        self.check_errors()?;
        Ok(out)
    }
}

/// The two vertex buffers: the mesh (per vertex) and the instances.
fn vertex_layouts() -> [Option<wgpu::VertexBufferLayout<'static>>; 2] {
    const MESH: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
    const INSTANCE: [wgpu::VertexAttribute; 4] =
        wgpu::vertex_attr_array![2 => Float32x4, 3 => Float32x4, 4 => Float32x4, 5 => Float32x4];
    [
        Some(wgpu::VertexBufferLayout {
            array_stride: size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &MESH,
        }),
        Some(wgpu::VertexBufferLayout {
            array_stride: size_of::<GpuInstance>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &INSTANCE,
        }),
    ]
}

/// sRGB (0 to 1) to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}
