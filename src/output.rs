//! Pictures of a run, headless (feature `render`): [`FrameRenderer`] draws a model with the wgpu renderer
//! ([`crate::gpu::render`]) into an offscreen target, [`save_png`] and [`GifWriter`] write the frames, and
//! [`Frames`] does all three for a run that may have no GPU at all: without an adapter it keeps the reason and
//! writes nothing, so the simulation still runs and the caller can say why nothing was drawn.
//!
//! ```no_run
//! use fissure::output::Frames;
//! use fissure::scene::Scene;
//!
//! let scene = Scene::load("scenes/ball_drop.toml")?;
//! let mut world = scene.world::<f32>()?;
//! let mut frames = Frames::headless("frames", 640, 360, &world.model, &world.state)?.with_gif(30.0)?;
//! for _ in 0..60 {
//!     world.advance(1.0 / 60.0, scene.solver.dt)?;
//!     frames.capture(&world.model, &world.state, &[format!("t = {:.2} s", world.state.time)])?;
//! }
//! frames.finish()?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::gpu::render::{Camera, Image, Offscreen, Positions, Renderer, View};
use crate::gpu::{GpuContext, GpuError};
use crate::{Model, State};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Something went wrong writing pictures.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The PNG or GIF encoder failed.
    #[error("cannot encode {path}: {message}")]
    Encode {
        /// The file.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
    /// The GPU failed while drawing.
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io { path: path.to_path_buf(), source }
}

/// Writes `image` as an 8-bit sRGB RGBA PNG.
pub fn save_png(image: &Image, path: impl AsRef<Path>) -> Result<(), OutputError> {
    let path = path.as_ref();
    let file = File::create(path).map_err(io_err(path))?;
    let mut enc = png::Encoder::new(BufWriter::new(file), image.width, image.height);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let encode = |e: png::EncodingError| OutputError::Encode { path: path.to_path_buf(), message: e.to_string() };
    let mut w = enc.write_header().map_err(encode)?;
    w.write_image_data(&image.rgba).map_err(encode)?;
    w.finish().map_err(encode)
}

/// Reads an 8-bit RGB or RGBA PNG (the frames [`save_png`] writes) back into an [`Image`].
pub fn load_png(path: impl AsRef<Path>) -> Result<Image, OutputError> {
    let path = path.as_ref();
    let bad = |message: String| OutputError::Encode { path: path.to_path_buf(), message };
    let file = File::open(path).map_err(io_err(path))?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(file)).read_info().map_err(|e| bad(e.to_string()))?;
    let mut buf = vec![0; dec.output_buffer_size().ok_or_else(|| bad("image too large".into()))?];
    let info = dec.next_frame(&mut buf).map_err(|e| bad(e.to_string()))?;
    let rgba = match (info.color_type, info.bit_depth) {
        (png::ColorType::Rgba, png::BitDepth::Eight) => buf[..info.buffer_size()].to_vec(),
        (png::ColorType::Rgb, png::BitDepth::Eight) => {
            buf[..info.buffer_size()].chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect()
        }
        other => return Err(bad(format!("unsupported PNG layout {other:?}"))),
    };
    Ok(Image { width: info.width, height: info.height, rgba })
}

/// An animated GIF written frame by frame (each frame quantised to its own 256-colour palette, looping).
pub struct GifWriter {
    encoder: gif::Encoder<BufWriter<File>>,
    path: PathBuf,
    size: (u16, u16),
    delay: u16,
    frames: usize,
}

impl GifWriter {
    /// A GIF of `width × height` playing at `fps` frames per second (GIF delays are whole hundredths).
    pub fn create(path: impl AsRef<Path>, width: u32, height: u32, fps: f64) -> Result<GifWriter, OutputError> {
        let path = path.as_ref().to_path_buf();
        let bad = |message: String| OutputError::Encode { path: path.clone(), message };
        let (w, h) = (
            u16::try_from(width).map_err(|_| bad(format!("width {width} > 65535")))?,
            u16::try_from(height).map_err(|_| bad(format!("height {height} > 65535")))?,
        );
        let file = File::create(&path).map_err(io_err(&path))?;
        let mut encoder = gif::Encoder::new(BufWriter::new(file), w, h, &[]).map_err(|e| bad(e.to_string()))?;
        encoder.set_repeat(gif::Repeat::Infinite).map_err(|e| bad(e.to_string()))?;
        let delay = (100.0 / fps.max(1.0)).round().clamp(2.0, 65535.0) as u16;
        Ok(GifWriter { encoder, path, size: (w, h), delay, frames: 0 })
    }

