//! `World::advance` over frames that are not a multiple of the step: the last steps of each frame share the
//! remainder (none shorter than half a step), so a frame boundary leaves no trace in the physics. Before, a frame of
//! 1/30 s in steps a hair too long ended with a step of a few nanoseconds, and the contact pass, which pushes a
//! pair inside its thickness apart within the step it is given, set velocities of hundreds of m/s there.

use fissure::glam::DVec3;
use fissure::*;

/// A soft balloon resting on another on the ground, with contact between them (as `soft_contact.rs`'s).
fn stack() -> World<f32> {
    let mut b = ModelBuilder::new();
    b.damping_model(DampingModel::Unprojected);
    b.add_collider(Collider::ground(0.0).with_friction(0.8).with_restitution(0.0)).unwrap();
    let c = Contact { friction: 0.8, ..Default::default() };
    for (y, mass) in [(0.21, 0.3), (0.64, 0.2)] {
        let opts = SoftBodyOptions {
            mass: Mass::Total(mass),
            stiffness: Stiffness::Membrane(1500.0),
            damping: Damping::Ratio(0.3),
            bending: Some(Stiffness::Membrane(20.0)),
            gas: Gas::Pressure(600.0),
            ..Default::default()
        };
        let h = b.add_soft_body(&Mesh::icosphere(0.2, 2).translated(DVec3::new(0.0, y, 0.0)), &opts).unwrap();
        b.set_contact(h.index, c).unwrap();
    }
    World::new(b.finalize().unwrap(), SolverConfig::default())
}

fn fastest(w: &World<f32>) -> f64 {
    w.state.particle_qd.iter().map(|v| v.length() as f64).fold(0.0, f64::max)
}

/// The stack settles for 0.5 s, then runs 0.5 s more in frames of 1/30 s whose step leaves a remainder of 1e-4
/// of a step per frame: the fastest particle stays as slow as in a run of whole steps (0.077 against 0.084 m/s;
/// with a last step of 1e-8 s per frame it read 0.84 m/s).
#[test]
fn frames_that_are_not_a_multiple_of_the_step_leave_no_trace() {
    let frame = 1.0 / 30.0;
    let dt = frame / 333.0001;
    let mut whole = stack();
    let mut framed = stack();
    whole.advance(0.5, 1.5e-4).unwrap();
    framed.advance(0.5, 1.5e-4).unwrap();
    let (mut v_whole, mut v_framed) = (0.0f64, 0.0f64);
    for _ in 0..15 {
        for _ in 0..333 {
            whole.step(dt).unwrap();
            v_whole = v_whole.max(fastest(&whole));
        }
        let adv = framed.advance(frame, dt).unwrap();
        assert_eq!(adv.steps, 334, "333 steps and the remainder shared by the last two");
        v_framed = v_framed.max(fastest(&framed));
    }
    assert!(v_whole < 1.0, "the stack is at rest: {v_whole} m/s");
    assert!(
        v_framed < 2.0 * v_whole.max(0.05),
        "a frame boundary kicked a particle to {v_framed} m/s ({v_whole} m/s in whole steps)"
    );
}

/// The steps `advance` takes: `dt` while at least 1.5 of them are left (or exactly one), then the rest in two
/// equal steps when it is between one and 1.5 steps, so no step is shorter than half of `dt`; a remainder of half
/// a step or more is one step as before (the scenes whose frames leave one keep their bits).
#[test]
fn advance_never_takes_a_step_shorter_than_half_of_dt() {
    let mut w = stack();
    let dt = 1e-4;
    for (duration, steps) in [(10.0 * dt, 10), (10.3 * dt, 11), (10.6 * dt, 11), (10.0001 * dt, 11), (0.3 * dt, 1)] {
        let t0 = w.state.time;
        let adv = w.advance(duration, dt).unwrap();
        assert_eq!(adv.steps, steps, "{duration} s in steps of {dt} s");
        assert!((w.state.time - t0 - duration).abs() < 1e-12, "lands on the end");
    }
}
