//! GPU timestamps on Vulkan: the two-query timestamp pool of a
//! [`LaunchTimer`](crate::LaunchTimer), and the queue's timestamp support (see
//! [`LaunchTimer`](crate::LaunchTimer)).

use std::sync::Arc;

use ash::vk;

use crate::error::{Error, Result};
use crate::vulkan::context::ContextInner;

/// A timestamp query pool of two queries: written before and after a trace.
pub(crate) struct TimestampPool {
    pub(crate) ctx: Arc<ContextInner>,
    pub(crate) pool: vk::QueryPool,
}

impl TimestampPool {
    /// A pool of two timestamp queries on `inner`'s device.
    pub(crate) fn new(inner: &Arc<ContextInner>) -> Result<TimestampPool> {
        let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(2);
        // SAFETY: valid create info on a live device.
        let pool = unsafe { inner.device.create_query_pool(&info, None) }.map_err(Error::vk("vkCreateQueryPool"))?;
        Ok(TimestampPool { ctx: inner.clone(), pool })
    }

    /// The two timestamps, in ticks, once a launch that wrote them was waited for.
    pub(crate) fn ticks(&self) -> Result<[u64; 2]> {
        let mut ticks = [0u64; 2];
        // SAFETY: both queries were written by the launch just waited for.
        unsafe {
            self.ctx.device.get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(self.ctx.shared.error("vkGetQueryPoolResults", "a timed launch"))?;
        Ok(ticks)
    }
}

impl Drop for TimestampPool {
    fn drop(&mut self) {
        // Destroyed once the launches writing it have finished.
        self.ctx.retire(crate::vulkan::timeline::Retired::QueryPool(self.pool));
    }
}

/// The queue's timestamp period (ns) and valid bits, if it has timestamps.
pub(crate) fn timestamp_support(inner: &ContextInner) -> Option<(f64, u32)> {
    let shared = &inner.shared;
    // SAFETY: the physical device belongs to the context's live instance.
    let families = unsafe { shared.instance.instance.get_physical_device_queue_family_properties(shared.physical) };
    let family = families.get(shared.queue_family as usize)?;
    let period = shared.properties.limits.timestamp_period as f64;
    if family.timestamp_valid_bits == 0 || period <= 0.0 {
        return None;
    }
    Some((period, family.timestamp_valid_bits))
}
