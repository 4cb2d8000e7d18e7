//! The GPU solver's settings ([`GpuConfig`]) and what a submission reports ([`RunReport`], [`Candidates`]).

use fissure_core::Integrator;

/// GPU solver settings.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuConfig {
    /// Symplectic Euler (default) or velocity Verlet; the others are CPU-only.
    pub integrator: Integrator,
    /// Read the status word after each submission and fail with [`crate::GpuError::NonFinite`] if a velocity became
    /// NaN or infinite. Default true; the cost is one 16-byte read-back per submission, not per substep.
    pub check_finite: bool,
    /// Fracture candidates kept per kind per submission (the counters count past it). Default 4096.
    pub candidate_capacity: u32,
    /// Cells along the longest side of a baked signed-distance grid (triangle-mesh colliders). Default 64.
    pub sdf_cells: u32,
    /// Contact pairs one substep can hold; 0 (default): 4 per particle in contact plus 1,024. A substep that
    /// finds more fails the run with [`crate::GpuError::ContactCapacity`].
    pub contact_capacity: u32,
    /// Jacobi iterations of the contact impulses per substep, rounded up to an even number. Default 16.
    pub contact_iterations: u32,
    /// Pairs up to which a submission runs all Jacobi iterations of a substep in one dispatch (one workgroup,
    /// `contact_jacobi_fused`) instead of one dispatch each, judged by the pairs the last submission's last substep
    /// had. Both give the same bits; the choice is one of speed only. Default 256 (one pair per invocation of the
    /// workgroup); 0: one dispatch per iteration. On an H200, the 128² fold with ~710 pairs: 16 iterations took
    /// ~290 µs of a substep in one workgroup against ~170 µs as 16 dispatches; on an H100, cloth_fold's ~215 pairs
    /// took 13–14 % less of the whole substep in one workgroup (`benches/RESULTS.md`).
    pub contact_fused_pairs: u32,
    /// Time every kernel on the device: a timestamp after each dispatch of a submission (at most
    /// [`crate::KERNEL_TIMESTAMPS`] − 1 of them), read back after it, each kernel's time added to
    /// [`crate::GpuSolver::kernel_times`] and to its stage in the stage timers (the integrators and the force gather
    /// under `integrate`, the surface kernels under `surface`, `collide`, the contact kernels under `contact`,
    /// the strain and load checks under `fracture`). A kernel's time runs from the timestamp before it to the
    /// one after, so it includes the wait for the kernels it depends on to finish. Needs timestamp queries inside
    /// passes (Vulkan, Metal and D3D12 adapters; not browsers): [`crate::GpuSolver::new`] fails without them
    /// ([`crate::GpuError::NoKernelTimers`]); [`crate::GpuContext`] asks for them where the adapter has them. Costs
    /// one read-back a submission. Default false.
    pub kernel_timers: bool,
}

impl Default for GpuConfig {
    fn default() -> Self {
        GpuConfig {
            integrator: Integrator::SymplecticEuler,
            check_finite: true,
            candidate_capacity: 4096,
            sdf_cells: 64,
            contact_capacity: 0,
            contact_iterations: 16,
            contact_fused_pairs: 256,
            kernel_timers: false,
        }
    }
}

/// What a submission found (zeros where it did not look).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunReport {
    /// Substeps run.
    pub steps: usize,
    /// Springs flagged past their strain limit (summed over substeps, may repeat).
    pub spring_candidates: u32,
    /// Vertices flagged past their load limit (summed over substeps, may repeat).
    pub vertex_candidates: u32,
}

/// The fracture candidates of the last submission, sorted, without repeats.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Candidates {
    /// Springs past their strain limit.
    pub springs: Vec<u32>,
    /// Vertices past their load limit.
    pub vertices: Vec<u32>,
    /// More were flagged than the capacity holds (the lists are incomplete).
    pub overflow: bool,
}
