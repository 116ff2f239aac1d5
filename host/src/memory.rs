//! Device memory: buffers allocated through gpu-allocator.
//!
//! [`DeviceBuffer<T>`] is what users see: a typed array in device memory that the
//! host can write and read, and that device programs reach through its
//! [`Buffer<T>`] handle (a slot in the context's bindless table). On Vulkan it
//! sits on the backend's untyped buffer (`vulkan::memory::RawBuffer`), the building
//! block raykit also uses for SBTs, acceleration structures and scratch memory.

use std::marker::PhantomData;
use std::sync::Arc;

use gpu_allocator::MemoryLocation;
use raykit_device::{Buffer, Element};

use crate::context::Context;
use crate::error::ResourceError;
use crate::error::{Error, Result};
use crate::vulkan::context::Submission;
use crate::vulkan::memory::RawBuffer;
use crate::vulkan::timeline::Retired;

/// A typed array of `T` in device memory, visible to device programs through
/// [`DeviceBuffer::handle`] and readable and writable from the host.
pub struct DeviceBuffer<T: Element> {
    repr: BufferRepr,
    slot: u32,
    /// The handle's value: the slot, and the generation that tells this buffer
    /// from earlier and later ones in the slot (see [`crate::validate::handles`]).
    handle: u32,
    len: usize,
    _element: PhantomData<T>,
}

/// Where a [`DeviceBuffer`]'s elements are.
enum BufferRepr {
    /// A Vulkan buffer.
    Vulkan(RawBuffer),
    /// Words in host memory, in the CPU backend's table.
    Cpu { ctx: Arc<crate::cpu::CpuContext>, words: crate::cpu::buffers::Words },
}

impl<T: Element> DeviceBuffer<T> {
    fn new(ctx: &Context, len: usize, location: MemoryLocation) -> Result<Self> {
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
        if let Some(cpu) = ctx.cpu() {
            let words = crate::cpu::buffers::zeroed_words(len * T::WORDS as usize);
            let (slot, handle) = cpu.buffers.insert(words.clone())?;
            let repr = BufferRepr::Cpu { ctx: cpu.clone(), words };
            return Ok(DeviceBuffer { repr, slot, handle, len, _element: PhantomData });
        }
        let inner = ctx.vulkan("a buffer")?;
        let (raw, slot, handle) = RawBuffer::storage(inner, size, location)?;
        Ok(DeviceBuffer { repr: BufferRepr::Vulkan(raw), slot, handle, len, _element: PhantomData })
    }

    /// A zero-filled buffer of `len` elements, for results the host reads back.
    pub fn zeroed(ctx: &Context, len: usize) -> Result<Self> {
        let mut buffer = Self::new(ctx, len, MemoryLocation::GpuToCpu)?;
        if let BufferRepr::Vulkan(raw) = &mut buffer.repr {
            if let Some(bytes) = raw.mapped_mut() {
                bytes.fill(0);
            }
        }
        Ok(buffer)
    }

