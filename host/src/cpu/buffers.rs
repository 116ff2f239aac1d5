//! The CPU backend's buffer table: what `Buffer<T>` handles name when device
//! programs run on the host.
//!
//! A buffer is an array of 32-bit words, atomic so that invocations on several
//! threads may read and write one buffer at once as they may on a GPU (plain
//! accesses of different words, relaxed ordering). Handles are numbered as on
//! Vulkan, a slot and a generation (see [`crate::handles`]), so launches check
//! them the same way. A launch takes a snapshot of the table when it starts:
//! buffers dropped while it runs stay alive in the snapshot until it ends.

use std::sync::atomic::AtomicU32;
use std::sync::{Arc, Mutex, MutexGuard};

use crate::error::{Error, Result};
use crate::handles::{handle_value, next_generation};

const SLOTS: u32 = raykit_abi::BUFFER_TABLE_SLOTS;

/// The words of one buffer.
pub(crate) type Words = Arc<[AtomicU32]>;

/// A buffer of `len` zeroed words.
pub(crate) fn zeroed_words(len: usize) -> Words {
    (0..len).map(|_| AtomicU32::new(0)).collect()
}

/// What each slot holds: its generation and words.
struct Slots {
    live: Vec<Option<(u32, Words)>>,
    /// Free slots, the next one taken at the end.
    free: Vec<u32>,
}

/// The table of one CPU context.
pub(crate) struct BufferTable {
    slots: Mutex<Slots>,
}

impl Default for BufferTable {
    fn default() -> Self {
        // Slot 0 stays empty: it is the null handle.
        let slots = Slots { live: (0..SLOTS).map(|_| None).collect(), free: (1..SLOTS).rev().collect() };
        BufferTable { slots: Mutex::new(slots) }
    }
}

impl BufferTable {
    fn lock(&self) -> MutexGuard<'_, Slots> {
        self.slots.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Puts `words` in a free slot; returns the slot and the handle's value.
    pub(crate) fn insert(&self, words: Words) -> Result<(u32, u32)> {
        let mut slots = self.lock();
        let slot = slots.free.pop().ok_or(Error::BufferTableFull { capacity: SLOTS - 1 })?;
        let generation = next_generation();
        slots.live[slot as usize] = Some((generation, words));
        Ok((slot, handle_value(slot, generation)))
    }

    /// Empties `slot` (its buffer was dropped); launches running keep the words.
    pub(crate) fn remove(&self, slot: u32) {
        let mut slots = self.lock();
        if let Some(entry) = slots.live.get_mut(slot as usize) {
            if entry.take().is_some() {
                slots.free.insert(0, slot);
            }
        }
    }

    /// Whether `handle` is the null handle or names a live buffer of this table.
    pub(crate) fn is_live(&self, handle: u32) -> bool {
        let slot = handle & (SLOTS - 1);
        let generation = handle >> SLOTS.trailing_zeros();
        handle == 0 || self.lock().live[slot as usize].as_ref().is_some_and(|(g, _)| *g == generation)
    }

    /// The words of every slot now, for a launch.
    pub(crate) fn snapshot(&self) -> Vec<Option<Words>> {
        self.lock().live.iter().map(|s| s.as_ref().map(|(_, w)| w.clone())).collect()
    }

    /// Live buffers and their bytes.
    pub(crate) fn usage(&self) -> (usize, u64) {
        let slots = self.lock();
        let live = slots.live.iter().flatten();
        live.fold((0, 0), |(n, bytes), (_, w)| (n + 1, bytes + 4 * w.len() as u64))
    }
}

/// Word accesses with the device's rules for those out of bounds (the same
/// functions device programs read and write buffers with).
pub(crate) use raykit_device::cpu::{read_words, write_words};
