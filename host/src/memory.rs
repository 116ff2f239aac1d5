//! Device memory, what OptiX programs get from `cudaMalloc`: buffers allocated through gpu-allocator.
//!
//! [`DeviceBuffer<T>`] is what users see: a typed array in device memory that the
//! host can write and read, and that device programs reach through its
//! [`Buffer<T>`] handle (a slot in the context's bindless table). On Vulkan it
//! sits on the backend's untyped buffer (`vulkan::memory::RawBuffer`), the building
//! block raykit also uses for SBTs, acceleration structures and scratch memory.
//!
//! # Where a buffer lives
//!
//! A buffer's [`BufferMemory`] says where its memory is. The default,
//! [`BufferMemory::DeviceLocal`], is the device's own memory, where device
//! programs read and write fastest: on a discrete GPU the host reaches it through
//! staging copies ([`DeviceBuffer::read`], [`DeviceBuffer::read_async`],
//! [`DeviceBuffer::write`], the upload in [`DeviceBuffer::from_slice`]), each
//! through a host-visible staging buffer the device buffer keeps and reuses, so
//! a progressive render that reads its image every step allocates it once. Where
//! device-local memory is also host-visible (lavapipe, integrated GPUs, and
//! GPUs whose whole memory the host can map), the host reads and writes it in
//! place, with no copy. [`BufferMemory::HostRead`] and [`BufferMemory::HostWrite`]
//! keep a buffer in host-visible memory for data that crosses the bus every
//! launch anyway (as wgpu's `MAP_READ` and `MAP_WRITE` buffers): the host maps
//! them, and device programs reach them over the bus.
//!
//! What raykit allocates for itself: SBTs and build inputs (vertices, indices,
//! instance records) are written once by the host and read by the device, in
//! host-visible memory the device reads (`CpuToGpu`, device-local where the host
//! can map it); acceleration structures, build scratch, textures, exception
//! counters and the params uniform are device-local; exception and timestamp
//! readbacks and texture uploads are host-visible staging.

use std::marker::PhantomData;
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use raykit_device::{Buffer, Element};

use crate::context::{Context, ContextRepr};
use crate::error::ResourceError;
use crate::error::{Error, Result};
use crate::vulkan::context::Submission;
use crate::vulkan::memory::{RawBuffer, StagingDirection, StagingSlot};
use crate::vulkan::timeline::Retired;

/// A typed array of `T` in device memory, visible to device programs through
/// [`DeviceBuffer::handle`] and readable and writable from the host.
#[doc(alias("cudaMalloc", "CUdeviceptr"))]
pub struct DeviceBuffer<T: Element> {
    repr: BufferRepr,
    slot: u32,
    /// The handle's value: the slot, and the generation that tells this buffer
    /// from earlier and later ones in the slot (see [`crate::validate::handles`]).
    handle: u32,
    len: usize,
    _element: PhantomData<T>,
}

/// Where a [`DeviceBuffer`]'s memory is (see the [module docs](self)).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum BufferMemory {
    /// The device's own memory: fastest for device programs. The host reaches it
    /// in place where the device's memory is host-visible, else through staging
    /// copies. The default.
    #[default]
    DeviceLocal,
    /// Host memory, cached for host reads, that device programs write over the
    /// bus: for a buffer read back after every launch.
    HostRead,
    /// Host memory the host writes and device programs read over the bus: for
    /// data rewritten before every launch (upload rings, per-frame constants).
    HostWrite,
}

impl BufferMemory {
    fn location(self) -> MemoryLocation {
        match self {
            BufferMemory::DeviceLocal => MemoryLocation::GpuOnly,
            BufferMemory::HostRead => MemoryLocation::GpuToCpu,
            BufferMemory::HostWrite => MemoryLocation::CpuToGpu,
        }
    }
}

/// A Vulkan [`DeviceBuffer`]: its buffer, where it lives, and the staging
/// buffers its copies reuse when the host cannot map it.
struct VulkanBuffer {
    raw: RawBuffer,
    memory: BufferMemory,
    readback: StagingSlot,
    upload: StagingSlot,
}

/// Where a [`DeviceBuffer`]'s elements are.
enum BufferRepr {
    /// A Vulkan buffer.
    Vulkan(VulkanBuffer),
    /// Words in host memory, in the CPU backend's table.
    Cpu { ctx: Arc<crate::cpu::CpuContext>, words: crate::cpu::buffers::Words },
}

