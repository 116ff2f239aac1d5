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
//! Nothing a launch needs is shared on the host with another launch in flight:
//! * its params travel in its own command buffer — as push constants, or recorded
//!   with `vkCmdUpdateBuffer` into the pipeline's uniform buffer;
//! * the pipeline's user-exception counters are zeroed with `vkCmdFillBuffer` at the
//!   start of its command buffer and copied into the launch's own readback buffer
//!   at its end — for the programs that can throw only: a module without the
//!   exception slot's specialization constant (rust-gpu leaves it out of modules
//!   that never call `throw_exception`) costs a launch nothing;
//! * every raykit submission ends with a memory barrier that orders it before the
//!   later work that may touch what it used: a launch's and a buffer readback's
//!   cover every later command, a build's, refit's or compaction's every later
//!   build and trace (and builds, refits and compactions begin with a barrier from
//!   all earlier commands). So on raykit's one queue a launch's programs start only
//!   after earlier submissions are done with what they touch, and see their
//!   writes. A launch that first writes with transfers (a params uniform, exception
//!   counters) also begins with a barrier from all earlier commands — the uniform
//!   buffer and the exception counters are rewritten only once the launch before
//!   has finished with them.
//!
//! A launch of push-constant params whose programs cannot throw records what a
//! hand-written one does: binding, stack size, push constants, the trace and one
//! barrier after it. A params uniform or exception buffers to zero add their
//! transfers and a barrier on each side of them, and exception copies a last
//! barrier.
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

use ash::vk;

use super::{Pipeline, PipelineInner, PipelineRepr};
use crate::error::{Error, Result};
use crate::sbt::{Sbt, SbtDevice};
use crate::vulkan::buffer_table::RT_STAGES;
use crate::vulkan::context::Submission;
use crate::vulkan::memory::RawBuffer;
use crate::vulkan::pipeline::exceptions::ExceptionBuffer;
use crate::vulkan::sbt::VulkanSbt;

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

/// A launch submitted to a Vulkan queue.
struct VulkanLaunch {
    // Field order matters: the submission (which waits in its drop) goes first.
    submission: Submission,
    /// Host-visible copies of the pipeline's exception buffers, written by the
    /// launch; returned to the pipeline's pool when the launch is done.
    readback: Option<RawBuffer>,
    pipeline: Arc<PipelineInner>,
    _sbt: Arc<RawBuffer>,
}

impl Drop for VulkanLaunch {
    fn drop(&mut self) {
        // The work is done once the submission has waited: only then may the
        // readback buffer serve another launch.
        if self.submission.wait().is_ok() {
            if let Some(readback) = self.readback.take() {
                let mut pool = self.pipeline.readbacks.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                if pool.len() < 8 {
                    pool.push(readback);
                }
            }
        }
    }
}

impl std::fmt::Debug for Launch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let this = match &self.repr {
            LaunchRepr::Vulkan(launch) => launch,
            LaunchRepr::Cpu(launch) => return launch.fmt(f),
        };
        let groups: Vec<_> = this.pipeline.groups.iter().map(|g| g.kind).collect();
        f.debug_struct("Launch")
            .field("pipeline_groups", &groups)
            .field("exception_buffers", &this.pipeline.exceptions.len())
            .finish_non_exhaustive()
    }
}

impl Launch {
    /// Whether the launch has finished, without blocking.
    pub fn is_done(&self) -> Result<bool> {
        match &self.repr {
            LaunchRepr::Vulkan(launch) => launch.submission.is_done(),
            LaunchRepr::Cpu(launch) => Ok(launch.is_done()),
        }
    }

