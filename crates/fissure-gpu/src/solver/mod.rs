//! [`GpuSolver`]: the model and state live in GPU buffers; a submission encodes many substeps; nothing is read back
//! unless asked for (the state), or needed (a 16-byte status word: the non-finite flag and the fracture candidate
//! counters, read only when `check_finite` is on or the model can break).
//!
//! A substep encodes only what the model needs (DESIGN.md, "work a scene doesn't need is not done"):
//!
//! | kernel | when |
//! |---|---|
//! | `surface_cross`, `surface_force` | gas or wind |
//! | `surface_caps`, `cap_force` | a gas body with openings |
//! | `surface_volume` | gas |
//! | `integrate_symplectic_euler` or `integrate_verlet_first` + `integrate_verlet_second` | always |
//! | `collide` | colliders |
//! | `contact_count`, `contact_scan_sums`, `contact_scan_spread`, `contact_scatter` (before the integrator) | contact |
//! | `contact_moves`, `contact_vt`, `contact_ee`, `contact_args`, `contact_prep`, `contact_jacobi_fused` (few pairs) or `contact_iterations` × `contact_jacobi_even`/`_odd`, `contact_friction`, `contact_apply` | contact |
//! | `strain_check` / `surface_pressure` + `load_check` | breakable springs / vertices (the pressure pass: gas) |
//! | `finite_check` | once per submission, with `check_finite` |
//!
//! [`GpuSolver::passes`] lists what the last submission encoded, in order.
//!
//! Each kernel has its own bind group layout with only the buffers it uses ([`crate::KERNEL_BINDINGS`], at most 8
//! storage buffers: WebGPU's default limit), so the solver runs on any WebGPU device without asking for more.

use fissure_core::timers::Instant;

use fissure_core::{Integrator, Model, Stage, StageTimers, State};
use glam::Vec3;

use crate::layout::{self, CLOCK_STRIDE, Clock, GpuCollider, MAX_GPU_HANDLES, Mirror, Packed, Params, STATE_STRIDE};
use crate::{GpuError, KERNEL_BINDINGS, READ_WRITE_BINDINGS, SHADERS, shader_source};

mod bind;
mod config;
mod scratch;

pub use config::{Candidates, GpuConfig, RunReport};

use scratch::{SCRATCH, Scratch, scratch, scratch_sizes};

/// Workgroup size of every kernel.
const WG: u32 = 64;
/// Largest workgroup count along one dispatch dimension (WebGPU's guaranteed minimum).
const MAX_GROUPS: u32 = 65535;

/// The kernels, each with its bind group layout, in the order of [`KERNEL_BINDINGS`].
struct Kernels {
    pipelines: Vec<wgpu::ComputePipeline>,
    layouts: Vec<wgpu::BindGroupLayout>,
}

/// The index of kernel `name` in [`KERNEL_BINDINGS`], found at compile time through [`k!`] (a name missing from
/// the table does not compile; encoding a substep looks nothing up).
const fn kernel(name: &str) -> usize {
    let mut k = 0;
    while k < KERNEL_BINDINGS.len() {
        let (a, b) = (KERNEL_BINDINGS[k].0.as_bytes(), name.as_bytes());
        if a.len() == b.len() {
            let mut i = 0;
            while i < a.len() && a[i] == b[i] {
                i += 1;
            }
            if i == a.len() {
                return k;
            }
        }
        k += 1;
    }
    panic!("a kernel missing from KERNEL_BINDINGS")
}

/// The index of a kernel, as a constant.
macro_rules! k {
    ($name:literal) => {
        const { kernel($name) }
    };
}

// After `k!`, which they use.
mod contact;
mod timers;
mod transfer;

pub use timers::KERNEL_TIMESTAMPS;
use timers::Profile;

