//! Creating a device for users who do not bring their own (the solver itself never creates one).

use crate::GpuError;

/// A wgpu device and queue with the adapter they came from.
#[derive(Clone, Debug)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// What the adapter says about itself (name, backend, driver).
    pub info: wgpu::AdapterInfo,
}

impl GpuContext {
    /// A device on the best adapter: a discrete or integrated GPU when there is one, otherwise a software device
    /// (lavapipe). Requests the adapter's own limits (the largest buffers it allows; the kernels themselves need no
    /// more than WebGPU's defaults). The environment variable `WGPU_BACKEND` (e.g. `vulkan`) restricts the
    /// backends tried.
    pub fn new() -> Result<Self, GpuError> {
        pollster::block_on(Self::new_async(None))
    }

    /// As [`GpuContext::new`], with exactly `limits` (for example `wgpu::Limits::default()`, WebGPU's defaults:
    /// what a browser grants without asking, which the kernels are kept within). Fails if the adapter cannot grant
    /// them.
    pub fn with_limits(limits: wgpu::Limits) -> Result<Self, GpuError> {
        pollster::block_on(Self::new_async(Some(limits)))
    }

    async fn new_async(limits: Option<wgpu::Limits>) -> Result<Self, GpuError> {
        let desc = instance_descriptor();
        let backends = desc.backends;
        let instance = wgpu::Instance::new(desc);
        let mut adapters = instance.enumerate_adapters(backends).await;
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter { details: format!("backends tried: {backends:?}") });
        }
        // Real hardware first: discrete, integrated, virtual, then CPU (software) devices.
        let rank = |t: wgpu::DeviceType| match t {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Other => 3,
            wgpu::DeviceType::Cpu => 4,
        };
        adapters.sort_by_key(|a| rank(a.get_info().device_type));
        let adapter = adapters.swap_remove(0);
        let info = adapter.get_info();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("fissure"),
                // Timestamps inside passes where the adapter has them, for `GpuConfig::kernel_timers` (unused,
                // they cost nothing).
                required_features: adapter.features()
                    & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES),
                required_limits: limits.unwrap_or_else(|| adapter.limits()),
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::Device { adapter: info.name.clone(), message: e.to_string() })?;
        Ok(GpuContext { device, queue, info })
    }

    /// `"name (backend, device type)"`, for benchmark output.
    pub fn describe(&self) -> String {
        format!("{} ({:?}, {:?})", self.info.name, self.info.backend, self.info.device_type)
    }
}

/// What tests do without an adapter: with `CI` set (to anything but `false` or `0`) a missing adapter is a
/// failure (CI installs lavapipe, so its absence is a broken CI), elsewhere the caller skips loudly.
pub fn adapter_required() -> bool {
    std::env::var("CI").map(|v| !v.is_empty() && v != "false" && v != "0").unwrap_or(false)
}

/// The instance settings of every device fissure opens (this context's and the viewer's): wgpu's, from the
/// environment (`WGPU_BACKEND`, `WGPU_VALIDATION`, ...), with the primary backends unless `WGPU_BACKEND` names
/// others, and without wgpu's indirect-call validation unless `WGPU_VALIDATION_INDIRECT_CALL` asks for it.
///
/// That validation (on by default, release builds too) runs a small compute pass of wgpu's own before every
/// indirect dispatch. fissure's only indirect dispatches are the contact pass's, over the pairs found in a substep,
/// and `contact_args` (`shaders/contact.wgsl`) writes their arguments within the device's limit (at most 65,535
/// workgroups per dimension), so the check finds nothing; on an H100 it cost ~30 µs of submission per indirect
/// dispatch, 18 of them per contact substep with the default 16 iterations (`benches/RESULTS.md`, issue 16).
pub fn instance_descriptor() -> wgpu::InstanceDescriptor {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    if std::env::var_os("WGPU_BACKEND").is_none() {
        desc.backends = wgpu::Backends::PRIMARY;
    }
    if std::env::var_os("WGPU_VALIDATION_INDIRECT_CALL").is_none() {
        desc.flags.remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
    }
    desc
}
