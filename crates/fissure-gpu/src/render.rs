//! The renderer: soft bodies lit and double-sided, a wireframe of their springs and mass points, the scene's
//! ground, walls and obstacles, and a text overlay, drawn with wgpu into a window's surface or an offscreen
//! texture (headless, read back as RGBA8 for PNG frames).
//!
//! It draws the GPU solver's position buffer in place ([`Positions::Buffer`] with
//! [`crate::GpuSolver::position_buffer`]: no read-back per frame), or CPU state uploaded with
//! [`Renderer::upload_positions`]. After a fracture changes the topology, call [`Renderer::set_model`] again.
//!
//! ```no_run
//! use fissure_core::*;
//! use fissure_gpu::GpuContext;
//! use fissure_gpu::render::{Camera, Offscreen, Positions, Renderer, View};
//!
//! let mut b = ModelBuilder::new();
//! b.add_soft_body(&Mesh::icosphere(0.25, 3).translated(glam::DVec3::Y), &SoftBodyOptions::default())?;
//! b.add_collider(Collider::ground(0.0));
//! let model: Model<f32> = b.finalize()?;
//! let state = model.state();
//! let ctx = GpuContext::new()?;
//! let mut r = Renderer::new(&ctx.device, &ctx.queue, Offscreen::FORMAT);
//! r.set_model(&model, 0.0);
//! r.upload_positions(&state);
//! let camera = Camera::framing(&model, &state);
//! let mut target = Offscreen::new(&ctx.device, 640, 360);
//! let image = target.render(&ctx.device, &ctx.queue, &mut r, &camera, &View::default(), Positions::Uploaded)?;
//! assert_eq!(image.rgba.len(), 640 * 360 * 4);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Shading is in `shaders/render.wgsl`: soft bodies are shaded flat from screen-space derivatives (no normal
//! buffer to rebuild when a mesh tears), lit by a key light, a hemispherical ambient and a rim term on whichever
//! side faces the viewer; the inside of a torn body is tinted darker. Walls are drawn only when the camera is on
//! their open side, so a wall never hides the room from a camera outside it.

use crate::GpuError;
use fissure_core::{Model, SpringKind, State};
use glam::{Mat4, Vec3};
use std::sync::mpsc;
use wgpu::util::DeviceExt;

/// The WGSL source of the renderer.
pub const RENDER_WGSL: &str = include_str!("../../../shaders/render.wgsl");

/// Multisampling of every render target.
pub const SAMPLES: u32 = 4;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Body colours (sRGB), by body index modulo the palette length.
pub const PALETTE: [[u8; 3]; 6] =
    [[236, 140, 64], [86, 160, 226], [120, 196, 96], [220, 96, 128], [200, 180, 80], [150, 120, 210]];
const GROUND: [u8; 3] = [206, 200, 188];
const WALL: [u8; 3] = [176, 188, 204];
const OBSTACLE: [u8; 3] = [128, 140, 160];
const BACKGROUND: wgpu::Color = wgpu::Color { r: 0.012, g: 0.016, b: 0.026, a: 1.0 };

/// An orbit camera: it looks at `target` from `distance` away, at `yaw` about +y and `pitch` above the horizon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// The point looked at [m].
    pub target: Vec3,
    /// Angle about +y [rad]; 0 looks along -z.
    pub yaw: f32,
    /// Angle above the horizontal [rad], kept within ±1.5.
    pub pitch: f32,
    /// Distance from the target [m].
    pub distance: f32,
    /// Vertical field of view [rad].
    pub fov_y: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Camera { target: Vec3::new(0.0, 0.6, 0.0), yaw: 0.5, pitch: 0.35, distance: 4.0, fov_y: 0.8 }
    }
}

impl Camera {
    /// A camera that frames the model's bodies and bounded colliders (and the room, if there are walls), seen
    /// from the front, a little from the side and above.
    pub fn framing(model: &Model<f32>, state: &State<f32>) -> Camera {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for q in state.particle_q.iter().filter(|q| q.is_finite()) {
            lo = lo.min(*q);
            hi = hi.max(*q);
        }
        let scene = SceneGeometry::extent(model, lo, hi);
        for c in &model.colliders {
            if c.shape.as_halfspace().is_none() {
                let aabb = c.shape.compute_aabb(&c.pose);
                lo = lo.min(aabb.mins);
                hi = hi.max(aabb.maxs);
            }
        }
        if scene.walls {
            lo = lo.min(Vec3::new(-scene.half_width, 0.0, -scene.half_width));
            hi = hi.max(Vec3::new(scene.half_width, lo.y.max(0.0), scene.half_width));
        }
        if !lo.is_finite() || !hi.is_finite() {
            return Camera::default();
        }
        let center = 0.5 * (lo + hi);
        // Without walls, bodies move out of their starting box (a cloth blows downwind): leave room.
        let radius = (0.5 * (hi - lo).length()).max(0.1) * if scene.walls { 1.0 } else { 1.5 };
        let fov_y = 0.8f32;
        Camera { target: center, yaw: 0.45, pitch: 0.42, distance: 0.9 * radius / (0.5 * fov_y).sin(), fov_y }
    }