    /// Blocks until the launch has finished; then the buffers it wrote hold the
    /// results. Returns [`Error::UserExceptions`] if device programs threw any, or
    /// [`Error::RecursionTooDeep`] if traces past the pipeline's `max_trace_depth`
    /// were refused on the device.
    /// Errors of the CPU backend's launches: [`Error::ProgramPanicked`] and
    /// [`Error::CpuLaunchFault`].
    pub fn wait(self) -> Result<()> {
        let mut launch = match self.repr {
            LaunchRepr::Vulkan(launch) => launch,
            LaunchRepr::Cpu(launch) => return launch.wait(),
        };
        launch.submission.wait()?;
        let Some(bytes) = launch.readback.as_ref().and_then(|r| r.mapped()) else { return Ok(()) };
        let mut total = 0;
        let mut exceptions = Vec::new();
        for copy in bytes.chunks_exact(ExceptionBuffer::SIZE as usize) {
            let (n, thrown) = ExceptionBuffer::parse(copy);
            total += n;
            exceptions.extend(thrown);
        }
        if total > 0 {
            return Err(super::exceptions_error(total, exceptions, launch.pipeline.max_trace_depth));
        }
        Ok(())
    }
}

impl<P: raykit_device::LaunchParams> Pipeline<P> {
    /// Traces a `dims = [width, height, depth]` grid with `params`, using `sbt`,
    /// and waits until it is done: [`Pipeline::launch_async`] then [`Launch::wait`].
    pub fn launch(&self, sbt: &Sbt, params: &P, dims: [u32; 3]) -> Result<()> {
        self.launch_async(sbt, params, dims)?.wait()
    }

