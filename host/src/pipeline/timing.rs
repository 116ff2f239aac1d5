//! GPU-timed launches, for benchmarks: [`LaunchTimer`] holds a timestamp query
//! pool, and [`Pipeline::launch_timed`] launches as [`Pipeline::launch`] does,
//! with timestamps written right before and after `vkCmdTraceRaysKHR`, and
//! returns the GPU time between them. See
//! [`vkCmdWriteTimestamp`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdWriteTimestamp.html)
//! and [timestamp queries](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#queries-timestamps).

use std::sync::Arc;
use std::time::Duration;

use super::Pipeline;
use crate::backend::{refused_on_cpu, CpuRefusal};
use crate::context::{Context, ContextRepr};
use crate::error::DeviceError;
use crate::error::{Error, Result};
use crate::sbt::Sbt;
use crate::vulkan::pipeline::timing::TimestampPool;

/// A timestamp query pool of two queries, and how to turn ticks into time.
pub struct LaunchTimer {
    pool: TimestampPool,
    period_ns: f64,
    valid_bits: u32,
}

impl LaunchTimer {
    /// A timer for launches on `ctx`; `None` when its queue has no timestamps
    /// (`timestampValidBits == 0` or a zero `timestampPeriod`).
    pub fn new(ctx: &Context) -> Result<Option<LaunchTimer>> {
        let inner = match ctx.repr() {
            ContextRepr::Vulkan(inner) => inner,
            ContextRepr::Cpu(_) => return Err(refused_on_cpu(CpuRefusal::VulkanOnly("GPU timestamps"))),
        };
        let Some((period_ns, valid_bits)) = crate::vulkan::pipeline::timing::timestamp_support(inner) else {
            return Ok(None);
        };
        let pool = TimestampPool::new(inner)?;
        Ok(Some(LaunchTimer { pool, period_ns, valid_bits }))
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

impl<P: raykit_device::LaunchParams> Pipeline<P> {
    /// [`Pipeline::launch`] with GPU timestamps around the trace: returns the GPU
    /// time of `vkCmdTraceRaysKHR` alone (without binding, submission and wait).
    pub fn launch_timed(&self, sbt: &Sbt, params: &P, dims: [u32; 3], timer: &LaunchTimer) -> Result<Duration> {
        if self.vulkan_inner().is_none_or(|inner| !Arc::ptr_eq(&timer.pool.ctx, &inner.ctx)) {
            return Err(Error::Device(DeviceError::ContextMismatch));
        }
        self.launch_recording(sbt, params, dims, Some(&timer.pool))?;
        let ticks = timer.pool.ticks()?;
        let mask = if timer.valid_bits >= 64 { u64::MAX } else { (1u64 << timer.valid_bits) - 1 };
        let elapsed = ticks[1].wrapping_sub(ticks[0]) & mask;
        Ok(Duration::from_nanos((elapsed as f64 * timer.period_ns) as u64))
    }
}
