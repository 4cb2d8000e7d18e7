//! `fissure run SCENE` (headless: frames, GIF, meshes, a summary) and `fissure view SCENE` (a window).

use fissure::gpu::{GpuConfig, GpuContext, GpuSolver};
use fissure::mesh::{write_obj, write_ply};
use fissure::output::{FrameRenderer, Frames};
use fissure::scene::{Override, Scene};
use fissure::vtk::{VtkKind, VtkSeries};
use fissure::{FractureKind, Model, Stage, StageTimers, State, World};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `fissure run`.
#[derive(Clone, Debug)]
pub struct RunConfig {
    pub scene: PathBuf,
    pub frames: Option<usize>,
    pub fps: f64,
    pub out: Option<PathBuf>,
    pub gpu: bool,
    /// Steps between two fracture passes (`World::fracture_every`), on either backend.
    pub fracture_every: usize,
    /// Time every GPU kernel (`GpuConfig::kernel_timers`; `--kernel-timers`, with `--backend gpu`).
    pub kernel_timers: bool,
    pub size: [u32; 2],
    pub gif: bool,
    pub png: bool,
    pub mesh: Option<MeshFormat>,
    pub wireframe: bool,
    /// Colour surfaces by strain (`--color strain`).
    pub strain: bool,
    /// Scene keys set from the command line (`--set KEY=VALUE`).
    pub overrides: Vec<Override>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MeshFormat {
    Obj,
    Ply,
    /// A `.vtp` per frame and `run.pvd` (`fissure::vtk`).
    Vtk,
    /// A `.vtu` per frame and `run.pvd`.
    Vtu,
}

pub const RUN_USAGE: &str = "\
usage: fissure run SCENE [--set KEY=VALUE ...] [--frames N] [--fps F] [--out DIR] [--backend cpu|gpu]
                         [--size WxH] [--mesh obj|ply|vtk] [--no-gif] [--no-png] [--wireframe]
                         [--color body|strain]

  Simulates a scene file headless and writes PNG frames and an animated GIF of it.

