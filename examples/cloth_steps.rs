//! Times 1000 steps of the benchmark cloth (128 × 128, see `benches/cloth.rs`) from Rust: the reference the
//! Python benchmark (`benches/python_vs_rust.py`) compares against. Prints the minimum over 7 repetitions.
//!
//! ```text
//! cargo run --release --example cloth_steps
//! ```

use fissure::*;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let model: Model<f32> = fissure::scenes::benchmark_cloth(128)?.finalize()?;
    let mut state = model.state();
    let mut solver = CpuSolver::<f32>::default();
    for _ in 0..200 {
        solver.step(&model, &mut state, 2e-4)?;
    }
    let mut best = f64::MAX;
    for _ in 0..7 {
        let t = Instant::now();
        for _ in 0..1000 {
            solver.step(&model, &mut state, 2e-4)?;
        }
        best = best.min(t.elapsed().as_secs_f64());
    }
    println!("rust: {:.1} ms per 1000 steps (min of 7)", best * 1e3);
    Ok(())
}
