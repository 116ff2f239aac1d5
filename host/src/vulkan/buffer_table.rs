//! The bindless buffer table: one descriptor set per context holding every live
//! [`crate::DeviceBuffer`] at a slot, so device programs reach buffers through
//! `Buffer<T>` handles in their launch params, the way OptiX programs follow
//! pointers in `Params`.
//!
//! The set has one binding (set 0, binding 0): an array of storage buffers with
//! `PARTIALLY_BOUND` and `UPDATE_AFTER_BIND`
//! ([descriptor indexing](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#descriptorsets-updates-consecutive)),
//! so slots can be filled while the set is bound and empty slots are legal.
//!
//! Slot 0 is the null handle (a zeroed `Buffer<T>`): it is never given to a
//! buffer and holds a null descriptor (`VK_EXT_robustness2`'s `nullDescriptor`),
//! as does every slot not yet given to a buffer (the table starts with null
//! descriptors in every slot) and every slot whose buffer was dropped and whose
//! pending work finished:
//! device reads through them give zero and writes are discarded. The table has
//! exactly [`raykit_abi::BUFFER_TABLE_SLOTS`] slots and device programs mask
//! handles to that range, so no handle value reaches outside the table.

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;

use ash::vk;

use std::mem::ManuallyDrop;

use crate::error::ResourceError;
use crate::error::{Error, Result};
use crate::validate::handles::{handle_value, next_generation, SLOT_BITS};
use crate::vulkan::texture_table::TextureTable;

/// The table's size.
const SLOTS: u32 = raykit_abi::BUFFER_TABLE_SLOTS;

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
    /// Free slots, the next to use last; the descriptor set is also updated
    /// under this lock.
    free: Mutex<Vec<u32>>,
    /// The generation of the live buffer in each slot, 0 when none (cleared when
    /// the buffer is dropped, before its slot waits for its pending work).
    live: Vec<AtomicU32>,
    /// The texture table, binding 1 of the same set (see [`crate::vulkan::texture_table`]).
    pub(crate) textures: ManuallyDrop<TextureTable>,
}

/// Which free slot a new entry of the table takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SlotReuse {
    /// The slot free the longest, so stale user handles stay refused longest.
    Oldest,
    /// The slot freed last: for raykit's own buffers whose slot is built into
    /// pipelines (the user-exception buffer's slot is a specialization constant), so a
    /// pipeline made again gets the same constants and hits the compile cache.
    Newest,
}

