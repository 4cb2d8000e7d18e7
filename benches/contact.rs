//! Issue 16's contact benchmark: a 128 × 128 cloth (1 cm spacing, 1.27 m wide) dropped onto a ball collider
//! (radius 0.3 m) and the floor, with self-collision, against the same cloth without it, per step, from the same
//! folded state. Prints µs/step both ways, their ratio, and the contact pass's pairs per step.
//!
//! Then the same two models on the GPU (`GpuSolver`, the adapter `GpuContext` picks), from the same folded state,
//! at the CPU's substep, many substeps per submission: µs per substep both ways and their ratio. Without an
//! adapter the GPU arm is skipped with the reason printed (and the run fails when `CI` is set).
//!
//! Run: `cargo bench --bench contact`. `FISSURE_BENCH_QUICK=1` shrinks the cloth to 32 × 32 so CI can run it fast.

use criterion::{Criterion, criterion_group, criterion_main};
use fissure::*;
use fissure_gpu::{GpuConfig, GpuContext, GpuSolver};
use std::hint::black_box;
use std::time::Instant;

fn fold_model(n: usize, contact: bool) -> Model<f32> {
    fissure::scenes::folding_cloth(n, contact).unwrap().finalize().unwrap()
}

fn bench(c: &mut Criterion) {
    let n = if std::env::var_os("FISSURE_BENCH_QUICK").is_some() { 32 } else { 128 };
    let (with, without) = (fold_model(n, true), fold_model(n, false));
    let config = SolverConfig { substep_safety: Some(0.8), ..Default::default() };
    let mut state = with.state();
    let mut solver = CpuSolver::<f32>::new(config.clone());
    let dt = 2e-4;
    // Fall onto the ball and start folding (0.5 s).
    for _ in 0..2500 {
        solver.step(&with, &mut state, dt).unwrap();
    }
    let folded = state.clone();
    let steps = 300;
    // Seconds per step, and the mean length of the candidate lists over the steps (read after each step: the
    // lists change with every refresh, so the last step alone misstates them).
    let time = |model: &Model<f32>, solver: &mut CpuSolver<f32>| {
        let mut s = folded.clone();
        solver.reset_timers();
        let (mut listed, mut elapsed) = (0usize, 0.0);
        for _ in 0..steps {
            let t0 = Instant::now();
            solver.step(model, &mut s, dt).unwrap();
            elapsed += t0.elapsed().as_secs_f64();
            listed += solver.contact_stats().candidates;
        }
        (elapsed / steps as f64, listed as f64 / steps as f64)
    };
    let mut plain = CpuSolver::<f32>::new(config);
    // The solver with contact estimated its stability bound during the fall; a fresh solver estimates it in its
    // first step (a power iteration over the 16,384 particles, ~0.25 s on the development VM), which spread over
    // the timed steps had counted four times the cloth's own stepping in the time without self-collision. Warm
    // it on the same state first, so that both times are of stepping alone: 120 steps, past the ~100 in which a
    // fresh solver times the team against the other way (`team::Pick`; within the timed steps, its trial of
    // the slower way had counted in the time without self-collision).
    let mut warm = folded.clone();
    for _ in 0..120 {
        plain.step(&without, &mut warm, dt).unwrap();
    }
    let (t_without, _) = time(&without, &mut plain);
    let before = solver.contact_stats();
    let (t_with, listed) = time(&with, &mut solver);
    let after = solver.contact_stats();
    let per = |a: u64, b: u64| (a - b) as f64 / steps as f64;
    println!(
        "cloth {n}x{n} folding on a ball, {} threads: {:.1} µs/step with self-collision, {:.1} without: {:.2}x; \
         {:.0} pairs within reach and {:.0} pushed per step, {:.0} candidates listed (mean over the steps), {} \
         candidate lists built and {} refreshed in {steps} steps",
        rayon::current_num_threads(),
        t_with * 1e6,
        t_without * 1e6,
        t_with / t_without,
        per(after.near_total, before.near_total),
        per(after.pushed_total, before.pushed_total),
        listed,
        after.builds - before.builds,
        after.refreshes - before.refreshes
    );
    println!("{}", solver.timers());
    gpu_arm(n, [&with, &without], &folded, dt / solver.last_substeps().max(1) as f64);
    let mut s = folded.clone();
    c.bench_function(&format!("cloth_{n}x{n}_fold_self_collision_step"), |b| {
        b.iter(|| {
            solver.step(&with, &mut s, dt).unwrap();
            black_box(&s);
        })
    });
}

/// The same comparison on the GPU: each model from `folded`, substeps of `dt` \[s\] (the CPU's substep), 32 a
/// submission; µs per substep with self-collision and without, read with the queue drained.
fn gpu_arm(n: usize, models: [&Model<f32>; 2], folded: &State<f32>, dt: f64) {
    let ctx = match GpuContext::new() {
        Ok(ctx) => ctx,
        Err(e) => {
            assert!(!fissure_gpu::adapter_required(), "CI is set and there is no GPU adapter: {e}");
            println!("GPU arm skipped: {e}");
            return;
        }
    };
    let quick = std::env::var_os("FISSURE_BENCH_QUICK").is_some();
    let (k, submissions) = if quick { (4, 2) } else { (32, 20) };
    let mut per_step = [0.0; 2];
    let mut pairs = 0.0;
    for (slot, m) in models.into_iter().enumerate() {
        let config = GpuConfig { contact_capacity: 1 << 18, ..Default::default() };
        let mut g = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), m, config).unwrap();
        g.upload_state(folded).unwrap();
        g.run(m, dt, k).unwrap();
        g.wait().unwrap();
        let before = g.contact_stats();
        let t0 = Instant::now();
        for _ in 0..submissions {
            g.run(m, dt, k).unwrap();
        }
        g.wait().unwrap();
        per_step[slot] = t0.elapsed().as_secs_f64() / (submissions * k) as f64;
        if slot == 0 {
            let after = g.contact_stats();
            pairs = (after.near_total - before.near_total) as f64 / (submissions * k) as f64;
        }
    }
    println!(
        "GPU ({}): cloth {n}x{n} folding, substep {:.2e} s, {k} substeps a submission: {:.1} µs/substep with \
         self-collision, {:.1} without: {:.2}x; {pairs:.0} pairs within reach per substep",
        ctx.describe(),
        dt,
        per_step[0] * 1e6,
        per_step[1] * 1e6,
        per_step[0] / per_step[1]
    );
    // Where a substep with self-collision goes: the same run again with the kernel timers (a timestamp after each
    // dispatch), device µs per substep by kernel.
    let timed = GpuConfig { contact_capacity: 1 << 18, kernel_timers: true, ..Default::default() };
    let Ok(mut g) = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), models[0], timed) else {
        println!("GPU kernel timers: not offered by this device");
        return;
    };
    g.upload_state(folded).unwrap();
    g.run(models[0], dt, k).unwrap();
    g.reset_timers();
    for _ in 0..submissions {
        g.run(models[0], dt, k).unwrap();
    }
    let mut times = g.kernel_times();
    times.sort_by_key(|t| std::cmp::Reverse(t.1));
    let per = (submissions * k) as f64;
    let total: f64 = times.iter().map(|t| t.1.as_secs_f64()).sum::<f64>() / per;
    println!("GPU kernels with self-collision, device µs per substep (sum {:.1}):", total * 1e6);
    for (name, t, calls) in times {
        println!("  {name:<28} {:>8.1} µs  {:>5.1} dispatches", t.as_secs_f64() / per * 1e6, calls as f64 / per);
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
