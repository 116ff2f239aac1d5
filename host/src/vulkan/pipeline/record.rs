//! Launch recording on Vulkan: a launch's command buffer (params, exception
//! counters, bindings, stack size, the trace, optional timestamps and the
//! barriers between them), its submission and its user-exception readback.
//!
//! # The rules it keeps: several launches in flight
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

use std::sync::Arc;

use ash::vk;

use crate::error::Result;
use crate::validate::launch::LaunchChecks;
use crate::vulkan::barrier::memory_barrier;
use crate::vulkan::buffer_table::RT_STAGES;
use crate::vulkan::context::Submission;
use crate::vulkan::memory::RawBuffer;
use crate::vulkan::pipeline::exceptions::ExceptionBuffer;
use crate::vulkan::pipeline::link::PipelineInner;
use crate::vulkan::sbt::VulkanSbt;

/// A launch submitted to a Vulkan queue.
pub(crate) struct VulkanLaunch {
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

impl VulkanLaunch {
    /// The pipeline launched.
    pub(crate) fn pipeline(&self) -> &PipelineInner {
        &self.pipeline
    }

    /// Whether the launch has finished, without blocking.
    pub(crate) fn is_done(&self) -> Result<bool> {
        self.submission.is_done()
    }

    /// Blocks until the launch has finished; then reads back the user exceptions
    /// its programs threw.
    pub(crate) fn wait(mut self) -> Result<()> {
        self.submission.wait()?;
        let Some(bytes) = self.readback.as_ref().and_then(|r| r.mapped()) else { return Ok(()) };
        let mut total = 0;
        let mut exceptions = Vec::new();
        for copy in bytes.chunks_exact(ExceptionBuffer::SIZE as usize) {
            let (n, thrown) = ExceptionBuffer::parse(copy);
            total += n;
            exceptions.extend(thrown);
        }
        if total > 0 {
            return Err(crate::error::exceptions_error(total, exceptions, self.pipeline.max_trace_depth).into());
        }
        Ok(())
    }
}

/// Records and submits a launch of `inner` with `sbt` (made for it) over `dims`
/// (checked), with the params of `checks`, which run under the timeline's lock,
/// setting `stack_size`, with optional timestamps around the trace.
pub(crate) fn submit(
    inner: &Arc<PipelineInner>,
    sbt: &VulkanSbt,
    checks: LaunchChecks<'_>,
    dims: [u32; 3],
    stack_size: u32,
    timestamps: Option<vk::QueryPool>,
) -> Result<VulkanLaunch> {
    let ctx = &inner.ctx;
    let device = &ctx.device;
    let params_bytes = checks.params;
    // `vkCmdUpdateBuffer` takes whole words: pad the params to the buffer's size.
    let uniform = inner.params_uniform.as_ref().and_then(|u| {
        let buffer = u.buffer.as_ref()?;
        let mut padded = params_bytes.to_vec();
        padded.resize(u.size as usize, 0);
        Some((u.set, buffer.buffer, padded))
    });
    // Only the exception buffers of programs that can throw are zeroed, copied
    // and read back (see `ModuleInner::records_exceptions`).
    let throwing = &inner.throwing;
    let readback = exception_readback(inner)?;
    // Whether the launch writes anything with transfers before tracing.
    let transfers = !throwing.is_empty() || uniform.is_some();
    // The handles of the params, those in SBT records whose type derives
    // `SbtRecordData` (see `crate::validate::handles`), and the scene's reach into the SBT.
    let check = || checks.run(&**ctx);
    let VulkanSbt { raygen, miss, hit, callable, buffer, .. } = sbt;
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
                memory_barrier(
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
                memory_barrier(
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
            memory_barrier(
                device,
                cmd,
                vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                vk::AccessFlags::SHADER_WRITE,
                vk::PipelineStageFlags::ALL_COMMANDS | vk::PipelineStageFlags::HOST,
                vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE | vk::AccessFlags::HOST_READ,
            );
            if let Some(readback) = &readback {
                record_exception_copies(device, cmd, throwing, readback);
            }
        }
    })?;
    let launch = VulkanLaunch { submission, readback, pipeline: inner.clone(), _sbt: buffer.clone() };
    Ok(launch)
}

/// The host buffer a launch of `inner` copies its exception buffers into (one
/// from the pipeline's pool, else a new one), or `None` when no program can throw.
fn exception_readback(inner: &PipelineInner) -> Result<Option<RawBuffer>> {
    if inner.throwing.is_empty() {
        return Ok(None);
    }
    let pooled = inner.readbacks.lock().unwrap_or_else(std::sync::PoisonError::into_inner).pop();
    Ok(Some(match pooled {
        Some(buffer) => buffer,
        None => RawBuffer::new(
            &inner.ctx,
            "user exception readback",
            ExceptionBuffer::SIZE * inner.throwing.len() as u64,
            vk::BufferUsageFlags::TRANSFER_DST,
            gpu_allocator::MemoryLocation::GpuToCpu,
            16,
        )?,
    }))
}

/// Records the copies of the `throwing` programs' exception buffers into
/// `readback`, and the barrier that makes them visible to the host.
///
/// # Safety
/// `cmd` is recording on `device`; the buffers stay alive until it has run.
unsafe fn record_exception_copies(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    throwing: &[Arc<ExceptionBuffer>],
    readback: &RawBuffer,
) {
    for (i, exceptions) in throwing.iter().enumerate() {
        let region =
            vk::BufferCopy { src_offset: 0, dst_offset: i as u64 * ExceptionBuffer::SIZE, size: ExceptionBuffer::SIZE };
        // SAFETY: per the contract above; the regions lie inside both buffers.
        unsafe { device.cmd_copy_buffer(cmd, exceptions.buffer.buffer, readback.buffer, &[region]) };
    }
    // SAFETY: per the contract above.
    unsafe {
        memory_barrier(
            device,
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::PipelineStageFlags::HOST,
            vk::AccessFlags::HOST_READ,
        )
    };
}

/// What the programs of a launch access: uniform params, buffers (read and written).
const SHADER_ACCESS: vk::AccessFlags = vk::AccessFlags::from_raw(
    vk::AccessFlags::UNIFORM_READ.as_raw()
        | vk::AccessFlags::SHADER_READ.as_raw()
        | vk::AccessFlags::SHADER_WRITE.as_raw(),
);
