//! What both hand-written ash launchers ([`crate::ash_baseline::AshTracer`] and
//! [`crate::ash_independent::IndependentTracer`]) submit through: one command
//! buffer and its fence on a queue, two timestamp queries bracketing
//! `vkCmdTraceRaysKHR` (as raykit's `launch_timed` does), and a device-local
//! output copied to a mapped host-visible buffer after the launch, outside the
//! timed part; and the shader groups of the primary-ray programs both create
//! pipelines of (as does the `launch` suite's hand-written pipeline).

use anyhow::Context as _;
use ash::vk;

use crate::ash_baseline::Buffer;

/// The shader groups of the primary-ray programs, stages in the order raygen,
/// miss, closest-hit: two general groups and a triangle hit group.
pub(crate) fn primary_groups() -> [vk::RayTracingShaderGroupCreateInfoKHR<'static>; 3] {
    let group = |ty: vk::RayTracingShaderGroupTypeKHR| {
        vk::RayTracingShaderGroupCreateInfoKHR::default()
            .ty(ty)
            .general_shader(vk::SHADER_UNUSED_KHR)
            .closest_hit_shader(vk::SHADER_UNUSED_KHR)
            .any_hit_shader(vk::SHADER_UNUSED_KHR)
            .intersection_shader(vk::SHADER_UNUSED_KHR)
    };
    let general = vk::RayTracingShaderGroupTypeKHR::GENERAL;
    [
        group(general).general_shader(0),
        group(general).general_shader(1),
        group(vk::RayTracingShaderGroupTypeKHR::TRIANGLES_HIT_GROUP).closest_hit_shader(2),
    ]
}

/// A command buffer, its fence and the timestamp queries of one launcher.
pub(crate) struct Submitter<'d> {
    device: &'d ash::Device,
    queue: vk::Queue,
    /// The pool `cmd` came from (the owner's, destroyed by it after [`Submitter::destroy`]).
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    /// Two queries, where the queue has timestamps.
    timestamps: Option<vk::QueryPool>,
    period_ns: f64,
    mask: u64,
}

