//! # fissure-web
//!
//! fissure in a web page (`web/` at the workspace root): the seed's scenes simulated by the GPU kernels on
//! WebGPU and drawn from the same buffers into a canvas, the fracture pass on the CPU side in wasm, as on the
//! desktop GPU path. The page's JavaScript creates a `Sim` for a canvas and a scene and calls `Sim::frame`
//! once per animation frame; a drag grabs a mass point, a right click punctures the body.
//!
//! The stepping is `fissure::World::advance_async`, the same steps and fracture passes as every other front end
//! (`World::advance` is that method polled once): in a browser a GPU read-back completes only after control
//! returns to the event loop, so it is awaited instead of waited for.
//!
//! Build and serve: `scripts/web` (wasm-bindgen output in `web/pkg/`), then open the printed address. Everything
//! here is for `wasm32-unknown-unknown`; on other targets the crate is empty.
#![cfg(all(target_arch = "wasm32", target_os = "unknown"))]
#![warn(missing_docs)]
// Each call holds the simulation's `RefCell` across its read-back awaits on purpose: a second call arriving
// meanwhile (a click during a frame) is refused with an error instead of stepping a half-updated world.
#![allow(clippy::await_holding_refcell_ref)]

use std::cell::RefCell;
use std::path::Path;
use std::rc::Rc;

use fissure::gpu::render::{Camera, Offscreen, Positions, Renderer, SAMPLES, View, targets};
use fissure::gpu::{GpuConfig, GpuSolver, wgpu};
use fissure::scene::{Override, Scene};
use fissure::{Model, World};
use glam::Vec3;
use wasm_bindgen::prelude::*;

/// The scenes the page offers: the repository's scene files, embedded (the same TOML `fissure run` reads).
/// The seed's three first; then a cloth pulled apart by its handles, to tear further by dragging.
const SCENES: [(&str, &str); 4] = [
    ("fracture", include_str!("../../../scenes/fracture.toml")),
    ("ball_drop", include_str!("../../../scenes/ball_drop.toml")),
    ("cloth_wind", include_str!("../../../scenes/cloth_wind.toml")),
    ("cloth_tear", include_str!("../../../scenes/cloth_tear.toml")),
];

/// Steps between two fracture passes in the page: each pass that finds candidates reads the state back, and a
/// read-back costs a trip through the browser's event loop; 16 steps of the fracture scene are 3.2 ms simulated.
const FRACTURE_EVERY: usize = 16;

/// Simulated time per animation frame \[s\] (real time at 60 frames per second).
const FRAME: f64 = 1.0 / 60.0;

/// The names of the scenes the page can load.
#[wasm_bindgen]
pub fn scene_names() -> Vec<String> {
    SCENES.iter().map(|(n, _)| n.to_string()).collect()
}

/// Pixel statistics of a frame read from the canvas (RGBA rows, as `getImageData` gives them): an empty string
/// when it shows something and body 0 covers at least `min_body` of it, else what failed. The same statistics as
/// the native frame checks (`Image::check_not_blank`).
#[wasm_bindgen]
pub fn check_frame(rgba: Vec<u8>, width: u32, height: u32, min_body: f64) -> String {
    if rgba.len() != (4 * width * height) as usize {
        return format!("{} bytes for a {width} x {height} RGBA frame", rgba.len());
    }
    let image = fissure::gpu::render::Image { width, height, rgba };
    image.check_not_blank(min_body).err().unwrap_or_default()
}

/// Messages of Rust panics go to the browser console (instead of "unreachable executed").
#[wasm_bindgen(start)]
pub fn start() {
    std::panic::set_hook(Box::new(|info| web_sys::console::error_1(&info.to_string().into())));
}

fn js_err(e: impl std::fmt::Display) -> JsValue {
    JsValue::from_str(&e.to_string())
}

/// A scene running in a canvas. Its methods return promises; the page awaits each before the next call (a call
/// made while another is pending is refused with an error rather than interleaved).
#[wasm_bindgen]
pub struct Sim {
    inner: Rc<RefCell<Inner>>,
}

struct Grab {
    handle: usize,
    particle: usize,
    plane_point: Vec3,
    target: Vec3,
}

