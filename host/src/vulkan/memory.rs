//! Vulkan memory: a buffer with its gpu-allocator allocation, the untyped
//! building block under [`DeviceBuffer`](crate::DeviceBuffer), SBTs,
//! acceleration structures and scratch memory.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use crate::error::{DeviceError, ResourceError};
use crate::error::{Error, Result};
use crate::vulkan::barrier::memory_barrier;
use crate::vulkan::context::ContextInner;
use crate::vulkan::context::Submission;
use crate::vulkan::timeline::Retired;

/// A Vulkan buffer with its memory, freed on drop.
pub(crate) struct RawBuffer {
    pub(crate) ctx: Arc<ContextInner>,
    pub(crate) buffer: vk::Buffer,
    allocation: Option<Allocation>,
    pub(crate) size: u64,
    pub(crate) address: u64,
}

impl RawBuffer {
    /// Allocates `size` bytes with `usage` (device addresses are always on) at
    /// `location`, with at least `alignment` for its device address.
    pub(crate) fn new(
        ctx: &Arc<ContextInner>,
        what: &'static str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
        alignment: u64,
    ) -> Result<RawBuffer> {
        ctx.check_device("a buffer allocation")?;
        let device = &ctx.device;
        let info = vk::BufferCreateInfo::default()
            .size(size.max(1))
            .usage(usage | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info on a live device.
        let buffer = unsafe { device.create_buffer(&info, None) }.map_err(|result| match result {
            // Drivers may refuse a buffer too large for any heap already here.
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
                Error::Device(DeviceError::Allocation { what, source: gpu_allocator::AllocationError::OutOfMemory })
            }
            other => Error::Device(DeviceError::Vulkan { call: "vkCreateBuffer", result: other }),
        })?;
        // Wrapped at once, so an early return frees it.
        let mut raw = RawBuffer { ctx: ctx.clone(), buffer, allocation: None, size, address: 0 };
        ctx.set_name(buffer, what);
        // SAFETY: `buffer` is a live buffer of this device.
        let mut requirements = unsafe { device.get_buffer_memory_requirements(buffer) };
        requirements.alignment = requirements.alignment.max(alignment);
        let allocation = ctx
            .allocator()
            .allocate(&AllocationCreateDesc {
                name: what,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|source| Error::Device(DeviceError::Allocation { what, source }))?;
        // SAFETY: the allocation satisfies the buffer's requirements and is unbound.
        let bound = unsafe { device.bind_buffer_memory(buffer, allocation.memory(), allocation.offset()) };
        raw.allocation = Some(allocation);
        bound.map_err(Error::vk("vkBindBufferMemory"))?;
        let address_info = vk::BufferDeviceAddressInfo::default().buffer(buffer);
        // SAFETY: the buffer was created with SHADER_DEVICE_ADDRESS and is bound.
        raw.address = unsafe { device.get_buffer_device_address(&address_info) };
        Ok(raw)
    }

    /// The mapped bytes of a host-visible buffer.
    pub(crate) fn mapped(&self) -> Option<&[u8]> {
        let a = self.allocation.as_ref()?;
        a.mapped_slice().map(|s| &s[..self.size as usize])
    }

    /// The mapped bytes of a host-visible buffer, writable.
    pub(crate) fn mapped_mut(&mut self) -> Option<&mut [u8]> {
        let size = self.size as usize;
        let a = self.allocation.as_mut()?;
        a.mapped_slice_mut().map(|s| &mut s[..size])
    }

    /// Copies `bytes` into a host-visible buffer, from its start.
    pub(crate) fn write_bytes(&mut self, bytes: &[u8]) -> Result<()> {
        let mapped = self.mapped_mut().ok_or(Error::Resource(ResourceError::BufferSize {
            len: bytes.len(),
            element_size: 1,
            reason: "the buffer is not host-visible",
        }))?;
        let n = bytes.len().min(mapped.len());
        mapped[..n].copy_from_slice(&bytes[..n]);
        Ok(())
    }
}

impl Drop for RawBuffer {
    fn drop(&mut self) {
        // Work in flight may still use the buffer: the timeline destroys it, and
        // frees its memory, once the last submitted epoch has finished.
        self.ctx.retire(Retired::Buffer(self.buffer, self.allocation.take()));
    }
}

impl RawBuffer {
    /// A storage buffer of `size` bytes at `location` for a
    /// [`DeviceBuffer`](crate::DeviceBuffer), in a slot of the context's buffer
    /// table: the buffer, the slot and the handle.
    pub(crate) fn storage(
        ctx: &Arc<ContextInner>,
        size: u64,
        location: MemoryLocation,
    ) -> Result<(RawBuffer, u32, u32)> {
        let raw = RawBuffer::new(
            ctx,
            "DeviceBuffer",
            size,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC
                | vk::BufferUsageFlags::TRANSFER_DST,
            location,
            16,
        )?;
        let table = &ctx.buffer_table;
        let (slot, handle) = match table.insert(&ctx.device, raw.buffer) {
            // Slots of buffers dropped while work used them come back once it has
            // finished: collect those, then try again.
            Err(Error::Resource(ResourceError::BufferTableFull { .. })) => {
                ctx.collect()?;
                table.insert(&ctx.device, raw.buffer)?
            }
            other => other?,
        };
        Ok((raw, slot, handle))
    }

