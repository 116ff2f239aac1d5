//! SBTs on Vulkan: the packed records in a host-visible buffer with
//! `SHADER_BINDING_TABLE_KHR` usage, and the regions `vkCmdTraceRaysKHR` is
//! given (see [`crate::sbt`]).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::error::SbtError;
use crate::error::{Error, Result};
use crate::types::sbt::{PlainRecord, RegionLayout, SbtRegion};
use crate::vulkan::memory::RawBuffer;
use crate::vulkan::pipeline::link::PipelineInner;

/// An SBT's records in a Vulkan buffer, and its regions' device addresses.
pub(crate) struct VulkanSbt {
    pub(crate) pipeline: Arc<PipelineInner>,
    pub(crate) raygen: vk::StridedDeviceAddressRegionKHR,
    pub(crate) miss: vk::StridedDeviceAddressRegionKHR,
    pub(crate) hit: vk::StridedDeviceAddressRegionKHR,
    pub(crate) callable: vk::StridedDeviceAddressRegionKHR,
    /// Shared with launches in flight ([`crate::Launch`]), which keep it alive.
    pub(crate) buffer: Arc<RawBuffer>,
    /// The exception program's index in the callable region, if the pipeline has one.
    pub(crate) exception_index: Option<u32>,
}

impl VulkanSbt {
    /// Packs the checked records of `regions` (raygen, miss, hit, callable) of
    /// `pipeline`, each its group's handle then its data, laid out as `layouts`
    /// say in `total` bytes, and uploads them; the exception program (if any)
    /// is at `exception_index` in the callable region.
    pub(crate) fn new(
        pipeline: &Arc<PipelineInner>,
        regions: &[Vec<PlainRecord<'_>>; 4],
        layouts: [RegionLayout; 4],
        total: u64,
        exception_index: Option<u32>,
    ) -> Result<VulkanSbt> {
        let mut bytes = Vec::new();
        usize::try_from(total)
            .ok()
            .and_then(|n| bytes.try_reserve_exact(n).ok())
            .ok_or(Error::Sbt(SbtError::TooLarge { bytes: total }))?;
        bytes.resize(total as usize, 0u8);
        let handle_size = pipeline.ctx.limits.shader_group_handle_size as usize;
        for (layout, records) in layouts.iter().zip(regions) {
            for (i, record) in records.iter().enumerate() {
                let at = (layout.offset + layout.stride * i as u64) as usize;
                let handle = &pipeline.handles[record.group * handle_size..][..handle_size];
                bytes[at..at + handle_size].copy_from_slice(handle);
                bytes[at + handle_size..at + handle_size + record.data.len()].copy_from_slice(record.data);
            }
        }
        let bytes = &bytes[..];
        let [rg, ms, ht, cl] = layouts;
        let mut buffer = RawBuffer::new(
            &pipeline.ctx,
            "shader binding table",
            bytes.len() as u64,
            vk::BufferUsageFlags::SHADER_BINDING_TABLE_KHR,
            MemoryLocation::CpuToGpu,
            pipeline.ctx.limits.shader_group_base_alignment as u64,
        )?;
        buffer.write_bytes(bytes)?;
        let region = |l: RegionLayout| vk::StridedDeviceAddressRegionKHR {
            device_address: if l.size == 0 { 0 } else { buffer.address + l.offset },
            stride: l.stride,
            size: l.size,
        };
        Ok(VulkanSbt {
            pipeline: pipeline.clone(),
            raygen: region(rg),
            miss: region(ms),
            hit: region(ht),
            callable: region(cl),
            buffer: Arc::new(buffer),
            exception_index,
        })
    }

    /// The raygen, miss, hit and callable regions.
    pub(crate) fn regions(&self) -> [vk::StridedDeviceAddressRegionKHR; 4] {
        [self.raygen, self.miss, self.hit, self.callable]
    }

    /// Writes `bytes` at byte `at` of the buffer (data of a record of `region`,
    /// checked to fit).
    pub(crate) fn write(&mut self, region: SbtRegion, at: usize, bytes: &[u8]) -> Result<()> {
        // A launch in flight holds a clone of the buffer: the device may be reading
        // it. Write into a copy, which launches from now on use.
        if Arc::get_mut(&mut self.buffer).is_none() {
            self.copy_on_write(region)?;
        }
        let buffer = Arc::get_mut(&mut self.buffer)
            .ok_or(Error::Sbt(SbtError::Update { region, reason: "the SBT buffer is shared".to_owned() }))?;
        let mapped = buffer
            .mapped_mut()
            .ok_or(Error::Sbt(SbtError::Update { region, reason: "the SBT buffer is not host-visible".to_owned() }))?;
        mapped[at..at + bytes.len()].copy_from_slice(bytes);
        Ok(())
    }

    /// Replaces the buffer with a copy of it, for an update while launches use it.
    fn copy_on_write(&mut self, region: SbtRegion) -> Result<()> {
        let old = &*self.buffer;
        let ctx = &self.pipeline.ctx;
        let mut copy = RawBuffer::new(
            ctx,
            "shader binding table",
            old.size,
            vk::BufferUsageFlags::SHADER_BINDING_TABLE_KHR,
            MemoryLocation::CpuToGpu,
            ctx.limits.shader_group_base_alignment as u64,
        )?;
        let bytes = old
            .mapped()
            .ok_or(Error::Sbt(SbtError::Update { region, reason: "the SBT buffer is not host-visible".to_owned() }))?;
        copy.write_bytes(bytes)?;
        let (from, to) = (old.address, copy.address);
        for r in [&mut self.raygen, &mut self.miss, &mut self.hit, &mut self.callable] {
            if r.size != 0 {
                r.device_address = r.device_address - from + to;
            }
        }
        self.buffer = Arc::new(copy);
        Ok(())
    }
}