    /// A buffer holding a copy of `data`, for inputs of device programs.
    pub fn from_slice(ctx: &Context, data: &[T]) -> Result<Self> {
        let mut buffer = Self::new(ctx, data.len(), MemoryLocation::CpuToGpu)?;
        match &mut buffer.repr {
            BufferRepr::Vulkan(raw) => raw.write_bytes(bytemuck::cast_slice(data))?,
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

    /// Copies the buffer's contents to the host. Waits first for the work
    /// submitted so far (launches, copies) to finish, so the contents are those
    /// pending launches leave; see [`DeviceBuffer::read_async`] for a copy that
    /// does not block.
    pub fn read(&self) -> Result<Vec<T>> {
        let raw = match &self.repr {
            BufferRepr::Vulkan(raw) => raw,
            BufferRepr::Cpu { ctx, words } => {
                ctx.wait_idle();
                return Ok(read_cpu(words, self.len));
            }
        };
        raw.ctx.wait_for_pending_work()?;
        let bytes = raw.mapped().ok_or(Error::Resource(ResourceError::BufferSize {
            len: self.len,
            element_size: std::mem::size_of::<T>(),
            reason: "the buffer is not host-visible",
        }))?;
        Ok(bytemuck::pod_collect_to_vec(bytes))
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
        let raw = match &self.repr {
            BufferRepr::Vulkan(raw) => raw,
            BufferRepr::Cpu { ctx, words } => {
                let after = ctx.last_epoch();
                let state = ReadRepr::Cpu { ctx: ctx.clone(), words: words.clone(), after, len: self.len };
                return Ok(PendingRead { state, _element: PhantomData });
            }
        };
        let (submission, staging) = raw.read_back()?;
        Ok(PendingRead { state: ReadRepr::Vulkan { submission, staging, len: self.len }, _element: PhantomData })
    }

    /// Copies elements `first..first + out.len()` into `out`: a part of
    /// [`DeviceBuffer::read`], which waits for pending work the same way.
    pub fn read_into(&self, first: usize, out: &mut [T]) -> Result<()> {
        let end = self.check_range(first, out.len())?;
        let size = std::mem::size_of::<T>();
        match &self.repr {
            BufferRepr::Vulkan(raw) => {
                raw.ctx.wait_for_pending_work()?;
                let bytes = raw.mapped().ok_or(Error::Resource(ResourceError::BufferSize {
                    len: self.len,
                    element_size: size,
                    reason: "the buffer is not host-visible",
                }))?;
                bytemuck::cast_slice_mut::<T, u8>(out).copy_from_slice(&bytes[first * size..end * size]);
            }
            BufferRepr::Cpu { ctx, words } => {
                ctx.wait_idle();
                let mut tmp = vec![0u32; out.len() * T::WORDS as usize];
                crate::cpu::buffers::read_words(words, first as u64 * u64::from(T::WORDS), &mut tmp);
                bytemuck::cast_slice_mut::<T, u8>(out).copy_from_slice(bytemuck::cast_slice(&tmp));
            }
        }
        Ok(())
    }

    /// Overwrites elements `first..first + data.len()` (after pending work that
    /// may use the buffer has finished, as [`DeviceBuffer::write`] does).
    pub fn write_at(&mut self, first: usize, data: &[T]) -> Result<()> {
        let end = self.check_range(first, data.len())?;
        let size = std::mem::size_of::<T>();
        let len = self.len;
        match &mut self.repr {
            BufferRepr::Vulkan(raw) => {
                raw.ctx.wait_for_pending_work()?;
                let bytes = raw.mapped_mut().ok_or(Error::Resource(ResourceError::BufferSize {
                    len,
                    element_size: size,
                    reason: "the buffer is not host-visible",
                }))?;
                bytes[first * size..end * size].copy_from_slice(bytemuck::cast_slice(data));
            }
            BufferRepr::Cpu { ctx, words } => {
                ctx.wait_idle();
                let mut tmp = vec![0u32; data.len() * T::WORDS as usize];
                bytemuck::cast_slice_mut::<u32, u8>(&mut tmp).copy_from_slice(bytemuck::cast_slice(data));
                crate::cpu::buffers::write_words(words, first as u64 * u64::from(T::WORDS), &tmp);
            }
        }
        Ok(())
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
        // Pending launches may read or write the buffer: let them finish first.
        match &mut self.repr {
            BufferRepr::Vulkan(raw) => {
                raw.ctx.wait_for_pending_work()?;
                raw.write_bytes(bytemuck::cast_slice(data))
            }
            BufferRepr::Cpu { ctx, words } => {
                ctx.wait_idle();
                crate::cpu::buffers::write_words(words, 0, bytemuck::cast_slice(data));
                Ok(())
            }
        }
    }
}

impl<T: Element> std::fmt::Debug for DeviceBuffer<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (bytes, host_visible) = match &self.repr {
            BufferRepr::Vulkan(raw) => (raw.size, raw.mapped().is_some()),
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
            BufferRepr::Vulkan(raw) => {
                raw.ctx.buffer_table.kill(self.slot);
                raw.ctx.retire(Retired::Slot(self.slot));
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
        staging: RawBuffer,
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
        let bytes = staging.mapped().ok_or(Error::Resource(ResourceError::BufferSize {
            len,
            element_size: std::mem::size_of::<T>(),
            reason: "the readback buffer is not host-visible",
        }))?;
        Ok(bytemuck::pod_collect_to_vec(bytes))
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
