//! The renderer's growable GPU buffers.

/// A buffer that grows (by a quarter more than asked) and is otherwise reused.
pub(super) struct Sized {
    pub(super) buffer: wgpu::Buffer,
    usage: wgpu::BufferUsages,
    label: &'static str,
}

impl Sized {
    pub(super) fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages) -> Self {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        Sized { buffer: Self::make(device, label, usage, 256), usage, label }
    }

    fn make(device: &wgpu::Device, label: &str, usage: wgpu::BufferUsages, bytes: u64) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16).next_multiple_of(16),
            usage,
            mapped_at_creation: false,
        })
    }

    pub(super) fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[u8]) {
        if data.len() as u64 > self.buffer.size() {
            self.buffer = Self::make(device, self.label, self.usage, (data.len() + data.len() / 4) as u64);
        }
        if !data.is_empty() {
            // write_buffer needs a multiple of 4 bytes; every array here is of 4-byte elements.
            queue.write_buffer(&self.buffer, 0, data);
        }
    }
}
