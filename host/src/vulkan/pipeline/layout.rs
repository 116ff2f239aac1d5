//! The pipeline layout every raykit pipeline and library has for its launch params
//! `P`: the context's bindless buffer table at set 0, and the params either as a
//! push-constant range or as a uniform buffer at set 1, binding 0 (when `P` is over
//! [`PUSH_CONSTANT_BUDGET`](raykit_device::PUSH_CONSTANT_BUDGET) bytes). Pipelines and
//! libraries made for one `P` get compatible layouts, as linking requires. See
//! [`VkPipelineLayoutCreateInfo`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkPipelineLayoutCreateInfo.html).

use std::sync::Arc;

use ash::vk;
use raykit_device::LaunchParams;
use raykit_spirv::ParamsDelivery;

use crate::error::{Error, Result};
use crate::types::program::params_delivery;
use crate::vulkan::buffer_table::RT_STAGES;
use crate::vulkan::context::ContextInner;
use crate::vulkan::memory::RawBuffer;

/// The set layout of the params uniform buffer (set 1). Its one owner is the
/// [`PipelineLayout`] made with it.
pub(crate) struct ParamsSetLayout {
    ctx: Arc<ContextInner>,
    pub(crate) handle: vk::DescriptorSetLayout,
}

impl ParamsSetLayout {
    fn new(ctx: &Arc<ContextInner>) -> Result<ParamsSetLayout> {
        let bindings = [vk::DescriptorSetLayoutBinding::default()
            .binding(raykit_device::PARAMS_BINDING)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .descriptor_count(1)
            .stage_flags(RT_STAGES)];
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid create info on a live device.
        let handle = unsafe { ctx.device.create_descriptor_set_layout(&info, None) }
            .map_err(Error::vk("vkCreateDescriptorSetLayout"))?;
        Ok(ParamsSetLayout { ctx: ctx.clone(), handle })
    }
}

impl Drop for ParamsSetLayout {
    fn drop(&mut self) {
        // Destroyed once the work that may use it has finished (see `crate::timeline`).
        self.ctx.retire(crate::vulkan::timeline::Retired::DescriptorSetLayout(self.handle));
    }
}

/// The pipeline layout for params `P`, with the params set layout when `P` goes
/// through a uniform buffer.
pub(crate) struct PipelineLayout {
    ctx: Arc<ContextInner>,
    pub(crate) handle: vk::PipelineLayout,
    /// Bytes of push constants each launch pushes (0 when the params go through a
    /// uniform buffer).
    pub(crate) push_constant_size: u32,
    /// Set 1, for params over the push-constant budget; dropped after the layout.
    pub(crate) params_set: Option<ParamsSetLayout>,
}

impl PipelineLayout {
    /// The layout for params `P`.
    pub(crate) fn new<P: LaunchParams>(ctx: &Arc<ContextInner>) -> Result<PipelineLayout> {
        let params_set = match params_delivery::<P>() {
            ParamsDelivery::PushConstants => None,
            ParamsDelivery::UniformBuffer { .. } => Some(ParamsSetLayout::new(ctx)?),
        };
        let mut set_layouts = vec![ctx.buffer_table.layout];
        set_layouts.extend(params_set.as_ref().map(|s| s.handle));
        let push_constant_size = if params_set.is_some() { 0 } else { std::mem::size_of::<P>() as u32 };
        let push_ranges = [vk::PushConstantRange { stage_flags: RT_STAGES, offset: 0, size: push_constant_size }];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if push_constant_size > 0 {
            layout_info = layout_info.push_constant_ranges(&push_ranges);
        }
        // SAFETY: valid create info; the set layouts outlive the layout (the params
        // set layout is dropped after it).
        let handle = unsafe { ctx.device.create_pipeline_layout(&layout_info, None) }
            .map_err(Error::vk("vkCreatePipelineLayout"))?;
        ctx.set_name(handle, "raykit pipeline layout");
        Ok(PipelineLayout { ctx: ctx.clone(), handle, push_constant_size, params_set })
    }
}

impl Drop for PipelineLayout {
    fn drop(&mut self) {
        // Destroyed once the work that may use it has finished (see `crate::timeline`).
        self.ctx.retire(crate::vulkan::timeline::Retired::PipelineLayout(self.handle));
    }
}

/// A uniform buffer holding the launch params, with its descriptor set (allocated
/// with the pipeline layout's params set layout, which outlives it).
pub(crate) struct ParamsUniform {
    ctx: Arc<ContextInner>,
    pool: vk::DescriptorPool,
    pub(crate) set: vk::DescriptorSet,
    /// Device memory, written by each launch's command buffer
    /// (`vkCmdUpdateBuffer`), so every launch carries its own params and launches in
    /// flight never share host-visible state.
    pub(crate) buffer: Option<RawBuffer>,
    /// Bytes each launch writes (the params' size rounded up to 4, as
    /// `vkCmdUpdateBuffer` requires).
    pub(crate) size: u64,
}

impl ParamsUniform {
    /// The params uniform buffer for `layout`'s params of `P`, if they go through one.
    pub(crate) fn for_layout<P: LaunchParams>(
        ctx: &Arc<ContextInner>,
        layout: &PipelineLayout,
    ) -> Result<Option<ParamsUniform>> {
        match &layout.params_set {
            None => Ok(None),
            Some(set_layout) => {
                Ok(Some(ParamsUniform::new(ctx, set_layout, (std::mem::size_of::<P>() as u64).next_multiple_of(4))?))
            }
        }
    }

    fn new(ctx: &Arc<ContextInner>, set_layout: &ParamsSetLayout, size: u64) -> Result<ParamsUniform> {
        let device = &ctx.device;
        // Wrapped at once, so an early return frees what exists.
        let mut uniform = ParamsUniform {
            ctx: ctx.clone(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            buffer: None,
            size,
        };
        let sizes = [vk::DescriptorPoolSize { ty: vk::DescriptorType::UNIFORM_BUFFER, descriptor_count: 1 }];
        let pool_info = vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes);
        // SAFETY: valid create info on a live device.
        uniform.pool =
            unsafe { device.create_descriptor_pool(&pool_info, None) }.map_err(Error::vk("vkCreateDescriptorPool"))?;
        let layouts = [set_layout.handle];
        let alloc = vk::DescriptorSetAllocateInfo::default().descriptor_pool(uniform.pool).set_layouts(&layouts);
        // SAFETY: the pool has room for exactly this set.
        uniform.set =
            unsafe { device.allocate_descriptor_sets(&alloc) }.map_err(Error::vk("vkAllocateDescriptorSets"))?[0];
        let buffer = RawBuffer::new(
            ctx,
            "launch params uniform buffer",
            size,
            vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            gpu_allocator::MemoryLocation::GpuOnly,
            ctx.limits.min_uniform_buffer_offset_alignment.max(16),
        )?;
        let buffer_info = [vk::DescriptorBufferInfo { buffer: buffer.buffer, offset: 0, range: size }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(uniform.set)
            .dst_binding(raykit_device::PARAMS_BINDING)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .buffer_info(&buffer_info);
        // SAFETY: the set and buffer are alive; the set is not in use yet.
        unsafe { device.update_descriptor_sets(&[write], &[]) };
        uniform.buffer = Some(buffer);
        Ok(uniform)
    }
}

impl Drop for ParamsUniform {
    fn drop(&mut self) {
        // Destroyed (with its set) once the launches that may use it have finished.
        self.ctx.retire(crate::vulkan::timeline::Retired::DescriptorPool(self.pool));
    }
}
