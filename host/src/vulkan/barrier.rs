//! Global memory barriers: how the backend orders its commands within a
//! submission (images also get their layout transitions, in `texture`).

use ash::vk;

/// Records a global memory barrier: the `src_access` writes and reads of
/// `src_stage` work before it are done and visible to the `dst_access` of
/// `dst_stage` work after it.
///
/// # Safety
/// `cmd` must be a command buffer of `device` in the recording state.
pub(crate) unsafe fn memory_barrier(
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
