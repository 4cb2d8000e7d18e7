//! Collisions, resting contact, restitution, and a cloth hanging from its pins.

use fissure_core::glam::{DVec3, Vec3};
use fissure_core::*;

#[test]
fn point_mass_bounces_according_to_restitution() {
    for e in [0.0f32, 0.5, 0.8] {
        let mut b = ModelBuilder::new();
        let h0 = 1.0;
        b.add_particle(DVec3::new(0.0, h0, 0.0), DVec3::ZERO, 0.1).unwrap();
        b.add_collider(Collider::ground(0.0).with_restitution(e).with_friction(0.0)).unwrap();
        let model: Model<f64> = b.finalize().unwrap();
        let mut s = model.state();
        let mut solver = CpuSolver::<f64>::default();
        let dt = 1e-5;
        let mut bounced = false;
        let mut apex: f64 = 0.0;
        let mut min_y = f64::MAX;
        while s.time < 0.45 + 0.9 * e as f64 {
            solver.step(&model, &mut s, dt).unwrap();
            min_y = min_y.min(s.particle_q[0].y);
            if s.particle_qd[0].y > 0.0 {
                bounced = true;
            }
            if bounced {
                apex = apex.max(s.particle_q[0].y);
            }
        }
        assert!(min_y >= 0.0, "particle went below the ground: {min_y}");
        // Rebound height e² h0; the discrete impact time adds O(dt) relative error.
        let expected = (e * e) as f64 * h0;
        assert!((apex - expected).abs() < 2e-3 * h0 + 1e-6, "e = {e}: apex {apex} vs e² h0 = {expected}");
    }
}

fn ball_scene(colliders: Vec<Collider>, x0: DVec3, v0: DVec3) -> Model<f32> {
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        mass: Mass::Total(0.5),
        stiffness: Stiffness::Membrane(3000.0),
        damping: Damping::Ratio(0.2),
        gas: Gas::Pressure(3000.0),
        velocity: v0,
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.2, 3).translated(x0), &opts).unwrap();
    for c in colliders {
        b.add_collider(c).unwrap();
    }
    b.finalize().unwrap()
}

#[test]
fn pressurised_ball_comes_to_rest_on_the_ground() {
    // A taut balloon stores its impact in the gas and gives it back (it bounces like a basketball under the
    // explicit integrators; the restitution law itself is checked on a point mass above). Implicit Euler at a
    // frame-rate step adds the numerical damping a game wants and must still never let it sink.
    let model = ball_scene(vec![Collider::ground(0.0).with_restitution(0.2)], DVec3::new(0.0, 1.0, 0.0), DVec3::ZERO);
    let mut s = model.state();
    let mut solver = CpuSolver::<f32>::with_integrator(Integrator::ImplicitEuler);
    let v_rest = model.body_volumes(&s)[0];
    let dt = 1.0 / 240.0;
    let mut min_y = f32::MAX;
    while s.time < 4.0 {
        solver.step(&model, &mut s, dt).unwrap();
        // No particle is ever left below the ground after a step.
        let lowest = s.particle_q.iter().map(|q| q.y).fold(f32::MAX, f32::min);
        min_y = min_y.min(lowest);
    }
    assert!(min_y >= 0.0, "a particle was left inside the ground: y = {min_y}");
    let com = model.center_of_mass(&s);
    let speed = model.momentum(&s).length() / model.total_mass();
    // At rest: centre of mass about one (slightly squashed) radius up, no net motion, volume kept by the gas.
    assert!(speed < 0.05, "still moving: {speed} m/s");
    assert!(com.y > 0.17 && com.y < 0.21, "centre of mass at {com:?}");
    let v = model.body_volumes(&s)[0];
    assert!(v > 0.9 * v_rest, "ball collapsed: V = {v}, rest {v_rest}");
}

#[test]
fn explicit_ball_bounces_and_stays_above_the_ground() {
    let model = ball_scene(vec![Collider::ground(0.0).with_restitution(0.2)], DVec3::new(0.0, 1.0, 0.0), DVec3::ZERO);
    let mut s = model.state();
    let mut solver = CpuSolver::<f32>::default();
    let (mut min_y, mut bounced) = (f32::MAX, false);
    while s.time < 1.0 {
        solver.step(&model, &mut s, 1e-4).unwrap();
        min_y = min_y.min(s.particle_q.iter().map(|q| q.y).fold(f32::MAX, f32::min));
        bounced |= model.momentum(&s).y > 0.5;
    }
    assert!(bounced, "the ball did not bounce");
    assert!(min_y >= 0.0, "a particle was left inside the ground: y = {min_y}");
}

