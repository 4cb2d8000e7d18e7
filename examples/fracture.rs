//! The seed's Fig. 6: a pressurised ball with many local fractures (scene `scenes/fracture.toml`).
//!
//! ```text
//! cargo run --release --example fracture -- [--headless] [--scene PATH] [--duration SECONDS]
//! ```
//! With a display it opens the viewer on the scene. Headless (no display, or `--headless`) it writes every 5th
//! frame as a PNG and all of them as a GIF into `target/examples/fracture/`, prints a line per 0.1 s of
//! simulated time (fracture events so far, bodies, pieces, volume and gas of the
//! ball), then the events, a summary table and the stage timers, and checks the outcome: at least three fracture
//! events in at least two separate places, a core block broken off (more pieces than at the start), the
//! punctured ball's volume falling as its gas leaks, no NaN and no particle inside a collider for the whole run.

mod common;

use fissure::glam::DVec3;
use fissure::scene::Scene;
use fissure::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a run produced, for the final check and the tests.
#[derive(Debug)]
pub struct Summary {
    /// Simulated time \[s\].
    pub time: f64,
    /// Every fracture event.
    pub events: Vec<FractureEvent>,
    /// Connected pieces at the start and at the end.
    pub pieces: (usize, usize),
    /// The ball's (capped) volume at the first puncture and at the end \[m^3\].
    pub volume_after_puncture: Option<(f64, f64)>,
    /// The ball's gas `nRT` at the start and at the end \[J\].
    pub gas: (f64, f64),
    /// Deepest penetration into any collider seen after a frame \[m\].
    pub max_penetration: f64,
    /// Whether every position and velocity stayed finite.
    pub finite: bool,
    /// PNG frames written.
    pub pngs: Vec<PathBuf>,
}

impl Summary {
    /// Events farther apart than `d` \[m\] from each other, counted greedily.
    pub fn places(&self, d: f64) -> usize {
        let mut seen: Vec<DVec3> = Vec::new();
        for e in &self.events {
            if seen.iter().all(|p| p.distance(e.position) > d) {
                seen.push(e.position);
            }
        }
        seen.len()
    }

    /// Events of `kind`.
    pub fn count(&self, kind: FractureKind) -> usize {
        self.events.iter().filter(|e| e.kind == kind).count()
    }
}

const FPS: f64 = 60.0;

/// The default scene file.
pub fn default_scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/fracture.toml")
}

fn penetration(model: &Model<f32>, state: &State<f32>) -> f64 {
    let mut deepest = 0.0f64;
    for c in &model.colliders {
        let pose = c.pose_at(state.time);
        for q in &state.particle_q {
            let local = pose.inverse_transform_point(*q);
            let proj = c.shape.project_local_point(local, false);
            if proj.is_inside {
                deepest = deepest.max((proj.point - local).length() as f64);
            }
        }
    }
    deepest
}

