//! An owned `VkPipeline`: a ray-tracing pipeline or pipeline library, created
//! through the context's pipeline cache and destroyed when dropped. See
//! [`vkCreateRayTracingPipelinesKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCreateRayTracingPipelinesKHR.html).

use std::sync::Arc;

use ash::vk;

use crate::error::{Error, Result};
use crate::log::ValidationMessage;
use crate::vulkan::context::ContextInner;

/// A created ray-tracing pipeline (or library), with what the validation layer
/// reported while it was created.
pub(crate) struct PipelineHandle {
    ctx: Arc<ContextInner>,
    pub(crate) handle: vk::Pipeline,
    pub(crate) log: Vec<ValidationMessage>,
}

impl PipelineHandle {
    /// Creates one ray-tracing pipeline (or library) from `create_info` through the
    /// context's pipeline cache, and names it `name`.
    pub(crate) fn create(
        ctx: &Arc<ContextInner>,
        create_info: &vk::RayTracingPipelineCreateInfoKHR<'_>,
        name: &str,
    ) -> Result<PipelineHandle> {
        ctx.check_device("a pipeline creation")?;
        let (pipelines, log) = crate::log::capture(|| {
            let _creating = crate::vulkan::driver_lock::shared();
            // SAFETY: the callers' create infos are valid: every stage's module is
            // alive, libraries are live pipeline libraries of this device, and the
            // recursion depth was checked against the device limit.
            unsafe {
                ctx.rt.create_ray_tracing_pipelines(
                    vk::DeferredOperationKHR::null(),
                    ctx.pipeline_cache.handle,
                    std::slice::from_ref(create_info),
                    None,
                )
            }
        });
        match pipelines {
            Ok(p) => {
                let pipeline = PipelineHandle { ctx: ctx.clone(), handle: p[0], log };
                ctx.set_name(pipeline.handle, name);
                Ok(pipeline)
            }
            Err((p, e)) => {
                for pipeline in p.into_iter().filter(|p| *p != vk::Pipeline::null()) {
                    let _exclusive = crate::vulkan::driver_lock::exclusive();
                    // SAFETY: never used.
                    unsafe { ctx.device.destroy_pipeline(pipeline, None) };
                }
                Err(Error::vk("vkCreateRayTracingPipelinesKHR")(e))
            }
        }
    }
}

impl Drop for PipelineHandle {
    fn drop(&mut self) {
        // Pipelines linked from a library hold an `Arc` of it; launches in flight
        // may still use it: the timeline destroys it once they have finished.
        self.ctx.retire(crate::vulkan::timeline::Retired::Pipeline(self.handle));
    }
}
