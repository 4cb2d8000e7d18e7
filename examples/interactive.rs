//! The interactive viewer on a scene file (default `scenes/fracture.toml`).
//!
//! ```text
//! cargo run --release --example interactive -- [SCENE] [--frames N --screenshot FILE]
//! ```
//! Mouse: left-drag a body to pull a mass point, left-drag elsewhere to orbit, wheel to zoom, right-click to
//! puncture. Keys: space pause, n single step, w wind, p pressure, f wireframe, v mass points, s surfaces,
//! r restart, q or esc quit. The overlay shows the stage timers and the fracture count.
//!
//! Without a display it says so and writes a few headless frames to `target/examples/interactive/` instead.
//! With `--screenshot` it closes after `--frames` frames (default 60), saves the last one and checks it shows the
//! body and the room (pixel statistics), for CI under Xvfb.

mod common;

use fissure::scene::Scene;
use fissure::viewer::{ViewerOptions, display_available};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut path = common::scene_path("fracture.toml");
    let mut opts = ViewerOptions::default();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--frames" => opts.exit_after = Some(args.next().ok_or("--frames needs a number")?.parse()?),
            "--screenshot" => opts.screenshot = Some(PathBuf::from(args.next().ok_or("--screenshot needs a file")?)),
            "-h" | "--help" => {
                println!("usage: interactive [SCENE] [--frames N --screenshot FILE]");
                return Ok(());
            }
            s if s.starts_with('-') => return Err(format!("unknown argument {s:?} (try --help)").into()),
            s => path = PathBuf::from(s),
        }
    }
    if opts.screenshot.is_some() && opts.exit_after.is_none() {
        opts.exit_after = Some(60);
    }
    let scene = Scene::load(&path)?;
    let world = scene.world::<f32>()?;
    if !display_available() {
        eprintln!("interactive: no display (DISPLAY and WAYLAND_DISPLAY are unset): writing headless frames instead");
        let mut world = world;
        let mut pics = common::Pictures::new("interactive", 10, 60.0, &world.model, &world.state)?;
        for frame in 1..=60 {
            let events = world.events.len();
            world.advance(1.0 / 60.0, scene.solver.dt)?;
            if world.events.len() > events {
                pics.model_changed(&world.model, world.state.time);
            }
            pics.frame(frame, &world.model, &world.state, &[format!("t = {:.2} s", world.state.time)])?;
        }
        let (pngs, why) = pics.finish()?;
        println!("{} frames written{}", pngs.len(), why.map(|w| format!(" (none drawn: {w})")).unwrap_or_default());
        common::check_frames(&pngs, 0.002)?;
        return Ok(());
    }
    opts.title = format!("fissure: {}", scene.title);
    let again = scene.clone();
    let report = fissure::viewer::run(world, scene.solver.dt, move || again.world().ok(), opts)?;
    println!(
        "{} frames on {}, t = {:.3} s, {} fracture events",
        report.frames, report.adapter, report.time, report.events
    );
    if let Some((p, from_window)) = &report.screenshot {
        let image = fissure::output::load_png(p)?;
        let (body, room) = (image.body_coverage(0), image.room_coverage());
        println!(
            "screenshot {} ({}): body {:.2} % of the pixels, floor and walls {:.1} %",
            p.display(),
            if *from_window { "from the window" } else { "drawn offscreen" },
            100.0 * body,
            100.0 * room
        );
        if body < 0.002 || room < 0.10 {
            return Err("the screenshot does not show both the body and the room".into());
        }
    }
    Ok(())
}
