//! The interactive viewer (feature `viewer`): a window (winit; X11 on Linux) showing a [`World`] as it runs, drawn
//! by the wgpu renderer ([`crate::gpu::render`]) and stepped on the CPU, so fracture, puncture and every
//! integrator work.
//!
//! | input | action |
//! |---|---|
//! | left drag on a body | move the mass point under the cursor with it (held as a moving pin, at most 2 m/s): pulled past its strength, a cloth tears |
//! | left drag elsewhere | orbit the camera; wheel: zoom |
//! | right click on a body | puncture it there: the vertex under the cursor breaks out as a core block |
//! | `space` / `n` | pause and resume / advance one frame while paused |
//! | `w` / `p` | wind on and off / gas pressure on and off |
//! | `f` / `v` / `s` | wireframe of springs / mass points / shaded surfaces |
//! | `c` / `k` | colour by strain (blue at rest to red at the tear limit) or by body / crack edges on and off |
//! | `r` / `esc`, `q` | restart the scene / quit |
//!
//! The overlay shows simulated time, the cost of the last frame per stage (springs, pressure, wind, collisions,
//! integration, fracture), frames per second and the fracture events so far.
//!
//! For tests and CI, [`ViewerOptions::screenshot`] writes the frame shown after [`ViewerOptions::exit_after`]
//! frames to a PNG and closes the window: read back from the window's own surface texture when the driver
//! allows (lavapipe on Xvfb does), otherwise drawn again offscreen from the same state and camera.

mod drag;
mod pace;
mod script;
use drag::Drag;
use pace::Pacer;
pub use script::Action;

use crate::gpu::render::{Camera, Offscreen, Positions, Readback, Renderer, View, samples_for, targets};
use crate::gpu::{GpuError, wgpu};
use crate::output::{OutputError, save_png};
use crate::{FractureKind, Stage, StepError, TopologyDelta, World};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// Settings of a viewer session.
#[derive(Clone, Debug)]
pub struct ViewerOptions {
    /// Window title.
    pub title: String,
    /// Window size \[px\].
    pub size: [u32; 2],
    /// Simulated time per drawn frame \[s\] when not [`ViewerOptions::real_time`], and per frame advanced with
    /// the `n` key. Default 1/60.
    pub frame_time: f64,
    /// Keep simulated time in pace with the wall clock (default): each frame advances the simulation by the wall
    /// time since the last one, in whole steps of `dt` (the remainder carried to the next frame), so a scene runs
    /// at its real speed whatever the frame rate. A frame advances at most [`MAX_LAG_FRAMES`] × `frame_time`: a
    /// machine too slow for the scene shows it in slow motion instead of falling ever further behind. False:
    /// every frame advances `frame_time` (reproducible: a scripted session replays the same).
    pub real_time: bool,
    /// Close after this many frames (for tests and screenshots).
    pub exit_after: Option<usize>,
    /// Write the last frame here before closing.
    pub screenshot: Option<PathBuf>,
    /// Start paused.
    pub paused: bool,
    /// Input to replay, by frame number (for tests and demos): what a user would do with mouse and keys.
    pub script: Vec<(usize, Action)>,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        ViewerOptions {
            title: "fissure".into(),
            size: [1280, 720],
            frame_time: 1.0 / 60.0,
            real_time: true,
            exit_after: None,
            screenshot: None,
            paused: false,
            script: Vec::new(),
        }
    }
}

/// In real time ([`ViewerOptions::real_time`]), the most simulated time one frame catches up, in frames.
pub const MAX_LAG_FRAMES: f64 = 4.0;

/// What a session did.
#[derive(Clone, Debug)]
pub struct ViewerReport {
    /// Frames drawn.
    pub frames: usize,
    /// Simulated time at the end \[s\].
    pub time: f64,
    /// Simulated time advanced while the simulation ran (not paused) \[s\], and the wall time of those frames
    /// \[s\]: their ratio is the real-time factor (1: the scene ran at its real speed).
    pub simulated: f64,
    /// See `simulated`.
    pub wall: f64,
    /// Mean time per frame spent simulating and drawing \[ms\] (frames that simulated; drawing: all frames).
    pub sim_ms: f64,
    /// See `sim_ms`.
    pub draw_ms: f64,
    /// Fracture events (including punctures).
    pub events: usize,
    /// The adapter drawn on.
    pub adapter: String,
    /// The screenshot written, if asked for; and whether it was read from the window's surface itself.
    pub screenshot: Option<(PathBuf, bool)>,
}

