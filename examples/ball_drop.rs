//! The seed's Fig. 5: a pressurised ball drops into a walled room with sphere obstacles (`scenes/ball_drop.toml`).
//!
//! ```text
//! cargo run --release --example ball_drop -- [--headless] [--frames N] [--integrator symplectic_euler|velocity_verlet|rk4|implicit_euler]
//! ```
//! With a display it opens the viewer on the scene. Headless (no display, or `--headless`) it prints a line per
//! 0.1 s of simulated time (height, speed, volume, pressure, contacts), writes every 10th frame as a PNG and
//! all of them as a GIF into `target/examples/ball_drop/`, then a summary table with the stage timers, and
//! checks the outcome: no NaN, no particle inside the floor, walls or obstacles, and the ball at rest on the floor
//! inside the room.

mod common;

use fissure::glam::DVec3;
use fissure::scene::Scene;
use fissure::*;
use std::path::PathBuf;
use std::time::Instant;

/// What a run produced, for the final check and the tests.
#[derive(Debug)]
pub struct Summary {
    /// Frames simulated.
    pub frames: usize,
    /// Lowest y of any particle over the run \[m\].
    pub min_y: f64,
    /// Deepest penetration into any collider seen after a step \[m\].
    pub max_penetration: f64,
    /// Final centre of mass \[m\].
    pub com: DVec3,
    /// Final speed of the centre of mass \[m/s\].
    pub speed: f64,
    /// Volume at the start and at the end \[m^3\].
    pub volume: (f64, f64),
    /// Particles that touched an obstacle ball at some point.
    pub obstacle_contacts: usize,
    /// Lowest particle at the end \[m\].
    pub final_lowest: f64,
    /// PNG frames written (empty without an adapter or when not asked for).
    pub pngs: Vec<PathBuf>,
}

impl Summary {
    /// At rest on the floor: slower than 5 cm/s, its lowest point within 5 mm of the floor.
    pub fn at_rest_on_floor(&self) -> bool {
        self.speed < 0.05 && self.final_lowest < 5e-3
    }
}

const FPS: f64 = 60.0;

fn penetration(model: &Model<f32>, state: &State<f32>) -> (f64, bool) {
    let mut deepest = 0.0f64;
    let mut touched_obstacle = false;
    for (ci, c) in model.colliders.iter().enumerate() {
        let pose = c.pose_at(state.time);
        for q in &state.particle_q {
            let local = pose.inverse_transform_point(*q);
            let proj = c.shape.project_local_point(local, false);
            let d = (proj.point - local).length() as f64;
            if proj.is_inside {
                deepest = deepest.max(d);
            }
            // Colliders 0..5 are the floor and walls; the rest are obstacles.
            if ci >= 5 && d < 2e-3 {
                touched_obstacle = true;
            }
        }
    }
    (deepest, touched_obstacle)
}