/// How frames reach the canvas.
enum Present {
    /// The canvas's WebGPU context: drawn into its texture (an sRGB view of it), presented by the browser.
    Canvas {
        surface: wgpu::Surface<'static>,
        config: wgpu::SurfaceConfiguration,
        view_format: wgpu::TextureFormat,
        msaa: wgpu::TextureView,
        depth: wgpu::TextureView,
    },
    /// Drawn into an offscreen texture, read back and put into the canvas's 2D context: for browsers whose
    /// WebGPU cannot present to a canvas (headless Chromium on its software adapter loses the device at the first
    /// present), at the cost of a read-back per frame. `?present=copy` on the page, which also falls back to it
    /// on a fresh canvas and device when the canvas path loses its device in the first frames.
    Copy { target: Offscreen, ctx: web_sys::CanvasRenderingContext2d },
}

struct Inner {
    world: World<f32>,
    /// Kept alive: in a browser, dropping the instance or the adapter invalidates what was made from them.
    _instance: wgpu::Instance,
    _adapter: wgpu::Adapter,
    device: wgpu::Device,
    queue: wgpu::Queue,
    present: Present,
    size: [u32; 2],
    renderer: Renderer,
    camera: Camera,
    view: View,
    adapter: String,
    name: String,
    title: String,
    dt: f64,
    /// The gas bodies' total volume at the start \[m^3\].
    volume0: f64,
    /// Frames drawn, and the smoothed frame rate from the page's timestamps.
    frames: u64,
    fps: f64,
    last_ms: f64,
    /// Wall time of the last frame's simulation (stepping and read-backs) \[ms\].
    sim_ms: f64,
    /// The mass point held by the mouse, if any.
    grab: Option<Grab>,
    orbit_from: Option<(f32, f32)>,
    notes: Vec<String>,
}

fn now_ms() -> f64 {
    web_sys::window().and_then(|w| w.performance()).map_or(0.0, |p| p.now())
}

fn gas_volume(w: &World<f32>) -> f64 {
    let m = &w.model;
    m.body_volumes(&w.state).iter().zip(&m.body_gas_amount).filter(|(_, g)| **g > 0.0).map(|(v, _)| *v).sum()
}

/// The scene `name` as the page runs it, and what it changed to run it on the GPU.
fn scene(name: &str, contact: bool) -> Result<(Scene, Vec<String>), JsValue> {
    let (_, text) = SCENES
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| js_err(format!("no scene {name:?}; the page has {:?}", scene_names())))?;
    let path = Path::new(name);
    let base = Scene::parse(text, path).map_err(js_err)?;
    // Contact between surfaces runs on the GPU like the rest; `contact = false` (the page's `?contact=off`) runs
    // those bodies without it, and the page says so.
    let mut overrides = Vec::new();
    let mut notes = Vec::new();
    for (k, b) in base.bodies.iter().enumerate() {
        if !contact && (b.contact || b.self_collision) {
            overrides.push(Override::new(format!("body[{k}].contact"), false));
            overrides.push(Override::new(format!("body[{k}].self_collision"), false));
            notes.push(format!("body {k}: contact off (?contact=off)"));
        }
    }
    Ok((Scene::parse_with(text, path, &overrides).map_err(js_err)?, notes))
}

