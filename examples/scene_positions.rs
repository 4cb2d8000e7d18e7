//! The positions after a number of steps of a scene file, as JSON, on the CPU or the GPU backend: what the web
//! page's parity test (`web/test_page.py`) compares the browser's positions with.
//!
//! ```text
//! cargo run --release --example scene_positions -- scenes/ball_drop.toml 600 gpu
//! ```
//!
//! The GPU device gets WebGPU's default limits, as the page's does; the steps are taken as the page takes them
//! (`World::advance` over `steps × dt`, fracture every 16 steps).
use std::error::Error;

use fissure::gpu::{GpuConfig, GpuContext, GpuSolver, wgpu};
use fissure::scene::Scene;

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: scene_positions SCENE.toml STEPS cpu|gpu";
    let [path, steps, backend] = args.as_slice() else { return Err(usage.into()) };
    let steps: usize = steps.parse().map_err(|e| format!("STEPS: {e}; {usage}"))?;
    let scene = Scene::load(path)?;
    let mut world = scene.world::<f32>()?;
    world.fracture_every = 16;
    let adapter = match backend.as_str() {
        "cpu" => "cpu".to_string(),
        "gpu" => {
            let ctx = GpuContext::with_limits(wgpu::Limits::default())?;
            let config = GpuConfig { integrator: scene.integrator()?, ..Default::default() };
            world.solver = Box::new(GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &world.model, config)?);
            ctx.describe()
        }
        other => return Err(format!("backend {other:?}: {usage}").into()),
    };
    let dt = scene.solver.dt;
    world.advance(steps as f64 * dt, dt)?;
    let q: Vec<String> = world.state.particle_q.iter().flat_map(|p| p.to_array()).map(|v| format!("{v:e}")).collect();
    println!(
        "{{\"adapter\": \"{}\", \"time\": {}, \"positions\": [{}]}}",
        adapter.replace('"', "'"),
        world.state.time,
        q.join(", ")
    );
    Ok(())
}
