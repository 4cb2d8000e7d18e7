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
//! | `contact_save`, `contact_edges`, `contact_scan`, `contact_scatter` (before the integrator) | contact |
//! | `contact_moves`, `contact_vt`, `contact_ee`, `contact_args`, `contact_prep`, `contact_iterations` × `contact_jacobi_even`/`_odd`, `contact_friction`, `contact_apply` | contact |
//! | `strain_check` / `surface_pressure` + `load_check` | breakable springs / vertices (the pressure pass: gas) |
//! | `finite_check` | once per submission, with `check_finite` |
//!
//! [`GpuSolver::passes`] lists what the last submission encoded, in order.
//!
//! Each kernel has its own bind group layout with only the buffers it uses ([`crate::KERNEL_BINDINGS`], at most 8
//! storage buffers: WebGPU's default limit), so the solver runs on any WebGPU device without asking for more.

use fissure_core::timers::Instant;

use fissure_core::{Integrator, Model, StageTimers, State};
use glam::Vec3;

use crate::layout::{self, CLOCK_STRIDE, Clock, GpuCollider, MAX_GPU_HANDLES, Mirror, Packed, Params, STATE_STRIDE};
use crate::{GpuError, KERNEL_BINDINGS, READ_WRITE_BINDINGS, SHADERS, shader_source};

mod bind;
mod transfer;

/// Workgroup size of every kernel.
const WG: u32 = 64;
/// Largest workgroup count along one dispatch dimension (WebGPU's guaranteed minimum).
const MAX_GROUPS: u32 = 65535;

/// GPU solver settings.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuConfig {
    /// Symplectic Euler (default) or velocity Verlet; the others are CPU-only.
    pub integrator: Integrator,
    /// Read the status word after each submission and fail with [`GpuError::NonFinite`] if a velocity became
    /// NaN or infinite. Default true; the cost is one 16-byte read-back per submission, not per substep.
    pub check_finite: bool,
    /// Fracture candidates kept per kind per submission (the counters count past it). Default 4096.
    pub candidate_capacity: u32,
    /// Cells along the longest side of a baked signed-distance grid (triangle-mesh colliders). Default 64.
    pub sdf_cells: u32,
    /// Contact pairs one substep can hold; 0 (default): 4 per particle in contact plus 1,024. A substep that
    /// finds more fails the run with [`GpuError::ContactCapacity`].
    pub contact_capacity: u32,
    /// Jacobi iterations of the contact impulses per substep, rounded up to an even number (one dispatch each).
    /// Default 16.
    pub contact_iterations: u32,
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

/// Buffers that depend on the model's size (everything but the state and the mirrors).
struct Scratch {
    tri_cross: wgpu::Buffer,
    tri_f: wgpu::Buffer,
    body_state: wgpu::Buffer,
    partials: wgpu::Buffer,
    cap_data: wgpu::Buffer,
    cap_f: wgpu::Buffer,
    c_x0: wgpu::Buffer,
    c_grid: wgpu::Buffer,
    c_pairs: wgpu::Buffer,
    c_ctl: wgpu::Buffer,
    c_acc: wgpu::Buffer,
    c_args: wgpu::Buffer,
    /// (triangles, bodies, partial floats, openings, particles with cap forces, particles in a contact model, grid
    /// words, contact pairs) they hold.
    sized: [usize; SCRATCH],
}

/// Bytes of a contact pair (`Pair` in WGSL).
const PAIR_BYTES: usize = 80;

/// Entries of [`Scratch::sized`].
const SCRATCH: usize = 8;

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
    /// The contact pass's counts (see [`GpuSolver::contact_stats`]).
    contact_stats: fissure_core::ContactStats,
    passes: Vec<&'static str>,
    last_upload: usize,
    /// Elements (particles, rows, springs, triangles, bodies, ...) re-packed by the last model sync.
    last_repacked: usize,
    /// Particles `0..state_valid` hold a valid state on the GPU (a reallocation of the state buffers empties it).
    state_valid: usize,
    timers: StageTimers,
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

