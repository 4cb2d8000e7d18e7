//! Speed: step time against size, thread scaling, memory per particle and per spring, and each large-mesh figure
//! as a fraction of the memory-bandwidth floor (bytes a step must move ÷ the machine's measured triad bandwidth).

use super::{Report, sig3};
use fissure::glam::Vec3;
use fissure::*;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::mem::size_of;
use std::time::Instant;

/// STREAM's triad `a = b + s c` over `n` f64 on `threads` threads: the best of 5 in bytes/s (24 bytes per
/// element, STREAM's convention: write-allocate traffic not counted).
fn triad(n: usize, threads: usize) -> f64 {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
    pool.install(|| {
        let mut a = vec![0.0f64; n];
        let b: Vec<f64> = (0..n).into_par_iter().map(|i| i as f64).collect();
        let c: Vec<f64> = (0..n).into_par_iter().map(|i| (n - i) as f64).collect();
        let chunk = (n / (threads * 8)).max(1 << 14);
        let mut best = f64::INFINITY;
        for rep in 0..6 {
            let s = 1.0 + rep as f64 * 1e-3;
            let t = Instant::now();
            a.par_chunks_mut(chunk).zip(b.par_chunks(chunk)).zip(c.par_chunks(chunk)).for_each(|((a, b), c)| {
                for k in 0..a.len() {
                    a[k] = b[k] + s * c[k];
                }
            });
            let e = t.elapsed().as_secs_f64();
            if rep > 0 {
                best = best.min(e);
            }
        }
        std::hint::black_box(&a);
        24.0 * n as f64 / best
    })
}

/// Bytes one symplectic-Euler step of the fused spring-run kernel must move at least: positions and velocities
/// read and written, masses and inverse masses read (56 bytes per particle in f32), and rest length, stiffness
/// and damping (12 bytes) of each spring that does not share its run's (`Model::springs_with_own_parameters`:
/// on the benchmark cloth none, since 2026-11-25; before, every spring's were read and counted here). Springs
/// that are not grid runs read their own and their two indices (20 bytes).
fn floor_bytes(m: &Model<f32>) -> f64 {
    let springs = if m.springs_are_runs() {
        12.0 * m.springs_with_own_parameters() as f64
    } else {
        20.0 * m.spring_count() as f64
    };
    56.0 * m.particle_count() as f64 + springs
}

/// Bytes held per particle and per spring by the model, the state and the solver's per-particle buffers, from
/// the arrays' capacities.
fn memory(m: &Model<f32>, s: &State<f32>) -> (f64, f64) {
    let v = size_of::<Vec3>() as f64;
    let n = m.particle_count() as f64;
    let ns = m.spring_count() as f64;
    let particle_arrays = (m.particle_q0.capacity() + m.particle_qd0.capacity()) as f64 * v
        + (m.particle_mass.capacity() + m.particle_inv_mass.capacity() + m.particle_load_limit.capacity()) as f64 * 4.0
        + m.particle_body.capacity() as f64 * 4.0
        + (m.particle_springs.start.capacity() + m.particle_springs.len.capacity() + m.particle_springs.cap.capacity()) as f64
            * 4.0
        + (m.particle_tris.start.capacity() + m.particle_tris.len.capacity() + m.particle_tris.cap.capacity()) as f64 * 4.0
        + (s.particle_q.capacity() + s.particle_qd.capacity()) as f64 * v
        // The solver's second position/velocity buffers (fused path; its blocks' force sums are per thread).
        + 2.0 * n * v;
    let spring_arrays = m.spring_indices.capacity() as f64 * 8.0
        + (m.spring_rest_length.capacity()
            + m.spring_stiffness.capacity()
            + m.spring_damping.capacity()
            + m.spring_strain_limit.capacity()) as f64
            * 4.0
        + m.spring_kind.capacity() as f64 * size_of::<SpringKind>() as f64
        + m.particle_springs.items.capacity() as f64 * 4.0
        // The solver's per-spring force buffer.
        + ns * v;
    (particle_arrays / n, spring_arrays / ns)
}

