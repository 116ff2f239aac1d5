//! Launches: `optixLaunch` as `vkCmdTraceRaysKHR`, blocking or asynchronous.
//!
//! A launch pushes the params as push constants (or writes them into the
//! pipeline's uniform buffer from its own command buffer), binds the bindless
//! buffer table, sets the pipeline's stack size
//! (`vkCmdSetRayTracingPipelineStackSizeKHR`, see [`crate::stack`]) and traces a
//! `width × height × depth` grid with the SBT's regions. See
//! [`vkCmdTraceRaysKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdTraceRaysKHR.html).
//!
//! [`Pipeline::launch_async`] submits the work and returns a [`Launch`] at once,
//! like OptiX's launch on a CUDA stream: the work runs in the background, and the
//! handle (its epoch on the GPU timeline) is polled with [`Launch::is_done`] or waited on with
//! [`Launch::wait`]. [`Pipeline::launch`] is the simple path: submit, then wait.
//!
//! # Several launches in flight
//! Nothing a launch needs is shared on the host with another launch in flight (on
//! Vulkan, `vulkan::pipeline::record` states how its command buffers keep that).
//!
//! So no lock is held between submission and completion, and any thread may launch
//! while launches of the same pipeline are in flight. A [`Launch`] holds `Arc`s of
//! the pipeline and the SBT's buffer; [`crate::Sbt::update`] while a launch holds
//! the SBT writes into a copy, so the launch keeps the records it was given.
//!
//! # Dropping what a launch uses
//! Each launch is an epoch on the context's GPU timeline ([`crate::timeline`]). The
//! buffers, acceleration structures, SBT and pipeline a pending launch uses may be
//! dropped at any time: they are destroyed, and their memory and bindless slots
//! reused, only once the launch has finished. [`crate::DeviceBuffer::read`] waits
//! for pending work; [`crate::DeviceBuffer::read_async`] submits a copy into host
//! memory of its own, so a launch's image can be read even after it was dropped.

use std::sync::Arc;

use super::{Pipeline, PipelineRepr};
use crate::error::{Error, Result};
use crate::error::{LaunchError, SbtError};
use crate::sbt::{Sbt, SbtRepr};
use crate::validate::launch::LaunchChecks;
use crate::vulkan::pipeline::record::VulkanLaunch;
use crate::vulkan::pipeline::timing::TimestampPool;

/// A launch submitted to the device and not yet waited for (OptiX's launch on a
/// stream). Dropping it waits for the work first.
#[must_use = "a Launch is waited on (or polled); dropping it waits and discards its user exceptions"]
pub struct Launch {
    repr: LaunchRepr,
}

/// What a [`Launch`] is underneath.
enum LaunchRepr {
    Vulkan(VulkanLaunch),
    Cpu(crate::cpu::launch::CpuLaunch),
}

impl std::fmt::Debug for Launch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let this = match &self.repr {
            LaunchRepr::Vulkan(launch) => launch,
            LaunchRepr::Cpu(launch) => return launch.fmt(f),
        };
        let pipeline = this.pipeline();
        let groups: Vec<_> = pipeline.groups.iter().map(|g| g.kind).collect();
        f.debug_struct("Launch")
            .field("pipeline_groups", &groups)
            .field("exception_buffers", &pipeline.exceptions.len())
            .finish_non_exhaustive()
    }
}

impl Launch {
    /// Whether the launch has finished, without blocking.
    pub fn is_done(&self) -> Result<bool> {
        match &self.repr {
            LaunchRepr::Vulkan(launch) => launch.is_done(),
            LaunchRepr::Cpu(launch) => Ok(launch.is_done()),
        }
    }

    /// Blocks until the launch has finished; then the buffers it wrote hold the
    /// results. Returns [`LaunchError::UserExceptions`] if device programs threw any, or
    /// [`LaunchError::RecursionTooDeep`] if traces past the pipeline's `max_trace_depth`
    /// were refused on the device.
    /// Errors of the CPU backend's launches: [`LaunchError::ProgramPanicked`] and
    /// [`LaunchError::CpuLaunchFault`].
    pub fn wait(self) -> Result<()> {
        match self.repr {
            LaunchRepr::Vulkan(launch) => launch.wait(),
            LaunchRepr::Cpu(launch) => launch.wait(),
        }
    }
}

impl<P: raykit_device::LaunchParams> Pipeline<P> {
    /// Traces a `dims = [width, height, depth]` grid with `params`, using `sbt`,
    /// and waits until it is done: [`Pipeline::launch_async`] then [`Launch::wait`].
    #[doc(alias("optixLaunch", "vkCmdTraceRaysKHR"))]
    pub fn launch(&self, sbt: &Sbt, params: &P, dims: [u32; 3]) -> Result<()> {
        self.launch_async(sbt, params, dims)?.wait()
    }

