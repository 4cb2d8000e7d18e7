//! Examples double as tests: each runs here headless, draws some frames on the GPU adapter (lavapipe in CI), and
//! its own final check must hold, including pixel statistics of every PNG it wrote (not blank, the body seen).
//! With `CI` set a missing adapter fails these tests; elsewhere they run without pictures and say so.
// Each example file declares `mod common;` (examples/common/mod.rs); included here side by side, the module
// is compiled once per example, which is what the examples themselves do too.
#![allow(clippy::duplicate_mod)]

#[allow(dead_code)]
#[path = "../examples/ball_drop.rs"]
mod ball_drop;

use fissure::Integrator;

/// The PNGs a run wrote: with `CI` set there must be some (CI installs lavapipe).
fn expect_pictures(name: &str, pngs: &[std::path::PathBuf]) {
    if pngs.is_empty() {
        assert!(!fissure::gpu::adapter_required(), "{name}: no frames drawn, and CI requires a GPU adapter");
        eprintln!("{name}: no GPU adapter, so no frames were drawn (the simulation checks still ran)");
    }
}

/// The whole ball-drop scene (4 s): the ball strikes an obstacle, comes to rest on the floor and never enters a
/// collider; every 60th frame is drawn and must show the ball.
#[test]
fn ball_drop_example_comes_to_rest_and_its_frames_are_not_blank() {
    let s = ball_drop::run(240, Integrator::SymplecticEuler, false, Some(60)).unwrap();
    ball_drop::check(&s, 1.2, true).unwrap();
    assert!(s.obstacle_contacts > 0, "the ball never reached the obstacle: {s:?}");
    expect_pictures("ball_drop", &s.pngs);
    assert!(s.pngs.is_empty() || s.pngs.len() == 4, "{:?}", s.pngs);
}

#[allow(dead_code)]
#[path = "../examples/cloth_wind.rs"]
mod cloth_wind;

/// One second of the cloth in the wind: blown downwind, no spring over 25 %, above the ground, frames not blank.
#[test]
fn cloth_wind_example_is_blown_downwind_and_its_frames_are_not_blank() {
    let s = cloth_wind::run(60, false, Some(20)).unwrap();
    cloth_wind::check(&s).unwrap();
    expect_pictures("cloth_wind", &s.pngs);
}

/// The frame check fails on a blank frame and on one without the body: it can fail.
#[test]
fn the_frame_check_rejects_blank_frames() {
    use fissure::gpu::render::{Image, PALETTE};
    let blank = Image { width: 64, height: 32, rgba: [20u8, 24, 30, 255].repeat(64 * 32) };
    assert!(blank.check_not_blank(0.0).unwrap_err().contains("blank"));
    let mut noisy = blank.clone();
    for (k, p) in noisy.rgba.chunks_exact_mut(4).enumerate() {
        // Blues and greens: nothing of the body's orange.
        p[1] = (k * 7 % 256) as u8;
        p[2] = (k * 13 % 256) as u8;
    }
    assert!(noisy.check_not_blank(0.01).unwrap_err().contains("body covers"));
    let mut with_body = noisy.clone();
    for p in with_body.rgba.chunks_exact_mut(4).take(400) {
        p[..3].copy_from_slice(&PALETTE[0]);
    }
    with_body.check_not_blank(0.01).unwrap();
}

#[test]
fn ball_drop_example_runs_and_passes_its_check() {
    // 45 frames (0.75 s): the ball has fallen onto the first obstacle by then.
    let s = ball_drop::run(45, Integrator::SymplecticEuler, false, None).unwrap();
    ball_drop::check(&s, 1.2, false).unwrap();
    assert!(s.obstacle_contacts > 0, "the ball never reached the obstacle: {s:?}");
    assert!(s.com.y < 1.6, "the ball did not fall: {s:?}");
}

#[test]
fn ball_drop_example_runs_with_the_implicit_integrator() {
    let s = ball_drop::run(45, Integrator::ImplicitEuler, false, None).unwrap();
    ball_drop::check(&s, 1.2, false).unwrap();
}

#[allow(dead_code)]
#[path = "../examples/fracture.rs"]
mod fracture;

/// The fracture scene (`scenes/fracture.toml`) for its whole duration: at least three fracture events in at least
/// two separate places, a core block broken off, the punctured ball deflating as its gas leaks, no NaN and no
/// particle inside a collider at any frame.
#[test]
fn fracture_example_runs_and_passes_its_check() {
    let s = fracture::run(&fracture::default_scene(), None, false, Some(15)).unwrap();
    fracture::check(&s).unwrap();
    expect_pictures("fracture", &s.pngs);
    assert!(s.events.len() >= 3 && s.places(0.1) >= 2, "{} events in {} places", s.events.len(), s.places(0.1));
    assert!(s.count(fissure::FractureKind::Core) >= 1 && s.pieces.1 > s.pieces.0);
    let (at, end) = s.volume_after_puncture.expect("punctured");
    assert!(end < at, "volume {at} -> {end}");
}

/// Scene files name the offending key in their errors.
#[test]
fn scene_errors_name_the_key() {
    use fissure::scene::Scene;
    use std::path::Path;
    let p = Path::new("inline.toml");
    let e = Scene::parse("[solver]\ndtt = 1e-4\n", p).unwrap_err().to_string();
    assert!(e.contains("dtt"), "{e}");
    let e = Scene::parse("[solver]\ndt = -1.0\n", p).unwrap_err().to_string();
    assert!(e.contains("solver.dt"), "{e}");
    let e =
        Scene::parse("[[body]]\nshape = \"icosphere\"\nradius = 0.2\nmass = \"heavy\"\n", p).unwrap_err().to_string();
    assert!(e.contains("mass"), "{e}");
    let s = Scene::parse("[[body]]\nshape = \"icosphere\"\n", p).unwrap();
    let e = s.builder().expect_err("radius is required").to_string();
    assert!(e.contains("body[0].radius"), "{e}");
    let s = Scene::parse("[[collider]]\nshape = \"ball\"\ncenter = [0, 0, 0]\nradius = -1\n", p).unwrap();
    let e = s.builder().expect_err("bad radius").to_string();
    assert!(e.contains("collider[0].radius"), "{e}");
}