/// The wgpu solver (f32). See the module docs.
pub struct GpuSolver {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// Settings (the integrator is fixed at creation).
    config: GpuConfig,
    kernels: Kernels,
    layout1: wgpu::BindGroupLayout,
    clock_bind: wgpu::BindGroup,
    clock: wgpu::Buffer,
    clock_capacity: usize,
    params: wgpu::Buffer,
    params_host: Params,
    /// The two states (positions and velocities interleaved per particle, [`STATE_STRIDE`] bytes each).
    state: [wgpu::Buffer; 2],
    state_capacity: usize,
    particles: Mirror<layout::GpuParticle>,
    adj: Mirror<u32>,
    springs: Mirror<layout::GpuSpring>,
    tris: Mirror<[u32; 4]>,
    bodies: Mirror<layout::GpuBody>,
    openings: Mirror<u32>,
    spring_ends: Mirror<[u32; 2]>,
    caps: Mirror<u32>,
    c_part: Mirror<[u32; 4]>,
    c_body: Mirror<[f32; 4]>,
    c_edges: Mirror<[u32; 2]>,
    colliders: Mirror<GpuCollider>,
    sdf: Mirror<f32>,
    scratch: Scratch,
    candidates: wgpu::Buffer,
    status: wgpu::Buffer,
    /// Per kernel (in [`KERNEL_BINDINGS`] order), its bind group reading state 0 and the one reading state 1.
    bind: Vec<[wgpu::BindGroup; 2]>,
    /// Which of the two state buffers holds the current state.
    cur: usize,
    packed: Packed,
    time: f64,
    /// The state must be uploaded before the next run (particles were added).
    state_stale: bool,
    /// What the last submission found.
    last_report: RunReport,
    /// Refuses explicit steps above the stability bound of a model in contact (the CPU's guard: see its docs).
    contact_guard: fissure_core::ContactStepGuard,
    /// Pieces born crossing their family, left out of contact with it until they part (the CPU's, asked when
    /// the host holds the current state: see `fissure_core::contact::family`).
    excused: fissure_core::contact::family::Excused,
    /// The contact pass's counts (see [`GpuSolver::contact_stats`]).
    contact_stats: fissure_core::ContactStats,
    passes: Vec<&'static str>,
    last_upload: usize,
    /// Elements (particles, rows, springs, triangles, bodies, ...) re-packed by the last model sync.
    last_repacked: usize,
    /// Particles `0..state_valid` hold a valid state on the GPU (a reallocation of the state buffers empties it).
    state_valid: usize,
    timers: StageTimers,
    /// The kernel timers ([`GpuConfig::kernel_timers`]).
    profile: Option<Profile>,
}

fn buffer_entry(binding: u32, ty: wgpu::BufferBindingType, dynamic: bool, min: u64) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: dynamic, min_binding_size: wgpu::BufferSize::new(min) },
        count: None,
    }
}

/// Workgroups for `n` invocations as a 2-D grid (the kernels flatten it with `flat_index`).
fn groups(n: usize) -> (u32, u32) {
    let g = (n as u32).div_ceil(WG).max(1);
    let x = g.min(MAX_GROUPS);
    (x, g.div_ceil(x))
}

/// Positions and velocities: storage for the kernels, copies both ways, and a vertex buffer for the renderer
/// ([`crate::render`] draws the position buffer in place).
const STATE_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_DST)
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::VERTEX);