impl<T: Element> DeviceBuffer<T> {
    fn new(ctx: &Context, len: usize, memory: BufferMemory) -> Result<Self> {
        let element_size = std::mem::size_of::<T>();
        if len == 0 {
            return Err(Error::Resource(ResourceError::BufferSize {
                len,
                element_size,
                reason: "a buffer needs at least one element",
            }));
        }
        if element_size != T::WORDS as usize * 4 {
            return Err(Error::Resource(ResourceError::BufferSize {
                len,
                element_size,
                reason:
                    "the element's host size differs from its device size (WORDS × 4); use a type without SIMD padding",
            }));
        }
        let size = (len as u64).checked_mul(element_size as u64).ok_or(Error::Resource(ResourceError::BufferSize {
            len,
            element_size,
            reason: "the size overflows 64 bits",
        }))?;
        crate::validate::check_storage_buffer(size, ctx.limits().max_storage_buffer_range)?;
        let (repr, slot, handle) = match ctx.repr() {
            ContextRepr::Cpu(cpu) => {
                let words = crate::cpu::buffers::zeroed_words(len * T::WORDS as usize);
                let (slot, handle) = cpu.buffers.insert(words.clone())?;
                (BufferRepr::Cpu { ctx: cpu.clone(), words }, slot, handle)
            }
            ContextRepr::Vulkan(inner) => {
                let (raw, slot, handle) = RawBuffer::storage(inner, size, memory.location())?;
                let staging = (StagingSlot::default(), StagingSlot::default());
                let vulkan = VulkanBuffer { raw, memory, readback: staging.0, upload: staging.1 };
                (BufferRepr::Vulkan(vulkan), slot, handle)
            }
        };
        Ok(DeviceBuffer { repr, slot, handle, len, _element: PhantomData })
    }

    /// A zero-filled buffer of `len` elements in device-local memory, for
    /// results of device programs.
    pub fn zeroed(ctx: &Context, len: usize) -> Result<Self> {
        Self::zeroed_in(ctx, len, BufferMemory::DeviceLocal)
    }

    /// A zero-filled buffer of `len` elements in `memory`.
    pub fn zeroed_in(ctx: &Context, len: usize, memory: BufferMemory) -> Result<Self> {
        let mut buffer = Self::new(ctx, len, memory)?;
        if let BufferRepr::Vulkan(vulkan) = &mut buffer.repr {
            match vulkan.mapped_mut() {
                Some(bytes) => bytes.fill(0),
                None => vulkan.raw.fill_zero()?.wait()?,
            }
        }
        Ok(buffer)
    }

    /// A buffer in device-local memory holding a copy of `data`, for inputs of
    /// device programs.
    pub fn from_slice(ctx: &Context, data: &[T]) -> Result<Self> {
        Self::from_slice_in(ctx, data, BufferMemory::DeviceLocal)
    }

    /// A buffer in `memory` holding a copy of `data`.
    pub fn from_slice_in(ctx: &Context, data: &[T], memory: BufferMemory) -> Result<Self> {
        let mut buffer = Self::new(ctx, data.len(), memory)?;
        match &mut buffer.repr {
            BufferRepr::Vulkan(vulkan) => vulkan.write(0, bytemuck::cast_slice(data))?,
            BufferRepr::Cpu { words, .. } => crate::cpu::buffers::write_words(words, 0, bytemuck::cast_slice(data)),
        }
        Ok(buffer)
    }