#[wasm_bindgen]
impl Sim {
    /// Loads scene `name` (see [`scene_names`]) into `canvas`: a WebGPU device with the default limits, the GPU
    /// solver, the renderer; `copy` draws offscreen and copies each frame into the canvas's 2D context (see
    /// `Present::Copy`); `contact` false runs the scene's contact bodies without contact. Rejects with a message
    /// on a browser without WebGPU.
    pub async fn create(
        canvas: web_sys::HtmlCanvasElement,
        name: String,
        copy: bool,
        contact: bool,
    ) -> Result<Sim, JsValue> {
        let (scene, notes) = scene(&name, contact)?;
        let mut world = scene.world::<f32>().map_err(js_err)?;
        let (width, height) = (canvas.width().max(1), canvas.height().max(1));
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::BROWSER_WEBGPU,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let (surface, ctx) = if copy {
            let ctx = canvas
                .get_context("2d")
                .ok()
                .flatten()
                .and_then(|c| c.dyn_into::<web_sys::CanvasRenderingContext2d>().ok())
                .ok_or_else(|| js_err("the canvas has no 2D context"))?;
            (None, Some(ctx))
        } else {
            let surface = instance
                .create_surface(wgpu::SurfaceTarget::Canvas(canvas))
                .map_err(|e| js_err(format!("this browser cannot draw WebGPU into a canvas: {e}")))?;
            (Some(surface), None)
        };
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                compatible_surface: surface.as_ref(),
                ..Default::default()
            })
            .await
            .map_err(|e| {
                js_err(format!("no WebGPU adapter: this browser has no WebGPU, or it is switched off ({e})"))
            })?;
        let info = adapter.get_info();
        let adapter_name = format!("{} ({:?})", if info.name.is_empty() { "WebGPU" } else { &info.name }, info.backend);
        // WebGPU's default limits: what every browser grants; the kernels are kept within them.
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("fissure web"),
                required_limits: wgpu::Limits::default(),
                ..Default::default()
            })
            .await
            .map_err(|e| js_err(format!("WebGPU device refused: {e}")))?;
        // A validation error of the device is a bug: to the console, where the page's test looks for errors.
        device.on_uncaptured_error(std::sync::Arc::new(|e: wgpu::Error| {
            web_sys::console::error_1(&format!("WebGPU: {e}").into());
        }));
        let config = GpuConfig { integrator: scene.integrator().map_err(js_err)?, ..Default::default() };
        let gpu = GpuSolver::new(device.clone(), queue.clone(), &world.model, config).map_err(js_err)?;
        world.solver = Box::new(gpu);
        world.fracture_every = FRACTURE_EVERY;
        let (present, format) = match (surface, ctx) {
            (Some(surface), _) => {
                let caps = surface.get_capabilities(&adapter);
                let format = caps.formats.first().copied().ok_or_else(|| js_err("the canvas offers no format"))?;
                // The renderer writes linear colour into an sRGB view of the canvas (a canvas is not sRGB).
                let view_format = format.add_srgb_suffix();
                let config = wgpu::SurfaceConfiguration {
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    format,
                    width,
                    height,
                    present_mode: wgpu::PresentMode::AutoVsync,
                    desired_maximum_frame_latency: 2,
                    alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
                    view_formats: vec![view_format],
                    color_space: wgpu::SurfaceColorSpace::Auto,
                };
                surface.configure(&device, &config);
                let (msaa, depth) = targets(&device, view_format, width, height, SAMPLES);
                (Present::Canvas { surface, config, view_format, msaa, depth }, view_format)
            }
            (None, Some(ctx)) => {
                (Present::Copy { target: Offscreen::new(&device, width, height), ctx }, Offscreen::FORMAT)
            }
            (None, None) => unreachable!("a surface or a 2D context was made above"),
        };
        let mut renderer = Renderer::new(&device, &queue, format);
        renderer.set_model(&world.model, world.state.time);
        let camera = Camera::framing(&world.model, &world.state);
        let volume0 = gas_volume(&world);
        let inner = Inner {
            dt: scene.solver.dt,
            title: scene.title.clone(),
            name,
            world,
            _instance: instance,
            _adapter: adapter,
            device,
            queue,
            present,
            size: [width, height],
            renderer,
            camera,
            view: View::default(),
            adapter: adapter_name,
            volume0,
            frames: 0,
            fps: 0.0,
            last_ms: 0.0,
            sim_ms: 0.0,
            grab: None,
            orbit_from: None,
            notes,
        };
        Ok(Sim { inner: Rc::new(RefCell::new(inner)) })
    }

    fn inner(&self) -> Result<std::cell::RefMut<'_, Inner>, JsValue> {
        self.inner.try_borrow_mut().map_err(|_| js_err("the simulation is busy: await the previous call first"))
    }

    /// One animation frame: 1/60 s of simulated time (the scene's steps, fracture every 16 steps), then a
    /// drawing. `timestamp` is the page's `requestAnimationFrame` time \[ms\] (for the frame rate).
    pub async fn frame(&self, timestamp: f64) -> Result<(), JsValue> {
        let mut s = self.inner()?;
        if s.last_ms > 0.0 && timestamp > s.last_ms {
            let fps = 1000.0 / (timestamp - s.last_ms);
            s.fps = if s.fps == 0.0 { fps } else { 0.9 * s.fps + 0.1 * fps };
        }
        s.last_ms = timestamp;
        s.steer();
        let t0 = now_ms();
        let dt = s.dt;
        let out = s.world.advance_async(FRAME, dt).await.map_err(js_err)?;
        s.sim_ms = now_ms() - t0;
        if out.topology_changed {
            s.model_changed();
        }
        s.draw().await
    }

    /// `n` steps of the scene's time step with no drawing and no fracture cadence change (for tests: positions
    /// after a fixed number of steps, to compare with the native backend).
    pub async fn run_steps(&self, n: u32) -> Result<(), JsValue> {
        let mut s = self.inner()?;
        let dt = s.dt;
        let out = s.world.advance_async(n as f64 * dt, dt).await.map_err(js_err)?;
        if out.topology_changed {
            s.model_changed();
        }
        Ok(())
    }

    /// Draws the current state (without stepping).
    pub async fn draw(&self) -> Result<(), JsValue> {
        self.inner()?.draw().await
    }

    /// The positions of every mass point, `[x0, y0, z0, x1, ...]` \[m\], as of the last frame.
    pub fn positions(&self) -> Result<Vec<f32>, JsValue> {
        let s = self.inner()?;
        Ok(s.world.state.particle_q.iter().flat_map(|q| q.to_array()).collect())
    }

    /// Where the centre of body `b` is on the canvas \[px\] (`[x, y]`; empty when it is behind the camera).
    pub fn body_pixel(&self, b: u32) -> Result<Vec<f32>, JsValue> {
        let s = self.inner()?;
        let (w, h) = (s.size[0] as f32, s.size[1] as f32);
        let at = s.camera.body_pixel(&s.world.model, &s.world.state.particle_q, b, w, h);
        Ok(at.map_or_else(Vec::new, |(x, y)| vec![x, y]))
    }

    /// Names the adapter in the overlay and the stats (a browser's WebGPU tells the page, not wgpu, its name).
    pub fn set_adapter(&self, label: String) -> Result<(), JsValue> {
        self.inner()?.adapter = label;
        Ok(())
    }

    /// Right click at pixel `(x, y)`: punctures the body there (a core block breaks out; a gas body leaks).
    /// Resolves to the number of fracture events.
    pub async fn puncture(&self, x: f32, y: f32) -> Result<u32, JsValue> {
        let mut s = self.inner()?;
        let Some(v) = s.pick(x, y) else { return Ok(0) };
        let events = s.world.break_core_async(v).await.map_err(js_err)?;
        if !events.is_empty() {
            s.model_changed();
        }
        Ok(events.len() as u32)
    }

    /// Left button down at `(x, y)`: grabs the mass point there, or starts orbiting the camera.
    pub fn mouse_down(&self, x: f32, y: f32) -> Result<(), JsValue> {
        let mut s = self.inner()?;
        match s.pick(x, y) {
            Some(i) => {
                if let Some(handle) = s.world.grab(i) {
                    let p = s.world.state.particle_q[i];
                    s.grab = Some(Grab { handle, particle: i, plane_point: p, target: p });
                }
            }
            None => s.orbit_from = Some((x, y)),
        }
        Ok(())
    }

    /// The pointer moved to `(x, y)`: drags the grabbed point (in the plane facing the camera) or orbits.
    pub fn mouse_move(&self, x: f32, y: f32) -> Result<(), JsValue> {
        let mut s = self.inner()?;
        if let Some(p) = s.grab.as_ref().map(|g| g.plane_point) {
            let target = s.drag_target(x, y, p);
            if let Some(g) = &mut s.grab {
                g.target = target;
            }
        } else if let Some((x0, y0)) = s.orbit_from {
            s.camera.orbit(-(x - x0) * 0.008, (y - y0) * 0.008);
            s.orbit_from = Some((x, y));
        }
        Ok(())
    }

    /// Left button up: lets go.
    pub fn mouse_up(&self) -> Result<(), JsValue> {
        let mut s = self.inner()?;
        if let Some(g) = s.grab.take() {
            s.world.release_grab(g.handle);
        }
        s.orbit_from = None;
        Ok(())
    }

    /// The mouse wheel: zooms by `0.9^lines`.
    pub fn zoom(&self, lines: f32) -> Result<(), JsValue> {
        self.inner()?.camera.zoom(0.9f32.powf(lines));
        Ok(())
    }

    /// What the page shows and the test reads, as JSON: scene, adapter, simulated time, frames, fps, fracture
    /// events, pieces, gas volume now and at the start, the gas (`nRT` \[J\], summed over the gas bodies), simulation
    /// time per frame, the step, substeps the contact pass ran and the pairs it found within reach (summed over them).
    pub fn stats(&self) -> Result<String, JsValue> {
        let s = self.inner()?;
        let w = &s.world;
        let contact = w.gpu_solver().map(|g| g.contact_stats()).unwrap_or_default();
        let esc = |t: &str| t.replace('\\', "\\\\").replace('"', "\\\"");
        Ok(format!(
            "{{\"scene\":\"{}\",\"title\":\"{}\",\"adapter\":\"{}\",\"time\":{},\"frames\":{},\"fps\":{},\"events\":{},\"pieces\":{},\"particles\":{},\"volume\":{},\"volume0\":{},\"gas\":{},\"sim_ms\":{},\"dt\":{},\"contact_steps\":{},\"contact_pairs\":{},\"notes\":[{}]}}",
            esc(&s.name),
            esc(&s.title),
            esc(&s.adapter),
            w.state.time,
            s.frames,
            s.fps,
            w.events.len(),
            w.model.body_count(),
            w.model.particle_count(),
            gas_volume(w),
            s.volume0,
            w.model.body_gas_amount.iter().map(|&g| g as f64).sum::<f64>(),
            s.sim_ms,
            s.dt,
            contact.steps,
            contact.near_total,
            s.notes.iter().map(|n| format!("\"{}\"", esc(n))).collect::<Vec<_>>().join(",")
        ))
    }
}

