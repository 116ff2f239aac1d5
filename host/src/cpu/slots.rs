//! The CPU backend's handle tables (buffers and textures): slots numbered as on
//! Vulkan, a slot and a generation (see [`crate::validate::handles`]), so that launches
//! check handles the same way on both backends.
//!
//! Slot 0 stays empty: it is the null handle. A launch takes a snapshot of the
//! table when it starts; what is dropped while it runs stays alive in the
//! snapshot until it ends. The snapshot is kept until a slot changes, so
//! launches of an unchanged table share one.

use std::sync::{Arc, Mutex, MutexGuard};

use crate::error::{Error, Result};
use crate::validate::handles::{handle_value, next_generation};

/// What a table holds.
pub(crate) trait SlotValue: Clone {
    /// The table's slots (a power of two), the null slot included.
    const SLOTS: u32;
    /// The error of a full table of `capacity` usable slots.
    fn table_full(capacity: u32) -> Error;
    /// Bytes the value holds, for memory usage.
    fn bytes(&self) -> u64;
}

/// The values of every slot when a launch started, up to the last one taken.
pub(crate) type Snapshot<T> = Arc<[Option<T>]>;

/// What each slot holds, and the snapshot launches take until a slot changes.
struct Slots<T> {
    live: Vec<Option<(u32, T)>>,
    /// Free slots, the next one taken at the end.
    free: Vec<u32>,
    snapshot: Option<Snapshot<T>>,
}

/// A table of one CPU context.
pub(crate) struct SlotTable<T> {
    slots: Mutex<Slots<T>>,
}

impl<T: SlotValue> Default for SlotTable<T> {
    fn default() -> Self {
        let slots =
            Slots { live: (0..T::SLOTS).map(|_| None).collect(), free: (1..T::SLOTS).rev().collect(), snapshot: None };
        SlotTable { slots: Mutex::new(slots) }
    }
}

impl<T: SlotValue> SlotTable<T> {
    fn lock(&self) -> MutexGuard<'_, Slots<T>> {
        self.slots.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Puts `value` in a free slot; returns the slot and the handle's value.
    pub(crate) fn insert(&self, value: T) -> Result<(u32, u32)> {
        let mut slots = self.lock();
        let slot = slots.free.pop().ok_or_else(|| T::table_full(T::SLOTS - 1))?;
        let generation = next_generation();
        slots.live[slot as usize] = Some((generation, value));
        slots.snapshot = None;
        Ok((slot, handle_value(slot, generation)))
    }

    /// Empties `slot` (its value was dropped); launches running keep the value.
    pub(crate) fn remove(&self, slot: u32) {
        let mut slots = self.lock();
        if let Some(entry) = slots.live.get_mut(slot as usize) {
            if entry.take().is_some() {
                slots.free.insert(0, slot);
                slots.snapshot = None;
            }
        }
    }

    /// Whether `handle` is the null handle or names a live value of this table.
    pub(crate) fn is_live(&self, handle: u32) -> bool {
        let slot = handle & (T::SLOTS - 1);
        let generation = handle >> T::SLOTS.trailing_zeros();
        handle == 0 || self.lock().live[slot as usize].as_ref().is_some_and(|(g, _)| *g == generation)
    }

    /// The value of every slot now, for a launch.
    pub(crate) fn snapshot(&self) -> Snapshot<T> {
        let mut slots = self.lock();
        if let Some(snapshot) = &slots.snapshot {
            return snapshot.clone();
        }
        let end = slots.live.iter().rposition(Option::is_some).map_or(0, |last| last + 1);
        let snapshot: Snapshot<T> = slots.live[..end].iter().map(|s| s.as_ref().map(|(_, v)| v.clone())).collect();
        slots.snapshot = Some(snapshot.clone());
        snapshot
    }

    /// Live values and their bytes.
    pub(crate) fn usage(&self) -> (usize, u64) {
        let slots = self.lock();
        slots.live.iter().flatten().fold((0, 0), |(n, bytes), (_, v)| (n + 1, bytes + v.bytes()))
    }
}