fn time_steps(model: &Model<f32>, seconds: f64) -> Result<f64, String> {
    let mut s = model.state();
    let mut solver = CpuSolver::<f32>::default();
    for _ in 0..3 {
        solver.step(model, &mut s, 2e-4).map_err(|e| e.to_string())?;
    }
    let t = Instant::now();
    let mut steps = 0;
    while steps < 5 || t.elapsed().as_secs_f64() < seconds {
        solver.step(model, &mut s, 2e-4).map_err(|e| e.to_string())?;
        steps += 1;
    }
    Ok(t.elapsed().as_secs_f64() / steps as f64)
}

/// Runs the section.
pub fn run(r: &mut Report) -> Result<(), String> {
    let quick = r.quick;
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let n_triad = if quick { 1 << 21 } else { 1 << 25 };
    let bw1 = triad(n_triad, 1);
    let bw = triad(n_triad, cores);
    let sizes: Vec<usize> = if quick { vec![32, 64, 128] } else { vec![32, 64, 128, 256, 512, 1024] };
    let secs = if quick { 0.1 } else { 1.0 };
    let _ = writeln!(
        r.md,
        "\n### Speed\n\nMemory bandwidth (STREAM triad, {} MB per array, best of 5): {} GB/s on 1 thread, {} GB/s on \
         {cores}. Cloth: the foundation benchmark's (1 cm, 1 g, structural + shear + bend springs of 1000 N/m, two \
         corners pinned), symplectic Euler, f32, dt = 2e-4 s, all threads. Floor: the bytes a step must move (56 per \
         particle, 12 per spring that does not share its run's parameters: none here) at the measured \
         {cores}-thread bandwidth; fraction = floor time ÷ step time (1 = bandwidth-bound). CSV: `speed.csv`, `threads.csv`.\n\n\
         | cloth | particles | springs | µs/step | particle-steps/s | floor µs | fraction of floor | bytes/particle | bytes/spring |\n\
         |---|---|---|---|---|---|---|---|---|",
        n_triad * 8 / 1_000_000,
        sig3(bw1 / 1e9),
        sig3(bw / 1e9),
    );
    let mut rows = Vec::new();
    let mut largest = None;
    for &n in &sizes {
        let model: Model<f32> =
            scenes::benchmark_cloth(n).map_err(|e| e.to_string())?.finalize().map_err(|e| e.to_string())?;
        let t = time_steps(&model, secs)?;
        let floor = floor_bytes(&model) / bw;
        let (bp, bs) = memory(&model, &model.state());
        let _ = writeln!(
            r.md,
            "| {n}² | {} | {} | {} | {} | {} | {:.2} | {:.0} | {:.0} |",
            model.particle_count(),
            model.spring_count(),
            sig3(t * 1e6),
            sig3(model.particle_count() as f64 / t),
            sig3(floor * 1e6),
            floor / t,
            bp,
            bs
        );
        rows.push(format!(
            "{n},{},{},{:e},{:e},{:e},{bp},{bs}",
            model.particle_count(),
            model.spring_count(),
            t,
            floor,
            floor / t
        ));
        largest = Some((n, floor / t));
    }
    if let Some((n, frac)) = largest
        && n >= 1024
    {
        r.target(
            "1024² cloth step reaches half the bandwidth floor's speed".to_string(),
            frac >= 0.5,
            format!("{:.2} of the floor", frac),
        );
    }
    // Thread scaling.
    let scale_sizes: Vec<usize> = if quick { vec![64] } else { vec![128, 1024] };
    let _ = writeln!(r.md, "\n| cloth | threads | µs/step | speed-up |\n|---|---|---|---|");
    let mut trows = Vec::new();
    for &n in &scale_sizes {
        let model: Model<f32> =
            scenes::benchmark_cloth(n).map_err(|e| e.to_string())?.finalize().map_err(|e| e.to_string())?;
        let mut t1 = f64::NAN;
        for threads in 1..=cores {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| e.to_string())?;
            let t = pool.install(|| time_steps(&model, secs))?;
            if threads == 1 {
                t1 = t;
            }
            let _ = writeln!(r.md, "| {n}² | {threads} | {} | {:.2}× |", sig3(t * 1e6), t1 / t);
            trows.push(format!("{n},{threads},{t:e}"));
        }
    }
    r.csv(
        "speed.csv",
        "n,particles,springs,step_s,floor_s,fraction_of_floor,bytes_per_particle,bytes_per_spring",
        &rows,
    )
    .map_err(|e| e.to_string())?;
    r.csv("threads.csv", "n,threads,step_s", &trows).map_err(|e| e.to_string())?;
    Ok(())
}
