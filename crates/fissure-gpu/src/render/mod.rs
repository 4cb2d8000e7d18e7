//! The renderer: soft bodies lit and double-sided (coloured by body or by strain), a wireframe of their springs
//! and mass points, crack edges in amber (the lips of slits, the rims of holes and blocks), the scene's
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

use crate::{GpuError, STATE_STRIDE};
use fissure_core::{Model, SpringKind, State};
use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

mod camera;
mod geometry;
mod image;
mod offscreen;
mod overlay;
mod sized;

pub use camera::Camera;
use camera::CameraUniform;
use geometry::*;
pub use image::Image;
pub use offscreen::{Offscreen, Readback, targets};
use overlay::TextImage;
use sized::Sized;

/// The WGSL source of the renderer.
pub const RENDER_WGSL: &str = include_str!("../../../../shaders/render.wgsl");

/// Multisampling of the render targets by default ([`Renderer::new`]; [`Renderer::with_samples`] chooses).
pub const SAMPLES: u32 = 4;

/// The multisampling worth its cost on `adapter`: [`SAMPLES`] on a hardware GPU, 1 on a software rasteriser
/// (llvmpipe, lavapipe: the CPU shades every sample, and the simulation shares those cores). Measured on the
/// development VM (2 cores, llvmpipe, 2026-11-24): the fracture scene's 1280×720 frame drew in 26 ms with 4
/// samples, 19 ms with 1.
pub fn samples_for(adapter: &wgpu::AdapterInfo) -> u32 {
    if adapter.device_type == wgpu::DeviceType::Cpu { 1 } else { SAMPLES }
}
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Body colours (sRGB), by body index modulo the palette length.
pub const PALETTE: [[u8; 3]; 6] =
    [[236, 140, 64], [86, 160, 226], [120, 196, 96], [220, 96, 128], [200, 180, 80], [150, 120, 210]];
const GROUND: [u8; 3] = [206, 200, 188];
const WALL: [u8; 3] = [176, 188, 204];
const OBSTACLE: [u8; 3] = [128, 140, 160];
const BACKGROUND: wgpu::Color = wgpu::Color { r: 0.012, g: 0.016, b: 0.026, a: 1.0 };

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
    /// Side of a mass point's square \[px\].
    pub point_size: f32,
    /// Colour surfaces by strain instead of by body (see [`Renderer::color_by_strain`]; CPU states only).
    pub strain: bool,
    /// Crack edges as bright lines: the lips of slits and the rims of holes and blocks
    /// (`fissure_core::topology::crack_edges`).
    pub cracks: bool,
}

impl Default for View {
    fn default() -> Self {
        View {
            surfaces: true,
            wireframe: false,
            points: false,
            scene: true,
            point_size: 4.0,
            strain: false,
            cracks: true,
        }
    }
}

/// Where the soft bodies' positions come from.
#[derive(Clone, Copy, Debug)]
pub enum Positions<'a> {
    /// The last [`Renderer::upload_positions`].
    Uploaded,
    /// A buffer with `VERTEX` usage holding each particle's position as a `vec4<f32>` at [`crate::STATE_STRIDE`]
    /// bytes apart, e.g. [`crate::GpuSolver::position_buffer`].
    Buffer(&'a wgpu::Buffer),
}

/// Draws models; see the module docs.
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    format: wgpu::TextureFormat,
    /// Samples per pixel of the targets it draws into (1: no multisampling, no resolve).
    samples: u32,
    camera: wgpu::Buffer,
    camera_bind: wgpu::BindGroup,
    overlay_layout: wgpu::BindGroupLayout,
    body: wgpu::RenderPipeline,
    statics: wgpu::RenderPipeline,
    lines: wgpu::RenderPipeline,
    crack_lines: wgpu::RenderPipeline,
    points: wgpu::RenderPipeline,
    overlay_pipeline: wgpu::RenderPipeline,
    positions: Sized,
    colors: Sized,
    tris: Sized,
    springs: Sized,
    cracks: Sized,
    static_vertices: Sized,
    static_indices: Sized,
    particles: u32,
    tri_indices: u32,
    spring_indices: u32,
    crack_indices: u32,
    static_draws: Vec<StaticDraw>,
    moving_colliders: bool,
    overlay: Option<Overlay>,
}

/// The text panel: its texture, where it goes (a uniform rectangle), their bind group, and its size \[px\].
struct Overlay {
    texture: wgpu::Texture,
    rect: wgpu::Buffer,
    bind: wgpu::BindGroup,
    size: [u32; 2],
}

/// Strain drawn red by [`Renderer::color_by_strain`] on springs without a strain limit.
pub const STRAIN_FULL_SCALE: f32 = 0.3;