/// Why the viewer could not run.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// No window system (no `DISPLAY` or `WAYLAND_DISPLAY`, or the connection failed).
    #[error("cannot open a window: {0}")]
    NoDisplay(String),
    /// The GPU side failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The window's surface could not be used.
    #[error("cannot draw into the window: {0}")]
    Surface(String),
    /// The simulation failed.
    #[error(transparent)]
    Step(#[from] StepError),
    /// The screenshot could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// Whether a window can probably be opened (on Linux: `DISPLAY` or `WAYLAND_DISPLAY` is set; elsewhere: yes).
/// Examples use it to choose between the window and headless frames.
pub fn display_available() -> bool {
    if cfg!(target_os = "linux") || cfg!(target_os = "freebsd") {
        ["DISPLAY", "WAYLAND_DISPLAY"].iter().any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()))
    } else {
        true
    }
}

/// Opens a window and runs `world` interactively, stepping by at most `dt` \[s\]; returns when the window closes.
/// `restart` rebuilds the world for the `r` key.
pub fn run(
    world: World<f32>,
    dt: f64,
    restart: impl Fn() -> Option<World<f32>> + 'static,
    options: ViewerOptions,
) -> Result<ViewerReport, ViewerError> {
    if !display_available() {
        return Err(ViewerError::NoDisplay("no DISPLAY or WAYLAND_DISPLAY is set".into()));
    }
    let event_loop = EventLoop::new().map_err(|e| ViewerError::NoDisplay(e.to_string()))?;
    let mut app = App {
        options,
        world,
        dt,
        restart: Box::new(restart),
        gfx: None,
        error: None,
        camera: Camera::default(),
        view: View::default(),
        paused: false,
        step_once: false,
        cursor: (0.0, 0.0),
        drag: None,
        orbit_from: None,
        frames: 0,
        saved_wind: None,
        saved_gas: None,
        last_frame: Instant::now(),
        fps: 0.0,
        sim_ms: 0.0,
        draw_ms: 0.0,
        stage_ms: [0.0; Stage::ALL.len()],
        screenshot: None,
        last_sim: None,
        pacer: Pacer::default(),
        pace: 0.0,
        totals: Totals::default(),
    };
    app.paused = app.options.paused;
    app.camera = Camera::framing(&app.world.model, &app.world.state);
    event_loop.run_app(&mut app).map_err(|e| ViewerError::NoDisplay(e.to_string()))?;
    if let Some(e) = app.error {
        return Err(e);
    }
    let t = &app.totals;
    Ok(ViewerReport {
        frames: app.frames,
        time: app.world.state.time,
        simulated: t.simulated,
        wall: t.wall,
        sim_ms: if t.sim_frames > 0 { t.sim_ms / t.sim_frames as f64 } else { 0.0 },
        draw_ms: if app.frames > 0 { t.draw_ms / app.frames as f64 } else { 0.0 },
        events: app.world.events.len(),
        adapter: app.gfx.as_ref().map(|g| g.adapter.clone()).unwrap_or_default(),
        screenshot: app.screenshot,
    })
}

struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    renderer: Renderer,
    msaa: wgpu::TextureView,
    depth: wgpu::TextureView,
    adapter: String,
}

struct App {
    options: ViewerOptions,
    world: World<f32>,
    dt: f64,
    restart: Box<dyn Fn() -> Option<World<f32>>>,
    gfx: Option<Gfx>,
    error: Option<ViewerError>,
    camera: Camera,
    view: View,
    paused: bool,
    step_once: bool,
    cursor: (f32, f32),
    drag: Option<Drag>,
    orbit_from: Option<(f32, f32)>,
    frames: usize,
    saved_wind: Option<crate::WindField>,
    saved_gas: Option<Vec<f32>>,
    last_frame: Instant,
    fps: f64,
    sim_ms: f64,
    draw_ms: f64,
    stage_ms: [f64; Stage::ALL.len()],
    screenshot: Option<(PathBuf, bool)>,
    /// When the last frame's simulation started (real time; `None` after a pause).
    last_sim: Option<Instant>,
    pacer: Pacer,
    /// Simulated time per wall time over the last frames (smoothed).
    pace: f64,
    totals: Totals,
}