    /// Submits a launch like [`Pipeline::launch`] and returns without waiting. See
    /// the [module docs](self) for what may be in flight at once.
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
        timestamps: Option<vk::QueryPool>,
    ) -> Result<()> {
        self.submit_launch(sbt, params, dims, timestamps)?.wait()
    }

    /// Records and submits a launch, with optional timestamps around the trace.
    fn submit_launch(
        &self,
        sbt: &Sbt,
        params: &P,
        dims: [u32; 3],
        timestamps: Option<vk::QueryPool>,
    ) -> Result<Launch> {
        let inner = match (&self.repr, &sbt.device) {
            (PipelineRepr::Vulkan(inner), SbtDevice::Vulkan(sbt)) if Arc::ptr_eq(&sbt.pipeline, inner) => inner,
            (PipelineRepr::Cpu(data), SbtDevice::Cpu { pipeline, data: records }) if Arc::ptr_eq(pipeline, data) => {
                check_dimensions(dims, &crate::cpu::LIMITS, crate::cpu::LAUNCH_DIMENSION_LIMITS)?;
                let launch = crate::cpu::launch::CpuLaunch::submit(data, sbt, records, params, dims)?;
                return Ok(Launch { repr: LaunchRepr::Cpu(launch) });
            }
            _ => return Err(Error::SbtOfAnotherPipeline),
        };
        let ctx = &inner.ctx;
        check_dimensions(dims, &ctx.limits, ctx.launch_dimension_limits)?;
        let device = &ctx.device;
        let params_bytes = bytemuck::bytes_of(params);
        // `vkCmdUpdateBuffer` takes whole words: pad the params to the buffer's size.
        let uniform = inner.params_uniform.as_ref().and_then(|u| {
            let buffer = u.buffer.as_ref()?;
            let mut padded = params_bytes.to_vec();
            padded.resize(u.size as usize, 0);
            Some((u.set, buffer.buffer, padded))
        });
        let stack_size = self.stack_size();
        // Only the exception buffers of programs that can throw are zeroed, copied
        // and read back (see `ModuleInner::records_exceptions`).
        let throwing = &inner.throwing;
        let readback = if throwing.is_empty() {
            None
        } else {
            let pooled = inner.readbacks.lock().unwrap_or_else(std::sync::PoisonError::into_inner).pop();
            Some(match pooled {
                Some(buffer) => buffer,
                None => RawBuffer::new(
                    ctx,
                    "user exception readback",
                    ExceptionBuffer::SIZE * throwing.len() as u64,
                    vk::BufferUsageFlags::TRANSFER_DST,
                    gpu_allocator::MemoryLocation::GpuToCpu,
                    16,
                )?,
            })
        };
        // Whether the launch writes anything with transfers before tracing.
        let transfers = !throwing.is_empty() || uniform.is_some();
        // The handles of the params, those in SBT records whose type derives
        // `SbtRecordData` (see `crate::handles`), and the scene's reach into the SBT.
        let check = || {
            ctx.check_handles(&inner.handle_fields, params_bytes, None)?;
            for record in &sbt.checked {
                ctx.check_handles(&record.fields, &record.data, Some((record.region, record.index)))?;
            }
            let hit_reach = |address| ctx.traversables.hit_reach(address);
            crate::validate::scene::check_scene(hit_reach, &inner.handle_fields, params_bytes, sbt, &inner.reach)
        };
        let SbtDevice::Vulkan(VulkanSbt { raygen, miss, hit, callable, .. }) = &sbt.device else {
            return Err(Error::SbtOfAnotherPipeline);
        };
        let submission = ctx.submit_checked("a launch", check, |cmd| {
            // SAFETY: the pipeline, layout, descriptor sets, uniform, exception and
            // SBT buffers are alive until the work is done (the returned `Launch`
            // holds them, and their drops wait for this submission's epoch on the
            // timeline); `cmd` is recording.
            unsafe {
                // Every submission before this one ends with a barrier that orders its
                // work before all later commands (a launch's is the one after its
                // trace), so a launch that writes only from its programs needs none
                // here. One that first writes with transfers (the params uniform, the
                // exception counters) or resets timestamp queries waits here for
                // earlier work.
                if transfers || timestamps.is_some() {
                    full_barrier(
                        device,
                        cmd,
                        vk::PipelineStageFlags::ALL_COMMANDS,
                        vk::AccessFlags::MEMORY_WRITE | vk::AccessFlags::MEMORY_READ,
                        vk::PipelineStageFlags::TRANSFER | vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                        vk::AccessFlags::TRANSFER_WRITE | SHADER_ACCESS,
                    );
                }
                if transfers {
                    for exceptions in throwing {
                        // The counter is the first word.
                        device.cmd_fill_buffer(cmd, exceptions.buffer.buffer, 0, 4, 0);
                        // Then where the exception program sits in the callable region.
                        let handler = sbt.exception_index.unwrap_or(raykit_device::exception::NO_EXCEPTION_PROGRAM);
                        device.cmd_fill_buffer(cmd, exceptions.buffer.buffer, 4, 4, handler);
                    }
                    if let Some((_, buffer, bytes)) = &uniform {
                        device.cmd_update_buffer(cmd, *buffer, 0, bytes);
                    }
                    full_barrier(
                        device,
                        cmd,
                        vk::PipelineStageFlags::TRANSFER,
                        vk::AccessFlags::TRANSFER_WRITE,
                        vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                        SHADER_ACCESS,
                    );
                }
                device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::RAY_TRACING_KHR, inner.pipeline.handle);
                // The pipeline's stack size is dynamic state (see `crate::stack`).
                ctx.rt.cmd_set_ray_tracing_pipeline_stack_size(cmd, stack_size);
                device.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::RAY_TRACING_KHR,
                    inner.layout.handle,
                    raykit_abi::BUFFER_TABLE_SET,
                    &[ctx.buffer_table.set],
                    &[],
                );
                if let Some((set, _, _)) = &uniform {
                    device.cmd_bind_descriptor_sets(
                        cmd,
                        vk::PipelineBindPoint::RAY_TRACING_KHR,
                        inner.layout.handle,
                        raykit_device::PARAMS_SET,
                        &[*set],
                        &[],
                    );
                }
                if inner.layout.push_constant_size > 0 {
                    device.cmd_push_constants(cmd, inner.layout.handle, RT_STAGES, 0, params_bytes);
                }
                if let Some(pool) = timestamps {
                    device.cmd_reset_query_pool(cmd, pool, 0, 2);
                    device.cmd_write_timestamp(cmd, vk::PipelineStageFlags::TOP_OF_PIPE, pool, 0);
                }
                ctx.rt.cmd_trace_rays(cmd, raygen, miss, hit, callable, dims[0], dims[1], dims[2]);
                if let Some(pool) = timestamps {
                    device.cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, pool, 1);
                }
                // The programs' writes: visible to the host once the epoch is signalled,
                // to the exception copies below, and to everything submitted later,
                // which also starts only once the programs are done with what they
                // read (see above).
                full_barrier(
                    device,
                    cmd,
                    vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                    vk::AccessFlags::SHADER_WRITE,
                    vk::PipelineStageFlags::ALL_COMMANDS | vk::PipelineStageFlags::HOST,
                    vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE | vk::AccessFlags::HOST_READ,
                );
                if let Some(readback) = &readback {
                    for (i, exceptions) in throwing.iter().enumerate() {
                        let region = vk::BufferCopy {
                            src_offset: 0,
                            dst_offset: i as u64 * ExceptionBuffer::SIZE,
                            size: ExceptionBuffer::SIZE,
                        };
                        device.cmd_copy_buffer(cmd, exceptions.buffer.buffer, readback.buffer, &[region]);
                    }
                    full_barrier(
                        device,
                        cmd,
                        vk::PipelineStageFlags::TRANSFER,
                        vk::AccessFlags::TRANSFER_WRITE,
                        vk::PipelineStageFlags::HOST,
                        vk::AccessFlags::HOST_READ,
                    );
                }
            }
        })?;
        let SbtDevice::Vulkan(VulkanSbt { buffer, .. }) = &sbt.device else { return Err(Error::SbtOfAnotherPipeline) };
        let launch = VulkanLaunch { submission, readback, pipeline: inner.clone(), _sbt: buffer.clone() };
        Ok(Launch { repr: LaunchRepr::Vulkan(launch) })
    }
}