/// Runs the scene at `path` for `duration` \[s\] (the scene's own if `None`), printing progress when `verbose`,
/// drawing every `pictures`-th frame when given.
pub fn run(
    path: &Path,
    duration: Option<f64>,
    verbose: bool,
    pictures: Option<usize>,
) -> Result<Summary, Box<dyn std::error::Error>> {
    let scene = Scene::load(path)?;
    let mut world: World<f32> = scene.world()?;
    let dt = scene.solver.dt;
    let duration = duration.unwrap_or(scene.solver.duration);
    let frames = (duration * FPS).round() as usize;
    let pieces0 = world.model.components().0;
    let gas0 = world.model.body_gas_amount[0] as f64;
    if verbose {
        println!(
            "{}\n{} particles, {} springs, {} triangles, {} colliders; {} at dt = {dt:.1e} s for {duration} s",
            scene.title,
            world.model.particle_count(),
            world.model.spring_count(),
            world.model.tri_count(),
            world.model.colliders.len(),
            scene.solver.integrator,
        );
        println!(
            "{:>6} {:>7} {:>7} {:>7} {:>7} {:>9} {:>9} {:>9}",
            "frame", "t [s]", "events", "bodies", "pieces", "openings", "V [l]", "gas/gas0"
        );
    }
    let (mut max_pen, mut finite) = (0.0f64, true);
    let mut puncture_volume = None;
    let mut pics = match pictures {
        Some(every) => Some(common::Pictures::new("fracture", every, FPS, &world.model, &world.state)?),
        None => None,
    };
    let wall = Instant::now();
    for frame in 1..=frames {
        let changed = world.advance(frame as f64 / FPS - world.state.time, dt)?.topology_changed;
        // The volume when the ball is first seen punctured (at a frame's end: the check compares the end with it).
        if puncture_volume.is_none() && !world.model.openings.is_empty() {
            puncture_volume = Some(world.model.body_volumes(&world.state)[0]);
        }
        if let Some(p) = &mut pics {
            if changed {
                p.model_changed(&world.model, world.state.time);
            }
            let text = [format!(
                "fracture  t = {:.2} s  events {}  pieces {}",
                world.state.time,
                world.events.len(),
                world.model.body_count()
            )];
            p.frame(frame, &world.model, &world.state, &text)?;
        }
        max_pen = max_pen.max(penetration(&world.model, &world.state));
        finite &= world.state.particle_q.iter().chain(&world.state.particle_qd).all(|v| v.is_finite());
        if verbose && (frame % 6 == 0 || frame == frames) {
            println!(
                "{frame:>6} {:>7.3} {:>7} {:>7} {:>7} {:>9} {:>9.3} {:>9.3}",
                world.state.time,
                world.events.len(),
                world.model.body_count(),
                world.model.components().0,
                world.model.openings.len(),
                world.model.body_volumes(&world.state)[0] * 1e3,
                world.model.body_gas_amount[0] as f64 / gas0,
            );
        }
    }
    let summary = Summary {
        time: world.state.time,
        events: world.events.clone(),
        pieces: (pieces0, world.model.components().0),
        volume_after_puncture: puncture_volume.map(|v| (v, world.model.body_volumes(&world.state)[0])),
        gas: (gas0, world.model.body_gas_amount[0] as f64),
        max_penetration: max_pen,
        finite,
        pngs: match pics {
            Some(p) => p.finish()?.0,
            None => Vec::new(),
        },
    };
    if verbose {
        let elapsed = wall.elapsed().as_secs_f64();
        println!("\nfirst events:");
        for e in summary.events.iter().take(12) {
            let p = e.position;
            println!(
                "  t = {:.4} s  {:<7} at ({:>6.3}, {:>6.3}, {:>6.3})  body {}  new particles {}{}",
                e.time,
                format!("{:?}", e.kind),
                p.x,
                p.y,
                p.z,
                e.body,
                e.new_particles.len(),
                e.new_body.map(|b| format!("  new body {b}")).unwrap_or_default()
            );
        }
        println!("\n| quantity | value |\n|---|---|");
        println!("| simulated | {:.2} s in {} steps |", summary.time, world.timers().steps);
        println!("| wall time | {elapsed:.2} s ({:.2}× real time) |", summary.time / elapsed);
        println!(
            "| fracture events | {} (spring {}, core {}, detach {}) |",
            summary.events.len(),
            summary.count(FractureKind::Spring),
            summary.count(FractureKind::Core),
            summary.count(FractureKind::Detach)
        );
        println!("| separate places (> 10 cm apart) | {} |", summary.places(0.1));
        println!("| pieces start → end | {} → {} |", summary.pieces.0, summary.pieces.1);
        if let Some((a, b)) = summary.volume_after_puncture {
            println!("| ball volume at puncture → end | {:.3} l → {:.3} l |", a * 1e3, b * 1e3);
        }
        println!("| gas nRT start → end | {:.2} J → {:.2} J |", summary.gas.0, summary.gas.1);
        println!("| deepest penetration | {:.2e} m |", summary.max_penetration);
        println!("| particles now | {} |", world.model.particle_count());
        println!("\nstage timers:\n{}", world.timers());
    }
    Ok(summary)
}

/// The example's final check (the issue's "done when" for the fracture scene).
pub fn check(s: &Summary) -> Result<(), String> {
    if !s.finite {
        return Err("a position or velocity became NaN or infinite".into());
    }
    if s.max_penetration > 1e-4 {
        return Err(format!("a particle was left inside a collider ({:.2e} m deep)", s.max_penetration));
    }
    if s.events.len() < 3 || s.places(0.1) < 2 {
        return Err(format!("{} events in {} places: want >= 3 in >= 2", s.events.len(), s.places(0.1)));
    }
    if s.count(FractureKind::Core) == 0 || s.pieces.1 <= s.pieces.0 {
        return Err(format!("no core block came off: pieces {:?}", s.pieces));
    }
    match s.volume_after_puncture {
        Some((at, end)) if end < at && s.gas.1 < s.gas.0 => {}
        other => return Err(format!("the punctured ball did not deflate: volume {other:?}, gas {:?}", s.gas)),
    }
    // The torn ball lies behind an obstacle late in the run: 0.19 % of a 640 × 360 frame at t = 1.17 s
    // (2026-11-25; 0.2 % failed the example's own check there). A blank or body-less frame shows none.
    common::check_frames(&s.pngs, 0.001)
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let all: Vec<String> = std::env::args().skip(1).collect();
    let mut path = default_scene();
    let mut duration = None;
    let mut args = all.clone().into_iter();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--scene" => path = args.next().ok_or("--scene needs a path")?.into(),
            "--duration" => duration = Some(args.next().ok_or("--duration needs seconds")?.parse()?),
            "--headless" => {}
            "-h" | "--help" => {
                println!("usage: fracture [--headless] [--scene PATH] [--duration SECONDS]");
                return Ok(());
            }
            other => return Err(format!("unknown argument {other:?} (try --help)").into()),
        }
    }
    if common::want_window(&all) {
        return common::open_window(&path);
    }
    let s = run(&path, duration, true, Some(5))?;
    check(&s)?;
    println!(
        "\nfinal check passed: {} fracture events in {} places, a core block broke off, the ball deflated, no NaN, \
         nothing inside a collider",
        s.events.len(),
        s.places(0.1)
    );
    Ok(())
}
