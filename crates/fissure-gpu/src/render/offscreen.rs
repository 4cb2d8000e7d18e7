//! Offscreen targets (multisampled colour and depth, resolved and read back) and the read-back shared with
//! window screenshots.

use super::*;

/// An offscreen target: multisampled colour and depth, a resolve texture, and a read-back buffer.
pub struct Offscreen {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) color: wgpu::TextureView,
    pub(super) resolve: wgpu::Texture,
    pub(super) resolve_view: wgpu::TextureView,
    pub(super) depth: wgpu::TextureView,
    pub(super) readback: Readback,
    /// Samples per pixel of `color` and `depth` (remade to match the renderer's when they differ).
    pub(super) samples: u32,
}

impl Offscreen {
    /// The colour format of offscreen targets (create the [`Renderer`] with it).
    pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

    /// A `width × height` target.
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Offscreen {
        let (width, height) = (width.max(1), height.max(1));
        let (color, depth) = targets(device, Self::FORMAT, width, height, SAMPLES);
        let resolve = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("offscreen"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: Self::FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let readback = Readback::new(device, width, height);
        let resolve_view = resolve.create_view(&Default::default());
        Offscreen { width, height, color, resolve, resolve_view, depth, readback, samples: SAMPLES }
    }

    /// Size in pixels.
    pub fn size(&self) -> [u32; 2] {
        [self.width, self.height]
    }

    /// Draws a frame and reads it back (in a browser use [`Offscreen::render_async`]).
    pub fn render(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        renderer: &mut Renderer,
        camera: &Camera,
        view: &View,
        positions: Positions<'_>,
    ) -> Result<Image, GpuError> {
        crate::mapping::now(self.render_async(device, queue, renderer, camera, view, positions))
    }

    /// [`Offscreen::render`], awaiting the read-back (what a browser needs).
    pub async fn render_async(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        renderer: &mut Renderer,
        camera: &Camera,
        view: &View,
        positions: Positions<'_>,
    ) -> Result<Image, GpuError> {
        if renderer.samples() != self.samples {
            self.samples = renderer.samples();
            (self.color, self.depth) = targets(device, Self::FORMAT, self.width, self.height, self.samples);
        }
        let mut enc = device.create_command_encoder(&Default::default());
        renderer.encode(&mut enc, &self.color, &self.resolve_view, &self.depth, self.size(), camera, view, positions);
        self.readback.encode_copy(&mut enc, &self.resolve);
        queue.submit([enc.finish()]);
        self.readback.read_async(device, Self::FORMAT).await
    }
}

/// A mappable buffer that a texture of a given size is copied into, rows padded to wgpu's 256-byte alignment:
/// the read-back of [`Offscreen`] frames and of a window's surface (screenshots).
pub struct Readback {
    pub(super) buffer: wgpu::Buffer,
    pub(super) row_bytes: u32,
    pub(super) size: [u32; 2],
}

impl Readback {
    /// For RGBA8 or BGRA8 textures of `width × height`.
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Readback {
        let row_bytes = (4 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: (row_bytes * height) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Readback { buffer, row_bytes, size: [width, height] }
    }

    /// Records the copy of `texture` (of this size, with `COPY_SRC` usage) into the buffer.
    pub fn encode_copy(&self, enc: &mut wgpu::CommandEncoder, texture: &wgpu::Texture) {
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.row_bytes),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d { width: self.size[0], height: self.size[1], depth_or_array_layers: 1 },
        );
    }

    /// Waits for the submitted copy and returns it as RGBA (`format` says whether the texture was BGRA). In a
    /// browser use [`Readback::read_async`].
    pub fn read(&self, device: &wgpu::Device, format: wgpu::TextureFormat) -> Result<Image, GpuError> {
        crate::mapping::now(self.read_async(device, format))
    }

    /// [`Readback::read`], awaiting the mapping (what a browser needs).
    pub async fn read_async(&self, device: &wgpu::Device, format: wgpu::TextureFormat) -> Result<Image, GpuError> {
        let bgra = matches!(format, wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb);
        let [width, height] = self.size;
        let mut rgba = Vec::with_capacity((4 * width * height) as usize);
        {
            let data = crate::mapping::map_read(device, &self.buffer, self.buffer.size()).await?;
            for row in data.chunks_exact(self.row_bytes as usize) {
                let row = &row[..(4 * width) as usize];
                if bgra {
                    rgba.extend(row.chunks_exact(4).flat_map(|p| [p[2], p[1], p[0], p[3]]));
                } else {
                    rgba.extend_from_slice(row);
                }
            }
        }
        self.buffer.unmap();
        Ok(Image { width, height, rgba })
    }
}

/// A colour texture of `format` with `samples` per pixel and a matching depth texture, `width × height` (for a
/// window's surface: resolve into the surface texture; with one sample the colour texture is not drawn into,
/// see [`crate::render::Renderer::encode`]).
pub fn targets(
    device: &wgpu::Device,
    format: wgpu::TextureFormat,
    width: u32,
    height: u32,
    samples: u32,
) -> (wgpu::TextureView, wgpu::TextureView) {
    let make = |label, format| {
        device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: width.max(1), height: height.max(1), depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default())
    };
    (make("msaa colour", format), make("depth", DEPTH))
}
