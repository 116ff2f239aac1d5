//! GPU-timed launches, for benchmarks: [`LaunchTimer`] holds a timestamp query
//! pool, and [`Pipeline::launch_timed`] launches as [`Pipeline::launch`] does,
//! with timestamps written right before and after `vkCmdTraceRaysKHR`, and
//! returns the GPU time between them. See
//! [`vkCmdWriteTimestamp`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdWriteTimestamp.html)
//! and [timestamp queries](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#queries-timestamps).

use std::sync::Arc;
use std::time::Duration;

use ash::vk;

use super::Pipeline;
use crate::context::{Context, ContextInner};
use crate::error::{Error, Result};
use crate::sbt::Sbt;

/// A timestamp query pool of two queries, and how to turn ticks into time.
pub struct LaunchTimer {
    ctx: Arc<ContextInner>,
    pool: vk::QueryPool,
    period_ns: f64,
    valid_bits: u32,
}

impl LaunchTimer {
    /// A timer for launches on `ctx`; `None` when its queue has no timestamps
    /// (`timestampValidBits == 0` or a zero `timestampPeriod`).
    pub fn new(ctx: &Context) -> Result<Option<LaunchTimer>> {
        let inner = ctx.vulkan("GPU timestamps")?;
        let Some((period_ns, valid_bits)) = timestamp_support(ctx) else {
            return Ok(None);
        };
        let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(2);
        // SAFETY: valid create info on a live device.
        let pool = unsafe { inner.device.create_query_pool(&info, None) }.map_err(Error::vk("vkCreateQueryPool"))?;
        Ok(Some(LaunchTimer { ctx: inner.clone(), pool, period_ns, valid_bits }))
    }

    /// Nanoseconds per timestamp tick.
    pub fn period_ns(&self) -> f64 {
        self.period_ns
    }
}

impl std::fmt::Debug for LaunchTimer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LaunchTimer")
            .field("period_ns", &self.period_ns)
            .field("valid_bits", &self.valid_bits)
            .finish_non_exhaustive()
    }
}

impl Drop for LaunchTimer {
    fn drop(&mut self) {
        // Destroyed once the launches writing it have finished.
        self.ctx.retire(crate::vulkan::timeline::Retired::QueryPool(self.pool));
    }
}

/// The queue's timestamp period (ns) and valid bits, if it has timestamps.
fn timestamp_support(ctx: &Context) -> Option<(f64, u32)> {
    let shared = &ctx.as_vulkan()?.shared;
    // SAFETY: the physical device belongs to the context's live instance.
    let families = unsafe { shared.instance.instance.get_physical_device_queue_family_properties(shared.physical) };
    let family = families.get(shared.queue_family as usize)?;
    let period = shared.properties.limits.timestamp_period as f64;
    if family.timestamp_valid_bits == 0 || period <= 0.0 {
        return None;
    }
    Some((period, family.timestamp_valid_bits))
}

impl<P: raykit_device::LaunchParams> Pipeline<P> {
    /// [`Pipeline::launch`] with GPU timestamps around the trace: returns the GPU
    /// time of `vkCmdTraceRaysKHR` alone (without binding, submission and wait).
    pub fn launch_timed(&self, sbt: &Sbt, params: &P, dims: [u32; 3], timer: &LaunchTimer) -> Result<Duration> {
        if self.vulkan_inner().is_none_or(|inner| !Arc::ptr_eq(&timer.ctx, &inner.ctx)) {
            return Err(Error::ContextMismatch);
        }
        self.launch_recording(sbt, params, dims, Some(timer.pool))?;
        let mut ticks = [0u64; 2];
        // SAFETY: both queries were written by the launch just waited for.
        unsafe {
            timer.ctx.device.get_query_pool_results(
                timer.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(timer.ctx.shared.error("vkGetQueryPoolResults", "a timed launch"))?;
        let mask = if timer.valid_bits >= 64 { u64::MAX } else { (1u64 << timer.valid_bits) - 1 };
        let elapsed = ticks[1].wrapping_sub(ticks[0]) & mask;
        Ok(Duration::from_nanos((elapsed as f64 * timer.period_ns) as u64))
    }
}