#[test]
fn no_particle_is_left_inside_any_collider_shape() {
    let obstacles = vec![
        Collider::ground(0.0),
        Collider::ball(Vec3::new(0.05, 0.4, 0.0), 0.15),
        Collider::cuboid(Vec3::new(-0.4, 0.15, 0.0), Vec3::new(0.1, 0.15, 0.4)),
        Collider::capsule(Vec3::new(0.3, 0.1, -0.3), Vec3::new(0.3, 0.1, 0.3), 0.08),
        Collider::plane(Vec3::new(0.6, 0.0, 0.0), Vec3::new(-1.0, 0.0, 0.0)),
        Collider::trimesh(&Mesh::icosphere(0.12, 2).translated(DVec3::new(-0.1, 0.12, 0.35))).unwrap(),
    ];
    let model = ball_scene(obstacles.clone(), DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.5, 0.0, 0.3));
    let mut s = model.state();
    let mut solver = CpuSolver::<f32>::default();
    let mut contacts = vec![0usize; obstacles.len()];
    for step in 0..8000 {
        solver.step(&model, &mut s, 2e-4).unwrap();
        if step % 10 != 0 {
            continue;
        }
        for (ci, c) in model.colliders.iter().enumerate() {
            let pose = c.pose_at(s.time);
            for q in &s.particle_q {
                let local = pose.inverse_transform_point(*q);
                // solid = false: an interior point projects to the boundary, so `depth` is its penetration.
                let proj = c.shape.project_local_point(local, false);
                let depth = (proj.point - local).length();
                if (proj.point - local).length() < 1e-3 {
                    contacts[ci] += 1;
                }
                // Inside by more than f32 rounding of the projection is a failure.
                assert!(
                    !proj.is_inside || depth < 1e-5,
                    "step {step}: particle {q:?} is {depth} m inside collider {ci}"
                );
            }
        }
    }
    assert!(contacts[0] > 0 && contacts[1] > 0, "the ball touched the ground and the obstacle ball: {contacts:?}");
    assert!(solver.timers().calls(Stage::Collide) > 0);
}

#[test]
fn moving_collider_pushes_particles_with_its_velocity() {
    // A plate moving up at 1 m/s lifts a resting particle: after contact the particle moves with it.
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    b.add_particle(DVec3::new(0.0, 0.5, 0.0), DVec3::ZERO, 0.1).unwrap();
    b.add_collider(
        Collider::cuboid(Vec3::new(0.0, -0.1, 0.0), Vec3::new(1.0, 0.1, 1.0))
            .with_velocity(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO)
            .with_restitution(0.0),
    )
    .unwrap();
    let model: Model<f32> = b.finalize().unwrap();
    let mut s = model.state();
    let mut solver = CpuSolver::<f32>::default();
    for _ in 0..1000 {
        solver.step(&model, &mut s, 1e-3).unwrap();
    }
    // Plate top at y = t; the particle rides on it at the plate's speed.
    assert!((s.particle_q[0].y - s.time as f32).abs() < 2e-3, "y = {} at t = {}", s.particle_q[0].y, s.time);
    assert!((s.particle_qd[0].y - 1.0).abs() < 1e-3, "v = {:?}", s.particle_qd[0]);
}

#[test]
fn friction_stops_a_sliding_particle_as_coulomb_predicts() {
    // v0 = 2 m/s along the ground with μ = 0.5: it stops after v0²/(2 μ g) = 0.4077 m.
    let mut b = ModelBuilder::new();
    b.add_particle(DVec3::new(0.0, 0.0, 0.0), DVec3::new(2.0, 0.0, 0.0), 0.1).unwrap();
    b.add_collider(Collider::ground(0.0).with_friction(0.5).with_restitution(0.0)).unwrap();
    let model: Model<f64> = b.finalize().unwrap();
    let mut s = model.state();
    let mut solver = CpuSolver::<f64>::default();
    for _ in 0..10000 {
        solver.step(&model, &mut s, 1e-4).unwrap();
    }
    let expected = 4.0 / (2.0 * 0.5 * 9.81);
    assert!(s.particle_qd[0].length() < 1e-9, "still sliding: {:?}", s.particle_qd[0]);
    assert!((s.particle_q[0].x - expected).abs() < 1e-3, "slid {} m, Coulomb {expected} m", s.particle_q[0].x);
}