    /// The camera's position [m].
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(sy * cp, sp, cy * cp)
    }

    /// World to clip space (wgpu's depth range 0..1) for a viewport of `aspect` = width / height.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let near = (self.distance * 0.01).max(1e-3);
        let far = self.distance * 20.0 + 10.0;
        use glam::camera::rh::{proj::directx::perspective, view::look_at_mat4};
        perspective(self.fov_y, aspect.max(1e-3), near, far) * look_at_mat4(self.eye(), self.target, Vec3::Y)
    }

    /// Turns the camera by `dyaw` and `dpitch` [rad].
    pub fn orbit(&mut self, dyaw: f32, dpitch: f32) {
        self.yaw += dyaw;
        self.pitch = (self.pitch + dpitch).clamp(-1.5, 1.5);
    }

    /// Moves the camera towards (`factor` < 1) or away from the target.
    pub fn zoom(&mut self, factor: f32) {
        self.distance = (self.distance * factor).clamp(0.05, 1e4);
    }

    /// The ray through pixel `(x, y)` of a `width × height` viewport (y down): origin and unit direction.
    pub fn ray(&self, x: f32, y: f32, width: f32, height: f32) -> (Vec3, Vec3) {
        let inv = self.view_proj(width / height).inverse();
        let ndc = Vec3::new(2.0 * x / width - 1.0, 1.0 - 2.0 * y / height, 0.0);
        let near = inv.project_point3(ndc);
        let far = inv.project_point3(Vec3::new(ndc.x, ndc.y, 1.0));
        (near, (far - near).normalize())
    }

    /// The pixel `(x, y)` (y down) and depth of world point `p`, or `None` behind the camera.
    pub fn project(&self, p: Vec3, width: f32, height: f32) -> Option<(f32, f32, f32)> {
        let c = self.view_proj(width / height) * p.extend(1.0);
        if c.w <= 0.0 {
            return None;
        }
        let n = c.truncate() / c.w;
        Some(((n.x + 1.0) * 0.5 * width, (1.0 - n.y) * 0.5 * height, n.z))
    }
}

/// What to draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Shaded triangles of the bodies.
    pub surfaces: bool,
    /// Springs as lines (structural and shear; bending springs would hide the mesh).
    pub wireframe: bool,
    /// Mass points as squares (pinned ones red).
    pub points: bool,
    /// Ground, walls and obstacles.
    pub scene: bool,
    /// Side of a mass point's square [px].
    pub point_size: f32,
}

impl Default for View {
    fn default() -> Self {
        View { surfaces: true, wireframe: false, points: false, scene: true, point_size: 4.0 }
    }
}

/// Where the soft bodies' positions come from.
#[derive(Clone, Copy, Debug)]
pub enum Positions<'a> {
    /// The last [`Renderer::upload_positions`].
    Uploaded,
    /// A buffer of `vec4<f32>` per particle with `VERTEX` usage, e.g. [`crate::GpuSolver::position_buffer`].
    Buffer(&'a wgpu::Buffer),
}

/// An RGBA8 (sRGB) image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width [px].
    pub width: u32,
    /// Height [px].
    pub height: u32,
    /// `width * height * 4` bytes.
    pub rgba: Vec<u8>,
}

