//! The buffers whose sizes follow the model (everything but the state and the mirrored model arrays): the
//! surface pass's per-triangle and per-body scratch, the caps', and the contact pass's grids, pairs and
//! per-particle accumulators. Reallocated, with a quarter's room, when a fracture outgrows them.

use super::*;

/// Buffers that depend on the model's size (everything but the state and the mirrors).
pub(super) struct Scratch {
    pub(super) tri_cross: wgpu::Buffer,
    pub(super) tri_f: wgpu::Buffer,
    pub(super) body_state: wgpu::Buffer,
    pub(super) partials: wgpu::Buffer,
    pub(super) cap_data: wgpu::Buffer,
    pub(super) cap_f: wgpu::Buffer,
    pub(super) c_x0: wgpu::Buffer,
    pub(super) c_grid: wgpu::Buffer,
    pub(super) c_pairs: wgpu::Buffer,
    pub(super) c_ctl: wgpu::Buffer,
    pub(super) c_acc: wgpu::Buffer,
    pub(super) c_args: wgpu::Buffer,
    /// (triangles, bodies, partial floats, openings, particles with cap forces, particles in a contact model, grid
    /// words, contact pairs) they hold.
    pub(super) sized: [usize; SCRATCH],
}

/// Bytes of a contact pair (`Pair` in WGSL).
pub(super) const PAIR_BYTES: usize = 80;

/// Entries of [`Scratch::sized`].
pub(super) const SCRATCH: usize = 8;

/// Entries the scratch buffers need: triangles (with a surface pass), bodies, volume partials, capped openings,
/// particles (with caps), particles (with contact), contact grid words, contact pairs (`capacity`, 0: automatic).
pub(super) fn scratch_sizes(m: &Model<f32>, p: &Packed, capacity: u32) -> [usize; SCRATCH] {
    let surface = m.has_pressure() || m.has_wind();
    let nt = if surface { m.tri_count() } else { 0 };
    let (gx, gy) = groups(m.tri_count());
    let np = if p.n_gas > 0 { (gx * gy * p.n_gas) as usize } else { 0 };
    let caps = p.n_caps as usize;
    let c = &p.contact;
    let (n, grid, pairs) = if c.on() {
        let pairs = if capacity > 0 { capacity as usize } else { 4 * c.particles + 1024 };
        (m.particle_count(), c.grid_items_at() + m.particle_count() + c.edges.len(), pairs)
    } else {
        (0, 0, 0)
    };
    [nt, m.body_count(), np, caps, if caps > 0 { m.particle_count() } else { 0 }, n, grid, pairs]
}

pub(super) fn scratch(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    m: &Model<f32>,
    p: &Packed,
    capacity: u32,
) -> Scratch {
    let mut sized = scratch_sizes(m, p, capacity).map(|n| n + n / 4);
    if capacity > 0 {
        // A capacity the user set is exact.
        sized[7] = capacity as usize;
    }
    // Every particle's contact words start empty: no velocity change, no bound (+inf), in no pair.
    let acc: Vec<i32> = (0..sized[5]).flat_map(|_| [0, 0, 0, 0, 0, 0, 0x7f80_0000, 0]).collect();
    let rw = layout::RW;
    let c_acc = layout::create(device, "c_acc", sized[5] * 32, rw);
    queue.write_buffer(&c_acc, 0, bytemuck::cast_slice(&acc));
    // The counters, then each body's box (empty: minima u32::MAX, maxima 0; `contact_args` empties them after
    // every substep).
    let boxes = if p.contact.on() { sized[1] } else { 0 };
    let ctl: Vec<u32> =
        [0; 8].into_iter().chain((0..boxes).flat_map(|_| [u32::MAX, u32::MAX, u32::MAX, 0, 0, 0])).collect();
    let c_ctl = layout::create(device, "c_ctl", ctl.len() * 4, rw);
    queue.write_buffer(&c_ctl, 0, bytemuck::cast_slice(&ctl));
    Scratch {
        tri_cross: layout::create(device, "tri_cross", sized[0] * 16, rw),
        tri_f: layout::create(device, "tri_f", sized[0] * 16, rw),
        body_state: layout::create(device, "body_state", sized[1] * 16, rw),
        partials: layout::create(device, "partials", sized[2] * 4, rw),
        cap_data: layout::create(device, "cap_data", sized[3] * 32, rw),
        cap_f: layout::create(device, "cap_f", sized[4] * 16, rw),
        c_x0: layout::create(device, "c_x0", sized[5] * 16, rw),
        // The grid counts start at zero: a new buffer is zeroed.
        c_grid: layout::create(device, "c_grid", sized[6] * 4, rw),
        c_pairs: layout::create(device, "c_pairs", sized[7] * PAIR_BYTES, rw),
        c_ctl,
        c_acc,
        c_args: layout::create(device, "c_args", 16, rw | wgpu::BufferUsages::INDIRECT),
        sized,
    }
}
