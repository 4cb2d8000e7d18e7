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
