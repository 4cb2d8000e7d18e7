//! Read-backs as futures. wgpu reports a buffer mapping through a callback; [`map_read`] turns it into a future.
//! Off the web the device is polled until the work is done before the future is first polled, so it is ready at
//! once and [`now`] gives the synchronous methods their result; in a browser the mapping completes only once
//! control is back in the event loop, and the future is awaited (a synchronous method there returns an error
//! naming the async one instead of blocking the browser's only thread).

use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Waker};

use crate::GpuError;

/// Where a buffer mapping's callback leaves its result and finds the waker of the future awaiting it.
#[derive(Default)]
struct MapSlot {
    result: Option<Result<(), wgpu::BufferAsyncError>>,
    waker: Option<Waker>,
}

/// The future of a buffer mapping (wgpu reports it through a callback).
struct Mapped(Arc<Mutex<MapSlot>>);

impl std::future::Future for Mapped {
    type Output = Result<(), wgpu::BufferAsyncError>;

    fn poll(self: std::pin::Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        let mut s = self.0.lock().unwrap_or_else(|e| e.into_inner());
        match s.result.take() {
            Some(r) => Poll::Ready(r),
            None => {
                s.waker = Some(cx.waker().clone());
                Poll::Pending
            }
        }
    }
}

/// The result of a read-back future, which off the web is ready at its first poll (the device was waited on;
/// [`fissure_core::ready_now`]); on the web an error naming the async methods instead of blocking the browser's
/// only thread.
pub(crate) fn now<T, E: From<GpuError>>(f: impl std::future::Future<Output = Result<T, E>>) -> Result<T, E> {
    fissure_core::ready_now(f).unwrap_or_else(|| {
        Err(GpuError::Readback(
            "a read-back cannot be waited for here (WebGPU in a browser): use the async methods (run_async, read_state_async, World::advance_async)".into(),
        )
        .into())
    })
}

/// Maps the first `bytes` of `buffer` (`MAP_READ`, after the submission that fills it) and returns the mapped
/// view; the caller copies what it needs and unmaps.
pub(crate) async fn map_read(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
    bytes: u64,
) -> Result<wgpu::BufferView, GpuError> {
    let slot = Arc::new(Mutex::new(MapSlot::default()));
    let done = slot.clone();
    buffer.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
        let mut s = done.lock().unwrap_or_else(|e| e.into_inner());
        s.result = Some(r);
        if let Some(w) = s.waker.take() {
            w.wake();
        }
    });
    #[cfg(not(target_arch = "wasm32"))]
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Readback(e.to_string()))?;
    #[cfg(target_arch = "wasm32")]
    let _ = device;
    Mapped(slot).await.map_err(|e| GpuError::Readback(e.to_string()))?;
    buffer.get_mapped_range(0..bytes).map_err(|e| GpuError::Readback(e.to_string()))
}