/// Runs `frames` frames at 60 fps with `integrator`, printing progress when `verbose`, drawing every
/// `pictures`-th frame when given.
pub fn run(
    frames: usize,
    integrator: Integrator,
    verbose: bool,
    pictures: Option<usize>,
) -> Result<Summary, Box<dyn std::error::Error>> {
    let scene = Scene::load(common::scene_path("ball_drop.toml"))?;
    let model: Model<f32> = scene.builder()?.finalize()?;
    let dt = if integrator == Integrator::ImplicitEuler { 1.0 / 600.0 } else { scene.solver.dt };
    let mut world = World::new(model, SolverConfig::with(integrator));
    let v0 = world.model.body_volumes(&world.state)[0];
    if verbose {
        println!(
            "ball drop: {} particles, {} springs, {} triangles, {} colliders; {} at dt = {dt:.1e} s",
            world.model.particle_count(),
            world.model.spring_count(),
            world.model.tri_count(),
            world.model.colliders.len(),
            integrator.name()
        );
        println!(
            "{:>6} {:>7} {:>9} {:>9} {:>10} {:>10} {:>8}",
            "frame", "t [s]", "com y [m]", "|v| [m/s]", "V/V0", "P [Pa]", "contact"
        );
    }
    let (mut min_y, mut max_pen, mut obstacle_contacts) = (f64::MAX, 0.0f64, 0usize);
    let mut pics = match pictures {
        Some(every) => Some(common::Pictures::new("ball_drop", every, FPS, &world.model, &world.state)?),
        None => None,
    };
    let wall = Instant::now();
    for frame in 1..=frames {
        world.advance(1.0 / FPS, dt)?;
        if let Some(p) = &mut pics {
            let text = [format!("ball drop  t = {:.2} s  {}", world.state.time, integrator.name())];
            p.frame(frame, &world.model, &world.state, &text)?;
        }
        let lowest = world.state.particle_q.iter().map(|q| q.y as f64).fold(f64::MAX, f64::min);
        min_y = min_y.min(lowest);
        let (pen, touched) = penetration(&world.model, &world.state);
        max_pen = max_pen.max(pen);
        obstacle_contacts += touched as usize;
        if verbose && (frame % 6 == 0 || frame == frames) {
            let com = world.model.center_of_mass(&world.state);
            let speed = world.model.momentum(&world.state).length() / world.model.total_mass();
            let v = world.model.body_volumes(&world.state)[0];
            let p = world.model.body_pressures(&world.state)[0];
            let contact = if lowest < 2e-3 {
                "floor"
            } else if touched {
                "obstacle"
            } else {
                ""
            };
            println!(
                "{frame:>6} {:>7.3} {:>9.3} {:>9.3} {:>10.4} {:>10.1} {:>8}",
                world.state.time,
                com.y,
                speed,
                v / v0,
                p,
                contact
            );
        }
    }
    let com = world.model.center_of_mass(&world.state);
    let summary = Summary {
        frames,
        min_y,
        max_penetration: max_pen,
        com,
        speed: world.model.momentum(&world.state).length() / world.model.total_mass(),
        volume: (v0, world.model.body_volumes(&world.state)[0]),
        obstacle_contacts,
        final_lowest: world.state.particle_q.iter().map(|q| q.y as f64).fold(f64::MAX, f64::min),
        pngs: match pics {
            Some(p) => p.finish()?.0,
            None => Vec::new(),
        },
    };
    if verbose {
        let elapsed = wall.elapsed().as_secs_f64();
        println!("\n| quantity | value |\n|---|---|");
        println!("| simulated | {:.2} s in {} steps |", world.state.time, world.timers().steps);
        println!("| wall time | {elapsed:.2} s ({:.1}× real time) |", world.state.time / elapsed);
        println!("| final centre of mass | ({:.3}, {:.3}, {:.3}) m |", com.x, com.y, com.z);
        println!("| final speed | {:.3} m/s |", summary.speed);
        println!("| volume end / start | {:.4} |", summary.volume.1 / summary.volume.0);
        println!("| lowest particle | {:.5} m |", summary.min_y);
        println!("| deepest penetration | {:.2e} m |", summary.max_penetration);
        println!("| frames touching an obstacle | {} |", summary.obstacle_contacts);
        println!("\nstage timers:\n{}", world.timers());
    }
    Ok(summary)
}

/// The example's final check: physically sane for the whole run, and (`rest`) at rest on the floor at the end.
pub fn check(s: &Summary, room_half_width: f64, rest: bool) -> Result<(), String> {
    if !(s.com.is_finite() && s.speed.is_finite()) {
        return Err(format!("non-finite state: {s:?}"));
    }
    if s.min_y < -1e-5 || s.max_penetration > 1e-4 {
        return Err(format!(
            "a particle was left inside a collider: lowest y {}, deepest {}",
            s.min_y, s.max_penetration
        ));
    }
    if s.com.x.abs() > room_half_width || s.com.z.abs() > room_half_width {
        return Err(format!("ball left the room: {:?}", s.com));
    }
    if s.volume.1 < 0.5 * s.volume.0 {
        return Err(format!("ball collapsed: volume {:?}", s.volume));
    }
    if rest && !s.at_rest_on_floor() {
        return Err(format!(
            "the ball is not at rest on the floor: speed {:.3} m/s, lowest point {:.4} m",
            s.speed, s.final_lowest
        ));
    }
    common::check_frames(&s.pngs, 0.002)
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let all: Vec<String> = std::env::args().skip(1).collect();
    if common::want_window(&all) {
        return common::open_window(&common::scene_path("ball_drop.toml"));
    }
    let mut frames = 240;
    let mut integrator = Integrator::SymplecticEuler;
    let mut args = all.into_iter();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--frames" => frames = args.next().ok_or("--frames needs a number")?.parse()?,
            "--integrator" => {
                let name = args.next().ok_or("--integrator needs a name")?;
                integrator = *Integrator::ALL.iter().find(|i| i.name() == name).ok_or_else(|| {
                    format!(
                        "unknown integrator {name:?}; one of symplectic_euler, velocity_verlet, rk4, implicit_euler"
                    )
                })?;
            }
            "--headless" => {}
            "-h" | "--help" => {
                println!(
                    "usage: ball_drop [--headless] [--frames N] [--integrator symplectic_euler|velocity_verlet|rk4|implicit_euler]"
                );
                return Ok(());
            }
            other => return Err(format!("unknown argument {other:?} (try --help)").into()),
        }
    }
    let s = run(frames, integrator, true, Some(10))?;
    // At rest only after the full four seconds.
    check(&s, 1.2, frames >= 240)?;
    println!(
        "\nfinal check passed: no NaN, nothing inside a collider, the ball stayed in the room{}; {} frames drawn",
        if frames >= 240 { " and came to rest on the floor" } else { "" },
        s.pngs.len()
    );
    Ok(())
}