impl Inner {
    fn pick(&self, x: f32, y: f32) -> Option<usize> {
        let (w, h) = (self.size[0] as f32, self.size[1] as f32);
        self.camera.pick(&self.world.model, &self.world.state.particle_q, x, y, w, h)
    }

    /// Where the pointer at `(x, y)` is in the plane through `p` facing the camera.
    fn drag_target(&self, x: f32, y: f32, p: Vec3) -> Vec3 {
        let (w, h) = (self.size[0] as f32, self.size[1] as f32);
        self.camera.drag_target(x, y, w, h, p)
    }

    /// Steers the grabbed point's pin towards the pointer over the coming frame.
    fn steer(&mut self) {
        if let Some(g) = &self.grab {
            let (h, i, target) = (g.handle, g.particle, g.target.as_dvec3());
            self.world.steer_grab(h, i, target, FRAME);
        }
    }

    fn model_changed(&mut self) {
        self.renderer.set_model(&self.world.model, self.world.state.time);
    }

    fn overlay(&self) -> Vec<String> {
        let w = &self.world;
        let mut lines = vec![
            self.title.clone(),
            format!(
                "t = {:.2} s   {:.0} fps   sim {:.1} ms/frame   fracture events {}   pieces {}",
                w.state.time,
                self.fps,
                self.sim_ms,
                w.events.len(),
                w.model.body_count()
            ),
            format!("WebGPU: {}", self.adapter),
        ];
        lines.extend(self.notes.iter().cloned());
        lines
    }