    /// The handle device programs use (put it in the launch params).
    pub fn handle(&self) -> Buffer<T> {
        Buffer::from_table_index(self.handle)
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the buffer has no elements (never: a buffer has at least one).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Where the buffer's memory is (on the CPU backend, always
    /// [`BufferMemory::DeviceLocal`]: the host's memory is the device's).
    pub fn memory(&self) -> BufferMemory {
        match &self.repr {
            BufferRepr::Vulkan(vulkan) => vulkan.memory,
            BufferRepr::Cpu { .. } => BufferMemory::DeviceLocal,
        }
    }

    /// Whether the host reads and writes the buffer in place, without a staging
    /// copy: host-visible memory, or device-local memory the host can map.
    pub fn is_host_mapped(&self) -> bool {
        match &self.repr {
            BufferRepr::Vulkan(vulkan) => vulkan.mapped().is_some(),
            BufferRepr::Cpu { .. } => true,
        }
    }

    /// The `VkBuffer` (usable as a transfer source and destination and as a storage
    /// buffer), for Vulkan code beside raykit such as a window's presentation; `None`
    /// on the CPU backend. Work on it submitted outside raykit (see
    /// [`Context::with_raw_queue`]) must have finished before the buffer is dropped.
    pub fn raw_buffer(&self) -> Option<vk::Buffer> {
        match &self.repr {
            BufferRepr::Vulkan(vulkan) => Some(vulkan.raw.buffer),
            BufferRepr::Cpu { .. } => None,
        }
    }

    /// Copies the buffer's contents to the host. Waits first for the work
    /// submitted so far (launches, copies) to finish, so the contents are those
    /// pending launches leave; see [`DeviceBuffer::read_async`] for a copy that
    /// does not block.
    pub fn read(&self) -> Result<Vec<T>> {
        let mut out = vec![T::zeroed(); self.len];
        self.read_into(0, &mut out)?;
        Ok(out)
    }

    /// Submits a copy of the buffer's contents, as the work submitted before it
    /// leaves them, into host memory owned by the returned [`PendingRead`], and
    /// returns without waiting. The buffer may be dropped at once: the copy keeps
    /// what it reads alive on the device (see [`crate::timeline`]).
    ///
    /// On the CPU backend the copy is made once the launches started before it
    /// have ended (when [`PendingRead::wait`] finds them ended), from the
    /// buffer's words, which the returned value keeps.
    pub fn read_async(&self) -> Result<PendingRead<T>> {
        let vulkan = match &self.repr {
            BufferRepr::Vulkan(vulkan) => vulkan,
            BufferRepr::Cpu { ctx, words } => {
                let after = ctx.last_epoch();
                let state = ReadRepr::Cpu { ctx: ctx.clone(), words: words.clone(), after, len: self.len };
                return Ok(PendingRead { state, _element: PhantomData });
            }
        };
        let raw = &vulkan.raw;
        let staging = vulkan.readback.take(&raw.ctx, raw.size, StagingDirection::Readback)?;
        let submission = raw.copy_to(&staging, 0, raw.size)?;
        let staging = Staged { buffer: Some(staging), slot: vulkan.readback.clone() };
        Ok(PendingRead { state: ReadRepr::Vulkan { submission, staging, len: self.len }, _element: PhantomData })
    }

    /// Copies elements `first..first + out.len()` into `out`: a part of
    /// [`DeviceBuffer::read`], which waits for pending work the same way.
    pub fn read_into(&self, first: usize, out: &mut [T]) -> Result<()> {
        self.check_range(first, out.len())?;
        if out.is_empty() {
            // Nothing to copy (and Vulkan refuses a copy of 0 bytes).
            return Ok(());
        }
        let size = std::mem::size_of::<T>();
        match &self.repr {
            BufferRepr::Vulkan(vulkan) => vulkan.read((first * size) as u64, bytemuck::cast_slice_mut(out)),
            BufferRepr::Cpu { ctx, words } => {
                ctx.wait_idle();
                let mut tmp = vec![0u32; out.len() * T::WORDS as usize];
                crate::cpu::buffers::read_words(words, first as u64 * u64::from(T::WORDS), &mut tmp);
                bytemuck::cast_slice_mut::<T, u8>(out).copy_from_slice(bytemuck::cast_slice(&tmp));
                Ok(())
            }
        }
    }

    /// Overwrites elements `first..first + data.len()` (after pending work that
    /// may use the buffer has finished, as [`DeviceBuffer::write`] does).
    pub fn write_at(&mut self, first: usize, data: &[T]) -> Result<()> {
        self.check_range(first, data.len())?;
        if data.is_empty() {
            // Nothing to copy (and Vulkan refuses a copy of 0 bytes).
            return Ok(());
        }
        let size = std::mem::size_of::<T>();
        match &mut self.repr {
            BufferRepr::Vulkan(vulkan) => {
                vulkan.raw.ctx.wait_for_pending_work()?;
                vulkan.write((first * size) as u64, bytemuck::cast_slice(data))
            }
            BufferRepr::Cpu { ctx, words } => {
                ctx.wait_idle();
                let mut tmp = vec![0u32; data.len() * T::WORDS as usize];
                bytemuck::cast_slice_mut::<u32, u8>(&mut tmp).copy_from_slice(bytemuck::cast_slice(data));
                crate::cpu::buffers::write_words(words, first as u64 * u64::from(T::WORDS), &tmp);
                Ok(())
            }
        }
    }

    /// The end of the `count` elements from `first`, when they are in the buffer.
    fn check_range(&self, first: usize, count: usize) -> Result<usize> {
        match first.checked_add(count) {
            Some(end) if end <= self.len => Ok(end),
            end => Err(Error::Resource(ResourceError::BufferRange {
                start: first,
                end: end.unwrap_or(usize::MAX),
                len: self.len,
            })),
        }
    }

    /// Overwrites the buffer's first `data.len()` elements.
    pub fn write(&mut self, data: &[T]) -> Result<()> {
        if data.len() > self.len {
            return Err(Error::Resource(ResourceError::BufferSize {
                len: data.len(),
                element_size: std::mem::size_of::<T>(),
                reason: "more elements than the buffer holds",
            }));
        }
        self.write_at(0, data)
    }
}

impl VulkanBuffer {
    /// The buffer's bytes, where the host can map it.
    fn mapped(&self) -> Option<&[u8]> {
        if self.staging_forced() {
            return None;
        }
        self.raw.mapped()
    }