impl Image {
    /// The pixel at `(x, y)`.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = 4 * (y * self.width + x) as usize;
        [self.rgba[i], self.rgba[i + 1], self.rgba[i + 2], self.rgba[i + 3]]
    }

    /// Fraction of pixels within `tolerance` (per channel) of colour `rgb`.
    pub fn fraction_near(&self, rgb: [u8; 3], tolerance: u8) -> f64 {
        let n = self.rgba.chunks_exact(4).filter(|p| (0..3).all(|c| p[c].abs_diff(rgb[c]) <= tolerance)).count();
        n as f64 / (self.width as f64 * self.height as f64).max(1.0)
    }

    /// Mean and standard deviation of the luma (0..255) over all pixels.
    pub fn luma_stats(&self) -> (f64, f64) {
        let n = (self.width as f64 * self.height as f64).max(1.0);
        let luma = |p: &[u8]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
        let mean = self.rgba.chunks_exact(4).map(luma).sum::<f64>() / n;
        let var = self.rgba.chunks_exact(4).map(|p| (luma(p) - mean).powi(2)).sum::<f64>() / n;
        (mean, var.sqrt())
    }

    /// Number of distinct colours (quantised to 5 bits per channel): a blank frame has one or two.
    pub fn distinct_colors(&self) -> usize {
        let mut seen = vec![false; 1 << 15];
        for p in self.rgba.chunks_exact(4) {
            seen[((p[0] as usize >> 3) << 10) | ((p[1] as usize >> 3) << 5) | (p[2] as usize >> 3)] = true;
        }
        seen.iter().filter(|&&s| s).count()
    }

    /// Fraction of bright, nearly grey pixels (luma > 110, channels within 40 of each other): the lit floor and
    /// walls of a room (the background is dark; bodies are saturated).
    pub fn room_coverage(&self) -> f64 {
        let n = self
            .rgba
            .chunks_exact(4)
            .filter(|p| {
                let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                let luma = 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
                luma > 110.0 && hi - lo < 40
            })
            .count();
        n as f64 / (self.width as f64 * self.height as f64).max(1.0)
    }

    /// A frame that shows something: not one flat colour (luma spread ≥ 10, ≥ 50 distinct colours) and at
    /// least `min_body` of the pixels in body colour 0. The error says which statistic failed.
    pub fn check_not_blank(&self, min_body: f64) -> Result<(), String> {
        let (mean, sd) = self.luma_stats();
        let colors = self.distinct_colors();
        let body = self.body_coverage(0);
        if sd < 10.0 || colors < 50 {
            return Err(format!("blank frame: luma {mean:.1} ± {sd:.1}, {colors} distinct colours"));
        }
        if body < min_body {
            return Err(format!(
                "the body covers {:.3} % of the frame, want >= {:.3} %",
                100.0 * body,
                100.0 * min_body
            ));
        }
        Ok(())
    }

    /// Fraction of pixels whose hue is close to body colour `k` of [`PALETTE`] (lit or in shade): the
    /// share of the frame a body of that colour covers.
    pub fn body_coverage(&self, k: usize) -> f64 {
        let c = PALETTE[k % PALETTE.len()].map(|v| v as f64);
        let cn = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let n = self
            .rgba
            .chunks_exact(4)
            .filter(|p| {
                let v = [p[0] as f64, p[1] as f64, p[2] as f64];
                let vn = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                vn > 40.0 && (v[0] * c[0] + v[1] * c[1] + v[2] * c[2]) / (vn * cn) > 0.985
            })
            .count();
        n as f64 / (self.width as f64 * self.height as f64).max(1.0)
    }
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct CameraUniform {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    viewport: [f32; 4],
    light: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct StaticVertex {
    p: [f32; 3],
    n: [f32; 3],
    color: [u8; 4],
}

/// One collider's triangles in the static buffers, and for a wall the plane that decides its visibility.
#[derive(Clone, Debug)]
struct StaticDraw {
    indices: std::ops::Range<u32>,
    /// A wall: drawn only when the camera is on the open side of (point, normal).
    wall: Option<(Vec3, Vec3)>,
}

/// Extent of the drawn room and whether it has walls.
struct SceneGeometry {
    half_width: f32,
    walls: bool,
}

impl SceneGeometry {
    fn extent(model: &Model<f32>, lo: Vec3, hi: Vec3) -> SceneGeometry {
        let mut half_width: f32 = 0.0;
        let mut walls = false;
        for c in &model.colliders {
            if let Some(h) = c.shape.as_halfspace() {
                let n = c.pose.rotation * h.normal;
                if n.y.abs() < 0.5 {
                    walls = true;
                    half_width = half_width.max(c.pose.translation.dot(-n).abs());
                }
            }
        }
        if !walls {
            let span = if lo.is_finite() && hi.is_finite() { lo.abs().max(hi.abs()).max_element() } else { 1.0 };
            half_width = (2.0 * span).max(1.5);
        }
        SceneGeometry { half_width, walls }
    }
}

/// Draws models; see the module docs.
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    format: wgpu::TextureFormat,
    camera: wgpu::Buffer,
    camera_bind: wgpu::BindGroup,
    overlay_layout: wgpu::BindGroupLayout,
    body: wgpu::RenderPipeline,
    statics: wgpu::RenderPipeline,
    lines: wgpu::RenderPipeline,
    points: wgpu::RenderPipeline,
    overlay_pipeline: wgpu::RenderPipeline,
    positions: Sized,
    colors: Sized,
    tris: Sized,
    springs: Sized,
    static_vertices: Sized,
    static_indices: Sized,
    particles: u32,
    tri_indices: u32,
    spring_indices: u32,
    static_draws: Vec<StaticDraw>,
    moving_colliders: bool,
    overlay: Option<Overlay>,
}

