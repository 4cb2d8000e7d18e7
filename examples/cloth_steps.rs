//! Times 1000 steps of the benchmark cloth (128 × 128, see `benches/cloth.rs`) from Rust: the reference the
//! Python benchmark (`benches/python_vs_rust.py`) compares against. Prints the minimum over 7 repetitions.
//!
//! ```text
//! cargo run --release --example cloth_steps
//! ```

use fissure::glam::DVec3;
use fissure::*;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n = 128;
    let mut b = ModelBuilder::new();
    let opts = ClothOptions {
        mass: Mass::PerParticle(1e-3),
        stiffness: Stiffness::PerSpring(1000.0),
        shear: Some(Stiffness::PerSpring(1000.0)),
        bending: Some(Stiffness::PerSpring(1000.0)),
        damping: Damping::PerSpring(0.01),
        pins: vec![0, n - 1],
        aero: Aero::NONE,
    };
    b.add_cloth_grid(n, n, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts)?;
    let model: Model<f32> = b.finalize()?;
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
