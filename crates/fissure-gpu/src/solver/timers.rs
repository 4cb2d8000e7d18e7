//! The kernel timers ([`GpuConfig::kernel_timers`]): a timestamp after each dispatch of a submission, read back
//! after it, each kernel's device time summed per kernel and added to its stage in the stage timers.

use super::*;
use std::time::Duration;

/// Timestamps a submission may write with [`GpuConfig::kernel_timers`]: wgpu's largest query set.
pub const KERNEL_TIMESTAMPS: u32 = wgpu::QUERY_SET_MAX_QUERIES;

/// The query set, the submission's timestamps and what they have summed.
pub(super) struct Profile {
    set: wgpu::QuerySet,
    pub(super) resolve: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period: f64,
    /// Timestamps are being written (inside a submission's pass).
    on: bool,
    /// The kernel of each timestamp after the first, this submission.
    pub(super) stamps: Vec<usize>,
    /// Per kernel (in [`KERNEL_BINDINGS`] order): time and dispatches timed.
    sums: Vec<(Duration, u64)>,
}

impl Profile {
    /// The query set and its resolve buffer; an error when the device has no timestamps inside passes.
    pub(super) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Self, GpuError> {
        let need = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES;
        if !device.features().contains(need) {
            return Err(GpuError::NoKernelTimers);
        }
        let set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel timers"),
            ty: wgpu::QueryType::Timestamp,
            count: KERNEL_TIMESTAMPS,
        });
        let usage = wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC;
        let resolve = layout::create(device, "kernel timestamps", KERNEL_TIMESTAMPS as usize * 8, usage);
        let sums = vec![(Duration::ZERO, 0); KERNEL_BINDINGS.len()];
        let period = queue.get_timestamp_period() as f64;
        Ok(Profile { set, resolve, period, on: false, stamps: Vec::new(), sums })
    }

    /// At the start of a submission's pass: the first timestamp, before its first kernel.
    pub(super) fn begin(&mut self, pass: &mut wgpu::ComputePass<'_>) {
        self.on = true;
        self.stamps.clear();
        pass.write_timestamp(&self.set, 0);
    }

    /// A timestamp after kernel `k`'s dispatch, while the submission has room.
    fn stamp(&mut self, pass: &mut wgpu::ComputePass<'_>, k: usize) {
        if self.on && self.stamps.len() + 1 < KERNEL_TIMESTAMPS as usize {
            self.stamps.push(k);
            pass.write_timestamp(&self.set, self.stamps.len() as u32);
        }
    }

    /// After the pass: the timestamps resolved into [`Profile::resolve`] for the read-back.
    pub(super) fn end(&mut self, enc: &mut wgpu::CommandEncoder) {
        self.on = false;
        enc.resolve_query_set(&self.set, 0..self.stamps.len() as u32 + 1, &self.resolve, 0);
    }

    /// Adds a submission's timestamps (ticks; the first before its first kernel) to the sums and to `timers`.
    pub(super) fn take(&mut self, ticks: &[u64], timers: &mut StageTimers) {
        for (w, &k) in ticks.windows(2).zip(&self.stamps) {
            let d = Duration::from_nanos((w[1].saturating_sub(w[0]) as f64 * self.period) as u64);
            self.sums[k].0 += d;
            self.sums[k].1 += 1;
            timers.add_time(stage_of(KERNEL_BINDINGS[k].0), d);
        }
    }
}

/// The stage a kernel's time counts under: the integrators, the force gather and the finite check under
/// `integrate`, the surface kernels under `surface`, `collide`, the contact kernels under `contact`, the strain
/// and load checks under `fracture`.
fn stage_of(kernel: &str) -> Stage {
    match kernel {
        "collide" => Stage::Collide,
        "strain_check" | "load_check" => Stage::Fracture,
        _ if kernel.starts_with("contact") => Stage::Contact,
        _ if kernel.starts_with("surface") || kernel == "cap_force" => Stage::Surface,
        _ => Stage::Integrate,
    }
}

impl GpuSolver {
    /// With the kernel timers on, a timestamp after kernel `k`'s dispatch.
    pub(super) fn stamp(&mut self, pass: &mut wgpu::ComputePass<'_>, k: usize) {
        if let Some(p) = &mut self.profile {
            p.stamp(pass, k);
        }
    }

    /// The kernel timers' sums: each kernel timed, its device time and dispatches, in [`KERNEL_BINDINGS`] order
    /// (empty without [`GpuConfig::kernel_timers`]). Reset with the stage timers.
    pub fn kernel_times(&self) -> Vec<(&'static str, Duration, u64)> {
        let Some(p) = &self.profile else { return Vec::new() };
        KERNEL_BINDINGS
            .iter()
            .zip(&p.sums)
            .filter(|(_, (_, calls))| *calls > 0)
            .map(|((name, _), &(t, calls))| (*name, t, calls))
            .collect()
    }

    pub(super) fn reset_kernel_times(&mut self) {
        if let Some(p) = &mut self.profile {
            p.sums.iter_mut().for_each(|s| *s = Default::default());
        }
    }
}
