//! Buffer layouts shared with `shaders/common.wgsl` (same field order; every struct is `Pod`, 16-byte multiple),
//! the packing of a [`Model`] into them, and [`Mirror`]: a GPU buffer with a host copy that uploads only what
//! changed.

use bytemuck::{Pod, Zeroable};
use fissure_core::collision::Collider;
use fissure_core::{DampingModel, Model, SpringKind, Vector3};

use crate::GpuError;
use crate::sdf::SdfGrid;

/// Sentinel of "no index" in the kernels (`NONE` in WGSL).
pub const NONE: u32 = u32::MAX;

/// The uniform of every kernel (`Params` in WGSL).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Params {
    /// xyz gravity \[m/s^2\]; w 1 for projected damping, 0 for unprojected.
    pub gravity: [f32; 4],
    /// particles, springs, triangles, bodies.
    pub counts: [u32; 4],
    /// colliders, gas bodies, openings with caps, volume partial rows.
    pub counts2: [u32; 4],
    /// xyz mean wind \[m/s\]; w air density \[kg/m^3\] (0 without wind).
    pub wind_u: [f32; 4],
    /// gust amplitude, gust frequency \[Hz\], gust wavelength \[m\], crosswind fraction.
    pub wind_p: [f32; 4],
    /// candidate capacity per kind, triangle forces present, caps present, 0.
    pub misc: [u32; 4],
    /// Contact: largest thickness \[m\], grid cell \[m\], fixed-point units per m/s, 0.
    pub contact_f: [f32; 4],
    /// Contact: edges, buckets per grid less one (a power of two less one), pair capacity, Jacobi iterations (even).
    pub contact_n: [u32; 4],
}

/// One clock entry (`Clock` in WGSL), stored at a 256-byte stride and selected by a dynamic offset.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Clock {
    /// Time \[s\].
    pub time: f32,
    /// Step \[s\].
    pub dt: f32,
    /// Padding.
    pub pad: [f32; 2],
    /// Each moving pin's displacement over the step that starts at `time` \[m\] (xyz; w unused): the
    /// integrators move a pinned particle on handle `h` by entry `h` and give it that displacement over `dt` as
    /// its velocity, as the CPU solver's `move_handles` does. Filled in the entries the integrators read.
    pub handles: [[f32; 4]; MAX_GPU_HANDLES],
}

/// The most moving pins ([`fissure_core::Handle`]) a model may have on the GPU: as many as fill a clock entry's 256
/// bytes.
pub const MAX_GPU_HANDLES: usize = 15;

/// Bytes per particle in a state buffer: its position, then its velocity, each a `vec4<f32>` (w unused).
/// Interleaved, so that a kernel binds one buffer per state (WebGPU's default allows 8 storage buffers per
/// kernel); the renderer draws positions from it at this stride.
pub const STATE_STRIDE: u64 = 32;

/// Stride of the clock entries [bytes] (the largest `min_uniform_buffer_offset_alignment` allowed).
pub const CLOCK_STRIDE: u64 = 256;

/// `Particle` in WGSL.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuParticle {
    /// Mass \[kg\].
    pub mass: f32,
    /// Inverse mass [1/kg], 0 pinned.
    pub inv_mass: f32,
    /// The moving pin holding the particle, plus one (0: none): the kernels move it by the clock's `handles` entry.
    pub handle: u32,
    /// Load limit \[N\], negative for none.
    pub load_limit: f32,
    /// Adjacency header: spring row start and length, triangle row start (offset by `tri_offset` in `adj`) and
    /// length.
    pub row: [u32; 4],
}

/// `Spring` in WGSL (the ends are a separate array).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSpring {
    /// Rest length \[m\].
    pub rest: f32,
    /// Stiffness \[N/m\].
    pub ks: f32,
    /// Damping [N s/m].
    pub kd: f32,
    /// Strain limit, negative for none (or broken).
    pub strain_limit: f32,
}

