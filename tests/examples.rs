//! Examples double as tests: each runs here with few frames and its own final check must hold.

#[allow(dead_code)]
#[path = "../examples/ball_drop.rs"]
mod ball_drop;

use fissure::Integrator;

#[test]
fn ball_drop_example_runs_and_passes_its_check() {
    // 45 frames (0.75 s): the ball has fallen onto the first obstacle by then.
    let s = ball_drop::run(45, Integrator::SymplecticEuler, false).unwrap();
    ball_drop::check(&s, 1.2).unwrap();
    assert!(s.obstacle_contacts > 0, "the ball never reached the obstacle: {s:?}");
    assert!(s.com.y < 1.6, "the ball did not fall: {s:?}");
}

#[test]
fn ball_drop_example_runs_with_the_implicit_integrator() {
    let s = ball_drop::run(45, Integrator::ImplicitEuler, false).unwrap();
    ball_drop::check(&s, 1.2).unwrap();
}

#[allow(dead_code)]
#[path = "../examples/fracture.rs"]
mod fracture;

/// The fracture scene (`scenes/fracture.toml`) for its whole duration: at least three fracture events in at least
/// two separate places, a core block broken off, the punctured ball deflating as its gas leaks, no NaN and no
/// particle inside a collider at any frame.
#[test]
fn fracture_example_runs_and_passes_its_check() {
    let s = fracture::run(&fracture::default_scene(), None, false).unwrap();
    fracture::check(&s).unwrap();
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