    /// The buffer's bytes, writable, where the host can map it.
    fn mapped_mut(&mut self) -> Option<&mut [u8]> {
        if self.staging_forced() {
            return None;
        }
        self.raw.mapped_mut()
    }

    /// Whether the context copies every buffer through staging (a test hook).
    fn staging_forced(&self) -> bool {
        #[cfg(feature = "fault-injection")]
        if self.memory == BufferMemory::DeviceLocal {
            return self.raw.ctx.force_staging.load(std::sync::atomic::Ordering::Relaxed);
        }
        false
    }

    /// Reads `out.len()` bytes from `offset` once the work submitted so far has
    /// finished: in place when mapped, else through the readback staging buffer.
    fn read(&self, offset: u64, out: &mut [u8]) -> Result<()> {
        let raw = &self.raw;
        raw.ctx.wait_for_pending_work()?;
        if let Some(bytes) = self.mapped() {
            out.copy_from_slice(&bytes[offset as usize..offset as usize + out.len()]);
            return Ok(());
        }
        let size = out.len() as u64;
        let staging = self.readback.take(&raw.ctx, size, StagingDirection::Readback)?;
        raw.copy_to(&staging, offset, size)?.wait()?;
        let bytes = staging.mapped().ok_or_else(not_host_visible(out.len()))?;
        out.copy_from_slice(&bytes[..out.len()]);
        self.readback.give_back(staging);
        Ok(())
    }

    /// Writes `data` at `offset` (the caller has waited for work that may use
    /// the buffer): in place when mapped, else through the upload staging
    /// buffer, waiting for the copy.
    fn write(&mut self, offset: u64, data: &[u8]) -> Result<()> {
        if let Some(bytes) = self.mapped_mut() {
            bytes[offset as usize..offset as usize + data.len()].copy_from_slice(data);
            return Ok(());
        }
        let raw = &self.raw;
        let mut staging = self.upload.take(&raw.ctx, data.len() as u64, StagingDirection::Upload)?;
        let mapped = staging.mapped_mut().ok_or_else(not_host_visible(data.len()))?;
        mapped[..data.len()].copy_from_slice(data);
        raw.copy_from(&staging, offset, data.len() as u64)?.wait()?;
        self.upload.give_back(staging);
        Ok(())
    }
}

/// The error of a staging buffer the host cannot map (a driver that offers no
/// host-visible memory).
fn not_host_visible(len: usize) -> impl FnOnce() -> Error {
    move || {
        Error::Resource(ResourceError::BufferSize {
            len,
            element_size: 1,
            reason: "the device offers no host-visible memory to copy through",
        })
    }
}

/// A staging buffer in use by a pending read: given back to the buffer's slot
/// when the read is done with it (or dropped).
struct Staged {
    buffer: Option<RawBuffer>,
    slot: StagingSlot,
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(buffer) = self.buffer.take() {
            self.slot.give_back(buffer);
        }
    }
}