    /// Records a copy of `size` bytes from `src` at `src_offset` to `dst` at
    /// `dst_offset`, between barriers that order it after all earlier work and
    /// before all later work and host reads (every raykit submission ends so; see
    /// `vulkan::pipeline::record`), and submits it.
    fn submit_copy(
        ctx: &Arc<ContextInner>,
        during: &'static str,
        (src, src_offset): (vk::Buffer, u64),
        (dst, dst_offset): (vk::Buffer, u64),
        size: u64,
    ) -> Result<Submission> {
        ctx.submit(during, |cmd| {
            let region = vk::BufferCopy { src_offset, dst_offset, size };
            // SAFETY: both buffers are alive while the copy is pending (the caller
            // keeps them until the submission has finished, or their drops wait
            // for its epoch); `cmd` is recording; the region lies inside both.
            unsafe {
                let device = &ctx.device;
                memory_barrier(device, cmd, ALL, ALL_MEMORY, vk::PipelineStageFlags::TRANSFER, TRANSFER_ACCESS);
                device.cmd_copy_buffer(cmd, src, dst, &[region]);
                memory_barrier(
                    device,
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::PipelineStageFlags::HOST | ALL,
                    vk::AccessFlags::HOST_READ | ALL_MEMORY,
                );
            }
        })
    }

    /// Submits a copy of `size` bytes of this buffer from `offset` into the start
    /// of the host-visible `staging`.
    pub(crate) fn copy_to(&self, staging: &RawBuffer, offset: u64, size: u64) -> Result<Submission> {
        Self::submit_copy(&self.ctx, "a buffer readback", (self.buffer, offset), (staging.buffer, 0), size)
    }

    /// Submits a copy of the first `size` bytes of the host-visible `staging` into
    /// this buffer at `offset`.
    pub(crate) fn copy_from(&self, staging: &RawBuffer, offset: u64, size: u64) -> Result<Submission> {
        Self::submit_copy(&self.ctx, "a buffer upload", (staging.buffer, 0), (self.buffer, offset), size)
    }

    /// Submits zeroing the whole buffer on the device.
    pub(crate) fn fill_zero(&self) -> Result<Submission> {
        let (ctx, buffer) = (&self.ctx, self.buffer);
        ctx.submit("a buffer fill", |cmd| {
            // SAFETY: the buffer is alive while the fill is pending (its drop waits
            // for this epoch); `cmd` is recording; the whole size is a multiple of 4.
            unsafe {
                let device = &ctx.device;
                memory_barrier(device, cmd, ALL, ALL_MEMORY, vk::PipelineStageFlags::TRANSFER, TRANSFER_ACCESS);
                device.cmd_fill_buffer(cmd, buffer, 0, vk::WHOLE_SIZE, 0);
                memory_barrier(
                    device,
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::AccessFlags::TRANSFER_WRITE,
                    ALL,
                    ALL_MEMORY,
                );
            }
        })
    }
}

const ALL: vk::PipelineStageFlags = vk::PipelineStageFlags::ALL_COMMANDS;
const ALL_MEMORY: vk::AccessFlags =
    vk::AccessFlags::from_raw(vk::AccessFlags::MEMORY_READ.as_raw() | vk::AccessFlags::MEMORY_WRITE.as_raw());
const TRANSFER_ACCESS: vk::AccessFlags =
    vk::AccessFlags::from_raw(vk::AccessFlags::TRANSFER_READ.as_raw() | vk::AccessFlags::TRANSFER_WRITE.as_raw());

/// Which way a staging buffer carries data.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum StagingDirection {
    /// Device to host: cached host memory the device writes (`GpuToCpu`).
    Readback,
    /// Host to device: write-combined host memory the device reads (`CpuToGpu`).
    Upload,
}

/// The staging buffer a device-local buffer reuses for its copies in one
/// direction: taken for a copy, given back when the copy has been read (or
/// written), so a progressive render that reads its image every step allocates
/// it once. Shared with pending reads, which give it back when they end, also
/// after the buffer was dropped.
#[derive(Clone, Default)]
pub(crate) struct StagingSlot {
    slot: Arc<std::sync::Mutex<Option<RawBuffer>>>,
}

impl StagingSlot {
    /// A host-visible buffer of at least `size` bytes for `direction`: the one
    /// kept here when it is large enough, else a new one.
    pub(crate) fn take(&self, ctx: &Arc<ContextInner>, size: u64, direction: StagingDirection) -> Result<RawBuffer> {
        let kept = self.slot.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
        if let Some(buffer) = kept.filter(|b| b.size >= size) {
            return Ok(buffer);
        }
        let (what, usage, location) = match direction {
            StagingDirection::Readback => {
                ("DeviceBuffer readback", vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu)
            }
            StagingDirection::Upload => {
                ("DeviceBuffer upload", vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)
            }
        };
        RawBuffer::new(ctx, what, size, usage, location, 16)
    }

    /// Keeps `buffer` for the next copy (the work that used it has finished).
    pub(crate) fn give_back(&self, buffer: RawBuffer) {
        *self.slot.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(buffer);
    }
}
