//! Every instruction set the vector kernels can run on (`fissure::isa`) gives the same bits: the cloth in wind
//! (the wind pass), the tearing cloth (the run kernel measuring its strains), the ball drop (the per-spring
//! kernel), the fracture scene (the update summing loads, the caps over openings), a grid cloth under symplectic Euler (the fused grid-run spring kernel and the update after it) and
//! under implicit Euler (the solver's runs), a grid cloth dropped onto the ground and a ball (the collision pass's
//! blocks in lanes, fused with the run kernel), a pressurised ball with pinned particles (the update eight particles
//! at a time), the same in wind (that update with the wind pass's corner forces), each run once per set this CPU has, their final states compared
//! bit for bit. One test in its own binary: the cap it sets holds for the whole process.

use fissure::isa::{self, Isa};
use fissure::scene::Scene;
use fissure::*;
use std::path::Path;

/// The bits of the final positions and velocities.
fn bits(w: &World<f32>) -> Vec<u32> {
    let s = &w.state;
    s.particle_q.iter().chain(&s.particle_qd).flat_map(|v| v.to_array().map(f32::to_bits)).collect()
}

fn scene(file: &str) -> Vec<u32> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(file);
    let scene = Scene::load(&path).expect("scene loads");
    let mut world: World<f32> = scene.world().expect("scene builds");
    world.advance(scene.solver.duration.min(0.5), scene.solver.dt).expect("scene runs");
    bits(&world)
}

/// The benchmark cloth (springs and gravity only: the fused run kernel and update) with `integrator`.
fn grid_cloth(integrator: Integrator, duration: f64, dt: f64) -> Vec<u32> {
    let model = scenes::benchmark_cloth(24).expect("cloth builds").finalize().expect("cloth finalizes");
    let mut world: World<f32> = World::new(model, SolverConfig::with(integrator));
    world.advance(duration, dt).expect("cloth runs");
    bits(&world)
}

/// A 40² cloth (1 cm, 1 g a particle) lying on the ground and falling onto a ball beneath it: every collision
/// block in contact with the plane, some with the ball (symplectic Euler: the colliders fused into the run pass).
fn draped_cloth() -> Vec<u32> {
    let mut b = ModelBuilder::new();
    let opts = ClothOptions { pins: vec![], mass: Mass::PerParticle(1e-3), ..Default::default() };
    b.add_cloth_grid(40, 40, 0.01, |p| fissure::glam::DVec3::new(p.x, 1.0, p.y), &opts).expect("cloth builds");
    b.add_collider(Collider::ground(0.9995)).expect("ground");
    b.add_collider(Collider::ball(fissure::glam::Vec3::new(0.2, 0.8, 0.2), 0.2).with_friction(0.5)).expect("ball");
    let model = b.finalize().expect("cloth finalizes");
    let mut world: World<f32> = World::new(model, SolverConfig::with(Integrator::SymplecticEuler));
    world.advance(0.1, 1e-4).expect("cloth runs");
    bits(&world)
}

/// A pressurised ball on the ground with three particles pinned (their inverse masses set to 0), symplectic
/// Euler with projected damping, breakable by strain: the per-spring kernel measuring each spring's length (the
/// strains the fracture trigger reads: springs split) and the update eight particles at a time with its gas push
/// and pinned lanes (`forces::gather_avx2`), the ball's 642 particles in 80 whole blocks and a tail of two.
fn pinned_ball() -> Vec<u32> {
    pinned_ball_in(false)
}

/// [`pinned_ball`] in the default wind: the update eight particles at a time with the wind pass's per-triangle
/// corner forces (gas included) in place of the gas push.
fn pinned_ball_in_wind() -> Vec<u32> {
    pinned_ball_in(true)
}