    async fn draw(&mut self) -> Result<(), JsValue> {
        let m: &Model<f32> = &self.world.model;
        if self.renderer.has_moving_colliders() {
            self.renderer.set_colliders(m, self.world.state.time);
        }
        let lines = self.overlay();
        self.renderer.set_overlay(&lines, 1);
        let gpu = self.world.gpu_solver().ok_or_else(|| js_err("the page runs on the GPU solver"))?;
        let positions = Positions::Buffer(gpu.position_buffer());
        match &mut self.present {
            Present::Canvas { surface, config, view_format, msaa, depth } => {
                let frame = match surface.get_current_texture() {
                    wgpu::CurrentSurfaceTexture::Success(f) | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
                    wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                        surface.configure(&self.device, config);
                        return Ok(());
                    }
                    other => return Err(js_err(format!("no canvas texture to draw into: {other:?}"))),
                };
                let view = frame
                    .texture
                    .create_view(&wgpu::TextureViewDescriptor { format: Some(*view_format), ..Default::default() });
                let mut enc = self.device.create_command_encoder(&Default::default());
                let (camera, v) = (&self.camera, &self.view);
                self.renderer.encode(&mut enc, msaa, &view, depth, self.size, camera, v, positions);
                self.queue.submit([enc.finish()]);
                self.queue.present(frame);
            }
            Present::Copy { target, ctx } => {
                let (d, q) = (&self.device, &self.queue);
                let image = target
                    .render_async(d, q, &mut self.renderer, &self.camera, &self.view, positions)
                    .await
                    .map_err(js_err)?;
                let data = web_sys::ImageData::new_with_u8_clamped_array_and_sh(
                    wasm_bindgen::Clamped(&image.rgba),
                    image.width,
                    image.height,
                )?;
                ctx.put_image_data(&data, 0.0, 0.0)?;
            }
        }
        self.frames += 1;
        Ok(())
    }
}
