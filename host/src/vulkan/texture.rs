//! Textures on Vulkan: an image (optimal tiling, `SAMPLED | TRANSFER_DST`)
//! uploaded through a staging buffer, its view and sampler, at a slot of the
//! context's bindless texture table (see [`crate::texture`]).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use crate::error::DeviceError;
use crate::error::{Error, Result};
use crate::types::texture::{Filter, FormatSupport, MipLevel, SamplerOptions, TextureFormat};
use crate::vulkan::context::ContextInner;
use crate::vulkan::conv;
use crate::vulkan::memory::RawBuffer;
use crate::vulkan::timeline::Retired;

/// A Vulkan image, its view, sampler and memory; freed (once no pending work
/// uses them) when dropped.
pub(crate) struct VulkanImage {
    ctx: Arc<ContextInner>,
    image: vk::Image,
    view: vk::ImageView,
    sampler: vk::Sampler,
    allocation: Option<Allocation>,
}

impl VulkanImage {
    /// Empties the texture's table slot: launches refuse its handle from now on,
    /// and the slot is reused once no pending work can sample it; the image is
    /// freed after it (when `self` drops).
    pub(crate) fn release_slot(&self, slot: u32) {
        self.ctx.buffer_table.textures.kill(slot);
        self.ctx.retire(Retired::TextureSlot(slot));
    }
}

impl Drop for VulkanImage {
    fn drop(&mut self) {
        self.ctx.retire(Retired::Image(self.image, self.view, self.sampler, self.allocation.take()));
    }
}

/// The device's filtering precision: `(subTexelPrecisionBits, mipmapPrecisionBits)`.
pub(crate) fn filter_precision_bits(inner: &ContextInner) -> (u32, u32) {
    let limits = &inner.shared.properties.limits;
    (limits.sub_texel_precision_bits, limits.mipmap_precision_bits)
}

/// The largest width and height of a texture on the device (`maxImageDimension2D`).
pub(crate) fn max_texture_size(inner: &ContextInner) -> u32 {
    inner.shared.properties.limits.max_image_dimension2_d
}

/// What the device can do with `format` in optimal tiling: sample it (and
/// upload it), filter it linearly, and its feature flags as text for errors.
pub(crate) fn format_support(inner: &ContextInner, format: TextureFormat) -> FormatSupport {
    // SAFETY: the physical device belongs to this instance.
    let props =
        unsafe { inner.instance.get_physical_device_format_properties(inner.shared.physical, conv::format(format)) };
    let features = props.optimal_tiling_features;
    FormatSupport {
        sampled: features.contains(vk::FormatFeatureFlags::SAMPLED_IMAGE | vk::FormatFeatureFlags::TRANSFER_DST),
        linear_filter: features.contains(vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR),
        features: format!("optimal-tiling features {features:?}"),
    }
}

/// Creates the Vulkan image, uploads `levels` (checked), makes the view and
/// sampler and takes a table slot; returns the image, its slot and its handle.
pub(crate) fn create(
    inner: &Arc<ContextInner>,
    format: TextureFormat,
    (width, height): (u32, u32),
    levels: &[MipLevel],
    options: SamplerOptions,
) -> Result<(VulkanImage, u32, u32)> {
    inner.check_device("a texture creation")?;
    let level_count = levels.len() as u32;
    // Wrapped at once: an early return frees whatever exists (null handles are no-ops).
    let mut texture = VulkanImage {
        ctx: inner.clone(),
        image: vk::Image::null(),
        view: vk::ImageView::null(),
        sampler: vk::Sampler::null(),
        allocation: None,
    };
    allocate_image(inner, &mut texture, format, (width, height), level_count)?;
    let range = vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count,
        base_array_layer: 0,
        layer_count: 1,
    };
    upload_levels(inner, texture.image, levels, range)?;
    create_view_and_sampler(inner, &mut texture, format, range, options)?;
    let table = &inner.buffer_table;
    let (slot, handle) = table.textures.insert(&inner.device, table.set, texture.view, texture.sampler)?;
    Ok((texture, slot, handle))
}

