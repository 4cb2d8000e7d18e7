//! Same input, bit-identical output, whatever the thread count.

use fissure_core::glam::{DVec3, Vec3};
use fissure_core::*;

/// A scene using every term, large enough (> one 2048-element chunk of particles, springs and triangles) for
/// every pass and reduction to run in parallel.
fn scene() -> Model<f32> {
    let mut b = ModelBuilder::new();
    let ball = SoftBodyOptions {
        mass: Mass::Total(0.5),
        gas: Gas::Pressure(3000.0),
        bending: Some(Stiffness::PerSpring(10.0)),
        aero: Aero::default(),
        velocity: DVec3::new(0.5, -1.0, 0.2),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.3, 4).translated(DVec3::new(0.0, 0.5, 0.0)), &ball).unwrap();
    b.add_cloth_grid(
        48,
        48,
        0.02,
        |p| DVec3::new(p.x - 0.5, 1.2, p.y),
        &ClothOptions { pins: vec![0, 47], mass: Mass::PerParticle(1e-3), ..Default::default() },
    )
    .unwrap();
    b.wind(WindField::default());
    b.add_collider(Collider::ground(0.0));
    b.add_collider(Collider::ball(Vec3::new(0.1, 0.1, 0.0), 0.15));
    b.finalize().unwrap()
}

fn fingerprint(s: &State<f32>) -> Vec<u32> {
    s.particle_q.iter().chain(&s.particle_qd).flat_map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]).collect()
}

fn run(threads: usize, integrator: Integrator) -> Vec<u32> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let model = scene();
        let mut s = model.state();
        let mut solver = CpuSolver::<f32>::with_integrator(integrator);
        let dt = if integrator == Integrator::ImplicitEuler { 2e-3 } else { 1e-4 };
        for _ in 0..60 {
            solver.step(&model, &mut s, dt).unwrap();
        }
        fingerprint(&s)
    })
}

#[test]
fn one_and_two_threads_give_identical_bits() {
    let m = scene();
    assert!(m.particle_count() > 4096 && m.spring_count() > 4096 && m.tri_count() > 4096);
    for integrator in Integrator::ALL {
        let a = run(1, integrator);
        let b = run(2, integrator);
        let c = run(2, integrator);
        assert_eq!(b, c, "{}: two runs on 2 threads differ", integrator.name());
        let first = a.iter().zip(&b).position(|(x, y)| x != y);
        assert!(first.is_none(), "{}: 1 vs 2 threads differ at word {first:?}", integrator.name());
    }
}