    /// Submits a launch like [`Pipeline::launch`] and returns without waiting. See
    /// the [module docs](self) for what may be in flight at once.
    #[doc(alias("optixLaunch", "vkCmdTraceRaysKHR"))]
    pub fn launch_async(&self, sbt: &Sbt, params: &P, dims: [u32; 3]) -> Result<Launch> {
        self.submit_launch(sbt, params, dims, None)
    }

    /// [`Pipeline::launch`], with GPU timestamps written into queries 0 and 1 of
    /// `timestamps` around the trace (see [`super::timing`]).
    pub(crate) fn launch_recording(
        &self,
        sbt: &Sbt,
        params: &P,
        dims: [u32; 3],
        timestamps: Option<&TimestampPool>,
    ) -> Result<()> {
        self.submit_launch(sbt, params, dims, timestamps)?.wait()
    }

    /// Records and submits a launch, with optional timestamps around the trace.
    fn submit_launch(
        &self,
        sbt: &Sbt,
        params: &P,
        dims: [u32; 3],
        timestamps: Option<&TimestampPool>,
    ) -> Result<Launch> {
        if !Arc::ptr_eq(&sbt.pipeline, &self.info) {
            return Err(Error::Sbt(SbtError::OfAnotherPipeline));
        }
        let info = &*self.info;
        check_dimensions(dims, &info.limits, info.launch_dimensions)?;
        let params = bytemuck::bytes_of(params);
        // What the backend checks under its lock, so no drop slips between the
        // checks and the submission.
        let checks = LaunchChecks { fields: &info.handle_fields, params, sbt: sbt.checks(), reach: &info.reach };
        // The one match of the pipeline with its SBT: each backend gets its own halves.
        let repr = match (&self.repr, &sbt.repr) {
            (PipelineRepr::Vulkan(inner), SbtRepr::Vulkan(device_sbt)) => {
                let timestamps = timestamps.map(|t| t.pool);
                let launch = crate::vulkan::pipeline::record::submit(
                    inner,
                    device_sbt,
                    checks,
                    dims,
                    self.stack_size(),
                    timestamps,
                )?;
                LaunchRepr::Vulkan(launch)
            }
            (PipelineRepr::Cpu(data), SbtRepr::Cpu(records)) => {
                LaunchRepr::Cpu(crate::cpu::launch::CpuLaunch::submit(data, checks, records, dims)?)
            }
            _ => return Err(Error::Sbt(SbtError::OfAnotherPipeline)),
        };
        Ok(Launch { repr })
    }
}

/// Checks a launch's `dims` against the device's limits: every dimension at
/// least 1, at most `invocation limit` invocations in all, and each dimension
/// within `dimension_limits`.
fn check_dimensions(
    dims: [u32; 3],
    limits: &crate::types::context::DeviceLimits,
    dimension_limits: [u64; 3],
) -> Result<()> {
    if dims.contains(&0) {
        return Err(Error::Launch(LaunchError::Dimensions {
            dims,
            reason: "every dimension must be at least 1".to_owned(),
        }));
    }
    // Three u32s can overflow u64 (2^96): an overflowing product is over any limit.
    let invocations = dims.iter().try_fold(1u64, |n, &d| n.checked_mul(d as u64));
    let limit = limits.max_ray_dispatch_invocation_count as u64;
    if invocations.is_none_or(|n| n > limit) {
        let count = invocations.map_or_else(|| "more than 2^64".to_owned(), |n| n.to_string());
        return Err(Error::Launch(LaunchError::Dimensions {
            dims,
            reason: format!(
                "{count} invocations exceed maxRayDispatchInvocationCount {limit}; split the launch into tiles"
            ),
        }));
    }
    // vkCmdTraceRaysKHR also bounds each dimension (VUID-vkCmdTraceRaysKHR-width-03638 …
    // depth-03640): maxComputeWorkGroupCount[i] × maxComputeWorkGroupSize[i].
    if let Some(i) = (0..3).find(|&i| dims[i] as u64 > dimension_limits[i]) {
        return Err(Error::Launch(LaunchError::Dimensions {
            dims,
            reason: format!(
                "{} {} is over this device's limit of {} (maxComputeWorkGroupCount[{i}] × maxComputeWorkGroupSize[{i}]); split the launch into tiles",
                ["width", "height", "depth"][i],
                dims[i],
                dimension_limits[i],
            ),
        }));
    }
    Ok(())
}
