//! The seed's cloth in a varying wind (Fig. 4) on the GPU backend, checked against the CPU engine.
//!
//! ```text
//! cargo run --release --example gpu_cloth                 # 32 x 32 cloth, 2 s of simulated time
//! cargo run --release --example gpu_cloth -- --n 128 --seconds 1
//! ```
//!
//! Runs the scene on the adapter `GpuContext` picks (a real GPU when there is one, else lavapipe) in frames of
//! 1/60 s, each one submission of many substeps, and on the CPU solver alongside; prints the throughput of both
//! and the RMS distance between the two cloths. It fails if they differ by more than 1 mm after 0.25 s, or if the
//! GPU cloth did not move downwind. (A cloth flapping in gusts is sensitive to rounding: the two f32 runs sum in
//! different orders, so after seconds they differ by centimetres while both stay right; the 0.25 s comparison is
//! inside the horizon where the difference is still rounding-sized.) Without an adapter it says what to install
//! and exits with an error.

use fissure::*;
use fissure_gpu::{GpuConfig, GpuContext, GpuSolver};
use std::time::{Duration, Instant};

fn arg(name: &str, default: f64) -> Result<f64, String> {
    let args: Vec<String> = std::env::args().collect();
    match args.iter().position(|a| a == name) {
        Some(i) => args
            .get(i + 1)
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("{name} needs a number, e.g. {name} {default}")),
        None => Ok(default),
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n = arg("--n", 32.0)? as usize;
    let seconds = arg("--seconds", 2.0)?;
    let model: Model<f32> = scenes::cloth_wind(n)?.finalize()?;
    let ctx = GpuContext::new()?;
    println!(
        "cloth {n}x{n} ({} particles, {} springs) on {}",
        model.particle_count(),
        model.spring_count(),
        ctx.describe()
    );
    let mut gpu = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &model, GpuConfig::default())?;
    let mut cpu = CpuSolver::<f32>::default();
    let mut cpu_state = model.state();
    let (dt, substeps) = (1.0 / 60.0 / 32.0, 32);
    let frames = (seconds * 60.0).round() as usize;
    let (mut t_gpu, mut t_cpu) = (Duration::ZERO, Duration::ZERO);
    for frame in 1..=frames {
        let t = Instant::now();
        gpu.run(&model, dt, substeps)?;
        t_gpu += t.elapsed();
        let t = Instant::now();
        for _ in 0..substeps {
            cpu.step(&model, &mut cpu_state, dt)?;
        }
        t_cpu += t.elapsed();
        if frame == 15 {
            let mut s = model.state();
            gpu.read_state(&mut s)?;
            let rms = rms(&s, &cpu_state);
            println!("t = {:.2} s  GPU - CPU: {rms:.2e} m RMS", s.time);
            if rms > 1e-3 {
                return Err(format!("GPU and CPU disagree by {rms} m RMS at t = {:.2} s", s.time).into());
            }
        }
        if frame % 30 == 0 {
            let com = model.center_of_mass(&cpu_state);
            println!("t = {:.2} s  centre of mass z = {:+.3} m", cpu_state.time, com.z);
        }
    }
    let mut gpu_state = model.state();
    gpu.read_state(&mut gpu_state)?;
    let steps = (frames * substeps) as f64;
    let n_p = model.particle_count() as f64;
    for (name, t) in [("gpu", t_gpu), ("cpu", t_cpu)] {
        let per = t.as_secs_f64() / steps;
        println!("{name}: {:.1} µs/step, {:.3e} particle-steps/s", per * 1e6, n_p / per);
    }
    let rms = (gpu_state
        .particle_q
        .iter()
        .zip(&cpu_state.particle_q)
        .map(|(a, b)| (*a - *b).length_squared() as f64)
        .sum::<f64>()
        / n_p)
        .sqrt();
    let downwind = model.center_of_mass(&gpu_state).z - model.center_of_mass(&model.state()).z;
    println!("t = {seconds:.2} s  GPU - CPU: {rms:.2e} m RMS; the GPU cloth moved {downwind:+.3} m downwind");
    if downwind.is_nan() || downwind <= 0.05 {
        return Err(format!("the cloth did not move downwind ({downwind} m)").into());
    }
    Ok(())
}

fn rms(a: &State<f32>, b: &State<f32>) -> f64 {
    let sum: f64 = a.particle_q.iter().zip(&b.particle_q).map(|(x, y)| (*x - *y).length_squared() as f64).sum();
    (sum / a.particle_q.len() as f64).sqrt()
}
