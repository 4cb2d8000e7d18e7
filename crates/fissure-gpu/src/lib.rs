//! # fissure-gpu
//!
//! The wgpu compute backend of fissure: springs, gravity, the closed pressure model, wind, symplectic Euler and
//! velocity Verlet, collisions and contact between surfaces run as WGSL kernels (`shaders/` at the workspace root), with the CPU engine
//! of `fissure-core` as their reference. Fracture stays on the CPU: a kernel flags the springs and vertices past
//! their limits, and only then is the state read back and the topology changed by `fissure_core::fracture`
//! (unchanged); the solver then re-uploads what changed.
//!
//! ```no_run
//! use fissure_core::glam::DVec3;
//! use fissure_core::*;
//! use fissure_gpu::{GpuConfig, GpuContext, GpuSolver};
//!
//! let mut b = ModelBuilder::new();
//! let ball = Mesh::icosphere(0.2, 3).translated(DVec3::new(0.0, 1.0, 0.0));
//! b.add_soft_body(&ball, &SoftBodyOptions { gas: Gas::Pressure(3000.0), ..Default::default() })?;
//! b.add_collider(Collider::ground(0.0))?;
//! let model: Model<f32> = b.finalize()?;
//! let ctx = GpuContext::new()?; // or bring your own wgpu::Device and Queue
//! let mut gpu = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &model, GpuConfig::default())?;
//! gpu.run(&model, 1e-4, 100)?; // 100 substeps in one submission, nothing read back
//! let mut state = model.state();
//! gpu.read_state(&mut state)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! In a browser (wasm32-unknown-unknown, WebGPU: `crates/fissure-web` and `web/`) the same kernels run: each binds
//! at most 8 storage buffers ([`KERNEL_BINDINGS`]), within WebGPU's default limits, and every read-back is a future
//! ([`GpuSolver::run_async`], [`GpuSolver::read_state_async`], `World::advance_async`), awaited there because a
//! browser maps a buffer only once control is back in its event loop; off the web the synchronous methods wait.
//!
//! Profiling: with [`GpuConfig::kernel_timers`] every dispatch is followed by a timestamp, and each kernel's
//! device time is summed ([`GpuSolver::kernel_times`]) and added to its stage in the stage timers
//! (`fissure run --backend gpu --kernel-timers` prints both). On an H200 through Vulkan a dependent dispatch costs
//! at least ~7 µs whatever its size (`benches/RESULTS.md`), so a substep's cost there follows its count of
//! dispatches as much as their work.
//!
//! Precision: the kernels run in `f32`. Per-step forces agree with the CPU `f32` forces to a few ulps of the
//! largest force term (the sums run in a different order: CSR order on both, but the CPU sums spring runs in
//! blocks); trajectories agree to the tolerances stated in `tests/gpu/parity.rs`.
#![warn(missing_docs)]

mod context;
mod layout;
mod mapping;
pub mod render;
pub mod sdf;
mod solver;

pub use context::{GpuContext, adapter_required, instance_descriptor};
pub use layout::{GpuBody, GpuCollider, GpuParticle, GpuSpring, MAX_GPU_HANDLES, Params, STATE_STRIDE};
pub use sdf::SdfGrid;
pub use solver::{Candidates, GpuConfig, GpuSolver, KERNEL_TIMESTAMPS, RunReport};
pub use wgpu;

/// The WGSL files of the solver, in the order they are concatenated after `common.wgsl`.
pub const SHADERS: [(&str, &str); 5] = [
    ("integrate.wgsl", include_str!("../../../shaders/integrate.wgsl")),
    ("surface.wgsl", include_str!("../../../shaders/surface.wgsl")),
    ("collide.wgsl", include_str!("../../../shaders/collide.wgsl")),
    ("fracture.wgsl", include_str!("../../../shaders/fracture.wgsl")),
    ("contact.wgsl", include_str!("../../../shaders/contact.wgsl")),
];