/// `Body` in WGSL.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuBody {
    /// nRT \[J\].
    pub gas: f32,
    /// Outside pressure \[Pa\].
    pub p_ext: f32,
    /// Rest volume \[m^3\].
    pub rest_volume: f32,
    /// Drag coefficient.
    pub drag: f32,
    /// Lift coefficient.
    pub lift: f32,
    /// Anchor particle of the volume sum.
    pub anchor: u32,
    /// Index among the gas bodies, or `NONE` (`u32::MAX`).
    pub gas_slot: u32,
    /// Padding.
    pub pad: u32,
}

/// `Collider` in WGSL.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuCollider {
    /// kind, grid offset, 0, 0.
    pub head: [u32; 4],
    /// restitution, threshold \[m/s\], friction, margin \[m\].
    pub material: [f32; 4],
    /// Translation at time 0 \[m\].
    pub translation: [f32; 4],
    /// Rotation at time 0 (x, y, z, w).
    pub rotation: [f32; 4],
    /// Linear velocity \[m/s\].
    pub linear_velocity: [f32; 4],
    /// Angular velocity \[rad/s\].
    pub angular_velocity: [f32; 4],
    /// Shape parameters (see the WGSL).
    pub a: [f32; 4],
    /// Shape parameters (see the WGSL).
    pub b: [f32; 4],
    /// Reserved.
    pub reserved: [f32; 4],
}

/// Collider kinds of the kernels.
pub mod kind {
    /// Half-space.
    pub const HALF_SPACE: u32 = 0;
    /// Ball.
    pub const BALL: u32 = 1;
    /// Cuboid.
    pub const CUBOID: u32 = 2;
    /// Capsule.
    pub const CAPSULE: u32 = 3;
    /// Signed-distance grid.
    pub const GRID: u32 = 4;
}

