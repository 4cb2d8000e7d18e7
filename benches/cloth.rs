//! The foundation benchmark: a 128 × 128 cloth (spacing 1 cm, 1 g per particle, structural + shear + bend springs =
//! 97,026, k = 1000 N/m, two corners pinned, gravity, symplectic Euler, dt = 2e-4 s), one step per iteration.
//!
//! Run: `cargo bench --bench cloth`. `FISSURE_BENCH_QUICK=1` shrinks the grid to 32 × 32 so CI can run it fast.

use criterion::{Criterion, criterion_group, criterion_main};
use fissure::*;
use std::hint::black_box;
use std::time::Instant;

fn bench(c: &mut Criterion) {
    let n = if std::env::var_os("FISSURE_BENCH_QUICK").is_some() { 32 } else { 128 };
    let model: Model<f32> = fissure::scenes::benchmark_cloth(n).unwrap().finalize().unwrap();
    let mut state = model.state();
    let mut solver = CpuSolver::<f32>::default();
    let dt = 2e-4;
    // Warm up into a deformed state, and print the per-stage picture once.
    for _ in 0..200 {
        solver.step(&model, &mut state, dt).unwrap();
    }
    solver.reset_timers();
    // A batch of steps (`Solver::advance`, what `World::advance` runs): the CPU solver steps it inside the thread
    // pool, handing it over once. Then the same steps one call at a time, each handed over on its own.
    let steps = 2000;
    let t0 = Instant::now();
    solver.advance(&model, &mut state, dt, steps).unwrap();
    let per_step = t0.elapsed().as_secs_f64() / steps as f64;
    let t0 = Instant::now();
    for _ in 0..steps {
        solver.step(&model, &mut state, dt).unwrap();
    }
    let per_call = t0.elapsed().as_secs_f64() / steps as f64;
    println!(
        "cloth {n}x{n}: {} particles, {} springs, {} threads: {:.1} µs/step ({:.0} steps/s, {:.2e} particle-steps/s)",
        model.particle_count(),
        model.spring_count(),
        rayon::current_num_threads(),
        per_step * 1e6,
        1.0 / per_step,
        model.particle_count() as f64 / per_step
    );
    println!("  one step per call: {:.1} µs/step", per_call * 1e6);
    println!("{}", solver.timers());
    // Implicit Euler at 1/60 s on the 32² cloth (issue 15's large-step row): time per step and CG iterations.
    {
        let model: Model<f32> = fissure::scenes::benchmark_cloth(32).unwrap().finalize().unwrap();
        let mut state = model.state();
        let mut solver = CpuSolver::<f32>::with_integrator(Integrator::ImplicitEuler);
        let h = 1.0 / 60.0;
        let (mut iterations, steps) = (0, 120);
        let t0 = Instant::now();
        for _ in 0..steps {
            solver.step(&model, &mut state, h).unwrap();
            iterations += solver.cg.iterations;
        }
        let per_step = t0.elapsed().as_secs_f64() / steps as f64;
        println!(
            "cloth 32x32 implicit Euler at 1/60 s: {:.2} ms/step, {:.1} CG iterations per step (2 s of motion)",
            per_step * 1e3,
            iterations as f64 / steps as f64
        );
    }
    c.bench_function(&format!("cloth_{n}x{n}_symplectic_euler_step"), |b| {
        b.iter(|| {
            solver.step(&model, &mut state, dt).unwrap();
            black_box(&state);
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
