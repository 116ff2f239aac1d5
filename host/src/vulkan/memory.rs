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
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
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

    /// Submits a copy of the whole buffer into a new host-visible one: the
    /// submission, and the copy, to read once the submission has finished.
    pub(crate) fn read_back(&self) -> Result<(Submission, RawBuffer)> {
        let ctx = &self.ctx;
        let staging = RawBuffer::new(
            ctx,
            "DeviceBuffer readback",
            self.size,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
            16,
        )?;
        let (src, dst, size) = (self.buffer, staging.buffer, self.size);
        let submission = ctx.submit("a buffer readback", |cmd| {
            // SAFETY: both buffers are alive while the copy is pending (the caller
            // keeps `staging` until the submission has finished, and the source's
            // drop waits for this epoch); `cmd` is recording; the sizes match.
            unsafe {
                let device = &ctx.device;
                memory_barrier(
                    device,
                    cmd,
                    vk::PipelineStageFlags::ALL_COMMANDS,
                    vk::AccessFlags::MEMORY_WRITE,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::AccessFlags::TRANSFER_READ,
                );
                device.cmd_copy_buffer(cmd, src, dst, &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size }]);
                // Also orders the copy before every later command (a launch that
                // writes the buffer next starts with no barrier of its own; see
                // `crate::vulkan::pipeline::record`).
                memory_barrier(
                    device,
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::PipelineStageFlags::HOST | vk::PipelineStageFlags::ALL_COMMANDS,
                    vk::AccessFlags::HOST_READ | vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE,
                );
            }
        })?;
        Ok((submission, staging))
    }
}
