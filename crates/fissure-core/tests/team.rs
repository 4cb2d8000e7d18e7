//! The spinning team (`CpuSolver::advance` outside rayon's pool: models below the pool's size threshold, and
//! larger ones where the team has as many threads as the pool, as here) gives the bits of one thread. Its own test binary: it sets the global pool to two threads, which the team's
//! helpers follow (one helper), whatever the machine's core count.

use fissure_core::glam::{DVec3, Vec3};
use fissure_core::*;

/// A mid-sized scene with every term the team serves: a pressurised ball, breakable (load limits: the fused load
/// gather) or not (the crosses formed beside the spring pass), a grid cloth (the spring-run kernel), wind, and two
/// colliders; with `contact`, the cloth starts 5 mm above the ball and both have contact on (its candidate lists,
/// 3,138 particles, are built and refreshed with their grids and merges on the team); with `big`, the cloth
/// has 130 × 130 particles (past the pool's threshold: its passes are cut as a large model's).
fn scene(breakable: bool, contact: bool, big: bool) -> Model<f32> {
    let mut b = ModelBuilder::new();
    let ball = SoftBodyOptions {
        mass: Mass::Total(0.4),
        stiffness: Stiffness::PerSpring(1e3),
        gas: Gas::Amount(200.0),
        velocity: DVec3::new(0.3, -1.0, 0.1),
        fracture: breakable.then_some(Breakable {
            strain_limit: f64::INFINITY,
            load_limit: 1e9,
            sealed: true,
            ..Default::default()
        }),
        ..Default::default()
    };
    let h = b.add_soft_body(&Mesh::icosphere(0.25, 4).translated(DVec3::new(0.0, 0.26, 0.0)), &ball).unwrap();
    let y = if contact { 0.515 } else { 0.8 };
    let (n, spacing) = if big { (130, 0.004) } else { (24, 0.02) };
    let c = b
        .add_cloth_grid(
            n,
            n,
            spacing,
            move |p| DVec3::new(p.x - 0.2, y, p.y - 0.2),
            &ClothOptions { pins: vec![0, n - 1], mass: Mass::PerParticle(1e-3), ..Default::default() },
        )
        .unwrap();
    if contact {
        b.set_contact(h.index, Contact::default()).unwrap();
        b.set_contact(c.index, Contact { self_collision: true, ..Default::default() }).unwrap();
    }
    b.wind(WindField::default()).unwrap();
    b.add_collider(Collider::ground(0.0)).unwrap();
    b.add_collider(Collider::ball(Vec3::new(0.1, 0.5, 0.0), 0.1)).unwrap();
    b.finalize().unwrap()
}

fn run(integrator: Integrator, (breakable, contact, big): (bool, bool, bool), batch: usize) -> Vec<u32> {
    let model = scene(breakable, contact, big);
    let below = model.particle_count() < 16_384 && model.spring_count() < 16_384;
    assert_eq!(below, !big, "below the pool's threshold, or past it");
    let mut s = model.state();
    let mut solver = CpuSolver::<f32>::with_integrator(integrator);
    let dt = if integrator == Integrator::ImplicitEuler { 2e-3 } else { 1e-4 };
    for _ in 0..(120 / batch) {
        solver.advance(&model, &mut s, dt, batch).unwrap();
    }
    // A state that went somewhere (the ball thrown down at 1 m/s), so equal bits say something.
    let moved = s.particle_q.iter().zip(&model.particle_q0).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max);
    assert!(moved > 1e-3, "{}: the scene barely moved ({moved} m)", integrator.name());
    let mut bits: Vec<u32> =
        s.particle_q.iter().chain(&s.particle_qd).flat_map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]).collect();
    // A breakable model's last measures too (strains, loads, volumes: on the team the spring pass measures beside
    // the crosses), after one more step of one evaluation.
    if breakable && integrator == Integrator::SymplecticEuler {
        solver.step(&model, &mut s, dt).unwrap();
        let m = solver.fracture_measures(&model).expect("a breakable model is measured");
        assert!(m.strain_spans.is_none() && m.load.iter().any(|&l| l > 0.0));
        bits.extend(m.strain.iter().chain(m.load).chain(m.volume).map(|x| x.to_bits()));
    }
    bits
}

#[test]
fn the_team_gives_the_bits_of_one_thread() {
    rayon::ThreadPoolBuilder::new().num_threads(2).build_global().expect("this binary's only global pool");
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let kinds = [(true, false, false), (false, false, false), (false, true, false), (false, false, true)];
    for (integrator, kind) in Integrator::ALL.into_iter().flat_map(|i| kinds.map(|k| (i, k))) {
        let inline = one.install(|| run(integrator, kind, 1));
        // Outside the pool: the team (step by step and in batches).
        let teamed = run(integrator, kind, 1);
        let batched = run(integrator, kind, 40);
        let first = inline.iter().zip(&teamed).position(|(a, b)| a != b);
        assert!(first.is_none(), "{} {kind:?}: the team differs from one thread at word {first:?}", integrator.name());
        assert_eq!(teamed, batched, "{} {kind:?}: steps one at a time and in batches differ", integrator.name());
    }
}
