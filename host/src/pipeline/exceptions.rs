//! User-exception buffers: where the programs of a pipeline (or of a library)
//! record the user exceptions they throw; see `raykit_device::exception`.

use std::sync::Arc;

use ash::vk;

use crate::buffer_table::SlotReuse;
use crate::context::ContextInner;
use crate::error::{Result, UserException};
use crate::memory::RawBuffer;

/// A user-exception buffer: a device buffer in the bindless table, one per set of
/// programs compiled together. Every launch zeroes its counter and copies it into
/// the launch's own readback buffer, on the device, so launches in flight never
/// share host-visible state (see [`crate::pipeline::launch`]).
pub(crate) struct ExceptionBuffer {
    ctx: Arc<ContextInner>,
    pub(crate) buffer: RawBuffer,
    /// Its slot in the bindless table, given to the programs as a specialization constant.
    pub(crate) slot: u32,
    /// Whether any of its programs can throw (see [`may_throw`]): launches zero,
    /// copy and read back only the buffers of programs that can.
    pub(crate) may_throw: bool,
}

/// Whether a module's programs can throw a user exception: whether anything in it
/// uses the exception buffer's slot, the specialization constant with SpecId
/// [`raykit_device::exception::EXCEPTION_SLOT_SPEC_ID`]. A program cannot reach the
/// exception buffer without that slot, so a module that only declares it (every
/// Rust module does) or lacks it (a GLSL or WGSL module that never throws) cannot
/// throw. Conservative: any word equal to the constant's id in an instruction
/// other than its declaration, names and decorations counts as a use.
pub(crate) fn may_throw(words: &[u32]) -> bool {
    const NAME: u32 = 5;
    const MEMBER_NAME: u32 = 6;
    const DECORATE: u32 = 71;
    const MEMBER_DECORATE: u32 = 72;
    const SPEC_ID: u32 = 1;
    let instructions = || {
        let mut at = 5usize;
        std::iter::from_fn(move || {
            let first = *words.get(at)?;
            let count = (first >> 16) as usize;
            let inst = words.get(at..at + count.max(1))?;
            at += count.max(1);
            Some(inst)
        })
    };
    let slot_id = instructions().find_map(|inst| {
        let is_spec_id = inst[0] & 0xffff == DECORATE && inst.len() >= 4 && inst[2] == SPEC_ID;
        (is_spec_id && inst[3] == raykit_device::exception::EXCEPTION_SLOT_SPEC_ID).then(|| inst[1])
    });
    let Some(id) = slot_id else { return false };
    instructions().any(|inst| {
        let op = inst[0] & 0xffff;
        if matches!(op, NAME | MEMBER_NAME | DECORATE | MEMBER_DECORATE) {
            return false;
        }
        // The declaration `OpSpecConstant %type %id default` names the id as its result.
        let declares = (48..=50).contains(&op) && inst.get(2) == Some(&id);
        !declares && inst[1..].contains(&id)
    })
}

impl ExceptionBuffer {
    /// Bytes of one exception buffer.
    pub(crate) const SIZE: u64 = raykit_device::exception::EXCEPTION_BUFFER_WORDS as u64 * 4;

    /// The exception buffer of programs that can throw (`may_throw`) or not.
    pub(crate) fn new(ctx: &Arc<ContextInner>, may_throw: bool) -> Result<ExceptionBuffer> {
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
        Ok(ExceptionBuffer { ctx: ctx.clone(), buffer, slot, may_throw })
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
        self.ctx.retire(crate::timeline::Retired::Slot(self.slot));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A module header and `body`, with a SpecId decoration of id 7 as the slot.
    fn module(body: &[&[u32]]) -> Vec<u32> {
        let mut words = vec![0x0723_0203, 0x0001_0500, 0, 100, 0];
        let decorate = [4 << 16 | 71, 7, 1, raykit_device::exception::EXCEPTION_SLOT_SPEC_ID];
        words.extend_from_slice(&decorate);
        for inst in body {
            words.extend_from_slice(inst);
        }
        words
    }

    #[test]
    fn a_module_throws_only_if_it_uses_the_exception_slot() {
        let name = [3 << 16 | 5, 7, 0x6c73];
        let declare = [4 << 16 | 50, 2, 7, 0];
        // `%9 = OpIAdd %2 %7 %8`: a use.
        let add = [5 << 16 | 128, 2, 9, 7, 8];
        assert!(!may_throw(&module(&[&name, &declare])), "declared only");
        assert!(may_throw(&module(&[&name, &declare, &add])), "used");
        // No SpecId decoration at all (a GLSL module that never throws).
        assert!(!may_throw(&[0x0723_0203, 0x0001_0500, 0, 100, 0, 5 << 16 | 128, 2, 9, 7, 8]));
        // A truncated module does not panic.
        assert!(!may_throw(&module(&[&[9 << 16 | 128, 2]])));
    }
}