fn pinned_ball_in(wind: bool) -> Vec<u32> {
    let mut b = ModelBuilder::new();
    let fracture = Some(Breakable { strain_limit: 0.12, ..Default::default() });
    let aero = if wind { Aero::default() } else { Aero::NONE };
    let opts = SoftBodyOptions { gas: Gas::Pressure(2000.0), fracture, aero, ..Default::default() };
    let ball = Mesh::icosphere(0.2, 3).translated(fissure::glam::DVec3::new(0.0, 0.25, 0.0));
    b.add_soft_body(&ball, &opts).expect("ball builds");
    b.add_collider(Collider::ground(0.0)).expect("ground");
    if wind {
        b.wind(WindField::default()).expect("wind");
    }
    let mut model: Model<f32> = b.finalize().expect("ball finalizes");
    for i in [0, 100, 641] {
        model.particle_inv_mass[i] = 0.0;
    }
    let mut world = World::new(model, SolverConfig::with(Integrator::SymplecticEuler));
    world.advance(0.05, 1e-4).expect("ball runs");
    assert!(!world.events.is_empty(), "springs split");
    bits(&world)
}

/// A ball without gas in the default wind, its membrane stiff enough to hold its shape: the wind pass forms each
/// triangle's cross itself (no gas pass formed them), eight triangles at a time on AVX2 (`forces::wind_avx2`), and
/// samples the air per particle in blocks of 16 on AVX-512.
fn ball_in_wind_without_gas() -> Vec<u32> {
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        gas: Gas::None,
        stiffness: Stiffness::Membrane(2500.0),
        aero: Aero::default(),
        ..Default::default()
    };
    let ball = Mesh::icosphere(0.2, 3).translated(fissure::glam::DVec3::new(0.0, 0.25, 0.0));
    b.add_soft_body(&ball, &opts).expect("ball builds");
    b.add_collider(Collider::ground(0.0)).expect("ground");
    b.wind(WindField { velocity: fissure::glam::DVec3::new(0.0, -2.0, 6.0), ..Default::default() }).expect("wind");
    let model: Model<f32> = b.finalize().expect("ball finalizes");
    let mut world = World::new(model, SolverConfig::with(Integrator::SymplecticEuler));
    world.advance(0.05, 1e-4).expect("ball runs");
    bits(&world)
}

#[test]
fn every_instruction_set_gives_the_same_bits() {
    let sets = isa::available();
    assert_eq!(sets[0], Isa::Baseline);
    type Run = (&'static str, fn() -> Vec<u32>);
    let runs: [Run; 10] = [
        ("cloth_wind.toml", || scene("cloth_wind.toml")),
        // A breakable grid: the run kernel measures its springs' strains every step.
        ("cloth_tear.toml", || scene("cloth_tear.toml")),
        ("ball_drop.toml", || scene("ball_drop.toml")),
        // Load limits (the update sums each particle's load) and the caps over the openings of its core splits.
        ("fracture.toml", || scene("fracture.toml")),
        ("24² cloth, symplectic Euler", || grid_cloth(Integrator::SymplecticEuler, 0.1, 2e-4)),
        ("24² cloth, implicit Euler", || grid_cloth(Integrator::ImplicitEuler, 0.25, 1.0 / 60.0)),
        ("40² cloth on the ground and a ball", draped_cloth),
        ("a pressurised ball with pinned particles", pinned_ball),
        ("a pressurised ball with pinned particles in wind", pinned_ball_in_wind),
        ("a ball without gas in wind", ball_in_wind_without_gas),
    ];
    for (name, run) in runs {
        let mut first: Option<(Isa, Vec<u32>)> = None;
        for &set in &sets {
            isa::set_limit(set);
            let got = run();
            match &first {
                None => first = Some((set, got)),
                Some((set0, want)) => {
                    let differ = want.iter().zip(&got).filter(|(a, b)| a != b).count();
                    assert!(
                        differ == 0,
                        "{name}: {differ} of {} values differ between {set0:?} and {set:?}",
                        got.len()
                    );
                }
            }
        }
    }
    isa::set_limit(Isa::Avx512);
    eprintln!("compared on {sets:?}");
}
