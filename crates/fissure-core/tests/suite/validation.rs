//! The core validates every value it is given: each public constructor and builder call rejects a non-finite or
//! out-of-range value with an error naming it, and keeps nothing of the bad call. The scene loader and Python
//! only map these names to their keys and keywords (tested in `tests/suite/validation.rs` and `test_validation.py`).

use fissure_core::glam::{DVec3, Vec3};
use fissure_core::*;

/// The parameter an error names, or a description of the other error.
fn named(e: ModelError) -> String {
    match e {
        ModelError::Parameter { name, .. } => name.to_string(),
        e => format!("not a parameter error: {e}"),
    }
}

fn collider_error(c: Collider) -> String {
    let mut b = ModelBuilder::new();
    let e = b.add_collider(c).expect_err("the collider is rejected");
    assert!(b.finalize::<f32>().is_err(), "nothing was added");
    named(e)
}

#[test]
fn nan_negative_and_zero_radius_are_rejected() {
    for r in [f32::NAN, -0.1, 0.0, f32::INFINITY] {
        assert_eq!(collider_error(Collider::ball(Vec3::ZERO, r)), "radius", "ball radius {r}");
        assert_eq!(collider_error(Collider::capsule(Vec3::ZERO, Vec3::X, r)), "radius", "capsule radius {r}");
    }
    assert_eq!(collider_error(Collider::cuboid(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0))), "half_extents");
    let msg = ModelBuilder::new().add_collider(Collider::ball(Vec3::ZERO, -0.1)).err().unwrap().to_string();
    assert!(msg.contains("radius") && msg.contains("-0.1"), "{msg}");
}

#[test]
fn a_zero_or_nan_normal_is_rejected() {
    assert_eq!(collider_error(Collider::plane(Vec3::ZERO, Vec3::ZERO)), "normal");
    assert_eq!(collider_error(Collider::plane(Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0))), "normal");
    // A non-unit but nonzero normal is normalised and accepted.
    assert!(ModelBuilder::new().add_collider(Collider::plane(Vec3::ZERO, Vec3::new(0.0, 3.0, 0.0))).is_ok());
}

#[test]
fn bad_collider_material_and_pose_are_rejected() {
    assert_eq!(collider_error(Collider::ground(0.0).with_restitution(1.5)), "restitution");
    assert_eq!(collider_error(Collider::ground(0.0).with_friction(f32::NAN)), "friction");
    assert_eq!(collider_error(Collider::ground(0.0).with_margin(-1.0)), "margin");
    assert_eq!(collider_error(Collider::ball(Vec3::new(f32::NAN, 0.0, 0.0), 1.0)), "position");
    assert_eq!(collider_error(Collider::ground(f32::NAN)), "position");
    assert_eq!(collider_error(Collider::ball(Vec3::ZERO, 1.0).with_velocity(Vec3::NAN, Vec3::ZERO)), "velocity");
}

fn ball_error(opts: SoftBodyOptions) -> String {
    let mut b = ModelBuilder::new();
    named(b.add_soft_body(&Mesh::icosphere(0.2, 1), &opts).expect_err("the body is rejected"))
}

#[test]
fn nan_and_negative_pressure_are_rejected() {
    for p in [f64::NAN, -100.0, f64::INFINITY] {
        assert_eq!(ball_error(SoftBodyOptions { gas: Gas::Pressure(p), ..Default::default() }), "pressure", "{p}");
    }
    assert_eq!(ball_error(SoftBodyOptions { gas: Gas::Amount(f64::NAN), ..Default::default() }), "gas_amount");
}

#[test]
fn negative_and_nan_mass_are_rejected() {
    for m in [-1.0, f64::NAN, 0.0] {
        assert_eq!(ball_error(SoftBodyOptions { mass: Mass::Total(m), ..Default::default() }), "mass", "{m}");
    }
    assert_eq!(named(ModelBuilder::new().add_particle(DVec3::ZERO, DVec3::ZERO, -1.0).unwrap_err()), "mass");
}

#[test]
fn nan_wind_and_gravity_are_rejected() {
    let mut b = ModelBuilder::new();
    let e = b.wind(WindField { velocity: DVec3::new(f64::NAN, 0.0, 0.0), ..Default::default() }).err().unwrap();
    assert_eq!(named(e), "velocity");
    let e = b.wind(WindField { air_density: 0.0, ..Default::default() }).err().unwrap();
    assert_eq!(named(e), "air_density");
    let e = b.wind(WindField { gust_wavelength: f64::NAN, ..Default::default() }).err().unwrap();
    assert_eq!(named(e), "gust_wavelength");
    assert_eq!(named(b.gravity(DVec3::new(0.0, f64::NAN, 0.0)).err().unwrap()), "gravity");
}

#[test]
fn non_positive_and_nan_time_steps_are_rejected() {
    let mut b = ModelBuilder::new();
    b.add_soft_body(&Mesh::icosphere(0.2, 1), &SoftBodyOptions::default()).unwrap();
    let m: Model<f32> = b.finalize().unwrap();
    let mut s = m.state();
    let mut solver = CpuSolver::<f32>::default();
    for dt in [0.0, -1e-4, f64::NAN, f64::INFINITY] {
        let before = s.clone();
        assert!(matches!(solver.step(&m, &mut s, dt), Err(StepError::BadTimeStep(_))), "dt = {dt}");
        assert_eq!(s, before, "a rejected step changes nothing");
    }
}

#[test]
fn bad_solver_and_fracture_settings_are_rejected() {
    let mut b = ModelBuilder::new();
    b.add_soft_body(&Mesh::icosphere(0.2, 1), &SoftBodyOptions::default()).unwrap();
    let m: Model<f32> = b.finalize().unwrap();
    let mut s = m.state();
    for (config, name) in [
        (SolverConfig { cg_tolerance: f64::NAN, ..Default::default() }, "cg_tolerance"),
        (SolverConfig { cg_max_iterations: 0, ..Default::default() }, "cg_max_iterations"),
        (SolverConfig { substep_safety: Some(1.5), ..Default::default() }, "substep_safety"),
    ] {
        match CpuSolver::<f32>::new(config).step(&m, &mut s, 1e-4) {
            Err(StepError::Config(msg)) => assert!(msg.contains(name), "{msg}"),
            r => panic!("{name}: {r:?}"),
        }
    }
    let bad = FractureConfig { gas_density: 0.0, ..Default::default() };
    assert_eq!(named(bad.validate().unwrap_err()), "gas_density");
    let bad = FractureConfig { trigger: Trigger::Averaged { window: -1.0 }, ..Default::default() };
    assert_eq!(named(bad.validate().unwrap_err()), "averaged_window");
    assert!(FractureConfig::default().validate().is_ok());
}