fn v4(v: glam::Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

/// The model packed for the kernels (host side of every model buffer).
#[derive(Clone, Debug, Default)]
pub(crate) struct Packed {
    pub particles: Vec<GpuParticle>,
    pub adj: Vec<u32>,
    pub springs: Vec<GpuSpring>,
    pub spring_ends: Vec<[u32; 2]>,
    pub tris: Vec<[u32; 4]>,
    pub bodies: Vec<GpuBody>,
    pub openings: Vec<u32>,
    pub caps: Vec<u32>,
    pub n_gas: u32,
    pub n_caps: u32,
    pub any_strain_limit: bool,
    pub any_load_limit: bool,
    pub tri_offset: usize,
    pub contact: ContactPack,
}

/// The model's contact elements as `contact.wgsl` reads them (empty without contact).
#[derive(Clone, Debug, Default)]
pub(crate) struct ContactPack {
    /// Per particle: origin, body, 1 if a corner of a contact triangle, 0.
    pub part: Vec<[u32; 4]>,
    /// Per body: thickness \[m\] (0: none), friction, 1 if against itself, 0 (body 0's last: the count of
    /// excused pairs); then the pairs of bodies left out of contact (`fissure_core::contact::family`), each as
    /// `[low, high, 0, 0]` (body indices are exact in `f32` below 2^24).
    pub body: Vec<[f32; 4]>,
    /// The unique edges of the contact triangles, lower index first, sorted.
    pub edges: Vec<[u32; 2]>,
    /// Particles in contact.
    pub particles: usize,
    /// Largest thickness \[m\].
    pub h_max: f32,
    /// Grid cell \[m\]: the contact edges' mean length at the model's initial positions, at least 2 h_max.
    pub cell: f32,
}

impl ContactPack {
    pub fn new(m: &Model<f32>) -> Self {
        if !m.has_contact() {
            return ContactPack::default();
        }
        let on = |b: u32| m.body_contact_thickness[b as usize] > 0.0;
        let mut part: Vec<[u32; 4]> =
            (0..m.particle_count()).map(|i| [m.particle_origin[i], m.particle_body[i], 0, 0]).collect();
        let mut edges = Vec::new();
        for (t, &[a, b, c]) in m.tri_indices.iter().enumerate() {
            if on(m.tri_body[t]) {
                for (i, j) in [(a, b), (b, c), (c, a)] {
                    edges.push([i.min(j), i.max(j)]);
                }
                for v in [a, b, c] {
                    part[v as usize][2] = 1;
                }
            }
        }
        edges.sort_unstable();
        edges.dedup();
        let body = (0..m.body_count())
            .map(|b| {
                let self_contact = if m.body_self_contact[b] { 1.0 } else { 0.0 };
                [m.body_contact_thickness[b], m.body_contact_friction[b], self_contact, 0.0]
            })
            .collect();
        let h_max = m.body_contact_thickness.iter().copied().fold(0.0, f32::max);
        let q = &m.particle_q0;
        let sum: f64 = edges.iter().map(|&[i, j]| (q[j as usize] - q[i as usize]).length() as f64).sum();
        let l_mean = (sum / edges.len().max(1) as f64) as f32;
        let particles = part.iter().filter(|p| p[2] != 0).count();
        ContactPack { part, body, edges, particles, h_max, cell: l_mean.max(2.0 * h_max).max(1e-6) }
    }

    /// Puts `pairs` after the model's `bodies` entries of `body`, their count in body 0's last component.
    pub fn excuse(&mut self, bodies: usize, pairs: &[[u32; 2]]) {
        if bodies == 0 || self.body.len() < bodies {
            return;
        }
        self.body.truncate(bodies);
        self.body[0][3] = pairs.len() as f32;
        self.body.extend(pairs.iter().map(|&[a, b]| [a as f32, b as f32, 0.0, 0.0]));
    }

    /// The model has contact (a contact body with triangles).
    pub fn on(&self) -> bool {
        !self.edges.is_empty()
    }

    /// Buckets per grid: a power of two, at least twice the larger grid's items and at least 128.
    pub fn buckets(&self) -> usize {
        (2 * self.particles.max(self.edges.len())).next_power_of_two().max(128)
    }

    /// Blocks of the bucket counts' scan (`SCAN_BLOCK` in `shaders/contact.wgsl`: 1,024 counts each).
    pub fn scan_blocks(&self) -> usize {
        (2 * self.buckets()).div_ceil(1024)
    }

    /// Where the grids' items start in `c_grid`: after both grids' counts and starts, the total and the scan's
    /// block sums (`grid_items_at` in `shaders/contact.wgsl`).
    pub fn grid_items_at(&self) -> usize {
        4 * self.buckets() + 1 + self.scan_blocks()
    }
}

/// Particle `i` as the kernels read it, with its adjacency header: its spring row, then its triangle row (offset
/// by `tri_offset` in `adj`).
pub(crate) fn pack_particle(m: &Model<f32>, i: usize, tri_offset: usize) -> GpuParticle {
    let lim = m.particle_load_limit[i];
    let (sp, tr) = (&m.particle_springs, &m.particle_tris);
    GpuParticle {
        mass: m.particle_mass[i],
        inv_mass: m.particle_inv_mass[i],
        handle: if m.particle_handle[i] == u32::MAX { 0 } else { m.particle_handle[i] + 1 },
        load_limit: if lim.is_finite() { lim } else { -1.0 },
        row: [sp.start[i], sp.len[i], tr.start[i] + tri_offset as u32, tr.len[i]],
    }
}

/// Spring `s` as the kernels read it (a broken spring, or one without a limit, has no strain limit: -1).
pub(crate) fn pack_spring(m: &Model<f32>, s: usize) -> GpuSpring {
    let lim = m.spring_strain_limit[s];
    let live = m.spring_kind[s] != SpringKind::Broken;
    GpuSpring {
        rest: m.spring_rest_length[s],
        ks: m.spring_stiffness[s],
        kd: m.spring_damping[s],
        strain_limit: if live && lim.is_finite() { lim } else { -1.0 },
    }
}

/// Triangle `t` with its body.
pub(crate) fn pack_tri(m: &Model<f32>, t: usize) -> [u32; 4] {
    let [a, b, c] = m.tri_indices[t];
    [a, b, c, m.tri_body[t]]
}

impl Packed {
    /// Packs `m`. The triangle rows go after the spring rows in `adj`, at `tri_offset` (or right after them if
    /// they are longer): keeping that offset fixed as the spring rows grow keeps a fracture's upload local.
    pub fn new(m: &Model<f32>, tri_offset: usize) -> Self {
        let mut p = Packed::default();
        let (sp, tr) = (&m.particle_springs, &m.particle_tris);
        let off = tri_offset.max(sp.items.len());
        p.tri_offset = off;
        p.particles.extend((0..m.particle_count()).map(|i| pack_particle(m, i, off)));
        p.any_load_limit = p.particles.iter().any(|q| q.load_limit >= 0.0);
        p.adj.extend_from_slice(&sp.items);
        p.adj.resize(off, 0);
        p.adj.extend_from_slice(&tr.items);
        p.spring_ends.extend_from_slice(&m.spring_indices);
        p.springs.extend((0..m.spring_count()).map(|s| pack_spring(m, s)));
        p.any_strain_limit = p.springs.iter().any(|s| s.strain_limit >= 0.0);
        p.tris.extend((0..m.tri_count()).map(|t| pack_tri(m, t)));
        p.pack_bodies(m);
        p.contact = ContactPack::new(m);
        p
    }

    /// Re-packs the bodies, the gas bodies' openings and the caps index: O(bodies + opening loops), plus
    /// O(particles) for the caps index when a gas body has openings.
    pub fn pack_bodies(&mut self, m: &Model<f32>) {
        let p = self;
        p.bodies.clear();
        p.openings.clear();
        p.caps.clear();
        let mut gas_bodies = Vec::new();
        p.bodies.extend((0..m.body_count()).map(|b| {
            let gas = m.body_gas_amount[b];
            let slot = if gas > 0.0 {
                gas_bodies.push(b as u32);
                gas_bodies.len() as u32 - 1
            } else {
                NONE
            };
            GpuBody {
                gas,
                p_ext: m.body_pressure_external[b],
                rest_volume: m.body_rest_volume[b],
                drag: m.body_drag[b],
                lift: m.body_lift[b],
                anchor: m.body_anchor[b],
                gas_slot: slot,
                pad: 0,
            }
        }));
        p.n_gas = gas_bodies.len() as u32;
        // Openings buffer: gas bodies by slot, then a header per capped opening, then the loops' vertices.
        let capped: Vec<_> = m.openings.iter().filter(|o| m.body_gas_amount[o.body as usize] > 0.0).collect();
        p.n_caps = capped.len() as u32;
        p.openings = gas_bodies;
        let mut first = p.openings.len() as u32 + 4 * p.n_caps;
        for o in &capped {
            p.openings.extend_from_slice(&[o.body, first, o.vertices.len() as u32, 0]);
            first += o.vertices.len() as u32;
        }
        for o in &capped {
            p.openings.extend_from_slice(&o.vertices);
        }
        if p.n_caps > 0 {
            let mut per: Vec<Vec<[u32; 2]>> = vec![Vec::new(); m.particle_count()];
            for (k, o) in capped.iter().enumerate() {
                for (at, &v) in o.vertices.iter().enumerate() {
                    per[v as usize].push([k as u32, at as u32]);
                }
            }
            let mut items_all: Vec<u32> = Vec::new();
            for items in &per {
                p.caps.extend_from_slice(&[(items_all.len() / 2) as u32, items.len() as u32]);
                items_all.extend(items.iter().flatten());
            }
            p.caps.extend(items_all);
        }
    }
}

/// The uniform for `m`; `rows` is the number of partial-sum rows of the triangle dispatch.
pub(crate) fn params(m: &Model<f32>, p: &Packed, rows: u32, capacity: u32, pairs: u32, iterations: u32) -> Params {
    let g = m.gravity.to_vec3();
    let projected = if m.damping_model == DampingModel::Projected { 1.0 } else { 0.0 };
    let surface = m.has_pressure() || m.has_wind();
    let (wind_u, wind_p) = match (&m.wind, m.has_wind()) {
        (Some(w), true) => (
            v4(w.velocity.as_vec3(), w.air_density as f32),
            [w.gust_amplitude as f32, w.gust_frequency as f32, w.gust_wavelength as f32, w.crosswind as f32],
        ),
        _ => ([0.0; 4], [0.0; 4]),
    };
    Params {
        gravity: v4(g, projected),
        counts: [m.particle_count() as u32, m.spring_count() as u32, m.tri_count() as u32, m.body_count() as u32],
        counts2: [m.colliders.len() as u32, p.n_gas, p.n_caps, rows],
        wind_u,
        wind_p,
        misc: [capacity, surface as u32, (p.n_caps > 0) as u32, 0],
        contact_f: [p.contact.h_max, p.contact.cell, CONTACT_FIXED, 0.0],
        contact_n: [p.contact.edges.len() as u32, p.contact.buckets() as u32 - 1, pairs, iterations],
    }
}

/// Fixed-point units per m/s of the contact kernels' velocity sums (2^20: a resolution of 1e-6 m/s, a range of
/// ±2,000 m/s).
pub const CONTACT_FIXED: f32 = 1_048_576.0;

/// Colliders packed for the kernels; triangle meshes and other general shapes are baked into `sdf`.
pub(crate) fn pack_colliders(
    colliders: &[Collider],
    cells: u32,
    sdf: &mut Vec<f32>,
) -> Result<Vec<GpuCollider>, GpuError> {
    let mut out = Vec::with_capacity(colliders.len());
    for (index, c) in colliders.iter().enumerate() {
        let mut g = GpuCollider {
            material: [c.restitution, c.restitution_threshold, c.friction, c.margin],
            translation: v4(c.pose.translation, 0.0),
            rotation: c.pose.rotation.to_array(),
            linear_velocity: v4(c.linear_velocity, 0.0),
            angular_velocity: v4(c.angular_velocity, 0.0),
            ..Default::default()
        };
        let s = &c.shape;
        if let Some(h) = s.as_halfspace() {
            g.head[0] = kind::HALF_SPACE;
            g.a = v4(h.normal, 0.0);
        } else if let Some(b) = s.as_ball() {
            g.head[0] = kind::BALL;
            g.a = [b.radius, 0.0, 0.0, 0.0];
        } else if let Some(b) = s.as_cuboid() {
            g.head[0] = kind::CUBOID;
            g.a = v4(b.half_extents, 0.0);
        } else if let Some(b) = s.as_capsule() {
            g.head[0] = kind::CAPSULE;
            g.a = v4(b.segment.a, b.radius);
            g.b = v4(b.segment.b, 0.0);
        } else {
            let grid =
                SdfGrid::bake(s.as_ref(), cells, c.margin).map_err(|message| GpuError::Collider { index, message })?;
            g.head = [kind::GRID, sdf.len() as u32, 0, 0];
            g.a = v4(grid.origin, grid.cell);
            g.b = [grid.dims[0] as f32, grid.dims[1] as f32, grid.dims[2] as f32, 0.0];
            sdf.extend_from_slice(&grid.values);
        }
        out.push(g);
    }
    Ok(out)
}

/// A GPU buffer mirrored on the host: [`Mirror::sync`] writes only the blocks that differ from what was uploaded
/// last (a memory compare on the host, then one write per changed block), and reallocates with 25 % room when the
/// data outgrows the buffer. After a fracture event this uploads a few blocks per array instead of the model.
pub(crate) struct Mirror<T: Pod> {
    pub host: Vec<T>,
    pub buffer: wgpu::Buffer,
    capacity: usize,
    label: &'static str,
    usage: wgpu::BufferUsages,
}

/// Elements compared (and written) at a time.
const BLOCK: usize = 64;

impl<T: Pod> Mirror<T> {
    /// `slack`: room to grow by a quarter (fracture appends) before the first reallocation; without it the
    /// buffer is exact (a 1024² cloth's springs fill 100 of the 128 MiB a binding may hold on many devices).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, label: &'static str, data: &[T], slack: bool) -> Self {
        let usage = RW;
        let capacity = (data.len() + if slack { data.len() / 4 } else { 0 }).max(4);
        let buffer = create(device, label, capacity * size_of::<T>(), usage);
        queue.write_buffer(&buffer, 0, bytemuck::cast_slice(data));
        Mirror { host: data.to_vec(), buffer, capacity, label, usage }
    }

    /// Makes the GPU copy equal `data`. Returns `(reallocated, bytes written)`; a reallocated buffer needs new
    /// bind groups.
    pub fn sync(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[T]) -> (bool, usize) {
        if data.len() > self.capacity {
            self.capacity = data.len() + data.len() / 4;
            self.buffer = create(device, self.label, self.capacity * size_of::<T>(), self.usage);
            queue.write_buffer(&self.buffer, 0, bytemuck::cast_slice(data));
            self.host.clear();
            self.host.extend_from_slice(data);
            return (true, std::mem::size_of_val(data));
        }
        let mut written = 0;
        let mut k = 0;
        while k < data.len() {
            let end = (k + BLOCK).min(data.len());
            let new = bytemuck::cast_slice::<T, u8>(&data[k..end]);
            let same = end <= self.host.len() && bytemuck::cast_slice::<T, u8>(&self.host[k..end]) == new;
            if !same {
                queue.write_buffer(&self.buffer, (k * size_of::<T>()) as u64, new);
                written += new.len();
            }
            k = end;
        }
        self.host.clear();
        self.host.extend_from_slice(data);
        (false, written)
    }
}

