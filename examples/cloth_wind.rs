//! The seed's Fig. 4: a cloth hanging from two corners in a varying wind (`scenes/cloth_wind.toml`).
//!
//! ```text
//! cargo run --release --example cloth_wind -- [--headless] [--frames N]
//! ```
//! With a display it opens the viewer on the scene (`w` toggles the wind). Headless (no display, or
//! `--headless`) it prints a line per 0.25 s (mean downwind displacement, the sheet's largest strain, its lowest
//! point), writes every 10th frame as a PNG and all of them as a GIF into `target/examples/cloth_wind/`, and
//! checks the outcome: no NaN, the cloth blown downwind (its mean displacement along the wind above 10 cm),
//! its springs stretched less than 25 %, nothing below the ground.

mod common;

use fissure::glam::DVec3;
use fissure::scene::Scene;
use fissure::*;
use std::path::PathBuf;

/// What a run produced, for the final check and the tests.
#[derive(Debug)]
pub struct Summary {
    /// Simulated time \[s\].
    pub time: f64,
    /// Mean displacement of the free particles along the mean wind at the end \[m\].
    pub downwind: f64,
    /// Largest spring strain seen at a frame.
    pub max_strain: f64,
    /// Lowest particle seen at a frame \[m\].
    pub min_y: f64,
    /// Whether every position and velocity stayed finite.
    pub finite: bool,
    /// PNG frames written.
    pub pngs: Vec<PathBuf>,
}

const FPS: f64 = 60.0;

fn max_strain(m: &Model<f32>, s: &State<f32>) -> f64 {
    m.spring_indices
        .iter()
        .zip(&m.spring_rest_length)
        .zip(&m.spring_kind)
        .filter(|(_, k)| **k == SpringKind::Edge)
        .map(|((&[i, j], &l0), _)| {
            let l = s.particle_q[i as usize].distance(s.particle_q[j as usize]) as f64;
            l / l0 as f64 - 1.0
        })
        .fold(0.0, f64::max)
}

/// Runs `frames` frames at 60 fps, printing progress when `verbose`, drawing every `pictures`-th frame.
pub fn run(frames: usize, verbose: bool, pictures: Option<usize>) -> Result<Summary, Box<dyn std::error::Error>> {
    let scene = Scene::load(common::scene_path("cloth_wind.toml"))?;
    let mut world: World<f32> = scene.world()?;
    let dt = scene.solver.dt;
    let wind = world.model.wind.clone().ok_or("the scene has no wind")?;
    let dir = wind.velocity.normalize();
    let free: Vec<usize> =
        (0..world.model.particle_count()).filter(|&i| world.model.particle_inv_mass[i] > 0.0).collect();
    let start: Vec<DVec3> = world.state.particle_q.iter().map(|q| q.as_dvec3()).collect();
    let downwind = |s: &State<f32>| {
        free.iter().map(|&i| (s.particle_q[i].as_dvec3() - start[i]).dot(dir)).sum::<f64>() / free.len() as f64
    };
    if verbose {
        println!(
            "{}: {} particles ({} pinned), {} springs, {} triangles; wind {:.1} m/s ± {:.0} % gusts; {} at dt = {dt:.1e} s",
            scene.title,
            world.model.particle_count(),
            world.model.particle_count() - free.len(),
            world.model.spring_count(),
            world.model.tri_count(),
            wind.velocity.length(),
            100.0 * wind.gust_amplitude,
            scene.solver.integrator
        );
        println!("{:>6} {:>7} {:>13} {:>11} {:>10}", "frame", "t [s]", "downwind [m]", "strain max", "lowest y");
    }
    let mut pics = match pictures {
        Some(every) => Some(common::Pictures::new("cloth_wind", every, FPS, &world.model, &world.state)?),
        None => None,
    };
    let (mut strain, mut min_y, mut finite) = (0.0f64, f64::MAX, true);
    for frame in 1..=frames {
        world.advance(1.0 / FPS, dt)?;
        let strain_now = max_strain(&world.model, &world.state);
        strain = strain.max(strain_now);
        let lowest = world.state.particle_q.iter().map(|q| q.y as f64).fold(f64::MAX, f64::min);
        min_y = min_y.min(lowest);
        finite &= world.state.particle_q.iter().chain(&world.state.particle_qd).all(|v| v.is_finite());
        if let Some(p) = &mut pics {
            let text =
                [format!("cloth in wind  t = {:.2} s  downwind {:.2} m", world.state.time, downwind(&world.state))];
            p.frame(frame, &world.model, &world.state, &text)?;
        }
        if verbose && (frame % 15 == 0 || frame == frames) {
            println!(
                "{frame:>6} {:>7.3} {:>13.3} {:>10.1}% {:>10.3}",
                world.state.time,
                downwind(&world.state),
                100.0 * strain_now,
                lowest
            );
        }
    }
    let summary = Summary {
        time: world.state.time,
        downwind: downwind(&world.state),
        max_strain: strain,
        min_y,
        finite,
        pngs: match pics {
            Some(p) => p.finish()?.0,
            None => Vec::new(),
        },
    };
    if verbose {
        println!("\nstage timers:\n{}", world.timers());
    }
    Ok(summary)
}

/// The example's final check.
pub fn check(s: &Summary) -> Result<(), String> {
    if !s.finite {
        return Err("a position or velocity became NaN or infinite".into());
    }
    if s.downwind < 0.1 {
        return Err(format!("the cloth was not blown downwind: mean displacement {:.3} m", s.downwind));
    }
    if s.max_strain > 0.25 {
        return Err(format!("a spring stretched {:.1} %", 100.0 * s.max_strain));
    }
    if s.min_y < -1e-5 {
        return Err(format!("the cloth went through the ground: lowest y {}", s.min_y));
    }
    common::check_frames(&s.pngs, 0.01)
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let all: Vec<String> = std::env::args().skip(1).collect();
    if common::want_window(&all) {
        return common::open_window(&common::scene_path("cloth_wind.toml"));
    }
    let mut frames = 180;
    let mut args = all.into_iter();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--frames" => frames = args.next().ok_or("--frames needs a number")?.parse()?,
            "--headless" => {}
            "-h" | "--help" => {
                println!("usage: cloth_wind [--headless] [--frames N]");
                return Ok(());
            }
            other => return Err(format!("unknown argument {other:?} (try --help)").into()),
        }
    }
    let s = run(frames, true, Some(10))?;
    check(&s)?;
    println!(
        "\nfinal check passed: the cloth blew {:.2} m downwind, strain at most {:.1} %, no NaN, above the ground; {} frames drawn",
        s.downwind,
        100.0 * s.max_strain,
        s.pngs.len()
    );
    Ok(())
}
