//! What the scene examples share: the choice between a window and headless frames, and the headless frames.
#![allow(dead_code)]

use fissure::output::Frames;
use fissure::scene::Scene;
use fissure::{Model, State};
use std::path::{Path, PathBuf};

/// The workspace root (scene files live in `scenes/`).
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A scene file of the repository.
pub fn scene_path(name: &str) -> PathBuf {
    root().join("scenes").join(name)
}

/// Whether to open a window: a display exists and `--headless` was not given.
pub fn want_window(args: &[String]) -> bool {
    fissure::viewer::display_available() && !args.iter().any(|a| a == "--headless")
}

/// Opens the viewer on a scene file (the `r` key restarts it).
pub fn open_window(path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let scene = Scene::load(path)?;
    let world = scene.world::<f32>()?;
    let again = scene.clone();
    let options = fissure::viewer::ViewerOptions { title: format!("fissure: {}", scene.title), ..Default::default() };
    let r = fissure::viewer::run(world, scene.solver.dt, move || again.world().ok(), options)?;
    println!("{} frames on {}, t = {:.3} s, {} fracture events", r.frames, r.adapter, r.time, r.events);
    Ok(())
}

/// Headless pictures of an example: every `every`-th frame as a PNG (and all of them drawn into a GIF at
/// `fps / every`) in `target/examples/<name>/`. Without a GPU adapter it says why and draws nothing.
pub struct Pictures {
    frames: Frames,
    every: usize,
}

impl Pictures {
    pub fn new(
        name: &str,
        every: usize,
        fps: f64,
        model: &Model<f32>,
        state: &State<f32>,
    ) -> Result<Pictures, Box<dyn std::error::Error>> {
        let dir = root().join("target/examples").join(name);
        let frames = Frames::headless(&dir, 640, 360, model, state)?.with_gif(fps / every.max(1) as f64)?;
        match frames.unavailable() {
            Some(why) => eprintln!("{name}: no frames will be drawn: {why}"),
            None => println!("{name}: frames go to {}", dir.display()),
        }
        Ok(Pictures { frames, every: every.max(1) })
    }

    /// Called once per simulated frame `k` (from 1); draws every `every`-th.
    pub fn frame(
        &mut self,
        k: usize,
        model: &Model<f32>,
        state: &State<f32>,
        overlay: &[String],
    ) -> Result<(), Box<dyn std::error::Error>> {
        if k.is_multiple_of(self.every) {
            self.frames.capture(model, state, overlay)?;
        }
        Ok(())
    }

    pub fn model_changed(&mut self, model: &Model<f32>, time: f64) {
        self.frames.model_changed(model, time);
    }

    /// Closes the GIF; returns the PNGs written and the reason none were, if so.
    pub fn finish(self) -> Result<(Vec<PathBuf>, Option<String>), Box<dyn std::error::Error>> {
        let pngs = self.frames.written().to_vec();
        let why = self.frames.unavailable().map(|e| e.to_string());
        if let Some(gif) = self.frames.finish()? {
            println!("animation: {}", gif.display());
        }
        Ok((pngs, why))
    }
}

/// Every PNG in `pngs` passes the pixel check of [`fissure::gpu::render::Image::check_not_blank`] with the body
/// covering at least `min_body` of the frame; the error names the file.
pub fn check_frames(pngs: &[PathBuf], min_body: f64) -> Result<(), String> {
    for p in pngs {
        let image = fissure::output::load_png(p).map_err(|e| e.to_string())?;
        image.check_not_blank(min_body).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    Ok(())
}