/// The text panel: its texture, where it goes (a uniform rectangle), their bind group, and its size [px].
struct Overlay {
    texture: wgpu::Texture,
    rect: wgpu::Buffer,
    bind: wgpu::BindGroup,
    size: [u32; 2],
}

/// A buffer that grows (by a quarter more than asked) and is otherwise reused.
struct Sized {
    buffer: wgpu::Buffer,
    usage: wgpu::BufferUsages,
    label: &'static str,
}

impl Sized {
    fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages) -> Self {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        Sized { buffer: Self::make(device, label, usage, 256), usage, label }
    }

    fn make(device: &wgpu::Device, label: &str, usage: wgpu::BufferUsages, bytes: u64) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16).next_multiple_of(16),
            usage,
            mapped_at_creation: false,
        })
    }

    fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[u8]) {
        if data.len() as u64 > self.buffer.size() {
            self.buffer = Self::make(device, self.label, self.usage, (data.len() + data.len() / 4) as u64);
        }
        if !data.is_empty() {
            // write_buffer needs a multiple of 4 bytes; every array here is of 4-byte elements.
            queue.write_buffer(&self.buffer, 0, data);
        }
    }
}

fn pack(rgb: [u8; 3], a: u8) -> [u8; 4] {
    [rgb[0], rgb[1], rgb[2], a]
}

