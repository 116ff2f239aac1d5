//! Launches: `optixLaunch` as `vkCmdTraceRaysKHR`.
//!
//! A launch pushes the params as push constants, binds the bindless buffer table,
//! traces a `width × height × depth` grid with the SBT's regions and waits for it,
//! so buffers read afterwards hold the results. See
//! [`vkCmdTraceRaysKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdTraceRaysKHR.html).

use std::sync::Arc;

use ash::vk;

use crate::buffer_table::RT_STAGES;
use crate::error::{Error, Result};
use crate::pipeline::Pipeline;
use crate::sbt::Sbt;

impl<P: raykit_device::LaunchParams> Pipeline<P> {
    /// Traces a `dims = [width, height, depth]` grid with `params`, using `sbt`,
    /// and waits until it is done.
    pub fn launch(&self, sbt: &Sbt, params: &P, dims: [u32; 3]) -> Result<()> {
        let inner = &self.inner;
        let ctx = &inner.ctx;
        if !Arc::ptr_eq(&sbt.pipeline, inner) {
            return Err(Error::SbtOfAnotherPipeline);
        }
        if dims.contains(&0) {
            return Err(Error::LaunchDimensions { dims, reason: "every dimension must be at least 1".to_owned() });
        }
        // Three u32s can overflow u64 (2^96): an overflowing product is over any limit.
        let invocations = dims.iter().try_fold(1u64, |n, &d| n.checked_mul(d as u64));
        let limit = ctx.limits.max_ray_dispatch_invocation_count as u64;
        if invocations.is_none_or(|n| n > limit) {
            let count = invocations.map_or_else(|| "more than 2^64".to_owned(), |n| n.to_string());
            return Err(Error::LaunchDimensions {
                dims,
                reason: format!("{count} invocations exceed maxRayDispatchInvocationCount {limit}; split the launch into tiles"),
            });
        }
        // vkCmdTraceRaysKHR also bounds each dimension (VUID-vkCmdTraceRaysKHR-width-03638 …
        // depth-03640): maxComputeWorkGroupCount[i] × maxComputeWorkGroupSize[i].
        if let Some(i) = (0..3).find(|&i| dims[i] as u64 > ctx.launch_dimension_limits[i]) {
            return Err(Error::LaunchDimensions {
                dims,
                reason: format!(
                    "{} {} is over this device's limit of {} (maxComputeWorkGroupCount[{i}] × maxComputeWorkGroupSize[{i}]); split the launch into tiles",
                    ["width", "height", "depth"][i],
                    dims[i],
                    ctx.launch_dimension_limits[i],
                ),
            });
        }
        let device = &ctx.device;
        let params_bytes = bytemuck::bytes_of(params);
        // Large params go through the pipeline's uniform buffer; the lock is held
        // until the launch is done, so concurrent launches cannot overwrite it.
        let mut uniform_guard = match &inner.params_uniform {
            Some(uniform) => {
                let mut guard = uniform.buffer.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                if let Some(buffer) = guard.as_mut() {
                    buffer.write_bytes(params_bytes)?;
                }
                Some((guard, uniform.set))
            }
            None => None,
        };
        let params_set = uniform_guard.as_ref().map(|(_, set)| *set);
        // User exceptions: the counter is zeroed now and read after the launch;
        // the lock keeps concurrent launches of this pipeline apart.
        let mut exceptions = inner.exceptions.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        exceptions.reset()?;
        let result = ctx.submit_and_wait("a launch", |cmd| {
            // SAFETY: the pipeline, layout, descriptor set and SBT buffer are alive
            // for the whole submission (held by `self` and `sbt`, and waited on).
            unsafe {
                device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::RAY_TRACING_KHR, inner.pipeline);
                device.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::RAY_TRACING_KHR,
                    inner.layout,
                    0,
                    &[ctx.buffer_table.set],
                    &[],
                );
                if let Some(set) = params_set {
                    device.cmd_bind_descriptor_sets(
                        cmd,
                        vk::PipelineBindPoint::RAY_TRACING_KHR,
                        inner.layout,
                        raykit_device::PARAMS_SET,
                        &[set],
                        &[],
                    );
                }
                if inner.push_constant_size > 0 {
                    device.cmd_push_constants(cmd, inner.layout, RT_STAGES, 0, params_bytes);
                }
                ctx.rt.cmd_trace_rays(cmd, &sbt.raygen, &sbt.miss, &sbt.hit, &sbt.callable, dims[0], dims[1], dims[2]);
                // Make the programs' writes visible to the host once the fence signals.
                let barrier = vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                    .dst_access_mask(vk::AccessFlags::HOST_READ);
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &[barrier],
                    &[],
                    &[],
                );
            }
        });
        uniform_guard.take();
        result?;
        let (total, thrown) = exceptions.read();
        if total > 0 {
            return Err(Error::UserExceptions { total, exceptions: thrown });
        }
        Ok(())
    }
}
