//! User-exception buffers: where the programs of a pipeline (or of a library)
//! record the user exceptions they throw; see `raykit_device::exception`.

use std::sync::Arc;

use ash::vk;

use crate::error::{Result, UserException};
use crate::vulkan::buffer_table::SlotReuse;
use crate::vulkan::context::ContextInner;
use crate::vulkan::memory::RawBuffer;
use crate::vulkan::module::SpirvGroup;

/// A user-exception buffer: a device buffer in the bindless table, one per set of
/// programs compiled together. Every launch zeroes its counter and copies it into
/// the launch's own readback buffer, on the device, so launches in flight never
/// share host-visible state (see [`super::record`]); launches skip that
/// for programs that cannot throw.
pub(crate) struct ExceptionBuffer {
    ctx: Arc<ContextInner>,
    pub(crate) buffer: RawBuffer,
    /// Its slot in the bindless table, given to the programs as a specialization constant.
    pub(crate) slot: u32,
    /// Whether any program compiled with it can throw (its module declares the
    /// slot's specialization constant): launches zero and read only such buffers.
    pub(crate) recorded: bool,
}

impl ExceptionBuffer {
    /// Bytes of one exception buffer.
    pub(crate) const SIZE: u64 = raykit_device::exception::EXCEPTION_BUFFER_WORDS as u64 * 4;

    /// The exception buffer of `groups`, compiled together.
    pub(crate) fn new(ctx: &Arc<ContextInner>, groups: &[&SpirvGroup]) -> Result<ExceptionBuffer> {
        let recorded =
            groups.iter().any(|g| g.programs().iter().any(|p| p.module().is_some_and(|m| m.records_exceptions)));
        let buffer = RawBuffer::new(
            ctx,
            "user exception buffer",
            Self::SIZE,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC
                | vk::BufferUsageFlags::TRANSFER_DST,
            gpu_allocator::MemoryLocation::GpuOnly,
            16,
        )?;
        // The slot is a specialization constant of the pipeline: reuse the last one
        // freed, so a pipeline made again is the same pipeline to the compile cache.
        let (slot, _) = ctx.buffer_table.insert_with(&ctx.device, buffer.buffer, SlotReuse::Newest)?;
        Ok(ExceptionBuffer { ctx: ctx.clone(), buffer, slot, recorded })
    }

    /// The exceptions in a copy of an exception buffer: `(total thrown, records)`.
    pub(crate) fn parse(bytes: &[u8]) -> (u32, Vec<UserException>) {
        use raykit_device::exception::{EXCEPTION_CAPACITY, EXCEPTION_RECORDS_WORD, EXCEPTION_RECORD_WORDS};
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(bytes);
        let total = words.first().copied().unwrap_or(0);
        let stored = total.min(EXCEPTION_CAPACITY) as usize;
        let records = (0..stored)
            .filter_map(|i| {
                let at = (EXCEPTION_RECORDS_WORD + i as u32 * EXCEPTION_RECORD_WORDS) as usize;
                let r = words.get(at..at + 4)?;
                Some(UserException { code: r[0], launch_index: [r[1], r[2], r[3]] })
            })
            .collect();
        (total, records)
    }
}

impl Drop for ExceptionBuffer {
    fn drop(&mut self) {
        // The slot is reused only once no pending work can write it.
        self.ctx.retire(crate::vulkan::timeline::Retired::Slot(self.slot));
    }
}
