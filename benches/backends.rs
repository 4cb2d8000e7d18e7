//! Steps per second and particle-steps per second of each backend on the sizes: the benchmark cloth
//! (`scenes::benchmark_cloth`: spacing 1 cm, 1 g per particle, structural + shear + bend springs of 1000 N/m,
//! two corners pinned) at 32², 128², 512² and 1024² particles, and a pressurised icosphere ball of 40,962
//! vertices on the ground (gas, a collider). Symplectic Euler, dt = 1e-4 s (1e-5 s for the 40,962-vertex ball, whose stability limit is ~2.6e-5 s).
//!
//! - CPU: `CpuSolver` on all rayon threads, one step per iteration.
//! - GPU: `GpuSolver` on the adapter `GpuContext` picks (its name is printed), `substeps` steps per submission
//!   (nothing read back but the 16-byte status word), per-step time = submission time / substeps.
//!
//! Run: `cargo bench --bench backends`. `FISSURE_BENCH_QUICK=1` runs only the 32² cloth and a 642-vertex ball (CI).
//! Without an adapter the GPU rows are skipped with the reason printed (and the run fails when `CI` is set).

use criterion::{Criterion, criterion_group, criterion_main};
use fissure::glam::DVec3;
use fissure::*;
use fissure_gpu::{GpuConfig, GpuContext, GpuSolver};
use std::hint::black_box;
use std::time::{Duration, Instant};

const DT: f64 = 1e-4;

struct Case {
    name: String,
    model: Model<f32>,
    /// Step \[s\]: below each scene's stability limit.
    dt: f64,
}

fn cases(quick: bool) -> Vec<Case> {
    let mut out = Vec::new();
    let sizes: &[usize] = if quick { &[32] } else { &[32, 128, 512, 1024] };
    for &n in sizes {
        let model = fissure::scenes::benchmark_cloth(n).unwrap().finalize().unwrap();
        out.push(Case { name: format!("cloth_{n}x{n}"), model, dt: DT });
    }
    let sub = if quick { 3 } else { 6 };
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        mass: Mass::Total(0.4),
        stiffness: Stiffness::Membrane(2500.0),
        damping: Damping::Ratio(0.3),
        gas: Gas::Pressure(3000.0),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.25, sub).translated(DVec3::new(0.0, 0.26, 0.0)), &opts).unwrap();
    b.add_collider(Collider::ground(0.0)).unwrap();
    let model = b.finalize().unwrap();
    // 10 µg particles on 2500 N/m membrane springs: the Gershgorin bound puts the stable step near 2.6e-5 s.
    let dt = if sub >= 6 { 1e-5 } else { DT };
    out.push(Case { name: format!("ball_{}", model.particle_count()), model, dt });
    out
}

/// Substeps per GPU submission: enough work per submission to hide its overhead, few enough to keep a software
/// device's iteration short.
fn substeps(particles: usize) -> usize {
    (4_000_000 / particles.max(1)).clamp(2, 64)
}

fn row(case: &Case, backend: &str, device: &str, per_step: f64) {
    let n = case.model.particle_count();
    println!(
        "| {} | {} | {} | {} | {} | {:.1} | {:.0} | {:.3e} |",
        case.name,
        n,
        case.model.spring_count(),
        backend,
        device,
        per_step * 1e6,
        1.0 / per_step,
        n as f64 / per_step
    );
}

fn bench(c: &mut Criterion) {
    let quick = std::env::var_os("FISSURE_BENCH_QUICK").is_some();
    let cases = cases(quick);
    let threads = rayon::current_num_threads();
    let cpu_name = format!("CPU, {threads} threads");
    let gpu = match GpuContext::new() {
        Ok(ctx) => Some(ctx),
        Err(e) => {
            assert!(!fissure_gpu::adapter_required(), "CI is set and there is no GPU adapter: {e}");
            println!("GPU rows skipped: {e}");
            None
        }
    };
    let gpu_name = gpu.as_ref().map(|g| g.describe()).unwrap_or_default();
    println!("| scene | particles | springs | backend | device | µs/step | steps/s | particle-steps/s |");
    println!("|---|---:|---:|---|---|---:|---:|---:|");
    let mut group = c.benchmark_group("step");
    group.sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(2));
    // All CPU rows first: a software GPU device (lavapipe) keeps its worker threads busy for a while after a
    // submission, which would slow a CPU row measured right after a GPU one.
    for case in &cases {
        let m = &case.model;
        let mut solver = CpuSolver::<f32>::default();
        let mut state = m.state();
        let reps = (2_000_000 / m.particle_count()).clamp(3, 500);
        for _ in 0..reps {
            solver.step(m, &mut state, case.dt).unwrap();
        }
        let t0 = Instant::now();
        for _ in 0..reps {
            solver.step(m, &mut state, case.dt).unwrap();
        }
        row(case, "cpu", &cpu_name, t0.elapsed().as_secs_f64() / reps as f64);
        group.bench_function(format!("{}_cpu", case.name), |b| {
            b.iter(|| {
                solver.step(m, &mut state, case.dt).unwrap();
                black_box(&state);
            })
        });
    }
    let Some(ctx) = &gpu else { return group.finish() };
    for case in &cases {
        let m = &case.model;
        let mut g = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), m, GpuConfig::default()).unwrap();
        let k = substeps(m.particle_count());
        g.run(m, case.dt, k).unwrap();
        let submissions = (20_000_000 / (m.particle_count() * k)).clamp(2, 50);
        let t0 = Instant::now();
        for _ in 0..submissions {
            g.run(m, case.dt, k).unwrap();
        }
        g.wait().unwrap();
        let per_step = t0.elapsed().as_secs_f64() / (submissions * k) as f64;
        row(case, &format!("gpu ({k} substeps/submission)"), &gpu_name, per_step);
        group.bench_function(format!("{}_gpu_{k}_substeps", case.name), |b| {
            b.iter(|| {
                g.run(m, case.dt, k).unwrap();
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
