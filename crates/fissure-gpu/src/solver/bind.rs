//! Bind groups: the model and state buffers as group 0 (two, one per state buffer, for ping-pong), the clock of
//! the current substep as group 1; rebuilt when a buffer is reallocated.

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

    #[allow(clippy::too_many_arguments)]
    pub(super) fn binds(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        params: &wgpu::Buffer,
        q: &[wgpu::Buffer; 2],
        qd: &[wgpu::Buffer; 2],
        m: [&wgpu::Buffer; 11],
        s: &Scratch,
        candidates: &wgpu::Buffer,
    ) -> [wgpu::BindGroup; 2] {
        let [particles, rows, adj, springs, tris, bodies, colliders, sdf, openings, spring_ends, caps] = m;
        [0, 1].map(|cur| {
            let other = 1 - cur;
            let list: [(u32, &wgpu::Buffer); 22] = [
                (0, params),
                (1, &q[cur]),
                (2, &qd[cur]),
                (3, &q[other]),
                (4, &qd[other]),
                (5, particles),
                (6, rows),
                (7, adj),
                (8, springs),
                (9, tris),
                (10, &s.tri_cross),
                (11, &s.tri_f),
                (12, bodies),
                (13, &s.body_state),
                (14, &s.partials),
                (15, colliders),
                (16, sdf),
                (17, openings),
                (18, spring_ends),
                (19, caps),
                (20, &s.cap_data),
                (21, candidates),
            ];
            let entries: Vec<_> = list
                .iter()
                .map(|&(binding, b)| wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() })
                .collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(if cur == 0 { "state 0 -> 1" } else { "state 1 -> 0" }),
                layout,
                entries: &entries,
            })
        })
    }

    pub(super) fn rebind(&mut self) {
        self.bind = Self::binds(
            &self.device,
            &self.layout0,
            &self.params,
            &self.q,
            &self.qd,
            [
                &self.particles.buffer,
                &self.rows.buffer,
                &self.adj.buffer,
                &self.springs.buffer,
                &self.tris.buffer,
                &self.bodies.buffer,
                &self.colliders.buffer,
                &self.sdf.buffer,
                &self.openings.buffer,
                &self.spring_ends.buffer,
                &self.caps.buffer,
            ],
            &self.scratch,
            &self.candidates,
        );
    }
}