impl GpuSolver {
    /// A solver for `model` at its initial state, on a device the caller created (see
    /// [`crate::GpuContext`] for one way). Fails when the integrator has no kernels, the device's limits are too
    /// small, or a collider cannot be baked.
    pub fn new(
        device: wgpu::Device,
        queue: wgpu::Queue,
        model: &Model<f32>,
        config: GpuConfig,
    ) -> Result<Self, GpuError> {
        match config.integrator {
            Integrator::SymplecticEuler | Integrator::VelocityVerlet => {}
            other => return Err(GpuError::UnsupportedIntegrator(other.name())),
        }
        if model.handles.len() > MAX_GPU_HANDLES {
            return Err(GpuError::UnsupportedHandles);
        }
        let limits = device.limits();
        let most = KERNEL_BINDINGS.iter().map(|(_, b)| b.len() as u32).max().unwrap_or(0);
        if limits.max_storage_buffers_per_shader_stage < most {
            return Err(GpuError::Limit {
                limit: "max_storage_buffers_per_shader_stage",
                have: limits.max_storage_buffers_per_shader_stage as u64,
                need: most as u64,
            });
        }
        let uniform = wgpu::BufferBindingType::Uniform;
        let layout1 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("fissure clock"),
            entries: &[buffer_entry(0, uniform, true, size_of::<Clock>() as u64)],
        });
        let modules: Vec<_> = SHADERS
            .iter()
            .map(|(file, src)| {
                let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(file),
                    source: wgpu::ShaderSource::Wgsl(shader_source(src).into()),
                });
                (entry_points(src), module)
            })
            .collect();
        let mut kernels = Kernels { pipelines: Vec::new(), layouts: Vec::new() };
        for (name, bindings) in KERNEL_BINDINGS {
            let mut entries = vec![buffer_entry(0, uniform, false, size_of::<Params>() as u64)];
            entries.extend(bindings.iter().map(|&b| {
                let read_only = !READ_WRITE_BINDINGS.contains(&b);
                buffer_entry(b, wgpu::BufferBindingType::Storage { read_only }, false, 0)
            }));
            let layout0 = device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(name), entries: &entries });
            let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(name),
                bind_group_layouts: &[Some(&layout0), Some(&layout1)],
                immediate_size: 0,
            });
            let (_, module) = modules
                .iter()
                .find(|(entries, _)| entries.contains(&name))
                .expect("every kernel of KERNEL_BINDINGS is in a shader file");
            kernels.pipelines.push(device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: Some(&pl),
                module,
                entry_point: Some(name),
                compilation_options: Default::default(),
                cache: None,
            }));
            kernels.layouts.push(layout0);
        }
        // Models that can change get room to grow; the others exact buffers.
        let slack = model.has_fracture() || !model.openings.is_empty();
        let items = model.particle_springs.items.len();
        let packed = Packed::new(model, items + items / 4);
        let max = limits.max_storage_buffer_binding_size;
        let n = model.particle_count() as u64;
        let slack_factor = if slack { 1.25 } else { 1.0 };
        for (buffer, bytes) in [
            ("positions", n * 16),
            ("springs", packed.springs.len() as u64 * 16),
            ("adjacency", packed.adj.len() as u64 * 4),
            ("triangles", packed.tris.len() as u64 * 16),
        ] {
            let bytes = (bytes as f64 * slack_factor) as u64;
            if bytes > max {
                return Err(GpuError::TooLarge { buffer, bytes, limit: max });
            }
        }
        let mut sdf_host = Vec::new();
        let colliders_host = layout::pack_colliders(&model.colliders, config.sdf_cells, &mut sdf_host)?;
        let particles = Mirror::new(&device, &queue, "particles", &packed.particles, slack);
        let adj = Mirror::new(&device, &queue, "adj", &packed.adj, slack);
        let springs = Mirror::new(&device, &queue, "springs", &packed.springs, slack);
        let tris = Mirror::new(&device, &queue, "tris", &packed.tris, slack);
        let bodies = Mirror::new(&device, &queue, "bodies", &packed.bodies, slack);
        let openings = Mirror::new(&device, &queue, "openings", &packed.openings, slack);
        let spring_ends = Mirror::new(&device, &queue, "spring_ends", &packed.spring_ends, slack);
        let caps = Mirror::new(&device, &queue, "caps", &packed.caps, slack);
        let c_part = Mirror::new(&device, &queue, "c_part", &packed.contact.part, slack);
        let c_body = Mirror::new(&device, &queue, "c_body", &packed.contact.body, slack);
        let c_edges = Mirror::new(&device, &queue, "c_edges", &packed.contact.edges, slack);
        let colliders = Mirror::new(&device, &queue, "colliders", &colliders_host, slack);
        let sdf = Mirror::new(&device, &queue, "sdf", &sdf_host, slack);
        let n = model.particle_count();
        let state_capacity = n + if slack { n / 4 } else { 0 };
        let mk = |l| layout::create(&device, l, state_capacity * STATE_STRIDE as usize, STATE_USAGE);
        let state = [mk("state 0"), mk("state 1")];
        let params = layout::create(
            &device,
            "params",
            size_of::<Params>(),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let cap = config.candidate_capacity.max(1);
        let candidates = layout::create(&device, "candidates", (4 + 2 * cap as usize) * 4, layout::RW);
        let status = layout::create(&device, "status", 48, wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
        let clock_capacity = 64;
        let clock = Self::clock_buffer(&device, clock_capacity);
        let clock_bind = Self::clock_bind(&device, &layout1, &clock);
        let scratch = scratch(&device, &queue, model, &packed, config.contact_capacity);
        let profile = if config.kernel_timers { Some(Profile::new(&device, &queue)?) } else { None };
        let mut s = GpuSolver {
            device,
            queue,
            config,
            kernels,
            layout1,
            clock_bind,
            clock,
            clock_capacity,
            params,
            params_host: Params::default(),
            state,
            state_capacity,
            particles,
            adj,
            springs,
            tris,
            bodies,
            openings,
            spring_ends,
            caps,
            c_part,
            c_body,
            c_edges,
            colliders,
            sdf,
            scratch,
            candidates,
            status,
            bind: Vec::new(),
            cur: 0,
            packed,
            time: 0.0,
            state_stale: false,
            last_report: RunReport::default(),
            contact_guard: Default::default(),
            excused: Default::default(),
            contact_stats: Default::default(),
            passes: Vec::new(),
            last_upload: 0,
            last_repacked: 0,
            state_valid: 0,
            timers: StageTimers::default(),
            profile,
        };
        s.rebind();
        s.write_params(model);
        s.upload_state(&model.state())?;
        Ok(s)
    }

    fn write_params(&mut self, m: &Model<f32>) {
        let (gx, gy) = groups(m.tri_count());
        let pairs = self.scratch.sized[7] as u32;
        let iterations = self.config.contact_iterations.next_multiple_of(2);
        let capacity = self.config.candidate_capacity.max(1);
        self.params_host = layout::params(m, &self.packed, gx * gy, capacity, pairs, iterations);
        self.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&self.params_host));
    }

    /// Particles of the model the buffers hold.
    fn particle_count(&self) -> usize {
        self.packed.particles.len()
    }

    /// The settings.
    pub fn config(&self) -> &GpuConfig {
        &self.config
    }

    /// The device's queue and device (for renderers drawing straight from [`GpuSolver::position_buffer`]).
    pub fn device(&self) -> (&wgpu::Device, &wgpu::Queue) {
        (&self.device, &self.queue)
    }

    /// The buffer holding the current state: per particle, its position then its velocity as `vec4<f32>` (w
    /// unused), [`crate::STATE_STRIDE`] bytes apart. The renderer draws positions from it in place.
    pub fn position_buffer(&self) -> &wgpu::Buffer {
        &self.state[self.cur]
    }

    /// Simulation time of the GPU state \[s\].
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The kernels the last submission encoded, in order (one entry per dispatch).
    pub fn passes(&self) -> &[&'static str] {
        &self.passes
    }

    /// Elements re-packed on the host by the last model sync (particles, adjacency rows and items, springs,
    /// triangles, bodies): after a fracture, the size of the change.
    pub fn last_repacked(&self) -> usize {
        self.last_repacked
    }

    /// Bytes written to model buffers by the last `notify_model_changed` (or creation), and to the
    /// state by the upload of new particles after it.
    pub fn last_upload_bytes(&self) -> usize {
        self.last_upload
    }

    fn ensure_clock(&mut self, entries: usize) {
        if entries > self.clock_capacity {
            self.clock_capacity = entries.next_power_of_two();
            self.clock = Self::clock_buffer(&self.device, self.clock_capacity);
            self.clock_bind = Self::clock_bind(&self.device, &self.layout1, &self.clock);
        }
    }

    /// The clock of `steps` steps of `dt` from `t0`: two entries a step (its start, which the integrators read
    /// with the handles' displacements over the step, and its end).
    fn write_clock(&mut self, m: &Model<f32>, t0: f64, dt: f64, steps: usize) {
        self.ensure_clock(2 * steps);
        let mut bytes = vec![0u8; 2 * steps * CLOCK_STRIDE as usize];
        for k in 0..2 * steps {
            let start = t0 + (k / 2) as f64 * dt;
            let t = start + if k % 2 == 1 { dt } else { 0.0 };
            let mut c = Clock { time: t as f32, dt: dt as f32, ..Default::default() };
            if k % 2 == 0 {
                for (h, slot) in m.handles.iter().zip(&mut c.handles) {
                    let d = (h.offset(start + dt) - h.offset(start)).as_vec3();
                    *slot = [d.x, d.y, d.z, 0.0];
                }
            }
            let at = k * CLOCK_STRIDE as usize;
            bytes[at..at + size_of::<Clock>()].copy_from_slice(bytemuck::bytes_of(&c));
        }
        self.queue.write_buffer(&self.clock, 0, &bytes);
    }

    /// Encodes kernel `k` (an index of [`KERNEL_BINDINGS`], from [`k!`]) reading state `cur`, with clock entry
    /// `clock`, over `n` workgroups.
    fn dispatch(&mut self, pass: &mut wgpu::ComputePass<'_>, k: usize, cur: usize, clock: usize, n: (u32, u32)) {
        self.bind_kernel(pass, k, cur, clock);
        pass.dispatch_workgroups(n.0, n.1, 1);
        self.stamp(pass, k);
    }

    /// Sets kernel `k`'s pipeline and bind groups (state `cur`, clock entry `clock`) and records the pass.
    fn bind_kernel(&mut self, pass: &mut wgpu::ComputePass<'_>, k: usize, cur: usize, clock: usize) {
        pass.set_pipeline(&self.kernels.pipelines[k]);
        pass.set_bind_group(0, &self.bind[k][cur], &[]);
        pass.set_bind_group(1, &self.clock_bind, &[(clock as u64 * CLOCK_STRIDE) as u32]);
        self.passes.push(KERNEL_BINDINGS[k].0);
    }

    /// Encodes the surface pass on state buffer `cur` (with the clock entry `clock`): crosses and volume
    /// partials, caps, volumes and pressures, then the per-corner forces and the caps' forces (`forces`), or the
    /// per-corner pressure shares alone (for the load check).
    fn encode_surface(
        &mut self,
        pass: &mut wgpu::ComputePass<'_>,
        m: &Model<f32>,
        cur: usize,
        clock: usize,
        forces: bool,
    ) {
        let nt = groups(m.tri_count());
        self.dispatch(pass, k!("surface_cross"), cur, clock, nt);
        if self.packed.n_caps > 0 {
            // One workgroup per opening (surface.wgsl).
            let caps = self.packed.n_caps.max(1);
            let x = caps.min(MAX_GROUPS);
            self.dispatch(pass, k!("surface_caps"), cur, clock, (x, caps.div_ceil(x)));
        }
        if self.packed.n_gas > 0 {
            self.dispatch(pass, k!("surface_volume"), cur, clock, (self.packed.n_gas, 1));
        }
        if !forces {
            self.dispatch(pass, k!("surface_pressure"), cur, clock, nt);
            return;
        }
        self.dispatch(pass, k!("surface_force"), cur, clock, nt);
        if self.packed.n_caps > 0 {
            self.dispatch(pass, k!("cap_force"), cur, clock, groups(self.particle_count()));
        }
    }

    fn encode_step(&mut self, pass: &mut wgpu::ComputePass<'_>, m: &Model<f32>, k: usize) {
        // The model's terms as packed (not re-derived from the model at every substep).
        let surface = self.params_host.misc[1] != 0;
        let colliders = self.params_host.counts2[0] > 0;
        let np = groups(self.particle_count());
        let (c0, c1) = (2 * k, 2 * k + 1);
        let cur = self.cur;
        let contact = self.packed.contact.on();
        if contact {
            self.encode_contact_start(pass, c0);
        }
        match self.config.integrator {
            Integrator::VelocityVerlet => {
                if surface {
                    self.encode_surface(pass, m, cur, c0, true);
                }
                self.dispatch(pass, k!("integrate_verlet_first"), cur, c0, np);
                if surface {
                    self.encode_surface(pass, m, 1 - cur, c1, true);
                }
                self.dispatch(pass, k!("integrate_verlet_second"), 1 - cur, c1, np);
                if colliders {
                    self.dispatch(pass, k!("collide"), 1 - cur, c1, np);
                }
            }
            _ => {
                if surface {
                    self.encode_surface(pass, m, cur, c0, true);
                }
                self.dispatch(pass, k!("integrate_symplectic_euler"), cur, c0, np);
                if colliders {
                    self.dispatch(pass, k!("collide"), cur, c1, np);
                }
                self.cur = 1 - cur;
            }
        }
        if contact {
            self.encode_contact_end(pass, m, c1);
        }
        if self.packed.any_strain_limit || self.packed.any_load_limit {
            let cur = self.cur;
            if self.packed.any_strain_limit {
                self.dispatch(pass, k!("strain_check"), cur, c1, groups(m.spring_count()));
            }
            if self.packed.any_load_limit {
                if self.packed.n_gas > 0 {
                    self.encode_surface(pass, m, cur, c1, false);
                }
                self.dispatch(pass, k!("load_check"), cur, c1, np);
            }
        }
    }

    fn check_model(&self, m: &Model<f32>) -> Result<(), GpuError> {
        if m.particle_count() != self.particle_count() {
            return Err(GpuError::StateMismatch { state: self.particle_count(), model: m.particle_count() });
        }
        if self.state_stale {
            return Err(GpuError::StateStale);
        }
        Ok(())
    }

    /// Runs `steps` substeps of `dt` \[s\] in one submission. Reads back only the 16-byte status word, and only
    /// when `check_finite` is on or the model can break. In a browser use [`GpuSolver::run_async`].
    pub fn run(&mut self, m: &Model<f32>, dt: f64, steps: usize) -> Result<RunReport, GpuError> {
        crate::mapping::now(self.run_async(m, dt, steps))
    }

    /// [`GpuSolver::run`], awaiting the status word's read-back (what a browser needs: its read-backs complete
    /// only once control is back in the event loop). Nothing is awaited when nothing is read.
    pub async fn run_async(&mut self, m: &Model<f32>, dt: f64, steps: usize) -> Result<RunReport, GpuError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(GpuError::BadTimeStep(dt));
        }
        self.check_model(m)?;
        let t0 = Instant::now();
        let start = self.time;
        self.write_clock(m, start, dt, steps);
        self.passes.clear();
        let mut enc = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("run") });
        enc.clear_buffer(&self.candidates, 0, Some(16));
        let contact = self.packed.contact.on();
        if contact {
            enc.clear_buffer(&self.scratch.c_ctl, 0, Some(32));
        }
        {
            let mut pass =
                enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("substeps"), ..Default::default() });
            if let Some(p) = &mut self.profile {
                p.begin(&mut pass);
            }
            for k in 0..steps {
                self.encode_step(&mut pass, m, k);
            }
            if self.config.check_finite {
                let last = 2 * steps.max(1) - 1;
                self.dispatch(&mut pass, k!("finite_check"), self.cur, last, groups(self.particle_count()));
            }
        }
        if let Some(p) = &mut self.profile {
            p.end(&mut enc);
        }
        let read = self.config.check_finite || m.has_fracture() || contact;
        if read {
            enc.copy_buffer_to_buffer(&self.candidates, 0, &self.status, 0, 16);
            if contact {
                enc.copy_buffer_to_buffer(&self.scratch.c_ctl, 0, &self.status, 16, 32);
            }
        }
        self.queue.submit([enc.finish()]);
        self.time = start + steps as f64 * dt;
        let mut report = RunReport { steps, ..Default::default() };
        let mut status = None;
        if read {
            let w: Vec<u32> = bytemuck::pod_collect_to_vec(&self.map_read(&self.status, 48).await?);
            report.spring_candidates = w[0];
            report.vertex_candidates = w[1];
            status = Some(w);
        }
        if let Some(p) = &self.profile {
            let bytes = self.read_bytes(&p.resolve, 8 * (p.stamps.len() as u64 + 1)).await?;
            let ticks = bytemuck::pod_collect_to_vec::<u8, u64>(&bytes);
            if let Some(p) = &mut self.profile {
                p.take(&ticks, &mut self.timers);
            }
        }
        self.timers.steps += steps as u64;
        self.timers.total += t0.elapsed();
        if let Some(w) = status {
            if contact {
                self.take_contact_status(&w[4..12])?;
            }
            if self.config.check_finite && w[2] != 0 {
                return Err(GpuError::NonFinite { from: start, to: self.time, dt });
            }
        }
        Ok(report)
    }

    /// Waits until the queue is idle (for timing).
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::Readback(e.to_string()))
    }
}

