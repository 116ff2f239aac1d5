//! The bindless buffer table: one descriptor set per context holding every live
//! [`crate::DeviceBuffer`] at a slot, so device programs reach buffers through
//! `Buffer<T>` handles in their launch params, the way OptiX programs follow
//! pointers in `Params`.
//!
//! The set has one binding (set 0, binding 0): an array of storage buffers with
//! `PARTIALLY_BOUND` and `UPDATE_AFTER_BIND`
//! ([descriptor indexing](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#descriptorsets-updates-consecutive)),
//! so slots can be filled while the set is bound and empty slots are legal.

use std::sync::Mutex;

use ash::vk;

use crate::error::{Error, Result};

/// Upper bound of the table's size; the device's limits may lower it.
const MAX_SLOTS: u32 = 4096;

/// Stages that see the table.
pub(crate) const RT_STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
    vk::ShaderStageFlags::RAYGEN_KHR.as_raw()
        | vk::ShaderStageFlags::MISS_KHR.as_raw()
        | vk::ShaderStageFlags::CLOSEST_HIT_KHR.as_raw()
        | vk::ShaderStageFlags::ANY_HIT_KHR.as_raw()
        | vk::ShaderStageFlags::INTERSECTION_KHR.as_raw()
        | vk::ShaderStageFlags::CALLABLE_KHR.as_raw(),
);

pub(crate) struct BufferTable {
    pub(crate) layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    pub(crate) set: vk::DescriptorSet,
    capacity: u32,
    /// Free slots; the descriptor set is also updated under this lock.
    free: Mutex<Vec<u32>>,
}

impl BufferTable {
    pub(crate) fn new(device: &ash::Device, instance: &ash::Instance, physical: vk::PhysicalDevice) -> Result<Self> {
        let mut indexing = vk::PhysicalDeviceDescriptorIndexingProperties::default();
        let mut props = vk::PhysicalDeviceProperties2::default().push_next(&mut indexing);
        // SAFETY: well-formed chain; `physical` belongs to `instance`.
        unsafe { instance.get_physical_device_properties2(physical, &mut props) };
        let capacity = MAX_SLOTS
            .min(indexing.max_per_stage_descriptor_update_after_bind_storage_buffers)
            .min(indexing.max_descriptor_set_update_after_bind_storage_buffers)
            .max(1);

        let bindings = [vk::DescriptorSetLayoutBinding::default()
            .binding(raykit_abi::BUFFER_TABLE_BINDING)
            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
            .descriptor_count(capacity)
            .stage_flags(RT_STAGES)];
        let flags = [vk::DescriptorBindingFlags::PARTIALLY_BOUND | vk::DescriptorBindingFlags::UPDATE_AFTER_BIND];
        let mut binding_flags = vk::DescriptorSetLayoutBindingFlagsCreateInfo::default().binding_flags(&flags);
        let layout_info = vk::DescriptorSetLayoutCreateInfo::default()
            .flags(vk::DescriptorSetLayoutCreateFlags::UPDATE_AFTER_BIND_POOL)
            .bindings(&bindings)
            .push_next(&mut binding_flags);
        // SAFETY: valid create info; the needed features were enabled.
        let layout = unsafe { device.create_descriptor_set_layout(&layout_info, None) }
            .map_err(Error::vk("vkCreateDescriptorSetLayout"))?;
        let sizes = [vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_BUFFER, descriptor_count: capacity }];
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .flags(vk::DescriptorPoolCreateFlags::UPDATE_AFTER_BIND)
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        let pool = match unsafe { device.create_descriptor_pool(&pool_info, None) } {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: the layout is unused.
                unsafe { device.destroy_descriptor_set_layout(layout, None) };
                return Err(Error::vk("vkCreateDescriptorPool")(e));
            }
        };
        let layouts = [layout];
        let alloc = vk::DescriptorSetAllocateInfo::default().descriptor_pool(pool).set_layouts(&layouts);
        // SAFETY: the pool has room for this one set.
        let set = match unsafe { device.allocate_descriptor_sets(&alloc) } {
            Ok(sets) => sets[0],
            Err(e) => {
                // SAFETY: both objects are unused.
                unsafe {
                    device.destroy_descriptor_pool(pool, None);
                    device.destroy_descriptor_set_layout(layout, None);
                }
                return Err(Error::vk("vkAllocateDescriptorSets")(e));
            }
        };
        let free = (0..capacity).rev().collect();
        Ok(BufferTable { layout, pool, set, capacity, free: Mutex::new(free) })
    }

    /// Takes a free slot and points it at `buffer`.
    pub(crate) fn insert(&self, device: &ash::Device, buffer: vk::Buffer) -> Result<u32> {
        let mut free = self.free.lock().unwrap_or_else(|p| p.into_inner());
        let slot = free.pop().ok_or(Error::BufferTableFull { capacity: self.capacity })?;
        let info = [vk::DescriptorBufferInfo { buffer, offset: 0, range: vk::WHOLE_SIZE }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(self.set)
            .dst_binding(raykit_abi::BUFFER_TABLE_BINDING)
            .dst_array_element(slot)
            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
            .buffer_info(&info);
        // SAFETY: the set is externally synchronised by the `free` lock held; the
        // binding is UPDATE_AFTER_BIND so pending launches are unaffected.
        unsafe { device.update_descriptor_sets(&[write], &[]) };
        Ok(slot)
    }

    /// Returns a slot to the free list, once no pending work uses it (see
    /// [`crate::timeline`]).
    pub(crate) fn remove(&self, _device: &ash::Device, slot: u32) {
        self.free.lock().unwrap_or_else(|p| p.into_inner()).push(slot);
    }

    /// # Safety
    /// The device must be idle and no other object may use the table.
    pub(crate) unsafe fn destroy(self, device: &ash::Device) {
        // SAFETY: per the contract above.
        unsafe {
            device.destroy_descriptor_pool(self.pool, None);
            device.destroy_descriptor_set_layout(self.layout, None);
        }
    }
}
