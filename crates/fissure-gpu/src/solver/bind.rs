//! Bind groups: per kernel, the model and state buffers it uses as group 0 (two, one per state buffer, for
//! ping-pong), the clock of the current substep as group 1; rebuilt when a buffer is reallocated.

use super::*;

impl GpuSolver {
    pub(super) fn clock_buffer(device: &wgpu::Device, entries: usize) -> wgpu::Buffer {
        layout::create(
            device,
            "clock",
            entries * CLOCK_STRIDE as usize,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        )
    }

    pub(super) fn clock_bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        clock: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("clock"),
            layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: clock,
                    offset: 0,
                    size: wgpu::BufferSize::new(size_of::<Clock>() as u64),
                }),
            }],
        })
    }

    /// The buffer at `binding` of group 0 (`common.wgsl`) for a kernel reading state `cur`.
    fn binding(&self, binding: u32, cur: usize) -> &wgpu::Buffer {
        let s = &self.scratch;
        match binding {
            0 => &self.params,
            1 => &self.state[cur],
            2 => &self.state[1 - cur],
            3 => &self.particles.buffer,
            4 => &self.adj.buffer,
            5 => &self.springs.buffer,
            6 => &self.spring_ends.buffer,
            7 => &self.tris.buffer,
            8 => &s.tri_cross,
            9 => &s.tri_f,
            10 => &self.bodies.buffer,
            11 => &s.body_state,
            12 => &s.partials,
            13 => &self.colliders.buffer,
            14 => &self.sdf.buffer,
            15 => &self.openings.buffer,
            16 => &self.caps.buffer,
            17 => &s.cap_data,
            18 => &s.cap_f,
            19 => &self.candidates,
            20 => &self.c_part.buffer,
            21 => &self.c_body.buffer,
            22 => &self.c_edges.buffer,
            23 => &s.c_x0,
            24 | 29 | 30 => &s.c_grid,
            25 => &s.c_pairs,
            26 => &s.c_ctl,
            27 => &s.c_acc,
            28 => &s.c_args,
            _ => unreachable!("common.wgsl has no binding {binding}"),
        }
    }

    /// Makes every kernel's two bind groups (one per state buffer it reads) anew: at creation and after a buffer
    /// was reallocated.
    pub(super) fn rebind(&mut self) {
        let bind = KERNEL_BINDINGS
            .iter()
            .zip(&self.kernels.layouts)
            .map(|((name, bindings), layout)| {
                [0, 1].map(|cur| {
                    let entries: Vec<_> = std::iter::once(&0)
                        .chain(bindings.iter())
                        .map(|&b| wgpu::BindGroupEntry {
                            binding: b,
                            resource: self.binding(b, cur).as_entire_binding(),
                        })
                        .collect();
                    self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some(name),
                        layout,
                        entries: &entries,
                    })
                })
            })
            .collect();
        self.bind = bind;
    }
}