impl<T: Pod> Mirror<T> {
    /// Makes the GPU copy equal `data` at the sorted indices `idx` (the rest is unchanged by contract): one write
    /// per run of consecutive indices, no comparison of the rest. Returns `(reallocated, bytes written)`; data that
    /// outgrows the buffer reallocates and writes everything (the caller then rebinds).
    pub fn write_items(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        data: &[T],
        idx: &[u32],
    ) -> (bool, usize) {
        if data.len() > self.capacity {
            return self.sync(device, queue, data);
        }
        self.host.resize(data.len(), T::zeroed());
        let mut written = 0;
        let mut k = 0;
        while k < idx.len() {
            let a = idx[k] as usize;
            let mut b = a + 1;
            k += 1;
            while k < idx.len() && idx[k] as usize == b {
                b += 1;
                k += 1;
            }
            if b > data.len() {
                break;
            }
            self.host[a..b].copy_from_slice(&data[a..b]);
            let bytes = bytemuck::cast_slice::<T, u8>(&data[a..b]);
            queue.write_buffer(&self.buffer, (a * size_of::<T>()) as u64, bytes);
            written += bytes.len();
        }
        (false, written)
    }
}

/// Storage that kernels write and the host may copy to and from.
pub(crate) const RW: wgpu::BufferUsages =
    wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST).union(wgpu::BufferUsages::COPY_SRC);

pub(crate) fn create(device: &wgpu::Device, label: &str, bytes: usize, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        // Bindings may not be empty; 16 bytes is the smallest useful size.
        size: (bytes.max(16) as u64).next_multiple_of(16),
        usage,
        mapped_at_creation: false,
    })
}