impl Renderer {
    /// A renderer drawing into targets of `format` (an `*Srgb` format gives correct shading) with
    /// [`SAMPLES`]-fold multisampling.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, format: wgpu::TextureFormat) -> Renderer {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("render.wgsl"),
            source: wgpu::ShaderSource::Wgsl(RENDER_WGSL.into()),
        });
        let camera = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("camera"),
            size: size_of::<CameraUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let uniform = |binding, visibility| wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let camera_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("camera"),
            entries: &[uniform(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
        });
        let camera_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("camera"),
            layout: &camera_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: camera.as_entire_binding() }],
        });
        let overlay_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("overlay"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                uniform(1, wgpu::ShaderStages::VERTEX),
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("render"),
            bind_group_layouts: &[Some(&camera_layout)],
            immediate_size: 0,
        });
        let overlay_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("overlay"),
            bind_group_layouts: &[Some(&camera_layout), Some(&overlay_layout)],
            immediate_size: 0,
        });

        let q_attr = [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x4, offset: 0, shader_location: 0 }];
        let c_attr = [wgpu::VertexAttribute { format: wgpu::VertexFormat::Unorm8x4, offset: 0, shader_location: 1 }];
        let per =
            |step_mode, array_stride, attributes| wgpu::VertexBufferLayout { array_stride, step_mode, attributes };
        let vertex = wgpu::VertexStepMode::Vertex;
        let instance = wgpu::VertexStepMode::Instance;
        let static_attr = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Unorm8x4];

        let depth = |write: bool| {
            Some(wgpu::DepthStencilState {
                format: DEPTH,
                depth_write_enabled: Some(write),
                depth_compare: Some(wgpu::CompareFunction::LessEqual),
                stencil: Default::default(),
                bias: Default::default(),
            })
        };
        let make = |label: &'static str,
                    layout: &wgpu::PipelineLayout,
                    vs: &'static str,
                    fs: &'static str,
                    buffers: &[Option<wgpu::VertexBufferLayout>],
                    topology,
                    depth_stencil,
                    blend| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState { topology, cull_mode: None, ..Default::default() },
                depth_stencil,
                multisample: wgpu::MultisampleState { count: SAMPLES, ..Default::default() },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        use wgpu::PrimitiveTopology as T;
        let body = make(
            "bodies",
            &layout,
            "body_vs",
            "body_fs",
            &[Some(per(vertex, 16, &q_attr)), Some(per(vertex, 4, &c_attr))],
            T::TriangleList,
            depth(true),
            None,
        );
        let statics = make(
            "scene",
            &layout,
            "static_vs",
            "static_fs",
            &[Some(per(vertex, size_of::<StaticVertex>() as u64, &static_attr))],
            T::TriangleList,
            depth(true),
            None,
        );
        let lines = make(
            "springs",
            &layout,
            "line_vs",
            "line_fs",
            &[Some(per(vertex, 16, &q_attr))],
            T::LineList,
            depth(false),
            None,
        );
        let points = make(
            "points",
            &layout,
            "point_vs",
            "line_fs",
            &[Some(per(instance, 16, &q_attr)), Some(per(instance, 4, &c_attr))],
            T::TriangleList,
            depth(true),
            None,
        );
        let overlay_pipeline = make(
            "overlay",
            &overlay_pipeline_layout,
            "overlay_vs",
            "overlay_fs",
            &[],
            T::TriangleList,
            depth(false).map(|d| wgpu::DepthStencilState { depth_compare: Some(wgpu::CompareFunction::Always), ..d }),
            Some(wgpu::BlendState::ALPHA_BLENDING),
        );
        let v = wgpu::BufferUsages::VERTEX;
        let ix = wgpu::BufferUsages::INDEX;
        Renderer {
            positions: Sized::new(device, "render positions", v),
            colors: Sized::new(device, "render colours", v),
            tris: Sized::new(device, "render triangles", ix),
            springs: Sized::new(device, "render springs", ix),
            static_vertices: Sized::new(device, "scene vertices", v),
            static_indices: Sized::new(device, "scene indices", ix),
            device: device.clone(),
            queue: queue.clone(),
            format,
            camera,
            camera_bind,
            overlay_layout,
            body,
            statics,
            lines,
            points,
            overlay_pipeline,
            particles: 0,
            tri_indices: 0,
            spring_indices: 0,
            static_draws: Vec::new(),
            moving_colliders: false,
            overlay: None,
        }
    }

    /// The colour format it draws into.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Takes the model's topology (triangles, springs, body colours, pinned particles) and its colliders at
    /// time `time`. Call again after a fracture event changed the model.
    pub fn set_model(&mut self, m: &Model<f32>, time: f64) {
        let colors: Vec<[u8; 4]> = (0..m.particle_count())
            .map(|i| {
                let body = m.particle_body[i] as usize;
                pack(PALETTE[body % PALETTE.len()], if m.particle_inv_mass[i] == 0.0 { 0 } else { 255 })
            })
            .collect();
        self.colors.write(&self.device, &self.queue, bytemuck::cast_slice(&colors));
        self.tris.write(&self.device, &self.queue, bytemuck::cast_slice(&m.tri_indices));
        let lines: Vec<[u32; 2]> = m
            .spring_indices
            .iter()
            .zip(&m.spring_kind)
            .filter(|(_, k)| matches!(k, SpringKind::Edge | SpringKind::Shear))
            .map(|(s, _)| *s)
            .collect();
        self.springs.write(&self.device, &self.queue, bytemuck::cast_slice(&lines));
        self.particles = m.particle_count() as u32;
        self.tri_indices = 3 * m.tri_indices.len() as u32;
        self.spring_indices = 2 * lines.len() as u32;
        self.set_colliders(m, time);
    }

    /// Rebuilds the colliders' triangles at time `time` (only needed when a collider moves; the model's
    /// topology is left as it was).
    pub fn set_colliders(&mut self, m: &Model<f32>, time: f64) {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for q in m.particle_q0.iter().filter(|q| q.is_finite()) {
            lo = lo.min(*q);
            hi = hi.max(*q);
        }
        let extent = SceneGeometry::extent(m, lo, hi);
        let wall_height =
            if extent.walls { (0.75 * extent.half_width).max(hi.y.min(2.0 * extent.half_width) * 0.7) } else { 0.0 };
        let mut vertices: Vec<StaticVertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        self.static_draws.clear();
        self.moving_colliders = false;
        for c in &m.colliders {
            self.moving_colliders |= c.linear_velocity != Vec3::ZERO || c.angular_velocity != Vec3::ZERO;
            let pose = c.pose_at(time);
            let first = indices.len() as u32;
            let mut wall = None;
            let (pts, tris, color, checker): (Vec<Vec3>, Vec<[u32; 3]>, [u8; 3], bool) =
                if let Some(h) = c.shape.as_halfspace() {
                    // The solid is behind the plane; its normal points to the free side.
                    let n = (pose.rotation * h.normal).normalize();
                    let p = pose.translation;
                    let hw = extent.half_width;
                    if n.y > 0.5 {
                        // A floor (drawn level at the plane's height).
                        let s = if extent.walls { hw } else { hw * 1.5 };
                        let y = p.y;
                        let quad = [Vec3::new(-s, y, -s), Vec3::new(s, y, -s), Vec3::new(s, y, s), Vec3::new(-s, y, s)];
                        (quad.to_vec(), vec![[0, 2, 1], [0, 3, 2]], GROUND, true)
                    } else {
                        wall = Some((p, n));
                        // A rectangle in the plane, hw wide either side of the point, from the floor up.
                        let side = Vec3::Y.cross(n).normalize_or(Vec3::X);
                        let (b0, b1) = (Vec3::new(p.x, 0.0, p.z), Vec3::new(p.x, wall_height, p.z));
                        let quad = [b0 - side * hw, b0 + side * hw, b1 + side * hw, b1 - side * hw];
                        (quad.to_vec(), vec![[0, 1, 2], [0, 2, 3]], WALL, true)
                    }
                } else {
                    let (pts, tris) = collider_mesh(&c.shape);
                    (pts.into_iter().map(|p| pose.transform_point(p)).collect(), tris, OBSTACLE, false)
                };
            let normals = vertex_normals(&pts, &tris);
            let base = vertices.len() as u32;
            for (p, n) in pts.iter().zip(&normals) {
                vertices.push(StaticVertex {
                    p: p.to_array(),
                    n: n.to_array(),
                    color: pack(color, if checker { 255 } else { 0 }),
                });
            }
            indices.extend(tris.iter().flat_map(|t| t.map(|k| k + base)));
            self.static_draws.push(StaticDraw { indices: first..indices.len() as u32, wall });
        }
        self.static_vertices.write(&self.device, &self.queue, bytemuck::cast_slice(&vertices));
        self.static_indices.write(&self.device, &self.queue, bytemuck::cast_slice(&indices));
    }

    /// Whether some collider moves (then call [`Renderer::set_colliders`] each frame).
    pub fn has_moving_colliders(&self) -> bool {
        self.moving_colliders
    }

    /// Uploads CPU positions for [`Positions::Uploaded`].
    pub fn upload_positions(&mut self, state: &State<f32>) {
        let q: Vec<[f32; 4]> = state.particle_q.iter().map(|v| [v.x, v.y, v.z, 1.0]).collect();
        self.positions.write(&self.device, &self.queue, bytemuck::cast_slice(&q));
    }

    /// Text drawn in the top-left corner (white on a translucent panel, 8×8 glyphs at `scale`); empty: none.
    pub fn set_overlay(&mut self, lines: &[String], scale: u32) {
        let Some(text) = TextImage::render(lines, scale) else {
            self.overlay = None;
            return;
        };
        let size = wgpu::Extent3d { width: text.width, height: text.height, depth_or_array_layers: 1 };
        // The text changes every frame, its panel's size rarely: the texture is rewritten in place, and made anew
        // (with its bind group) only when the size changes.
        if self.overlay.as_ref().is_none_or(|o| o.size != [text.width, text.height]) {
            let texture = self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("overlay"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba8Unorm,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            let rect = self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("overlay rect"),
                contents: &[0u8; 16],
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            });
            let view = texture.create_view(&Default::default());
            let bind = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("overlay"),
                layout: &self.overlay_layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                    wgpu::BindGroupEntry { binding: 1, resource: rect.as_entire_binding() },
                ],
            });
            self.overlay = Some(Overlay { texture, rect, bind, size: [text.width, text.height] });
        }
        let o = self.overlay.as_ref().expect("made above");
        self.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &o.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &text.rgba,
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * text.width), rows_per_image: None },
            size,
        );
    }

    /// Records the drawing of one frame into `encoder`: clears `color` (multisampled, [`SAMPLES`]) and
    /// `depth`, draws, and resolves into `resolve`. `size` is the target's size in pixels.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        resolve: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        size: [u32; 2],
        camera: &Camera,
        view: &View,
        positions: Positions<'_>,
    ) {
        let (w, h) = (size[0].max(1) as f32, size[1].max(1) as f32);
        let eye = camera.eye();
        let light = Vec3::new(0.45, 0.85, 0.35).normalize();
        let u = CameraUniform {
            view_proj: camera.view_proj(w / h).to_cols_array_2d(),
            eye: eye.extend(1.0).to_array(),
            viewport: [w, h, view.point_size * 0.5, 0.0],
            light: light.extend(0.0).to_array(),
        };
        self.queue.write_buffer(&self.camera, 0, bytemuck::bytes_of(&u));
        if let Some(o) = &self.overlay {
            let (x0, y0, [tw, th]) = (8.0, 8.0, o.size.map(|v| v as f32));
            let r = [2.0 * x0 / w - 1.0, 1.0 - 2.0 * y0 / h, 2.0 * (x0 + tw) / w - 1.0, 1.0 - 2.0 * (y0 + th) / h];
            self.queue.write_buffer(&o.rect, 0, bytemuck::cast_slice(&r));
        }
        let q = match positions {
            Positions::Uploaded => &self.positions.buffer,
            Positions::Buffer(b) => b,
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("frame"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: color,
                depth_slice: None,
                resolve_target: Some(resolve),
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(BACKGROUND), store: wgpu::StoreOp::Discard },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.camera_bind, &[]);
        if view.scene && !self.static_draws.is_empty() {
            pass.set_pipeline(&self.statics);
            pass.set_vertex_buffer(0, self.static_vertices.buffer.slice(..));
            pass.set_index_buffer(self.static_indices.buffer.slice(..), wgpu::IndexFormat::Uint32);
            for d in &self.static_draws {
                if let Some((p, n)) = d.wall
                    && (eye - p).dot(n) < 0.0
                {
                    continue; // the camera is behind this wall: it would hide the room
                }
                pass.draw_indexed(d.indices.clone(), 0, 0..1);
            }
        }
        if self.particles > 0 {
            if view.surfaces && self.tri_indices > 0 {
                pass.set_pipeline(&self.body);
                pass.set_vertex_buffer(0, q.slice(..));
                pass.set_vertex_buffer(1, self.colors.buffer.slice(..));
                pass.set_index_buffer(self.tris.buffer.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..self.tri_indices, 0, 0..1);
            }
            if view.wireframe && self.spring_indices > 0 {
                pass.set_pipeline(&self.lines);
                pass.set_vertex_buffer(0, q.slice(..));
                pass.set_index_buffer(self.springs.buffer.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..self.spring_indices, 0, 0..1);
            }
            if view.points {
                pass.set_pipeline(&self.points);
                pass.set_vertex_buffer(0, q.slice(..));
                pass.set_vertex_buffer(1, self.colors.buffer.slice(..));
                pass.draw(0..6, 0..self.particles);
            }
        }
        if let Some(o) = &self.overlay {
            pass.set_pipeline(&self.overlay_pipeline);
            pass.set_bind_group(1, &o.bind, &[]);
            pass.draw(0..6, 0..1);
        }
    }
}