    /// Appends a frame of the GIF's size.
    pub fn add(&mut self, image: &Image) -> Result<(), OutputError> {
        let bad = |message: String| OutputError::Encode { path: self.path.clone(), message };
        if (image.width, image.height) != (self.size.0 as u32, self.size.1 as u32) {
            return Err(bad(format!(
                "frame is {}×{}, the GIF {}×{}",
                image.width, image.height, self.size.0, self.size.1
            )));
        }
        let mut rgba = image.rgba.clone();
        let mut frame = gif::Frame::from_rgba_speed(self.size.0, self.size.1, &mut rgba, 10);
        frame.delay = self.delay;
        self.encoder.write_frame(&frame).map_err(|e| bad(e.to_string()))?;
        self.frames += 1;
        Ok(())
    }

    /// Frames written so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Writes the trailer and closes the file.
    pub fn finish(self) -> Result<PathBuf, OutputError> {
        let path = self.path;
        let mut w = self.encoder.into_inner().map_err(io_err(&path))?;
        w.flush().map_err(io_err(&path))?;
        Ok(path)
    }
}

/// A device, a renderer and an offscreen target: draws a model's CPU state (or a GPU solver's buffer) to images.
pub struct FrameRenderer {
    /// The device it draws on.
    pub ctx: GpuContext,
    /// The renderer.
    pub renderer: Renderer,
    /// The target.
    pub target: Offscreen,
    /// The camera (framing the scene at creation).
    pub camera: Camera,
    /// What is drawn.
    pub view: View,
}

impl FrameRenderer {
    /// On a new device (the best adapter: a GPU, else lavapipe). Fails with [`GpuError::NoAdapter`] (whose
    /// message says what to install) when there is none.
    pub fn new(width: u32, height: u32, model: &Model<f32>, state: &State<f32>) -> Result<Self, GpuError> {
        Ok(Self::with_context(GpuContext::new()?, width, height, model, state))
    }

    /// On a device the caller made (share it with a [`crate::gpu::GpuSolver`] to draw its buffer in place).
    pub fn with_context(ctx: GpuContext, width: u32, height: u32, model: &Model<f32>, state: &State<f32>) -> Self {
        let mut renderer = Renderer::new(&ctx.device, &ctx.queue, Offscreen::FORMAT);
        renderer.set_model(model, state.time);
        let target = Offscreen::new(&ctx.device, width, height);
        FrameRenderer { renderer, target, camera: Camera::framing(model, state), view: View::default(), ctx }
    }

    /// Takes a changed model (after fracture events); moving colliders are followed every frame anyway.
    pub fn model_changed(&mut self, model: &Model<f32>, time: f64) {
        self.renderer.set_model(model, time);
    }

    /// Draws CPU state with `overlay` text in the corner.
    pub fn render(&mut self, model: &Model<f32>, state: &State<f32>, overlay: &[String]) -> Result<Image, GpuError> {
        if self.renderer.has_moving_colliders() {
            self.renderer.set_colliders(model, state.time);
        }
        if self.view.strain {
            self.renderer.color_by_strain(model, &state.particle_q);
        }
        self.renderer.upload_positions(state);
        self.draw(Positions::Uploaded, overlay)
    }

    /// Draws positions already on this device (a GPU solver's [`crate::gpu::GpuSolver::position_buffer`]).
    pub fn render_buffer(&mut self, positions: &wgpu::Buffer, overlay: &[String]) -> Result<Image, GpuError> {
        self.draw(Positions::Buffer(positions), overlay)
    }

    fn draw(&mut self, positions: Positions<'_>, overlay: &[String]) -> Result<Image, GpuError> {
        let scale = if self.target.size()[0] >= 1000 { 2 } else { 1 };
        self.renderer.set_overlay(overlay, scale);
        self.target.render(&self.ctx.device, &self.ctx.queue, &mut self.renderer, &self.camera, &self.view, positions)
    }
}