#[test]
fn cloth_pinned_at_two_corners_hangs_from_them() {
    let mut b = ModelBuilder::new();
    let n = 16;
    let spacing = 0.05;
    let opts = ClothOptions {
        mass: Mass::PerParticle(1e-3),
        damping: Damping::Ratio(0.3),
        pins: vec![0, n - 1],
        ..Default::default()
    };
    // Horizontal sheet at y = 1 (grid rows along -z).
    let h = b.add_cloth_grid(n, n, spacing, |p| DVec3::new(p.x, 1.0, p.y), &opts).unwrap();
    // Still air: its drag is what stops the swinging (spring damping does not damp a rigid swing).
    b.wind(WindField::steady(DVec3::ZERO)).unwrap();
    let model: Model<f32> = b.finalize().unwrap();
    let mut s = model.state();
    let pins0 = [s.particle_q[0], s.particle_q[n - 1]];
    let mut solver = CpuSolver::<f32>::default();
    for _ in 0..40000 {
        solver.step(&model, &mut s, 1e-4).unwrap();
    }
    assert_eq!([s.particle_q[0], s.particle_q[n - 1]], pins0, "pins moved");
    let ys: Vec<f32> = h.particles().map(|i| s.particle_q[i].y).collect();
    let top = ys.iter().copied().fold(f32::MIN, f32::max);
    let bottom = ys.iter().copied().fold(f32::MAX, f32::min);
    // It hangs: nothing above the pins, the far edge about one cloth length (0.75 m) below them, and it has
    // mostly stopped swinging.
    // (The row between the pins buckles a little under compression: allow a fifth of the spacing.)
    assert!(top <= 1.0 + 0.2 * spacing as f32, "cloth above its pins: {top}");
    assert!(bottom < 1.0 - 0.6 && bottom > 1.0 - 0.9, "lowest point {bottom}");
    let speed = model.momentum(&s).length() / model.total_mass();
    // Without air it still swings at ~1.8 m/s after 4 s; air drag must have taken most of that out.
    assert!(speed < 0.3, "still swinging at {speed} m/s");
}

#[test]
fn analytic_shape_projections_agree_with_parry() {
    // The closed-form paths for half-spaces, balls, cuboids and capsules must put an interior point where
    // parry3d's own point projection does (which the trimesh path uses).
    use fissure_core::glam::Quat;
    let shapes = [
        Collider::plane(Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.3, 1.0, -0.2)),
        Collider::ball(Vec3::new(0.2, -0.1, 0.4), 0.7),
        Collider::cuboid(Vec3::new(-0.3, 0.2, 0.1), Vec3::new(0.5, 0.3, 0.8)).with_rotation(Quat::from_rotation_y(0.7)),
        Collider::capsule(Vec3::new(-0.4, 0.0, 0.1), Vec3::new(0.5, 0.3, -0.2), 0.35),
    ];
    let mut seed = 1u64;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    };
    let mut checked = 0;
    for c in &shapes {
        let pose = c.pose_at(0.0);
        for _ in 0..2000 {
            let x = Vec3::new(rnd(), rnd(), rnd()) * 1.2;
            let local = pose.inverse_transform_point(x);
            let proj = c.shape.project_local_point(local, false);
            let resolved = c.resolve(0.0, x, Vec3::ZERO);
            assert_eq!(resolved.is_some(), proj.is_inside, "{:?} at {x:?}", c.shape.shape_type());
            if let Some((x_new, _)) = resolved {
                let expected = pose.transform_point(proj.point);
                assert!(
                    (x_new - expected).length() < 1e-5,
                    "{:?}: {x_new:?} vs parry {expected:?}",
                    c.shape.shape_type()
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 1000, "only {checked} interior points checked");
}
