//! Resources reached through launch params, as OptiX programs reach everything
//! through `Params`.
//!
//! * [`Traversable`] is the TLAS, a 64-bit device address (OptiX's
//!   `OptixTraversableHandle`); the device turns it into an acceleration structure
//!   with `OpConvertUToAccelerationStructureKHR`.
//! * [`Buffer<T>`] is a typed handle to a storage buffer: an index into the bindless
//!   table ([`crate::BufferTable`]) that raykit binds for every launch. The host gets
//!   one from `raykit::DeviceBuffer::handle`; the device reads and writes it through
//!   its stage context (`ctx.load`, `ctx.store`).

use core::marker::PhantomData;

/// A top-level acceleration structure (or any traversable), as a device address.
///
/// Only raykit's host side creates non-null values (from a built `Ias`); a
/// zeroed value is the null handle, and tracing against it is undefined on the
/// device, as in OptiX.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
#[doc(alias("OptixTraversableHandle", "accelerationStructureEXT"))]
pub struct Traversable {
    address: u64,
}

impl Traversable {
    /// The null traversable.
    pub const NULL: Traversable = Traversable { address: 0 };

    /// Wraps a device address of an acceleration structure. Host-side code should use
    /// `raykit::Ias::handle` instead, whose handle every launch checks.
    ///
    /// # Safety
    /// `address` must be 0 or the device address of an acceleration structure
    /// that stays alive and built while any launch that traces it runs: tracing
    /// any other address makes the device read arbitrary memory. raykit's launches
    /// refuse params whose traversable is not a live IAS of their context.
    pub const unsafe fn from_device_address(address: u64) -> Self {
        Traversable { address }
    }

    /// The device address.
    pub const fn device_address(self) -> u64 {
        self.address
    }

    /// The acceleration structure this handle names, for `OpTraceRayKHR`.
    #[cfg(target_arch = "spirv")]
    pub(crate) fn acceleration_structure(self) -> spirv_std::ray_tracing::AccelerationStructure {
        // SAFETY: a non-null `Traversable` is only made by the host from a live,
        // built acceleration structure's device address.
        unsafe { spirv_std::ray_tracing::AccelerationStructure::from_u64(self.address) }
    }
}

/// A typed handle to a storage buffer of `T`s in the bindless buffer table.
///
/// Every launch checks on the host the handles in its params, and those in SBT
/// records whose type derives [`SbtRecordData`](macro@crate::SbtRecordData): a
/// handle of a dropped buffer, or of another context, is refused before the device
/// sees it. Handles the host cannot see (in records of plain `bytemuck::Pod`
/// types, or stored in buffers) reach the device as they are, and the device does
/// not bounds-check elements (`load` and `store` compile to a plain access). What
/// an access then does is defined by Vulkan's `robustBufferAccess2` and
/// `nullDescriptor`, which raykit requires and enables on every device:
/// * the null handle (slot 0, a zeroed `Buffer`), a slot never given to a buffer,
///   or the slot of a dropped buffer once the work pending at its drop has
///   finished: reads give zero, writes are discarded;
/// * the slot of a dropped buffer while work submitted before the drop is still
///   pending: the old buffer, which stays alive until that work has finished;
/// * a stale handle whose slot was given to a new buffer: the new buffer (the
///   device sees only the slot bits, not the generation the host checks);
/// * a handle past the table: programs use its low bits
///   (`index % raykit_abi::BUFFER_TABLE_SLOTS`), which name one of the above or a
///   live buffer;
/// * an element past the buffer's end: reads give zero, writes are discarded.
///
/// Element 0 and every other element of a live buffer read what the host last
/// wrote there (`raykit::DeviceBuffer::zeroed` buffers start as zeros) or what a
/// program stored.
#[repr(C)]
#[doc(alias("CUdeviceptr"))]
pub struct Buffer<T> {
    index: u32,
    _element: PhantomData<T>,
}

impl<T> Buffer<T> {
    /// A handle to slot `index` of the buffer table. Host-side code should use
    /// `raykit::DeviceBuffer::handle`, which keeps the slot and the type right.
    pub const fn from_table_index(index: u32) -> Self {
        Buffer { index, _element: PhantomData }
    }

    /// The slot of the buffer table this handle names (its value modulo the
    /// table's size, so that every handle names a slot of the table).
    pub const fn table_index(self) -> u32 {
        self.index & (raykit_abi::BUFFER_TABLE_SLOTS - 1)
    }

    /// The handle's value as the host stored it.
    pub const fn raw(self) -> u32 {
        self.index
    }
}

impl<T> Clone for Buffer<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Buffer<T> {}
impl<T> core::fmt::Debug for Buffer<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_tuple("Buffer").field(&self.index).finish()
    }
}
impl<T> PartialEq for Buffer<T> {
    fn eq(&self, other: &Self) -> bool {
        self.index == other.index
    }
}
impl<T> Eq for Buffer<T> {}
// SAFETY: `Buffer<T>` is `repr(C)` over a `u32` and a zero-sized `PhantomData`:
// no padding, every bit pattern valid, all-zero valid.
unsafe impl<T: 'static> bytemuck::Zeroable for Buffer<T> {}
// SAFETY: as above; `T` is only a marker and never stored.
unsafe impl<T: 'static> bytemuck::Pod for Buffer<T> {}