/// Names of the `@compute` entry points of a WGSL file, in order.
fn entry_points(src: &'static str) -> Vec<&'static str> {
    let mut out = Vec::new();
    let mut rest = src;
    while let Some(at) = rest.find("@compute") {
        rest = &rest[at..];
        let f = rest.find("fn ").expect("an entry point follows @compute") + 3;
        let end = rest[f..].find('(').expect("entry point has parameters") + f;
        out.push(rest[f..end].trim());
        rest = &rest[end..];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entry_points_are_found_in_order() {
        let src = "@compute @workgroup_size(64)\nfn a(x: u32) {}\nfn helper() {}\n@compute\nfn b_c() {}";
        assert_eq!(entry_points(src), vec!["a", "b_c"]);
    }

    #[test]
    fn groups_cover_every_invocation() {
        for n in [0usize, 1, 63, 64, 65, 64 * 65535, 64 * 65535 + 1, 10_000_000] {
            let (x, y) = groups(n);
            assert!(x <= MAX_GROUPS && y <= MAX_GROUPS);
            assert!((x as usize * y as usize * WG as usize) >= n, "{n}");
            // No more than one extra row of workgroups.
            assert!(((x as usize) * (y as usize - 1) * WG as usize) < n.max(1), "{n}");
        }
    }
}