use crate::gpu::wgpu;

/// PNG frames (and optionally a GIF) of a run in a directory: `frame_0001.png`, … and `run.gif`. Without an
/// adapter, [`Frames::headless`] still succeeds: [`Frames::unavailable`] says why, and nothing is drawn.
pub struct Frames {
    dir: PathBuf,
    renderer: Result<FrameRenderer, GpuError>,
    gif: Option<GifWriter>,
    png: bool,
    written: Vec<PathBuf>,
    index: usize,
    size: (u32, u32),
}

impl Frames {
    /// Frames of `width × height` into `dir` (created), on a new device.
    pub fn headless(
        dir: impl AsRef<Path>,
        width: u32,
        height: u32,
        model: &Model<f32>,
        state: &State<f32>,
    ) -> Result<Frames, OutputError> {
        let renderer = FrameRenderer::new(width, height, model, state);
        Self::with_renderer(dir, renderer, width, height)
    }

    /// Frames drawn by `renderer` (or, if it is an error, the reason nothing can be drawn).
    pub fn with_renderer(
        dir: impl AsRef<Path>,
        renderer: Result<FrameRenderer, GpuError>,
        width: u32,
        height: u32,
    ) -> Result<Frames, OutputError> {
        let dir = dir.as_ref().to_path_buf();
        std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
        Ok(Frames { dir, renderer, gif: None, png: true, written: Vec::new(), index: 0, size: (width, height) })
    }

    /// Also writes `run.gif` at `fps` (nothing if there is no adapter).
    pub fn with_gif(mut self, fps: f64) -> Result<Frames, OutputError> {
        if self.renderer.is_ok() {
            let path = self.dir.join("run.gif");
            self.gif = Some(GifWriter::create(path, self.size.0, self.size.1, fps)?);
        }
        Ok(self)
    }

    /// Writes no PNG files (only the GIF, if any).
    pub fn without_png(mut self) -> Frames {
        self.png = false;
        self
    }

    /// Why nothing is drawn (`None`: frames are drawn).
    pub fn unavailable(&self) -> Option<&GpuError> {
        self.renderer.as_ref().err()
    }

    /// The renderer, if there is an adapter (to change the camera or the view).
    pub fn renderer(&mut self) -> Option<&mut FrameRenderer> {
        self.renderer.as_mut().ok()
    }

    /// The directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// PNG files written so far.
    pub fn written(&self) -> &[PathBuf] {
        &self.written
    }

    /// Draws and writes the next frame of CPU state (nothing without an adapter). Returns the image.
    pub fn capture(
        &mut self,
        model: &Model<f32>,
        state: &State<f32>,
        overlay: &[String],
    ) -> Result<Option<Image>, OutputError> {
        let Ok(r) = self.renderer.as_mut() else { return Ok(None) };
        let image = r.render(model, state, overlay)?;
        self.write(image).map(Some)
    }

    /// Draws and writes the next frame from positions on the renderer's device.
    pub fn capture_buffer(
        &mut self,
        positions: &wgpu::Buffer,
        overlay: &[String],
    ) -> Result<Option<Image>, OutputError> {
        let Ok(r) = self.renderer.as_mut() else { return Ok(None) };
        let image = r.render_buffer(positions, overlay)?;
        self.write(image).map(Some)
    }

    fn write(&mut self, image: Image) -> Result<Image, OutputError> {
        self.index += 1;
        if self.png {
            let path = self.dir.join(format!("frame_{:04}.png", self.index));
            save_png(&image, &path)?;
            self.written.push(path);
        }
        if let Some(g) = &mut self.gif {
            g.add(&image)?;
        }
        Ok(image)
    }

    /// Takes a changed model (after fracture events).
    pub fn model_changed(&mut self, model: &Model<f32>, time: f64) {
        if let Ok(r) = self.renderer.as_mut() {
            r.model_changed(model, time);
        }
    }

    /// Closes the GIF. Returns its path, if one was written.
    pub fn finish(self) -> Result<Option<PathBuf>, OutputError> {
        self.gif.map(GifWriter::finish).transpose()
    }
}