/// Entries the scratch buffers need: triangles (with a surface pass), bodies, volume partials, capped openings,
/// particles (with caps), particles (with contact), contact grid words, contact pairs (`capacity`, 0: automatic).
fn scratch_sizes(m: &Model<f32>, p: &Packed, capacity: u32) -> [usize; SCRATCH] {
    let surface = m.has_pressure() || m.has_wind();
    let nt = if surface { m.tri_count() } else { 0 };
    let (gx, gy) = groups(m.tri_count());
    let np = if p.n_gas > 0 { (gx * gy * p.n_gas) as usize } else { 0 };
    let caps = p.n_caps as usize;
    let c = &p.contact;
    let contact = !c.edges.is_empty();
    let (n, grid, pairs) = if contact {
        let pairs = if capacity > 0 { capacity as usize } else { 4 * c.particles + 1024 };
        (m.particle_count(), 4 * c.buckets() + 1 + m.particle_count() + c.edges.len(), pairs)
    } else {
        (0, 0, 0)
    };
    [nt, m.body_count(), np, caps, if caps > 0 { m.particle_count() } else { 0 }, n, grid, pairs]
}

/// Positions and velocities: storage for the kernels, copies both ways, and a vertex buffer for the renderer
/// ([`crate::render`] draws the position buffer in place).
const STATE_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_DST)
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::VERTEX);

fn scratch(device: &wgpu::Device, queue: &wgpu::Queue, m: &Model<f32>, p: &Packed, capacity: u32) -> Scratch {
    let mut sized = scratch_sizes(m, p, capacity).map(|n| n + n / 4);
    if capacity > 0 {
        // A capacity the user set is exact.
        sized[7] = capacity as usize;
    }
    // Every particle's contact words start empty: no velocity change, no bound (+inf), in no pair.
    let acc: Vec<i32> = (0..sized[5]).flat_map(|_| [0, 0, 0, 0, 0, 0, 0x7f80_0000, 0]).collect();
    let c_acc = layout::create(device, "c_acc", sized[5] * 32, rw_usage());
    queue.write_buffer(&c_acc, 0, bytemuck::cast_slice(&acc));
    // The counters, then each body's box (empty: minima u32::MAX, maxima 0; `contact_args` empties them after
    // every substep).
    let boxes = if sized[6] > 0 { sized[1] } else { 0 };
    let ctl: Vec<u32> =
        [0; 8].into_iter().chain((0..boxes).flat_map(|_| [u32::MAX, u32::MAX, u32::MAX, 0, 0, 0])).collect();
    let c_ctl = layout::create(device, "c_ctl", ctl.len() * 4, rw_usage());
    queue.write_buffer(&c_ctl, 0, bytemuck::cast_slice(&ctl));
    let c_grid = layout::create(device, "c_grid", sized[6] * 4, rw_usage());
    // The counts must start at zero (a new buffer is zeroed; written anyway, to be explicit).
    queue.write_buffer(&c_grid, 0, &vec![0u8; sized[6] * 4]);
    let rw = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
    Scratch {
        tri_cross: layout::create(device, "tri_cross", sized[0] * 16, rw),
        tri_f: layout::create(device, "tri_f", sized[0] * 16, rw),
        body_state: layout::create(device, "body_state", sized[1] * 16, rw),
        partials: layout::create(device, "partials", sized[2] * 4, rw),
        cap_data: layout::create(device, "cap_data", sized[3] * 32, rw),
        cap_f: layout::create(device, "cap_f", sized[4] * 16, rw),
        c_x0: layout::create(device, "c_x0", sized[5] * 16, rw),
        c_grid,
        c_pairs: layout::create(device, "c_pairs", sized[7] * PAIR_BYTES, rw),
        c_ctl,
        c_acc,
        c_args: layout::create(device, "c_args", 16, rw_usage() | wgpu::BufferUsages::INDIRECT),
        sized,
    }
}