/// The triangles of a bounded collider shape in its local frame (balls and capsules tessellated finely enough to
/// look round at a few hundred pixels).
fn collider_mesh(shape: &parry3d::shape::SharedShape) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    if let Some(b) = shape.as_ball() {
        b.to_trimesh(48, 24)
    } else if let Some(c) = shape.as_cuboid() {
        c.to_trimesh()
    } else if let Some(c) = shape.as_capsule() {
        c.to_trimesh(48, 12)
    } else if let Some(t) = shape.as_trimesh() {
        (t.vertices().to_vec(), t.indices().to_vec())
    } else {
        // Any other shape: its bounding box, so it is at least seen.
        let aabb = shape.compute_local_aabb();
        let (v, t) = parry3d::shape::Cuboid::new(aabb.half_extents()).to_trimesh();
        (v.into_iter().map(|p| p + aabb.center()).collect(), t)
    }
}

/// Area-weighted vertex normals.
fn vertex_normals(p: &[Vec3], tris: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; p.len()];
    for t in tris {
        let [a, b, c] = t.map(|k| p[k as usize]);
        let f = (b - a).cross(c - a);
        for k in t {
            n[*k as usize] += f;
        }
    }
    n.into_iter().map(|v| v.normalize_or(Vec3::Y)).collect()
}

