//! The CPU backend's buffer table: what `Buffer<T>` handles name when device
//! programs run on the host.
//!
//! A buffer is an array of 32-bit words, atomic so that invocations on several
//! threads may read and write one buffer at once as they may on a GPU (plain
//! accesses of different words, relaxed ordering). The table is a
//! [`SlotTable`]: handles as on Vulkan, and a snapshot per launch that keeps
//! buffers dropped while it runs alive until it ends.

use std::sync::atomic::AtomicU32;
use std::sync::Arc;

use super::slots::{SlotTable, SlotValue};
use crate::error::Error;
use crate::error::ResourceError;

/// The words of one buffer.
pub(crate) type Words = Arc<[AtomicU32]>;

/// A buffer of `len` zeroed words.
pub(crate) fn zeroed_words(len: usize) -> Words {
    (0..len).map(|_| AtomicU32::new(0)).collect()
}

/// The buffer table of one CPU context.
pub(crate) type BufferTable = SlotTable<Words>;

impl SlotValue for Words {
    const SLOTS: u32 = raykit_abi::BUFFER_TABLE_SLOTS;

    fn table_full(capacity: u32) -> Error {
        Error::Resource(ResourceError::BufferTableFull { capacity })
    }

    fn bytes(&self) -> u64 {
        4 * self.len() as u64
    }
}

/// Word accesses with the device's rules for those out of bounds (the same
/// functions device programs read and write buffers with).
pub(crate) use raykit_device::cpu::{read_words, write_words};