impl<T: Element> std::fmt::Debug for DeviceBuffer<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (bytes, host_visible) = match &self.repr {
            BufferRepr::Vulkan(vulkan) => (vulkan.raw.size, vulkan.raw.mapped().is_some()),
            BufferRepr::Cpu { words, .. } => (4 * words.len() as u64, true),
        };
        f.debug_struct("DeviceBuffer")
            .field("element", &std::any::type_name::<T>())
            .field("len", &self.len)
            .field("bytes", &bytes)
            .field("table_index", &self.slot)
            .field("host_visible", &host_visible)
            .finish()
    }
}

impl<T: Element> Drop for DeviceBuffer<T> {
    fn drop(&mut self) {
        // Launches refuse its handle from now on; the slot is reused only once no
        // pending work can read it (on the CPU backend, launches running keep the
        // words they started with).
        match &self.repr {
            BufferRepr::Vulkan(vulkan) => {
                vulkan.raw.ctx.buffer_table.kill(self.slot);
                vulkan.raw.ctx.retire(Retired::Slot(self.slot));
            }
            BufferRepr::Cpu { ctx, .. } => ctx.buffers.remove(self.slot),
        }
    }
}

impl Context {
    /// A zero-filled [`DeviceBuffer`] of `len` elements.
    pub fn buffer<T: Element>(&self, len: usize) -> Result<DeviceBuffer<T>> {
        DeviceBuffer::zeroed(self, len)
    }

    /// A [`DeviceBuffer`] holding a copy of `data`.
    pub fn buffer_from<T: Element>(&self, data: &[T]) -> Result<DeviceBuffer<T>> {
        DeviceBuffer::from_slice(self, data)
    }
}

/// A copy of a [`DeviceBuffer`] on its way to the host
/// ([`DeviceBuffer::read_async`]); owns the host memory it lands in.
#[must_use = "a PendingRead is waited on to get the contents"]
pub struct PendingRead<T: Element> {
    state: ReadRepr,
    _element: PhantomData<T>,
}

/// Where a [`PendingRead`]'s contents are.
enum ReadRepr {
    /// On their way from a Vulkan buffer.
    Vulkan {
        // Field order: the submission (which waits when dropped) goes first.
        submission: Submission,
        staging: Staged,
        len: usize,
    },
    /// A CPU buffer's words, copied once the launches started before epoch
    /// `after` have ended.
    Cpu { ctx: Arc<crate::cpu::CpuContext>, words: crate::cpu::buffers::Words, after: u64, len: usize },
}

/// The first `len` elements of CPU buffer words.
fn read_cpu<T: Element>(words: &[std::sync::atomic::AtomicU32], len: usize) -> Vec<T> {
    let mut out = vec![0u32; len * T::WORDS as usize];
    crate::cpu::buffers::read_words(words, 0, &mut out);
    bytemuck::pod_collect_to_vec(&out)
}

impl<T: Element> PendingRead<T> {
    /// Whether the copy has finished, without blocking.
    pub fn is_done(&self) -> Result<bool> {
        match &self.state {
            ReadRepr::Vulkan { submission, .. } => submission.is_done(),
            ReadRepr::Cpu { ctx, after, .. } => Ok(!ctx.is_running_before(*after)),
        }
    }

    /// Blocks until the copy has finished and returns the contents.
    pub fn wait(self) -> Result<Vec<T>> {
        let (mut submission, staging, len) = match self.state {
            ReadRepr::Vulkan { submission, staging, len } => (submission, staging, len),
            ReadRepr::Cpu { ctx, words, after, len } => {
                ctx.wait_for(after);
                return Ok(read_cpu(&words, len));
            }
        };
        submission.wait()?;
        let size = len * std::mem::size_of::<T>();
        let bytes = staging.buffer.as_ref().and_then(RawBuffer::mapped).ok_or_else(not_host_visible(size))?;
        Ok(bytemuck::pod_collect_to_vec(&bytes[..size]))
    }
}

impl<T: Element> std::fmt::Debug for PendingRead<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.state {
            ReadRepr::Vulkan { submission, len, .. } => {
                f.debug_struct("PendingRead").field("len", len).field("epoch", &submission.epoch).finish()
            }
            ReadRepr::Cpu { len, after, .. } => {
                f.debug_struct("PendingRead").field("len", len).field("after_launch", after).finish()
            }
        }
    }
}