/// Lines of text rasterised with the public-domain 8×8 font onto a translucent dark panel.
struct TextImage {
    width: u32,
    height: u32,
    rgba: Vec<u8>,
}

impl TextImage {
    fn render(lines: &[String], scale: u32) -> Option<TextImage> {
        let scale = scale.max(1);
        let cols = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0) as u32;
        if cols == 0 {
            return None;
        }
        let pad = 4 * scale;
        let (width, height) = (cols * 8 * scale + 2 * pad, lines.len() as u32 * 10 * scale + 2 * pad);
        let mut rgba = [10u8, 12, 18, 170].repeat((width * height) as usize);
        for (row, line) in lines.iter().enumerate() {
            for (col, ch) in line.chars().enumerate() {
                let glyph = font8x8::legacy::BASIC_LEGACY.get(ch as usize).copied().unwrap_or([0; 8]);
                for (gy, bits) in glyph.iter().enumerate() {
                    for gx in 0..8u32 {
                        if bits >> gx & 1 == 0 {
                            continue;
                        }
                        for sy in 0..scale {
                            for sx in 0..scale {
                                let x = pad + (col as u32 * 8 + gx) * scale + sx;
                                let y = pad + (row as u32 * 10 + gy as u32) * scale + sy;
                                let i = 4 * (y * width + x) as usize;
                                rgba[i..i + 4].copy_from_slice(&[235, 238, 245, 255]);
                            }
                        }
                    }
                }
            }
        }
        Some(TextImage { width, height, rgba })
    }
}

/// An offscreen target: multisampled colour and depth, a resolve texture, and a read-back buffer.
pub struct Offscreen {
    width: u32,
    height: u32,
    color: wgpu::TextureView,
    resolve: wgpu::Texture,
    resolve_view: wgpu::TextureView,
    depth: wgpu::TextureView,
    readback: Readback,
}

impl Offscreen {
    /// The colour format of offscreen targets (create the [`Renderer`] with it).
    pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