/// Sums over the session, for [`ViewerReport`].
#[derive(Default)]
struct Totals {
    simulated: f64,
    wall: f64,
    sim_ms: f64,
    sim_frames: usize,
    draw_ms: f64,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewerError) {
        self.error.get_or_insert(e);
        event_loop.exit();
    }

    fn init(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewerError> {
        let [w, h] = self.options.size;
        let attrs = Window::default_attributes()
            .with_title(self.options.title.clone())
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = Arc::new(event_loop.create_window(attrs).map_err(|e| ViewerError::NoDisplay(e.to_string()))?);
        let instance = wgpu::Instance::new(crate::gpu::instance_descriptor());
        let surface = instance.create_surface(window.clone()).map_err(|e| ViewerError::Surface(e.to_string()))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter { details: format!("none can draw into this window: {e}") })?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("fissure viewer"),
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device { adapter: info.name.clone(), message: e.to_string() })?;
        let caps = surface.get_capabilities(&adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or(caps.formats.first().copied())
            .ok_or_else(|| ViewerError::Surface("the surface offers no format".into()))?;
        let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
        if caps.usages.contains(wgpu::TextureUsages::COPY_SRC) {
            usage |= wgpu::TextureUsages::COPY_SRC; // screenshots straight from the window
        }
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&device, &config);
        let samples = samples_for(&info);
        let mut renderer = Renderer::with_samples(&device, &queue, format, samples);
        renderer.set_model(&self.world.model, self.world.state.time);
        let (msaa, depth) = targets(&device, format, config.width, config.height, samples);
        let adapter_name = format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type);
        self.gfx = Some(Gfx { window, surface, device, queue, config, renderer, msaa, depth, adapter: adapter_name });
        Ok(())
    }

    fn resize(&mut self, w: u32, h: u32) {
        if let Some(g) = &mut self.gfx
            && w > 0
            && h > 0
        {
            g.config.width = w;
            g.config.height = h;
            g.surface.configure(&g.device, &g.config);
            (g.msaa, g.depth) = targets(&g.device, g.config.format, w, h, g.renderer.samples());
        }
    }

    fn size(&self) -> (f32, f32) {
        self.gfx.as_ref().map_or((1.0, 1.0), |g| (g.config.width as f32, g.config.height as f32))
    }

    /// The particle under pixel `(x, y)` ([`Camera::pick`]).
    fn pick(&self, x: f32, y: f32) -> Option<usize> {
        let (w, h) = self.size();
        self.camera.pick(&self.world.model, &self.world.state.particle_q, x, y, w, h)
    }

    /// Where the centre of body `b` is on screen \[px\].
    fn body_center_px(&self, b: usize) -> Option<(f32, f32)> {
        let (w, h) = self.size();
        self.camera.body_pixel(&self.world.model, &self.world.state.particle_q, b as u32, w, h)
    }

    fn puncture(&mut self, x: f32, y: f32) {
        let Some(v) = self.pick(x, y) else { return };
        if self.world.break_core(v).is_ok_and(|events| !events.is_empty()) {
            self.model_changed();
        }
    }

    fn model_changed(&mut self) {
        if let Some(g) = &mut self.gfx {
            g.renderer.set_model(&self.world.model, self.world.state.time);
        }
    }

    fn toggle_wind(&mut self) {
        let m = &mut self.world.model;
        if let Some(w) = m.wind.take() {
            self.saved_wind = Some(w);
        } else {
            m.wind = self.saved_wind.take();
        }
        self.world.solver.notify_model_changed(&self.world.model, &TopologyDelta::whole());
    }

    fn toggle_pressure(&mut self) {
        let m = &mut self.world.model;
        match self.saved_gas.take() {
            Some(g) if g.len() == m.body_gas_amount.len() => m.body_gas_amount = g,
            Some(_) => {}
            None => {
                self.saved_gas = Some(m.body_gas_amount.clone());
                m.body_gas_amount.iter_mut().for_each(|g| *g = 0.0);
            }
        }
        self.world.solver.notify_model_changed(&self.world.model, &TopologyDelta::whole());
    }

    fn restart(&mut self) {
        if let Some(w) = (self.restart)() {
            self.world = w;
            self.saved_wind = None;
            self.saved_gas = None;
            self.drag = None;
            self.model_changed();
        }
    }

    /// One frame of simulation through [`World::advance`], the grabbed particle's pin first set to move towards
    /// the cursor over the frame (the solver moves pinned particles exactly as their handle says, at every step).
    /// In real time the frame covers the wall time since the last one (see [`ViewerOptions::real_time`]);
    /// `step`: one `frame_time` whatever the clock (the `n` key).
    fn simulate(&mut self, step: bool) -> Result<(), StepError> {
        let t0 = Instant::now();
        let frame_time = self.options.frame_time;
        // The wall time this frame stands for: since the last frame's simulation (the first: one frame time).
        let wall = self.last_sim.map_or(frame_time, |t| t0.duration_since(t).as_secs_f64());
        let span =
            if self.options.real_time && !step { self.pacer.span(wall, frame_time, self.dt) } else { frame_time };
        self.totals.wall += wall;
        let pace = span / wall.max(1e-9);
        self.pace = if self.pace == 0.0 { pace } else { 0.9 * self.pace + 0.1 * pace };
        self.last_sim = Some(t0);
        self.world.reset_timers();
        if span > 0.0 {
            self.move_pin(span);
            if self.world.advance(span, self.dt)?.topology_changed {
                self.model_changed();
            }
        }
        self.totals.simulated += span;
        self.sim_ms = t0.elapsed().as_secs_f64() * 1e3;
        // Drawing follows, on the same cores: the solver's helpers sleep rather than spin through it.
        self.world.rest();
        self.totals.sim_ms += self.sim_ms;
        self.totals.sim_frames += 1;
        let t = self.world.timers();
        for (k, s) in Stage::ALL.iter().enumerate() {
            self.stage_ms[k] = t.time(*s).as_secs_f64() * 1e3;
        }
        Ok(())
    }

    fn overlay(&self) -> Vec<String> {
        let w = &self.world;
        let count = |k| w.events.iter().filter(|e| e.kind == k).count();
        let stages: Vec<String> = Stage::ALL
            .iter()
            .zip(&self.stage_ms)
            .filter(|(_, ms)| **ms > 0.0)
            .map(|(s, ms)| format!("{} {ms:.1}", s.name()))
            .collect();
        let on = |b: bool| if b { "on" } else { "off" };
        vec![
            format!(
                "t = {:.3} s  {}  {:.0} fps  {}  sim {:.1} ms/frame  draw {:.1} ms",
                w.state.time,
                if self.paused { "PAUSED" } else { "running" },
                self.fps,
                format!("{:.2}x real time{}", self.pace, if self.options.real_time { "" } else { " (fixed steps)" }),
                self.sim_ms,
                self.draw_ms
            ),
            format!("stages [ms]: {}", if stages.is_empty() { "-".into() } else { stages.join("  ") }),
            format!(
                "fracture events {} (spring {}, core {})  bodies {}  particles {}",
                w.events.len(),
                count(FractureKind::Spring),
                count(FractureKind::Core),
                w.model.body_count(),
                w.model.particle_count()
            ),
            format!(
                "[space] pause [n] step [w] wind {} [p] pressure {} [f] wireframe {} [v] points [c] strain {} [k] cracks {} [r] restart",
                on(w.model.wind.is_some()),
                on(self.saved_gas.is_none() && w.model.has_pressure()),
                on(self.view.wireframe),
                on(self.view.strain),
                on(self.view.cracks)
            ),
            "mouse: left drag a body / orbit, wheel zoom, right click puncture".into(),
        ]
    }

    fn play_script(&mut self, event_loop: &ActiveEventLoop) {
        let due: Vec<Action> =
            self.options.script.iter().filter(|(f, _)| *f == self.frames).map(|(_, a)| a.clone()).collect();
        for a in due {
            match a {
                Action::Key(k) if k == " " => self.key(event_loop, &Key::Named(NamedKey::Space)),
                Action::Key(k) => self.key(event_loop, &Key::Character(k.as_str().into())),
                Action::Puncture(x, y) => self.puncture(x, y),
                Action::PunctureBody(b) => {
                    if let Some((x, y)) = self.body_center_px(b) {
                        self.puncture(x, y);
                    }
                }
                Action::DragBody(b, dx, dy) => {
                    if let Some((x, y)) = self.body_center_px(b)
                        && let Some(i) = self.pick(x, y)
                    {
                        let p = self.world.state.particle_q[i];
                        self.cursor = (x + dx, y + dy);
                        let target = self.drag_target(p);
                        self.grab(i, target);
                    }
                }
                Action::Release => self.release(),
            }
        }
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewerError> {
        self.play_script(event_loop);
        if !self.paused || self.step_once {
            let step = std::mem::take(&mut self.step_once);
            self.simulate(step)?;
        }
        if self.paused {
            self.last_sim = None; // the time paused is not to be caught up
        }
        let overlay = self.overlay();
        let now = Instant::now();
        let dt = now.duration_since(self.last_frame).as_secs_f64();
        self.last_frame = now;
        self.fps = if self.fps == 0.0 { 1.0 / dt.max(1e-6) } else { 0.9 * self.fps + 0.1 / dt.max(1e-6) };
        let t0 = Instant::now();
        let last = self.options.exit_after.is_some_and(|n| self.frames + 1 >= n);
        let g = self.gfx.as_mut().expect("initialised");
        if self.view.strain {
            g.renderer.color_by_strain(&self.world.model, &self.world.state.particle_q);
        }
        g.renderer.upload_positions(&self.world.state);
        g.renderer.set_overlay(&overlay, if g.config.width >= 1600 { 2 } else { 1 });
        let frame = match g.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f) | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                g.surface.configure(&g.device, &g.config);
                return Ok(());
            }
            other => {
                if last {
                    return Err(ViewerError::Surface(format!("no frame to draw into: {other:?}")));
                }
                return Ok(()); // occluded or timed out: try again next time
            }
        };
        let view = frame.texture.create_view(&Default::default());
        let mut enc = g.device.create_command_encoder(&Default::default());
        let size = [g.config.width, g.config.height];
        g.renderer.encode(&mut enc, &g.msaa, &view, &g.depth, size, &self.camera, &self.view, Positions::Uploaded);
        let readback =
            (last && self.options.screenshot.is_some() && g.config.usage.contains(wgpu::TextureUsages::COPY_SRC))
                .then(|| Readback::new(&g.device, size[0], size[1]));
        if let Some(r) = &readback {
            r.encode_copy(&mut enc, &frame.texture);
        }
        g.queue.submit([enc.finish()]);
        let shot = match readback {
            Some(r) => Some((r.read(&g.device, g.config.format)?, true)),
            None => None,
        };
        g.queue.present(frame);
        self.draw_ms = t0.elapsed().as_secs_f64() * 1e3;
        self.totals.draw_ms += self.draw_ms;
        self.frames += 1;
        if last {
            if let Some(path) = self.options.screenshot.clone() {
                let (image, from_window) = match shot {
                    Some(s) => s,
                    None => {
                        // The surface cannot be copied from: draw the same frame offscreen.
                        let mut r = Renderer::new(&g.device, &g.queue, Offscreen::FORMAT);
                        r.set_model(&self.world.model, self.world.state.time);
                        if self.view.strain {
                            r.color_by_strain(&self.world.model, &self.world.state.particle_q);
                        }
                        r.upload_positions(&self.world.state);
                        r.set_overlay(&overlay, 1);
                        let mut target = Offscreen::new(&g.device, size[0], size[1]);
                        let image = target.render(
                            &g.device,
                            &g.queue,
                            &mut r,
                            &self.camera,
                            &self.view,
                            Positions::Uploaded,
                        )?;
                        (image, false)
                    }
                };
                save_png(&image, &path)?;
                self.screenshot = Some((path, from_window));
            }
            event_loop.exit();
        }
        Ok(())
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) {
        match key {
            Key::Named(NamedKey::Space) => self.paused = !self.paused,
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Character(c) => match c.as_str() {
                "q" => event_loop.exit(),
                "n" => {
                    self.paused = true;
                    self.step_once = true;
                }
                "w" => self.toggle_wind(),
                "p" => self.toggle_pressure(),
                "f" => self.view.wireframe = !self.view.wireframe,
                "c" => {
                    self.view.strain = !self.view.strain;
                    if !self.view.strain {
                        self.model_changed(); // the body colours back
                    }
                }
                "k" => self.view.cracks = !self.view.cracks,
                "v" => self.view.points = !self.view.points,
                "s" => self.view.surfaces = !self.view.surfaces,
                "r" => self.restart(),
                _ => {}
            },
            _ => {}
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gfx.is_none()
            && let Err(e) = self.init(event_loop)
        {
            self.fail(event_loop, e);
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if self.gfx.is_none() {
            return;
        }
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(s) => self.resize(s.width, s.height),
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(event_loop, &event.logical_key)
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = (position.x as f32, position.y as f32);
                if let Some(d) = &self.drag {
                    let target = self.drag_target(d.plane_point);
                    if let Some(d) = &mut self.drag {
                        d.target = target;
                    }
                } else if let Some((x0, y0)) = self.orbit_from {
                    self.camera.orbit(-(self.cursor.0 - x0) * 0.008, (self.cursor.1 - y0) * 0.008);
                    self.orbit_from = Some(self.cursor);
                }
            }
            WindowEvent::MouseInput { state, button, .. } => match (button, state) {
                (MouseButton::Left, ElementState::Pressed) => {
                    if let Some(i) = self.pick(self.cursor.0, self.cursor.1) {
                        let p = self.world.state.particle_q[i];
                        self.grab(i, p);
                    } else {
                        self.orbit_from = Some(self.cursor);
                    }
                }
                (MouseButton::Left, ElementState::Released) => {
                    self.release();
                    self.orbit_from = None;
                }
                (MouseButton::Right, ElementState::Pressed) => self.puncture(self.cursor.0, self.cursor.1),
                _ => {}
            },
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.camera.zoom(0.9f32.powf(lines));
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(g) = &self.gfx {
            g.window.request_redraw();
        }
    }
}
