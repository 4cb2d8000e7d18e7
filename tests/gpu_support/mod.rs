//! What the GPU test files share: a device with WebGPU's default limits (or, with `CI` set, a failure when there is
//! none), a solver on it, and the RMS difference of two states' positions.

use fissure::*;
use fissure_gpu::{GpuConfig, GpuContext, GpuSolver, adapter_required};

pub fn gpu() -> Option<GpuContext> {
    match GpuContext::with_limits(fissure_gpu::wgpu::Limits::default()) {
        Ok(c) => {
            eprintln!("GPU tests on {}", c.describe());
            Some(c)
        }
        Err(e) => {
            assert!(
                !adapter_required(),
                "CI is set, so the GPU tests need an adapter (install mesa-vulkan-drivers for lavapipe): {e}"
            );
            eprintln!("SKIPPED: no GPU adapter: {e}");
            None
        }
    }
}

pub fn solver(ctx: &GpuContext, m: &Model<f32>, integrator: Integrator) -> GpuSolver {
    GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), m, GpuConfig { integrator, ..Default::default() }).unwrap()
}

/// RMS difference of two states' positions [m].
pub fn rms_difference(a: &State<f32>, b: &State<f32>) -> f64 {
    let sum: f64 = a.particle_q.iter().zip(&b.particle_q).map(|(x, y)| (*x - *y).length_squared() as f64).sum();
    (sum / a.particle_q.len() as f64).sqrt()
}