/// Checks a launch's `dims` against the device's limits: every dimension at
/// least 1, at most `invocation limit` invocations in all, and each dimension
/// within `dimension_limits`.
fn check_dimensions(dims: [u32; 3], limits: &crate::context::DeviceLimits, dimension_limits: [u64; 3]) -> Result<()> {
    if dims.contains(&0) {
        return Err(Error::LaunchDimensions { dims, reason: "every dimension must be at least 1".to_owned() });
    }
    // Three u32s can overflow u64 (2^96): an overflowing product is over any limit.
    let invocations = dims.iter().try_fold(1u64, |n, &d| n.checked_mul(d as u64));
    let limit = limits.max_ray_dispatch_invocation_count as u64;
    if invocations.is_none_or(|n| n > limit) {
        let count = invocations.map_or_else(|| "more than 2^64".to_owned(), |n| n.to_string());
        return Err(Error::LaunchDimensions {
            dims,
            reason: format!(
                "{count} invocations exceed maxRayDispatchInvocationCount {limit}; split the launch into tiles"
            ),
        });
    }
    // vkCmdTraceRaysKHR also bounds each dimension (VUID-vkCmdTraceRaysKHR-width-03638 …
    // depth-03640): maxComputeWorkGroupCount[i] × maxComputeWorkGroupSize[i].
    if let Some(i) = (0..3).find(|&i| dims[i] as u64 > dimension_limits[i]) {
        return Err(Error::LaunchDimensions {
            dims,
            reason: format!(
                "{} {} is over this device's limit of {} (maxComputeWorkGroupCount[{i}] × maxComputeWorkGroupSize[{i}]); split the launch into tiles",
                ["width", "height", "depth"][i],
                dims[i],
                dimension_limits[i],
            ),
        });
    }
    Ok(())
}

/// What the programs of a launch access: uniform params, buffers (read and written).
const SHADER_ACCESS: vk::AccessFlags = vk::AccessFlags::from_raw(
    vk::AccessFlags::UNIFORM_READ.as_raw()
        | vk::AccessFlags::SHADER_READ.as_raw()
        | vk::AccessFlags::SHADER_WRITE.as_raw(),
);

/// A global memory barrier.
///
/// # Safety
/// `cmd` must be a command buffer of `device` in the recording state.
unsafe fn full_barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    src_stage: vk::PipelineStageFlags,
    src_access: vk::AccessFlags,
    dst_stage: vk::PipelineStageFlags,
    dst_access: vk::AccessFlags,
) {
    let barrier = vk::MemoryBarrier::default().src_access_mask(src_access).dst_access_mask(dst_access);
    // SAFETY: per the contract above.
    unsafe {
        device.cmd_pipeline_barrier(cmd, src_stage, dst_stage, vk::DependencyFlags::empty(), &[barrier], &[], &[])
    };
}