impl<'d> Submitter<'d> {
    /// A command buffer from `pool`, a fence, and timestamp queries when
    /// `valid_bits` and `period_ns` say the queue has them.
    pub(crate) fn new(
        device: &'d ash::Device,
        queue: vk::Queue,
        pool: vk::CommandPool,
        valid_bits: u32,
        period_ns: f64,
    ) -> anyhow::Result<Submitter<'d>> {
        let alloc = vk::CommandBufferAllocateInfo::default().command_pool(pool).command_buffer_count(1);
        // SAFETY: the owner's pool, used from this thread only.
        let cmd = unsafe { device.allocate_command_buffers(&alloc) }?[0];
        let mut submitter = Submitter {
            device,
            queue,
            pool,
            cmd,
            fence: vk::Fence::null(),
            timestamps: None,
            period_ns,
            mask: if valid_bits >= 64 { u64::MAX } else { (1u64 << valid_bits) - 1 },
        };
        let made = (|| -> anyhow::Result<()> {
            // SAFETY: valid create info.
            submitter.fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }?;
            if valid_bits > 0 && period_ns > 0.0 {
                let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(2);
                // SAFETY: valid create info.
                submitter.timestamps = Some(unsafe { device.create_query_pool(&info, None) }?);
            }
            Ok(())
        })();
        if let Err(e) = made {
            submitter.destroy();
            return Err(e);
        }
        Ok(submitter)
    }

    /// Records `record` into the command buffer, submits it and waits.
    pub(crate) fn submit(&self, record: impl FnOnce(vk::CommandBuffer)) -> anyhow::Result<()> {
        let d = self.device;
        // SAFETY: the command buffer is not in use (the last submission was waited for).
        unsafe {
            d.begin_command_buffer(
                self.cmd,
                &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )?;
            record(self.cmd);
            d.end_command_buffer(self.cmd)?;
            let cmds = [self.cmd];
            d.queue_submit(self.queue, &[vk::SubmitInfo::default().command_buffers(&cmds)], self.fence)?;
            d.wait_for_fences(&[self.fence], true, u64::MAX)?;
            d.reset_fences(&[self.fence])?;
        }
        Ok(())
    }

    /// One submission of `bind` (pipeline, sets, push constants) then `trace`
    /// (the `vkCmdTraceRaysKHR`) between the two timestamps; the seconds of the
    /// trace (GPU timestamps, else the wall time of the submission).
    pub(crate) fn timed(
        &self,
        bind: impl FnOnce(vk::CommandBuffer),
        trace: impl FnOnce(vk::CommandBuffer),
    ) -> anyhow::Result<f64> {
        let d = self.device;
        let start = std::time::Instant::now();
        self.submit(|cmd| {
            bind(cmd);
            if let Some(pool) = self.timestamps {
                // SAFETY: the query pool is this submitter's and live.
                unsafe {
                    d.cmd_reset_query_pool(cmd, pool, 0, 2);
                    d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::TOP_OF_PIPE, pool, 0);
                }
            }
            trace(cmd);
            if let Some(pool) = self.timestamps {
                // SAFETY: as above.
                unsafe { d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, pool, 1) };
            }
        })?;
        let wall = start.elapsed().as_secs_f64();
        let Some(pool) = self.timestamps else { return Ok(wall) };
        let mut ticks = [0u64; 2];
        // SAFETY: both queries were written by the finished submission.
        unsafe {
            d.get_query_pool_results(pool, 0, &mut ticks, vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT)
        }?;
        Ok((ticks[1].wrapping_sub(ticks[0]) & self.mask) as f64 * self.period_ns * 1e-9)
    }

    /// The words of `output` (written by the programs), copied into its readback.
    pub(crate) fn picture(&self, output: &Output) -> anyhow::Result<Vec<u32>> {
        let d = self.device;
        self.submit(|cmd| {
            let before = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                .dst_access_mask(vk::AccessFlags::TRANSFER_READ);
            let after = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ);
            let region = [vk::BufferCopy::default().size(output.bytes)];
            // SAFETY: both buffers are the owner's and live.
            unsafe {
                d.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::DependencyFlags::empty(),
                    &[before],
                    &[],
                    &[],
                );
                d.cmd_copy_buffer(cmd, output.device.buffer, output.readback.buffer, &region);
                d.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &[after],
                    &[],
                    &[],
                );
            }
        })?;
        anyhow::ensure!(!output.mapped.is_null(), "the launcher's readback buffer is not mapped");
        // SAFETY: the mapping covers `bytes` bytes of coherent memory the finished copy wrote.
        let bytes = unsafe { std::slice::from_raw_parts(output.mapped, output.bytes as usize) };
        Ok(bytes.chunks_exact(4).map(|c| u32::from_ne_bytes([c[0], c[1], c[2], c[3]])).collect())
    }

    /// Destroys the queries and the fence and frees the command buffer; the
    /// owner calls it once, with nothing in flight, before destroying the pool.
    pub(crate) fn destroy(&self) {
        // SAFETY: nothing is in flight (every submission was waited for); null
        // handles are ignored by Vulkan.
        unsafe {
            if let Some(pool) = self.timestamps {
                self.device.destroy_query_pool(pool, None);
            }
            self.device.destroy_fence(self.fence, None);
            self.device.free_command_buffers(self.pool, &[self.cmd]);
        }
    }
}

/// The programs' device-local output and its mapped host-visible copy; the
/// owner made both buffers and frees them.
#[derive(Default)]
pub(crate) struct Output {
    pub(crate) device: Buffer,
    pub(crate) readback: Buffer,
    /// `readback`'s mapping, for the owner's lifetime (null until mapped).
    pub(crate) mapped: *const u8,
    pub(crate) bytes: u64,
}

impl Output {
    /// `device` and `readback` (host-visible, coherent) of `bytes` bytes each,
    /// not mapped yet.
    pub(crate) fn new(device: Buffer, readback: Buffer, bytes: u64) -> Output {
        Output { device, readback, mapped: std::ptr::null(), bytes }
    }

    /// Maps the readback on `d`, for the owner's lifetime.
    pub(crate) fn map(&mut self, d: &ash::Device) -> anyhow::Result<()> {
        // SAFETY: host-visible memory, mapped until `unmap`.
        self.mapped = unsafe { d.map_memory(self.readback.memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()) }
            .context("mapping the launcher's readback buffer")? as *const u8;
        Ok(())
    }

    /// Unmaps the readback, if mapped (the owner then frees both buffers).
    pub(crate) fn unmap(&mut self, d: &ash::Device) {
        if !self.mapped.is_null() {
            // SAFETY: mapped by `map`; nothing reads the mapping after this.
            unsafe { d.unmap_memory(self.readback.memory) };
            self.mapped = std::ptr::null();
        }
    }
}