  --set KEY=VALUE   override a scene key, e.g. --set body[0].pressure=4000 --set solver.dt=2e-5
                    (TOML values; checked as the file is; repeat for more keys)
  --frames N        frames to simulate (default: the scene's duration times the frame rate)
  --fps F           frames per simulated second (default 30)
  --out DIR         output folder (default target/fissure-run/<scene name>)
  --backend B       cpu (default; every integrator, fracture) or gpu (symplectic Euler or velocity
                    Verlet kernels; drawn straight from the GPU's position buffer)
  --fracture-every N  steps between two fracture passes, on either backend (default 1: every step;
                    larger reads a GPU's state back less often, and fractures are noticed later)
  --kernel-timers   with --backend gpu: time every kernel on the device (timestamp queries; one
                    read-back a submission) and print the stages' device time and the costliest kernels
  --size WxH        frame size in pixels (default 640x360)
  --mesh F          also write each frame's surface mesh: obj, ply, or vtk (ParaView: one .vtp
                    per frame with velocity, strain, body and damage fields, and run.pvd, the
                    animation); vtu: the same as .vtu files (for meshio, which reads no .vtp)
  --no-gif          no GIF; --no-png: no PNG frames
  --wireframe       draw the springs over the surfaces
  --color C         colour surfaces by body (default) or strain (blue at rest to red at the tear limit; CPU)

Without a GPU the frames are drawn by the software Vulkan driver (lavapipe: on Debian or Ubuntu
`apt install mesa-vulkan-drivers`); with no adapter at all it still simulates and prints the summary.";

/// `WxH` in pixels, each within 16..=8192.
fn parse_size(v: &str) -> Result<[u32; 2], String> {
    let (w, h) = v.split_once('x').ok_or_else(|| format!("--size: want WxH, got {v:?}"))?;
    let p = |s: &str| s.parse::<u32>().ok().filter(|&n| (16..=8192).contains(&n));
    Ok([
        p(w).ok_or_else(|| format!("--size: width {w:?} not in 16..=8192"))?,
        p(h).ok_or_else(|| format!("--size: height {h:?} not in 16..=8192"))?,
    ])
}

pub fn parse(args: &[String]) -> Result<RunConfig, String> {
    let mut cfg = RunConfig {
        scene: PathBuf::new(),
        frames: None,
        fps: 30.0,
        out: None,
        gpu: false,
        fracture_every: 1,
        kernel_timers: false,
        size: [640, 360],
        gif: true,
        png: true,
        mesh: None,
        wireframe: false,
        strain: false,
        overrides: Vec::new(),
    };
    let mut scene = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or_else(|| format!("{name} needs a value"));
        match a.as_str() {
            "--frames" => {
                let v = value("--frames")?;
                cfg.frames = Some(v.parse().map_err(|_| format!("--frames: not a count: {v:?}"))?);
            }
            "--fps" => {
                let v = value("--fps")?;
                cfg.fps = v.parse().map_err(|_| format!("--fps: not a number: {v:?}"))?;
                if !(cfg.fps.is_finite() && cfg.fps > 0.0) {
                    return Err(format!("--fps must be > 0, got {v}"));
                }
            }
            "--out" => cfg.out = Some(value("--out")?.into()),
            "--set" => cfg.overrides.push(Override::parse(&value("--set")?)?),
            "--fracture-every" => {
                cfg.fracture_every =
                    value("--fracture-every")?.parse().map_err(|e| format!("--fracture-every: {e}"))?;
                if cfg.fracture_every == 0 {
                    return Err("--fracture-every: must be at least 1".into());
                }
            }
            "--kernel-timers" => cfg.kernel_timers = true,
            "--backend" => {
                cfg.gpu = match value("--backend")?.as_str() {
                    "cpu" => false,
                    "gpu" => true,
                    other => return Err(format!("--backend: {other:?} is neither cpu nor gpu")),
                }
            }
            "--size" => cfg.size = parse_size(&value("--size")?)?,
            "--mesh" => {
                cfg.mesh = Some(match value("--mesh")?.as_str() {
                    "obj" => MeshFormat::Obj,
                    "ply" => MeshFormat::Ply,
                    "vtk" | "vtp" => MeshFormat::Vtk,
                    "vtu" => MeshFormat::Vtu,
                    other => return Err(format!("--mesh: {other:?} is not obj, ply, vtk or vtu")),
                })
            }
            "--no-gif" => cfg.gif = false,
            "--no-png" => cfg.png = false,
            "--wireframe" => cfg.wireframe = true,
            "--color" => {
                cfg.strain = match value("--color")?.as_str() {
                    "strain" => true,
                    "body" => false,
                    other => return Err(format!("--color: {other:?} is neither body nor strain")),
                }
            }
            s if s.starts_with('-') => return Err(format!("unknown option `{s}`")),
            s if scene.is_none() => scene = Some(PathBuf::from(s)),
            s => return Err(format!("one scene at a time (got {s:?} too)")),
        }
    }
    cfg.scene = scene.ok_or("which scene? e.g. fissure run scenes/fracture.toml")?;
    if cfg.kernel_timers && !cfg.gpu {
        return Err("--kernel-timers times the GPU's kernels: add --backend gpu".into());
    }
    Ok(cfg)
}

struct Progress {
    tty: bool,
    total: usize,
    last_tenth: usize,
    start: Instant,
}

impl Progress {
    fn show(&mut self, done: usize, time: f64, events: usize) {
        let elapsed = self.start.elapsed().as_secs_f64();
        let eta = elapsed / done.max(1) as f64 * (self.total - done) as f64;
        let line = format!(
            "{done:>5}/{} frames  t = {time:.3} s  {:.1} ms/frame  {events} fracture events  ETA {eta:.0} s",
            self.total,
            1e3 * elapsed / done.max(1) as f64
        );
        if self.tty {
            let width = 30;
            let filled = width * done / self.total.max(1);
            eprint!("\r[{}{}] {line}  ", "#".repeat(filled), ".".repeat(width - filled));
            if done == self.total {
                eprintln!();
            }
            let _ = std::io::stderr().flush();
        } else {
            // Logs get a line per tenth, not a carriage-return storm.
            let tenth = 10 * done / self.total.max(1);
            if tenth > self.last_tenth || done == self.total {
                self.last_tenth = tenth;
                eprintln!("{line}");
            }
        }
    }
}

/// What `fissure run` did (for its summary and for tests).
pub struct RunSummary {
    pub world: World<f32>,
    pub frames: usize,
    pub wall: f64,
    pub pngs: Vec<PathBuf>,
    pub gif: Option<PathBuf>,
    pub meshes: usize,
    pub not_drawn: Option<String>,
    pub adapter: Option<String>,
}

fn overlay(scene: &Scene, world: &World<f32>, backend: &str) -> Vec<String> {
    let title = if scene.title.is_empty() { "fissure".to_string() } else { scene.title.clone() };
    vec![
        title,
        format!(
            "t = {:.2} s   {backend}   fracture events {}   pieces {}",
            world.state.time,
            world.events.len(),
            world.model.body_count()
        ),
    ]
}

fn export_mesh(dir: &Path, frame: usize, format: MeshFormat, m: &Model<f32>, s: &State<f32>) -> std::io::Result<()> {
    let q: Vec<fissure::glam::DVec3> = s.particle_q.iter().map(|v| v.as_dvec3()).collect();
    let (text, ext) = match format {
        MeshFormat::Obj => (write_obj(&q, &m.tri_indices), "obj"),
        MeshFormat::Ply => (write_ply(&q, &m.tri_indices), "ply"),
        // A lone frame; a run writes its series (and the .pvd) through fissure::vtk::VtkSeries.
        MeshFormat::Vtk => (fissure::vtk::vtk_string(m, s, VtkKind::PolyData), "vtp"),
        MeshFormat::Vtu => (fissure::vtk::vtk_string(m, s, VtkKind::UnstructuredGrid), "vtu"),
    };
    std::fs::write(dir.join(format!("mesh_{frame:04}.{ext}")), text)
}

pub fn run(cfg: &RunConfig) -> Result<RunSummary, Box<dyn std::error::Error>> {
    let scene = Scene::load_with(&cfg.scene, &cfg.overrides)?;
    let mut world: World<f32> = scene.world()?;
    let dt = scene.solver.dt;
    let frame_dt = 1.0 / cfg.fps;
    let frames = cfg.frames.unwrap_or_else(|| (scene.solver.duration * cfg.fps).round().max(1.0) as usize);
    let out = cfg.out.clone().unwrap_or_else(|| {
        let stem = cfg.scene.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from("target/fissure-run").join(stem)
    });
    let m = &world.model;
    println!("{}", if scene.title.is_empty() { cfg.scene.display().to_string() } else { scene.title.clone() });
    println!(
        "{} particles, {} springs, {} triangles, {} bodies, {} colliders; {} at dt = {dt:.1e} s; {frames} frames of {:.4} s",
        m.particle_count(),
        m.spring_count(),
        m.tri_count(),
        m.body_count(),
        m.colliders.len(),
        scene.solver.integrator,
        frame_dt
    );

    // The device: the GPU backend needs one; the CPU backend only to draw.
    let (renderer, adapter) = if cfg.gpu {
        let ctx = GpuContext::new().map_err(|e| format!("--backend gpu: {e}"))?;
        let config =
            GpuConfig { integrator: scene.integrator()?, kernel_timers: cfg.kernel_timers, ..Default::default() };
        world.solver = Box::new(GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &world.model, config)?);
        let adapter = ctx.describe();
        let r = FrameRenderer::with_context(ctx, cfg.size[0], cfg.size[1], &world.model, &world.state);
        (Ok(r), Some(adapter))
    } else {
        let r = FrameRenderer::new(cfg.size[0], cfg.size[1], &world.model, &world.state);
        let adapter = r.as_ref().ok().map(|r| r.ctx.describe());
        (r, adapter)
    };
    world.fracture_every = cfg.fracture_every;
    let backend_name = if cfg.gpu { "gpu" } else { "cpu" };
    let mut out_frames = Frames::with_renderer(&out, renderer, cfg.size[0], cfg.size[1])?;
    if cfg.gif {
        out_frames = out_frames.with_gif(cfg.fps)?;
    }
    if !cfg.png {
        out_frames = out_frames.without_png();
    }
    if let Some(r) = out_frames.renderer() {
        r.view.wireframe = cfg.wireframe;
        r.view.strain = cfg.strain;
    }
    let not_drawn = out_frames.unavailable().map(|e| e.to_string());
    match (&not_drawn, &adapter) {
        (Some(why), _) => {
            eprintln!("fissure run: cannot draw, so no frames will be written: {why}");
            eprintln!("fissure run: simulating anyway; the summary follows at the end");
        }
        (None, Some(a)) => println!("drawing on {a} into {}", out.display()),
        _ => {}
    }
    if cfg.mesh.is_some() {
        std::fs::create_dir_all(&out)?;
    }
    let mut vtk = match cfg.mesh {
        Some(MeshFormat::Vtk) => Some(VtkSeries::new(&out, "run", VtkKind::PolyData)?),
        Some(MeshFormat::Vtu) => Some(VtkSeries::new(&out, "run", VtkKind::UnstructuredGrid)?),
        _ => None,
    };

    let mut progress =
        Progress { tty: std::io::stderr().is_terminal(), total: frames, last_tenth: 0, start: Instant::now() };
    let mut meshes = 0;
    let wall = Instant::now();
    world.reset_timers();
    for frame in 1..=frames {
        // One stepping path (World::advance) for both backends: the same steps, fracture at the same cadence.
        let span = frame as f64 * frame_dt - world.state.time;
        if span > 1e-12 && world.advance(span, dt)?.topology_changed {
            out_frames.model_changed(&world.model, world.state.time);
        }
        // Nothing to write (--no-png --no-gif): no drawing either, the run is the simulation alone.
        if cfg.png || cfg.gif {
            // Drawing shares the cores (llvmpipe): the solver's helpers sleep rather than spin through it.
            world.rest();
            let text = overlay(&scene, &world, backend_name);
            match world.gpu_solver() {
                Some(gpu) => out_frames.capture_buffer(gpu.position_buffer(), &text)?,
                None => out_frames.capture(&world.model, &world.state, &text)?,
            };
        }
        match (cfg.mesh, vtk.as_mut()) {
            (_, Some(series)) => {
                series.write(&world.model, &world.state)?;
                meshes += 1;
            }
            (Some(f), None) => {
                export_mesh(&out, frame, f, &world.model, &world.state)?;
                meshes += 1;
            }
            _ => {}
        }
        progress.show(frame, world.state.time, world.events.len());
    }
    let pngs = out_frames.written().to_vec();
    let gif = out_frames.finish()?;
    let summary =
        RunSummary { world, frames, wall: wall.elapsed().as_secs_f64(), pngs, gif, meshes, not_drawn, adapter };
    print_summary(&scene, cfg, &summary);
    Ok(summary)
}

fn stage_line(t: &StageTimers) -> String {
    Stage::ALL
        .iter()
        .filter(|s| t.calls(**s) > 0)
        .map(|s| format!("{} {:.3} s", s.name(), t.time(*s).as_secs_f64()))
        .collect::<Vec<_>>()
        .join(", ")
}

fn print_summary(scene: &Scene, cfg: &RunConfig, s: &RunSummary) {
    let w = &s.world;
    let count = |k: FractureKind| w.events.iter().filter(|e| e.kind == k).count();
    let com = w.model.center_of_mass(&w.state);
    println!("\n| quantity | value |\n|---|---|");
    println!("| scene | {} |", cfg.scene.display());
    println!(
        "| backend | {}{} |",
        if cfg.gpu { "gpu" } else { "cpu" },
        s.adapter.as_ref().map(|a| format!(" (drawn on {a})")).unwrap_or_default()
    );
    println!("| integrator | {} |", scene.solver.integrator);
    println!("| simulated | {:.3} s in {} frames |", w.state.time, s.frames);
    println!("| wall time | {:.2} s ({:.2}× real time) |", s.wall, w.state.time / s.wall.max(1e-9));
    println!(
        "| particles, springs, triangles | {}, {}, {} |",
        w.model.particle_count(),
        w.model.live_spring_count(),
        w.model.tri_count()
    );
    println!(
        "| fracture events | {} (spring {}, core {}, detach {}) |",
        w.events.len(),
        count(FractureKind::Spring),
        count(FractureKind::Core),
        count(FractureKind::Detach)
    );
    println!("| bodies, pieces | {}, {} |", w.model.body_count(), w.model.components().0);
    println!("| centre of mass | ({:.3}, {:.3}, {:.3}) m |", com.x, com.y, com.z);
    if w.model.has_pressure() {
        let v: f64 = w.model.body_volumes(&w.state).iter().sum();
        println!("| gas volume | {:.3} l |", v * 1e3);
    }
    let any = w.solver.as_any();
    // The CPU keeps candidate lists between steps; the GPU builds its grids at every substep.
    let contact = match (any.downcast_ref::<fissure::CpuSolver<f32>>(), any.downcast_ref::<GpuSolver>()) {
        (Some(c), _) => {
            let st = c.contact_stats();
            Some((st, st.builds, format!("candidate lists built ({} refreshed)", st.refreshes)))
        }
        (_, Some(g)) => {
            Some((g.contact_stats(), g.contact_stats().steps, "grids built (one per substep on the GPU)".to_string()))
        }
        _ => None,
    };
    if let Some((c, count, built)) = contact.filter(|_| w.model.has_contact()) {
        let per = |x: u64| x as f64 / c.steps.max(1) as f64;
        println!(
            "| contact | {:.1} pairs within reach and {:.1} pushed per step, {} {built}, {} moves capped |",
            per(c.near_total),
            per(c.pushed_total),
            count,
            c.capped_total
        );
    }
    println!("| stage times | {} |", stage_line(&w.timers()));
    if let Some(g) = w.gpu_solver() {
        let mut k = g.kernel_times();
        k.sort_by_key(|t| std::cmp::Reverse(t.1));
        if !k.is_empty() {
            let steps = w.timers().steps.max(1) as f64;
            let line: Vec<String> =
                k.iter().take(5).map(|(n, t, _)| format!("{n} {:.1} µs", t.as_secs_f64() * 1e6 / steps)).collect();
            println!("| GPU kernels per step (device time, costliest first) | {} |", line.join(", "));
        }
    }
    match (&s.not_drawn, s.pngs.len()) {
        (Some(why), _) => println!("| pictures | none: {why} |"),
        (None, n) => {
            let dir = s.pngs.first().and_then(|p| p.parent()).map(|p| p.display().to_string()).unwrap_or_default();
            println!("| PNG frames | {n}{} |", if n > 0 { format!(" in {dir}") } else { String::new() });
        }
    }
    if let Some(g) = &s.gif {
        println!("| GIF | {} |", g.display());
    }
    if s.meshes > 0 {
        let what = match cfg.mesh {
            Some(MeshFormat::Vtk | MeshFormat::Vtu) => " (and run.pvd: open it in ParaView)",
            _ => "",
        };
        println!("| meshes | {}{what} |", s.meshes);
    }
}

/// `fissure view SCENE`.
pub const VIEW_USAGE: &str = "\
usage: fissure view SCENE [--set KEY=VALUE ...] [--size WxH] [--paused] [--frames N --screenshot FILE]
                          [--script ACTIONS] [--fixed]