impl BufferTable {
    pub(crate) fn new(device: &ash::Device) -> Result<Self> {
        let capacity = SLOTS;

        let bindings = [
            vk::DescriptorSetLayoutBinding::default()
                .binding(raykit_abi::BUFFER_TABLE_BINDING)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(capacity)
                .stage_flags(RT_STAGES),
            crate::vulkan::texture_table::layout_binding(),
        ];
        let flags = [vk::DescriptorBindingFlags::PARTIALLY_BOUND | vk::DescriptorBindingFlags::UPDATE_AFTER_BIND; 2];
        let mut binding_flags = vk::DescriptorSetLayoutBindingFlagsCreateInfo::default().binding_flags(&flags);
        let layout_info = vk::DescriptorSetLayoutCreateInfo::default()
            .flags(vk::DescriptorSetLayoutCreateFlags::UPDATE_AFTER_BIND_POOL)
            .bindings(&bindings)
            .push_next(&mut binding_flags);
        // SAFETY: valid create info; the needed features were enabled.
        let layout = unsafe { device.create_descriptor_set_layout(&layout_info, None) }
            .map_err(Error::vk("vkCreateDescriptorSetLayout"))?;
        let sizes = [
            vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_BUFFER, descriptor_count: capacity },
            crate::vulkan::texture_table::pool_size(),
        ];
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
        // Slot 0 stays null; the others are used lowest first.
        let free = (1..capacity).rev().collect();
        let live = (0..capacity).map(|_| AtomicU32::new(0)).collect();
        let textures = match TextureTable::new(device, set) {
            Ok(t) => t,
            Err(e) => {
                // SAFETY: both objects are unused.
                unsafe {
                    device.destroy_descriptor_pool(pool, None);
                    device.destroy_descriptor_set_layout(layout, None);
                }
                return Err(e);
            }
        };
        let textures = ManuallyDrop::new(textures);
        let table = BufferTable { layout, pool, set, capacity, free: Mutex::new(free), live, textures };
        // Every slot starts as a null descriptor, slot 0 and never-used slots alike: a
        // partially bound array's unwritten descriptors are undefined to access, null
        // ones read zero (`nullDescriptor`), which is what `Buffer<T>` promises.
        let nulls = vec![
            vk::DescriptorBufferInfo { buffer: vk::Buffer::null(), offset: 0, range: vk::WHOLE_SIZE };
            capacity as usize
        ];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(table.set)
            .dst_binding(raykit_abi::BUFFER_TABLE_BINDING)
            .dst_array_element(0)
            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
            .buffer_info(&nulls);
        // SAFETY: the set is new and owned here; `nullDescriptor` is enabled.
        unsafe { device.update_descriptor_sets(&[write], &[]) };
        Ok(table)
    }

    /// Points `slot` at `buffer` (or the null descriptor).
    fn write(&self, device: &ash::Device, slot: u32, buffer: vk::Buffer) {
        let info = [vk::DescriptorBufferInfo { buffer, offset: 0, range: vk::WHOLE_SIZE }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(self.set)
            .dst_binding(raykit_abi::BUFFER_TABLE_BINDING)
            .dst_array_element(slot)
            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
            .buffer_info(&info);
        // SAFETY: the set is externally synchronised: callers hold the `free` lock
        // or own the table exclusively; the binding is UPDATE_AFTER_BIND, so pending
        // launches are unaffected, and `nullDescriptor` is enabled for null buffers.
        unsafe { device.update_descriptor_sets(&[write], &[]) };
    }

    /// Whether `handle` is the null handle or names the live buffer of its slot.
    pub(crate) fn is_live(&self, handle: u32) -> bool {
        let (slot, generation) = (handle & (SLOTS - 1), handle >> SLOT_BITS);
        handle == 0 || (generation != 0 && self.live[slot as usize].load(Ordering::Acquire) == generation)
    }

    /// Marks `slot` as no longer holding a live buffer (its buffer was dropped);
    /// launches refuse handles to it from now on.
    pub(crate) fn kill(&self, slot: u32) {
        if let Some(l) = self.live.get(slot as usize) {
            l.store(0, Ordering::Release);
        }
    }

    /// Takes a free slot and points it at `buffer`; returns the slot and the
    /// handle value (slot and generation) of the buffer.
    pub(crate) fn insert(&self, device: &ash::Device, buffer: vk::Buffer) -> Result<(u32, u32)> {
        self.insert_with(device, buffer, SlotReuse::Oldest)
    }

    /// [`BufferTable::insert`], choosing the slot by `reuse`.
    pub(crate) fn insert_with(&self, device: &ash::Device, buffer: vk::Buffer, reuse: SlotReuse) -> Result<(u32, u32)> {
        let mut free = self.free.lock().unwrap_or_else(|p| p.into_inner());
        // Freed slots go to the front, so the back holds the slot free the longest.
        let taken = match reuse {
            SlotReuse::Oldest => free.pop(),
            SlotReuse::Newest => (!free.is_empty()).then(|| free.remove(0)),
        };
        // Slot 0 is the null handle: one less than the table for buffers.
        let slot = taken.ok_or(Error::Resource(ResourceError::BufferTableFull { capacity: self.capacity - 1 }))?;
        self.write(device, slot, buffer);
        let generation = next_generation();
        if let Some(l) = self.live.get(slot as usize) {
            l.store(generation, Ordering::Release);
        }
        Ok((slot, handle_value(slot, generation)))
    }

    /// Returns a slot to the free list, once no pending work uses it (see
    /// [`crate::timeline`]).
    pub(crate) fn remove(&self, device: &ash::Device, slot: u32) {
        let mut free = self.free.lock().unwrap_or_else(|p| p.into_inner());
        // Reads through a stale handle give zero from now on.
        self.write(device, slot, vk::Buffer::null());
        // Reused last (first in, first out), so stale handles stay refused longest.
        free.insert(0, slot);
    }

    /// # Safety
    /// The device must be idle and no other object may use the table.
    pub(crate) unsafe fn destroy(mut self, device: &ash::Device) {
        // SAFETY: per the contract above.
        unsafe {
            ManuallyDrop::take(&mut self.textures).destroy(device);
            device.destroy_descriptor_pool(self.pool, None);
            device.destroy_descriptor_set_layout(self.layout, None);
        }
    }
}