/// The storage buffers each kernel binds (bindings of group 0 in `common.wgsl`; every kernel also gets the uniform
/// at binding 0 and the clock as group 1). Each kernel's bind group layout lists only these, so no kernel binds more
/// than 8 storage buffers, WebGPU's default `maxStorageBuffersPerShaderStage` (what a browser grants without
/// asking): one layout with all 19 would need a device that allows 19. `tests/wgsl.rs` checks the table against
/// what naga finds each entry point using.
pub const KERNEL_BINDINGS: [(&str, &[u32]); 28] = [
    ("integrate_symplectic_euler", &FORCE_GATHER),
    ("integrate_verlet_first", &FORCE_GATHER),
    ("integrate_verlet_second", &FORCE_GATHER),
    ("net_forces", &FORCE_GATHER),
    ("finite_check", &[1, 19]),
    ("surface_cross", &[1, 7, 8, 10, 12]),
    ("surface_caps", &[1, 10, 15, 17]),
    ("surface_volume", &[10, 11, 12, 15, 17]),
    ("surface_force", &[1, 7, 8, 9, 10, 11]),
    ("surface_pressure", &[7, 8, 9, 10, 11]),
    ("cap_force", &[1, 11, 15, 16, 17, 18]),
    ("collide", &[2, 3, 13, 14]),
    ("strain_check", &[1, 5, 6, 19]),
    ("load_check", &[1, 3, 4, 5, 6, 9, 19]),
    ("contact_count", &[1, 20, 22, 23, 24, 26]),
    ("contact_scan_sums", &[30]),
    ("contact_scan_spread", &[30]),
    ("contact_scatter", &[20, 22, 23, 24]),
    ("contact_moves", &[2, 20, 23, 26]),
    ("contact_vt", &[3, 7, 20, 21, 23, 25, 26, 29]),
    ("contact_ee", &[3, 20, 21, 22, 23, 25, 26, 29]),
    ("contact_args", &[26, 28]),
    ("contact_prep", &[23, 25, 26, 27]),
    ("contact_jacobi_even", &CONTACT_IMPULSE),
    ("contact_jacobi_odd", &CONTACT_IMPULSE),
    ("contact_jacobi_fused", &CONTACT_IMPULSE),
    ("contact_friction", &CONTACT_IMPULSE),
    ("contact_apply", &[2, 3, 13, 14, 23, 26, 27]),
];

/// What the contact impulse kernels read and write: the state after the step, particles, the pairs, the contact
/// counters, the per-particle accumulators.
const CONTACT_IMPULSE: [u32; 5] = [2, 3, 25, 26, 27];

/// What the per-particle force gather reads and writes: both states, particles, adjacency, springs, their ends,
/// the triangles' corner forces and the caps' forces.
const FORCE_GATHER: [u32; 8] = [1, 2, 3, 4, 5, 6, 9, 18];

/// Storage buffers of `common.wgsl` written by some kernel (declared `read_write`); the rest are read-only.
pub const READ_WRITE_BINDINGS: [u32; 15] = [2, 8, 9, 11, 12, 17, 18, 19, 23, 24, 25, 26, 27, 28, 30];

/// The declarations every kernel file shares (bindings, structs, helpers).
pub const COMMON_WGSL: &str = include_str!("../../../shaders/common.wgsl");

/// The colliders' functions (`shaders/colliders.wgsl`): the collision kernel and the contact pass use them.
pub const COLLIDERS_WGSL: &str = include_str!("../../../shaders/colliders.wgsl");

/// The complete source of a kernel file: `common.wgsl`, `colliders.wgsl`, then the file.
pub fn shader_source(file: &str) -> String {
    format!("{COMMON_WGSL}\n{COLLIDERS_WGSL}\n{file}")
}