  Opens a window on the scene and runs it on the CPU. Mouse: left-drag a body to pull it (past a
  cloth's strength it tears), left-drag elsewhere to orbit, wheel to zoom, right-click to puncture.
  Keys: space pause, n step, w wind, p pressure, f wireframe, v mass points, s surfaces, c colour
  by strain, k crack edges, r restart, q or esc quit.

  The simulation keeps pace with the wall clock: each frame advances it by the time since the last
  (at most 4/60 s: a machine too slow for the scene shows it in slow motion). On exit it prints
  the real-time factor and the mean simulation and drawing time per frame.

  --frames N --screenshot FILE   close after N frames and save the last one (for tests)
  --script ACTIONS               replay input, e.g. \"20:puncture-body:0;25:key:f;30:puncture:480,270\"
                                 (also drag-body:B,DX,DY: grab body B's centre, pull it DX,DY pixels;
                                 release:); implies --fixed, so a replay is the same every time
  --fixed                        advance 1/60 s per frame whatever the clock";

pub fn view(args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let mut opts = fissure::viewer::ViewerOptions::default();
    let mut scene_path = None;
    let mut overrides = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or_else(|| format!("{name} needs a value"));
        match a.as_str() {
            "--size" => opts.size = parse_size(&value("--size")?)?,
            "--paused" => opts.paused = true,
            "--fixed" => opts.real_time = false,
            "--set" => overrides.push(Override::parse(&value("--set")?)?),
            "--frames" => opts.exit_after = Some(value("--frames")?.parse()?),
            "--screenshot" => opts.screenshot = Some(value("--screenshot")?.into()),
            "--script" => {
                for item in value("--script")?.split(';').filter(|s| !s.trim().is_empty()) {
                    let (frame, action) =
                        item.split_once(':').ok_or_else(|| format!("--script: {item:?} is not FRAME:ACTION"))?;
                    opts.script.push((frame.trim().parse()?, action.trim().parse()?));
                }
            }
            s if s.starts_with('-') => return Err(format!("unknown option `{s}`").into()),
            s => scene_path = Some(PathBuf::from(s)),
        }
    }
    let path = scene_path.ok_or("which scene? e.g. fissure view scenes/fracture.toml")?;
    if !opts.script.is_empty() {
        opts.real_time = false;
    }
    if opts.screenshot.is_some() && opts.exit_after.is_none() {
        opts.exit_after = Some(60);
    }
    let scene = Scene::load_with(&path, &overrides)?;
    opts.title =
        format!("fissure: {}", if scene.title.is_empty() { path.display().to_string() } else { scene.title.clone() });
    let world = scene.world::<f32>()?;
    let dt = scene.solver.dt;
    let again = scene.clone();
    let report = fissure::viewer::run(world, dt, move || again.world().ok(), opts)?;
    println!(
        "{} frames on {}, t = {:.3} s, {} fracture events",
        report.frames, report.adapter, report.time, report.events
    );
    if report.wall > 0.0 {
        println!(
            "{:.3} s simulated in {:.3} s ({:.2}x real time, {:.0} fps); per frame: simulation {:.1} ms, drawing {:.1} ms",
            report.simulated,
            report.wall,
            report.simulated / report.wall,
            report.frames as f64 / report.wall,
            report.sim_ms,
            report.draw_ms
        );
    }
    if let Some((p, from_window)) = &report.screenshot {
        println!(
            "screenshot: {} ({})",
            p.display(),
            if *from_window { "read from the window's surface" } else { "drawn offscreen from the same state" }
        );
    }
    Ok(())
}