fn rw_usage() -> wgpu::BufferUsages {
    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC
}

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
        let su = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
        let candidates = layout::create(&device, "candidates", (4 + 2 * cap as usize) * 4, su);
        let status = layout::create(&device, "status", 48, wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
        let clock_capacity = 64;
        let clock = Self::clock_buffer(&device, clock_capacity);
        let clock_bind = Self::clock_bind(&device, &layout1, &clock);
        let scratch = scratch(&device, &queue, model, &packed, config.contact_capacity);
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
            contact_stats: Default::default(),
            passes: Vec::new(),
            last_upload: 0,
            last_repacked: 0,
            state_valid: 0,
            timers: StageTimers::default(),
        };
        s.rebind();
        s.write_params(model);
        s.upload_state(&model.state())?;
        Ok(s)
    }

    fn write_params(&mut self, m: &Model<f32>) {
        let (gx, gy) = groups(m.tri_count());
        let pairs = self.scratch.sized[7] as u32;
        self.params_host = layout::params(m, &self.packed, gx * gy, self.config.candidate_capacity.max(1), pairs);
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
    }

    /// Sets kernel `k`'s pipeline and bind groups (state `cur`, clock entry `clock`) and records the pass.
    fn bind_kernel(&mut self, pass: &mut wgpu::ComputePass<'_>, k: usize, cur: usize, clock: usize) {
        pass.set_pipeline(&self.kernels.pipelines[k]);
        pass.set_bind_group(0, &self.bind[k][cur], &[]);
        pass.set_bind_group(1, &self.clock_bind, &[(clock as u64 * CLOCK_STRIDE) as u32]);
        self.passes.push(KERNEL_BINDINGS[k].0);
    }

    /// [`GpuSolver::dispatch`] with the workgroup counts read from the contact pass's `c_args` (one per pair this
    /// substep, written by `contact_args`).
    fn dispatch_pairs(&mut self, pass: &mut wgpu::ComputePass<'_>, k: usize, cur: usize, clock: usize) {
        self.bind_kernel(pass, k, cur, clock);
        pass.dispatch_workgroups_indirect(&self.scratch.c_args, 0);
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
            self.dispatch(pass, k!("surface_caps"), cur, clock, groups(self.packed.n_caps as usize));
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
        let contact = !self.packed.contact.edges.is_empty();
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

    /// The contact pass's first half, on the state at the start of the substep: positions saved, both grids built.
    fn encode_contact_start(&mut self, pass: &mut wgpu::ComputePass<'_>, clock: usize) {
        let (n, ne) = (self.particle_count(), self.packed.contact.edges.len());
        let cur = self.cur;
        self.dispatch(pass, k!("contact_save"), cur, clock, groups(n));
        self.dispatch(pass, k!("contact_edges"), cur, clock, groups(ne));
        self.dispatch(pass, k!("contact_scan"), cur, clock, (1, 1));
        self.dispatch(pass, k!("contact_scatter"), cur, clock, groups(n + ne));
    }

    /// The contact pass's second half, on the state after the integrator and the colliders (bound as the
    /// destination, which the kernels change in place): pairs, impulses, the displacement bound.
    fn encode_contact_end(&mut self, pass: &mut wgpu::ComputePass<'_>, m: &Model<f32>, clock: usize) {
        let (n, ne) = (self.particle_count(), self.packed.contact.edges.len());
        let np = groups(n);
        let dst = 1 - self.cur;
        self.dispatch(pass, k!("contact_moves"), dst, clock, np);
        self.dispatch(pass, k!("contact_vt"), dst, clock, groups(m.tri_count()));
        self.dispatch(pass, k!("contact_ee"), dst, clock, groups(ne));
        self.dispatch(pass, k!("contact_args"), dst, clock, (1, 1));
        self.dispatch_pairs(pass, k!("contact_prep"), dst, clock);
        // An even count: the friction pass reads the totals the last (odd) iteration completed.
        for it in 0..self.config.contact_iterations.next_multiple_of(2) {
            let k = if it % 2 == 0 { k!("contact_jacobi_even") } else { k!("contact_jacobi_odd") };
            self.dispatch_pairs(pass, k, dst, clock);
        }
        self.dispatch_pairs(pass, k!("contact_friction"), dst, clock);
        self.dispatch(pass, k!("contact_apply"), dst, clock, np);
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
        let contact = !self.packed.contact.edges.is_empty();
        if contact {
            enc.clear_buffer(&self.scratch.c_ctl, 0, Some(32));
        }
        {
            let mut pass =
                enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("substeps"), ..Default::default() });
            for k in 0..steps {
                self.encode_step(&mut pass, m, k);
            }
            if self.config.check_finite {
                let last = 2 * steps.max(1) - 1;
                self.dispatch(&mut pass, k!("finite_check"), self.cur, last, groups(self.particle_count()));
            }
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
        if read {
            let w: Vec<u32> = bytemuck::pod_collect_to_vec(&self.map_read(&self.status, 48).await?);
            report.spring_candidates = w[0];
            report.vertex_candidates = w[1];
            if contact {
                let c = &w[4..12];
                let s = &mut self.contact_stats;
                s.near = c[0].min(self.params_host.contact_n[2]) as usize;
                s.candidates = s.near;
                s.pushed = 0;
                s.steps += c[7] as u64;
                s.pushed_total += c[4] as u64;
                s.near_total += c[5] as u64;
                s.capped_total += c[6] as u64;
                s.builds += c[7] as u64;
                if c[3] > 0 {
                    self.timers.steps += steps as u64;
                    self.timers.total += t0.elapsed();
                    return Err(GpuError::ContactCapacity { wanted: c[3], capacity: self.params_host.contact_n[2] });
                }
            }
            if self.config.check_finite && w[2] != 0 {
                self.timers.steps += steps as u64;
                self.timers.total += t0.elapsed();
                return Err(GpuError::NonFinite { from: start, to: self.time, dt });
            }
        }
        self.timers.steps += steps as u64;
        self.timers.total += t0.elapsed();
        Ok(report)
    }

    /// Waits until the queue is idle (for timing).
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::Readback(e.to_string()))
    }

    /// The fracture candidates the last submission flagged.
    pub fn candidates(&self) -> Result<Candidates, GpuError> {
        let cap = self.config.candidate_capacity.max(1) as usize;
        let bytes = crate::mapping::now(self.read_bytes(&self.candidates, ((4 + 2 * cap) * 4) as u64))?;
        let w: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
        let list = |kind: usize| {
            let n = (w[kind] as usize).min(cap);
            let mut v = w[4 + kind * cap..4 + kind * cap + n].to_vec();
            v.sort_unstable();
            v.dedup();
            v
        };
        Ok(Candidates { springs: list(0), vertices: list(1), overflow: w[0] as usize > cap || w[1] as usize > cap })
    }

    /// The net force on every particle at `state` \[N\] (gravity, springs, pressure, wind; not collisions): the
    /// kernels' twin of `CpuSolver::compute_forces`. Replaces the GPU state with `state`.
    pub fn compute_forces(&mut self, m: &Model<f32>, state: &State<f32>) -> Result<Vec<Vec3>, GpuError> {
        self.check_model(m)?;
        self.upload_state(state)?;
        self.write_clock(m, state.time, 1.0, 1);
        self.passes.clear();
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            let cur = self.cur;
            if m.has_pressure() || m.has_wind() {
                self.encode_surface(&mut pass, m, cur, 0, true);
            }
            self.dispatch(&mut pass, k!("net_forces"), cur, 0, groups(self.particle_count()));
        }
        self.queue.submit([enc.finish()]);
        let f = crate::mapping::now(self.read_vec4(&self.state[1 - self.cur], 2 * self.particle_count()))?;
        Ok(f.iter().step_by(2).map(|v| Vec3::new(v[0], v[1], v[2])).collect())
    }

    /// What the contact pass did: `near` is the pairs within reach in the last substep of the last submission;
    /// the totals and `steps` sum over every substep run (`builds` counts grid builds: one per substep). Zeros
    /// without contact.
    pub fn contact_stats(&self) -> fissure_core::ContactStats {
        self.contact_stats
    }

    /// The contact pairs within reach in the last substep, in no particular order (the kernels list them as they
    /// find them): each pair's four particles (a vertex then its triangle's corners, or one edge's ends then the
    /// other's) and its gap at the start of the substep \[m\].
    pub fn contact_pairs(&self) -> Result<Vec<([u32; 4], f32)>, GpuError> {
        if self.packed.contact.edges.is_empty() {
            return Ok(Vec::new());
        }
        let ctl: Vec<u32> =
            bytemuck::pod_collect_to_vec(&crate::mapping::now(self.read_bytes(&self.scratch.c_ctl, 32))?);
        let n = (ctl[0] as usize).min(self.scratch.sized[7]);
        let bytes = crate::mapping::now(self.read_bytes(&self.scratch.c_pairs, (n * PAIR_BYTES) as u64))?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[..n * PAIR_BYTES]);
        Ok(words.chunks_exact(PAIR_BYTES / 4).map(|w| ([w[0], w[1], w[2], w[3]], f32::from_bits(w[11]))).collect())
    }

    /// Volume \[m^3\] and net pressure \[Pa\] of each body as of the last surface pass (zeros for bodies without gas).
    pub fn body_volumes_pressures(&self, m: &Model<f32>) -> Result<Vec<(f32, f32)>, GpuError> {
        let nb = m.body_count();
        let v = crate::mapping::now(self.read_vec4(&self.scratch.body_state, nb))?;
        Ok(v.iter()
            .zip(&self.packed.bodies)
            .map(|(x, b)| if b.gas_slot == layout::NONE { (0.0, 0.0) } else { (x[0], x[1]) })
            .collect())
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