    /// A `width × height` target.
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Offscreen {
        let (width, height) = (width.max(1), height.max(1));
        let (color, depth) = targets(device, Self::FORMAT, width, height);
        let resolve = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("offscreen"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: Self::FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let readback = Readback::new(device, width, height);
        let resolve_view = resolve.create_view(&Default::default());
        Offscreen { width, height, color, resolve, resolve_view, depth, readback }
    }

    /// Size in pixels.
    pub fn size(&self) -> [u32; 2] {
        [self.width, self.height]
    }

    /// Draws a frame and reads it back.
    pub fn render(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        renderer: &mut Renderer,
        camera: &Camera,
        view: &View,
        positions: Positions<'_>,
    ) -> Result<Image, GpuError> {
        let mut enc = device.create_command_encoder(&Default::default());
        renderer.encode(&mut enc, &self.color, &self.resolve_view, &self.depth, self.size(), camera, view, positions);
        self.readback.encode_copy(&mut enc, &self.resolve);
        queue.submit([enc.finish()]);
        self.readback.read(device, Self::FORMAT)
    }
}

/// A mappable buffer that a texture of a given size is copied into, rows padded to wgpu's 256-byte alignment:
/// the read-back of [`Offscreen`] frames and of a window's surface (screenshots).
pub struct Readback {
    buffer: wgpu::Buffer,
    row_bytes: u32,
    size: [u32; 2],
}

impl Readback {
    /// For RGBA8 or BGRA8 textures of `width × height`.
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Readback {
        let row_bytes = (4 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: (row_bytes * height) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Readback { buffer, row_bytes, size: [width, height] }
    }

    /// Records the copy of `texture` (of this size, with `COPY_SRC` usage) into the buffer.
    pub fn encode_copy(&self, enc: &mut wgpu::CommandEncoder, texture: &wgpu::Texture) {
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.row_bytes),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d { width: self.size[0], height: self.size[1], depth_or_array_layers: 1 },
        );
    }

    /// Waits for the submitted copy and returns it as RGBA (`format` says whether the texture was BGRA).
    pub fn read(&self, device: &wgpu::Device, format: wgpu::TextureFormat) -> Result<Image, GpuError> {
        let err = |e: &dyn std::fmt::Display| GpuError::Readback(e.to_string());
        let (tx, rx) = mpsc::channel();
        self.buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| err(&e))?;
        rx.recv().map_err(|e| err(&e))?.map_err(|e| err(&e))?;
        let bgra = matches!(format, wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb);
        let [width, height] = self.size;
        let mut rgba = Vec::with_capacity((4 * width * height) as usize);
        {
            let data = self.buffer.get_mapped_range(..).map_err(|e| err(&e))?;
            for row in data.chunks_exact(self.row_bytes as usize) {
                let row = &row[..(4 * width) as usize];
                if bgra {
                    rgba.extend(row.chunks_exact(4).flat_map(|p| [p[2], p[1], p[0], p[3]]));
                } else {
                    rgba.extend_from_slice(row);
                }
            }
        }
        self.buffer.unmap();
        Ok(Image { width, height, rgba })
    }
}

/// A multisampled colour texture of `format` and a matching depth texture, `width × height` (for a window's
/// surface: resolve into the surface texture).
pub fn targets(
    device: &wgpu::Device,
    format: wgpu::TextureFormat,
    width: u32,
    height: u32,
) -> (wgpu::TextureView, wgpu::TextureView) {
    let make = |label, format| {
        device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: width.max(1), height: height.max(1), depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: SAMPLES,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default())
    };
    (make("msaa colour", format), make("depth", DEPTH))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_projects_its_target_to_the_centre_and_rays_go_back_through_pixels() {
        let c = Camera { target: Vec3::new(0.3, 0.5, -0.2), yaw: 0.7, pitch: 0.3, distance: 3.0, fov_y: 0.8 };
        let (x, y, _) = c.project(c.target, 640.0, 360.0).unwrap();
        assert!((x - 320.0).abs() < 1e-3 && (y - 180.0).abs() < 1e-3, "{x} {y}");
        let p = Vec3::new(0.6, 0.9, 0.1);
        let (x, y, _) = c.project(p, 640.0, 360.0).unwrap();
        let (o, d) = c.ray(x, y, 640.0, 360.0);
        // The ray passes through p: its distance from the line is ~0.
        let off = (p - o) - d * (p - o).dot(d);
        assert!(off.length() < 1e-4, "{off}");
        assert!((o - c.eye()).length() < 0.1);
    }

    #[test]
    fn text_is_drawn_white_on_a_panel() {
        let t = TextImage::render(&["Hi".to_string()], 2).unwrap();
        assert_eq!((t.width, t.height), (2 * 8 * 2 + 16, 10 * 2 + 16));
        let white = t.rgba.chunks_exact(4).filter(|p| p[0] == 235).count();
        assert!(white > 20, "{white}");
        assert!(TextImage::render(&[], 2).is_none());
    }
}