/// What can go wrong on the GPU path.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter at all.
    #[error(
        "no GPU adapter found ({details}). Install a Vulkan driver: on Debian or Ubuntu `apt install mesa-vulkan-drivers` (it includes lavapipe, a software Vulkan device that works without a GPU); elsewhere your GPU vendor's driver"
    )]
    NoAdapter {
        /// What was tried.
        details: String,
    },
    /// The adapter refused a device.
    #[error("could not create a device on {adapter}: {message}")]
    Device {
        /// Adapter name.
        adapter: String,
        /// The driver's message.
        message: String,
    },
    /// A device limit is below what the kernels need.
    #[error(
        "the device allows {have} for {limit}, the solver needs {need}; request the adapter's limits (GpuContext does)"
    )]
    Limit {
        /// Which limit.
        limit: &'static str,
        /// The device's value.
        have: u64,
        /// Needed.
        need: u64,
    },
    /// A model array is larger than one storage binding may be on this device.
    #[error(
        "the model's {buffer} need {bytes} bytes, more than the {limit} one storage buffer may hold on this device; use a smaller model or a device with a larger max_storage_buffer_binding_size"
    )]
    TooLarge {
        /// Which array.
        buffer: &'static str,
        /// Its size.
        bytes: u64,
        /// The device's limit.
        limit: u64,
    },
    /// The integrator has no GPU kernels.
    #[error(
        "the GPU solver runs symplectic Euler and velocity Verlet; {0} runs on the CPU solver only (fissure_core::CpuSolver)"
    )]
    UnsupportedIntegrator(&'static str),
    /// More contact pairs came within reach in one substep than the pair buffer holds: pairs were missed.
    #[error(
        "{wanted} contact pairs came within reach in one substep, but the pair buffer holds {capacity}: some were missed; raise GpuConfig::contact_capacity"
    )]
    ContactCapacity {
        /// Pairs found in the worst substep.
        wanted: u32,
        /// The buffer's capacity.
        capacity: u32,
    },
    /// The model has more moving pins than a clock entry holds ([`MAX_GPU_HANDLES`]).
    #[error(
        "more than 15 moving pins (ModelBuilder::add_handle, the scene's `[[body.handle]]`): the GPU clock holds 15; use the CPU solver (`--backend cpu`)"
    )]
    UnsupportedHandles,
    /// [`GpuConfig::kernel_timers`] on a device without timestamp queries inside passes.
    #[error(
        "GpuConfig::kernel_timers needs timestamp queries inside compute passes, which this device does not offer (browsers never do); run without kernel timers"
    )]
    NoKernelTimers,
    /// A collider could not be prepared.
    #[error("collider {index}: {message}")]
    Collider {
        /// Its index in the model.
        index: usize,
        /// Why.
        message: String,
    },
    /// A state of another size.
    #[error("state has {state} particles but the model has {model}")]
    StateMismatch {
        /// Particles in the state.
        state: usize,
        /// Particles in the model.
        model: usize,
    },
    /// The model gained particles since the state was uploaded.
    #[error("the model gained particles: upload the state (GpuSolver::upload_state) before running")]
    StateStale,
    /// The time step is not positive and finite.
    #[error("time step must be positive and finite, got {0}")]
    BadTimeStep(f64),
    /// The state became NaN or infinite.
    #[error(
        "state blew up between t = {from:.6} s and t = {to:.6} s (a non-finite velocity); the time step {dt:e} s is probably above the stability limit (try more substeps or softer springs)"
    )]
    NonFinite {
        /// Time at the start of the submission.
        from: f64,
        /// Time at its end.
        to: f64,
        /// The step.
        dt: f64,
    },
    /// Mapping a buffer for reading failed (device lost).
    #[error("reading back from the GPU failed: {0}")]
    Readback(String),
}

impl From<GpuError> for fissure_core::StepError {
    fn from(e: GpuError) -> Self {
        match e {
            GpuError::BadTimeStep(dt) => fissure_core::StepError::BadTimeStep(dt),
            GpuError::StateMismatch { state, model } => fissure_core::StepError::StateMismatch { state, model },
            GpuError::NonFinite { to, dt, .. } => {
                fissure_core::StepError::NonFinite { time: to, dt, particle: 0, what: "velocity", stable_dt: f64::NAN }
            }
            e => fissure_core::StepError::Backend(e.to_string()),
        }
    }
}
