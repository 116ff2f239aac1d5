//! The bindless texture table: binding 1 of the buffer table's descriptor set
//! (set 0), an array of [`raykit_abi::TEXTURE_TABLE_SLOTS`] combined image
//! samplers with `PARTIALLY_BOUND | UPDATE_AFTER_BIND`, each live
//! [`crate::Texture`] at a slot. `Texture2D` handles in params and records name a
//! slot in their low 12 bits and a generation above, checked by every launch as
//! buffer handles are (see [`crate::validate::handles`]).
//!
//! Slot 0 is the null handle. Every slot not holding a texture holds a null
//! image view (`nullDescriptor`) with a default sampler, so sampling through it
//! returns zero.

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;

use ash::vk;

use crate::error::ResourceError;
use crate::error::{Error, Result};
use crate::validate::handles::{handle_value, next_generation};
use crate::vulkan::buffer_table::RT_STAGES;

/// The table's size.
pub(crate) const SLOTS: u32 = raykit_abi::TEXTURE_TABLE_SLOTS;

/// The table's binding in the buffer table's set layout.
pub(crate) fn layout_binding() -> vk::DescriptorSetLayoutBinding<'static> {
    vk::DescriptorSetLayoutBinding::default()
        .binding(raykit_abi::TEXTURE_TABLE_BINDING)
        .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
        .descriptor_count(SLOTS)
        .stage_flags(RT_STAGES)
}

/// The pool size the table needs.
pub(crate) fn pool_size() -> vk::DescriptorPoolSize {
    vk::DescriptorPoolSize { ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, descriptor_count: SLOTS }
}

pub(crate) struct TextureTable {
    /// The sampler of empty slots (a combined image sampler needs one even with a null view).
    default_sampler: vk::Sampler,
    /// Free slots, the next to use last; descriptor writes happen under this lock.
    free: Mutex<Vec<u32>>,
    /// The generation of the live texture in each slot, 0 when none.
    live: Vec<AtomicU32>,
}

impl TextureTable {
    /// The table in `set` (binding [`raykit_abi::TEXTURE_TABLE_BINDING`]), every slot null.
    pub(crate) fn new(device: &ash::Device, set: vk::DescriptorSet) -> Result<TextureTable> {
        let info = vk::SamplerCreateInfo::default();
        // SAFETY: valid create info on a live device.
        let default_sampler = unsafe { device.create_sampler(&info, None) }.map_err(Error::vk("vkCreateSampler"))?;
        let table = TextureTable {
            default_sampler,
            free: Mutex::new((1..SLOTS).rev().collect()),
            live: (0..SLOTS).map(|_| AtomicU32::new(0)).collect(),
        };
        let nulls = vec![
            vk::DescriptorImageInfo {
                sampler: default_sampler,
                image_view: vk::ImageView::null(),
                image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            };
            SLOTS as usize
        ];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(set)
            .dst_binding(raykit_abi::TEXTURE_TABLE_BINDING)
            .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .image_info(&nulls);
        // SAFETY: the set is new and owned by the buffer table; `nullDescriptor` is enabled.
        unsafe { device.update_descriptor_sets(&[write], &[]) };
        Ok(table)
    }

    fn write(
        &self,
        device: &ash::Device,
        set: vk::DescriptorSet,
        slot: u32,
        view: vk::ImageView,
        sampler: vk::Sampler,
    ) {
        let info = [vk::DescriptorImageInfo {
            sampler,
            image_view: view,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(set)
            .dst_binding(raykit_abi::TEXTURE_TABLE_BINDING)
            .dst_array_element(slot)
            .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .image_info(&info);
        // SAFETY: callers hold the `free` lock; the binding is UPDATE_AFTER_BIND, so
        // pending launches are unaffected; a null view is allowed (`nullDescriptor`).
        unsafe { device.update_descriptor_sets(&[write], &[]) };
    }

    /// Takes a free slot for `view` sampled with `sampler`; returns the slot and the handle value.
    pub(crate) fn insert(
        &self,
        device: &ash::Device,
        set: vk::DescriptorSet,
        view: vk::ImageView,
        sampler: vk::Sampler,
    ) -> Result<(u32, u32)> {
        let mut free = self.free.lock().unwrap_or_else(|p| p.into_inner());
        let slot = free.pop().ok_or(Error::Resource(ResourceError::TextureTableFull { capacity: SLOTS - 1 }))?;
        self.write(device, set, slot, view, sampler);
        let generation = next_generation();
        self.live[slot as usize].store(generation, Ordering::Release);
        Ok((slot, handle_value(slot, generation)))
    }

    /// Whether `handle` is the null handle or names the live texture of its slot.
    pub(crate) fn is_live(&self, handle: u32) -> bool {
        let slot = handle & (SLOTS - 1);
        let generation = handle >> SLOTS.trailing_zeros();
        handle == 0 || (generation != 0 && self.live[slot as usize].load(Ordering::Acquire) == generation)
    }

    /// Launches refuse handles to `slot` from now on (its texture was dropped).
    pub(crate) fn kill(&self, slot: u32) {
        if let Some(l) = self.live.get(slot as usize) {
            l.store(0, Ordering::Release);
        }
    }

    /// Empties `slot` and returns it to the free list, once no pending work uses it.
    pub(crate) fn remove(&self, device: &ash::Device, set: vk::DescriptorSet, slot: u32) {
        let mut free = self.free.lock().unwrap_or_else(|p| p.into_inner());
        self.write(device, set, slot, vk::ImageView::null(), self.default_sampler);
        free.insert(0, slot);
    }

    /// # Safety
    /// The device must be idle and no other object may use the table.
    pub(crate) unsafe fn destroy(self, device: &ash::Device) {
        // SAFETY: per the contract above.
        unsafe { device.destroy_sampler(self.default_sampler, None) };
    }
}