/// A heat map of `x` in \[0, 1\] (clamped): blue, cyan, green, yellow, red (sRGB).
fn heat(x: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 5] =
        [[40., 70., 200.], [40., 190., 220.], [60., 200., 80.], [240., 220., 40.], [220., 40., 30.]];
    let t = x.clamp(0.0, 1.0) * 4.0;
    let k = (t.floor() as usize).min(3);
    let f = t - k as f32;
    let (a, b) = (STOPS[k], STOPS[k + 1]);
    [0, 1, 2].map(|c| (a[c] + (b[c] - a[c]) * f).round() as u8)
}

fn pack(rgb: [u8; 3], a: u8) -> [u8; 4] {
    [rgb[0], rgb[1], rgb[2], a]
}

impl Renderer {
    /// A renderer drawing into targets of `format` (an `*Srgb` format gives correct shading) with
    /// [`SAMPLES`]-fold multisampling.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, format: wgpu::TextureFormat) -> Renderer {
        Renderer::with_samples(device, queue, format, SAMPLES)
    }

    /// [`Renderer::new`] with `samples` per pixel (1, 2, 4 or 8 as the adapter allows; see [`samples_for`]);
    /// [`targets`] makes matching targets.
    pub fn with_samples(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        format: wgpu::TextureFormat,
        samples: u32,
    ) -> Renderer {
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
                multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
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
            &[Some(per(vertex, STATE_STRIDE, &q_attr)), Some(per(vertex, 4, &c_attr))],
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
            &[Some(per(vertex, STATE_STRIDE, &q_attr))],
            T::LineList,
            depth(false),
            None,
        );
        let crack_lines = make(
            "cracks",
            &layout,
            "crack_vs",
            "line_fs",
            &[Some(per(vertex, STATE_STRIDE, &q_attr))],
            T::LineList,
            depth(false),
            None,
        );
        let points = make(
            "points",
            &layout,
            "point_vs",
            "line_fs",
            &[Some(per(instance, STATE_STRIDE, &q_attr)), Some(per(instance, 4, &c_attr))],
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
            samples,
            positions: Sized::new(device, "render positions", v),
            colors: Sized::new(device, "render colours", v),
            tris: Sized::new(device, "render triangles", ix),
            springs: Sized::new(device, "render springs", ix),
            cracks: Sized::new(device, "render cracks", ix),
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
            crack_lines,
            points,
            overlay_pipeline,
            particles: 0,
            tri_indices: 0,
            spring_indices: 0,
            crack_indices: 0,
            static_draws: Vec::new(),
            moving_colliders: false,
            overlay: None,
        }
    }

    /// The colour format it draws into.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Colours each particle by how near its most stretched edge spring is to breaking: blue at rest or
    /// compressed, through cyan, green and yellow, to red at the spring's strain limit (where it tears). Springs
    /// that cannot break are measured against [`STRAIN_FULL_SCALE`]. Call every frame, after
    /// [`Renderer::set_model`] (which puts the body colours back).
    pub fn color_by_strain(&mut self, m: &Model<f32>, q: &[Vec3]) {
        let (_, ratio) = m.particle_strain(q, STRAIN_FULL_SCALE as f64);
        let colors: Vec<[u8; 4]> = (0..m.particle_count())
            .map(|i| {
                let d = ratio.get(i).copied().unwrap_or(0.0).max(0.0) as f32;
                pack(heat(d), if m.particle_inv_mass[i] == 0.0 { 0 } else { 255 })
            })
            .collect();
        self.colors.write(&self.device, &self.queue, bytemuck::cast_slice(&colors));
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
        let cracks = fissure_core::topology::crack_edges(&m.tri_indices, &m.particle_origin);
        self.cracks.write(&self.device, &self.queue, bytemuck::cast_slice(&cracks));
        self.crack_indices = 2 * cracks.len() as u32;
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
        // At the GPU state's stride, so one pipeline draws either (the second `vec4` is unused here).
        let q: Vec<[f32; 8]> = state.particle_q.iter().map(|v| [v.x, v.y, v.z, 1.0, 0.0, 0.0, 0.0, 0.0]).collect();
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

    /// Samples per pixel of the targets it draws into.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Records the drawing of one frame into `encoder`: clears `color` (multisampled, as the renderer was made)
    /// and `depth`, draws, and resolves into `resolve`; with one sample it draws into `resolve` directly and
    /// `color` is not used. `size` is the target's size in pixels.
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
                view: if self.samples > 1 { color } else { resolve },
                depth_slice: None,
                resolve_target: (self.samples > 1).then_some(resolve),
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(BACKGROUND),
                    store: if self.samples > 1 { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store },
                },
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
            if view.cracks && self.crack_indices > 0 {
                pass.set_pipeline(&self.crack_lines);
                pass.set_vertex_buffer(0, q.slice(..));
                pass.set_index_buffer(self.cracks.buffer.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..self.crack_indices, 0, 0..1);
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