/// Creates `texture`'s image of `format`, `width × height` with `level_count`
/// mip levels, in device-local memory bound to it.
fn allocate_image(
    inner: &Arc<ContextInner>,
    texture: &mut VulkanImage,
    format: TextureFormat,
    (width, height): (u32, u32),
    level_count: u32,
) -> Result<()> {
    let device = &inner.device;
    let info = vk::ImageCreateInfo::default()
        .image_type(vk::ImageType::TYPE_2D)
        .format(conv::format(format))
        .extent(vk::Extent3D { width, height, depth: 1 })
        .mip_levels(level_count)
        .array_layers(1)
        .samples(vk::SampleCountFlags::TYPE_1)
        .tiling(vk::ImageTiling::OPTIMAL)
        .usage(vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST)
        .sharing_mode(vk::SharingMode::EXCLUSIVE)
        .initial_layout(vk::ImageLayout::UNDEFINED);
    // SAFETY: valid create info (size and format checked against the device).
    texture.image = unsafe { device.create_image(&info, None) }.map_err(Error::vk("vkCreateImage"))?;
    inner.set_name(texture.image, "texture");
    // SAFETY: a live image of this device.
    let requirements = unsafe { device.get_image_memory_requirements(texture.image) };
    let allocation = inner
        .allocator()
        .allocate(&AllocationCreateDesc {
            name: "texture",
            requirements,
            location: MemoryLocation::GpuOnly,
            linear: false,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        })
        .map_err(|source| Error::Device(DeviceError::Allocation { what: "a texture", source }))?;
    // SAFETY: the allocation satisfies the image's requirements; the image is unbound.
    let bound = unsafe { device.bind_image_memory(texture.image, allocation.memory(), allocation.offset()) };
    texture.allocation = Some(allocation);
    bound.map_err(Error::vk("vkBindImageMemory"))?;

    Ok(())
}

/// Uploads `levels` into `image` through a staging buffer and leaves it ready
/// for ray-tracing shaders to sample; waits for the copy.
fn upload_levels(
    inner: &Arc<ContextInner>,
    image: vk::Image,
    levels: &[MipLevel],
    range: vk::ImageSubresourceRange,
) -> Result<()> {
    let device = &inner.device;
    // Staging: each level at a 16-byte aligned offset (a multiple of every texel size).
    let mut offsets = Vec::with_capacity(levels.len());
    let mut total = 0u64;
    for level in levels {
        offsets.push(total);
        total = (total + level.data.len() as u64).next_multiple_of(16);
    }
    let mut staging = RawBuffer::new(
        inner,
        "texture staging buffer",
        total,
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::CpuToGpu,
        16,
    )?;
    let mapped = staging.mapped_mut().ok_or(Error::Device(DeviceError::Allocation {
        what: "a texture staging buffer",
        source: gpu_allocator::AllocationError::FailedToMap("not host-visible".to_owned()),
    }))?;
    for (level, &offset) in levels.iter().zip(&offsets) {
        mapped[offset as usize..offset as usize + level.data.len()].copy_from_slice(&level.data);
    }
    let regions: Vec<vk::BufferImageCopy> = levels
        .iter()
        .zip(&offsets)
        .enumerate()
        .map(|(i, (level, &offset))| vk::BufferImageCopy {
            buffer_offset: offset,
            buffer_row_length: 0,
            buffer_image_height: 0,
            image_subresource: vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                mip_level: i as u32,
                base_array_layer: 0,
                layer_count: 1,
            },
            image_offset: vk::Offset3D::default(),
            image_extent: vk::Extent3D { width: level.width, height: level.height, depth: 1 },
        })
        .collect();
    let src = staging.buffer;
    let mut submission = inner.submit("a texture upload", |cmd| {
        let to_transfer = vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::empty())
            .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(range);
        let to_shader = vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::SHADER_READ)
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(range);
        // SAFETY: the image and staging buffer are alive until the submission has
        // finished (it is waited on below); the regions lie inside both.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_transfer],
            );
            device.cmd_copy_buffer_to_image(cmd, src, image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &regions);
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_shader],
            );
        }
    })?;
    submission.wait()?;
    drop(staging);

    Ok(())
}

/// Makes `texture`'s view over `range` and its sampler of `options`.
fn create_view_and_sampler(
    inner: &Arc<ContextInner>,
    texture: &mut VulkanImage,
    format: TextureFormat,
    range: vk::ImageSubresourceRange,
    options: SamplerOptions,
) -> Result<()> {
    let device = &inner.device;
    let level_count = range.level_count;
    let view_info = vk::ImageViewCreateInfo::default()
        .image(texture.image)
        .view_type(vk::ImageViewType::TYPE_2D)
        .format(conv::format(format))
        .subresource_range(range);
    // SAFETY: a live, bound image with this format and range.
    texture.view = unsafe { device.create_image_view(&view_info, None) }.map_err(Error::vk("vkCreateImageView"))?;
    let sampler_info = vk::SamplerCreateInfo::default()
        .mag_filter(conv::filter(options.filter))
        .min_filter(conv::filter(options.filter))
        .mipmap_mode(match options.mip_filter {
            Filter::Nearest => vk::SamplerMipmapMode::NEAREST,
            Filter::Linear => vk::SamplerMipmapMode::LINEAR,
        })
        .address_mode_u(conv::address_mode(options.address_u))
        .address_mode_v(conv::address_mode(options.address_v))
        .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
        .min_lod(0.0)
        .max_lod(level_count as f32);
    // SAFETY: valid create info; filters are supported for the format (checked).
    texture.sampler = unsafe { device.create_sampler(&sampler_info, None) }.map_err(Error::vk("vkCreateSampler"))?;
    Ok(())
}
