//! Stage contexts: the OptiX device functions (`optixGetLaunchIndex`, `optixTrace`, …) each program kind may call.
//!
//! Vulkan allows each ray-tracing stage a different set of built-ins and
//! instructions (a miss program has no barycentrics; only raygen, miss and
//! closest-hit may trace). Each context type exposes exactly its stage's share.
//! The macros build the context from the entry point's built-ins and hand it to
//! the user's function, so programs never touch free-standing globals: that keeps
//! the door open for running the same programs on a CPU backend.

mod any_hit;
mod callable;
mod closest_hit;
mod exception;
mod hit;
mod intersection;
mod miss;
mod raygen;

pub use any_hit::AnyHit;
pub use callable::{ContinuationCallable, DirectCallable};
pub use closest_hit::ClosestHit;
pub use exception::Exception;
#[doc(hidden)]
pub use hit::HitBuiltins;
pub use hit::{HIT_KIND_BACK_FACING_TRIANGLE, HIT_KIND_FRONT_FACING_TRIANGLE};
pub use intersection::Intersection;
pub use miss::Miss;
pub use raygen::Raygen;

use crate::{Buffer, Element, Ray, RayType, Traversable};

/// What a program reaches its resources (buffers, tracing, callables,
/// exceptions) through: on the device, the bindless buffer table (the other
/// operations are SPIR-V instructions); on the host, the CPU backend's runtime
/// (see [`crate::cpu`]).
#[cfg(target_arch = "spirv")]
pub type DeviceAccess<'a> = &'a mut crate::BufferTable;
/// What a program reaches its resources (buffers, tracing, callables,
/// exceptions) through: on the host, the CPU backend's runtime (see
/// [`crate::cpu`]); on the device, the bindless buffer table.
#[cfg(not(target_arch = "spirv"))]
pub type DeviceAccess<'a> = &'a dyn crate::cpu::Runtime;

/// The methods of the stages that may call callables and have no hit:
/// raygen, miss and the callables (fields `launch_index`, `launch_dimensions`,
/// `device`, `exception_slot`, `exception_call`).
macro_rules! launch_accessors {
    () => {
        /// This invocation's index in the launch grid (`optixGetLaunchIndex`).
        #[doc(alias("optixGetLaunchIndex", "gl_LaunchIDEXT"))]
        pub fn launch_index(&self) -> spirv_std::glam::UVec3 {
            self.launch_index
        }

        /// The launch grid's size (`optixGetLaunchDimensions`).
        #[doc(alias("optixGetLaunchDimensions", "gl_LaunchSizeEXT"))]
        pub fn launch_dimensions(&self) -> spirv_std::glam::UVec3 {
            self.launch_dimensions
        }

        /// Throws user exception `code` (OptiX's `optixThrowException`): the
        /// launch returns it to the host with this launch index, and the
        /// pipeline's `#[exception]` program, if any, runs now. The program goes
        /// on: return after it (see [`crate::exception`](mod@crate::exception)).
        #[doc(alias("optixThrowException"))]
        pub fn throw_exception(&mut self, code: u32) {
            super::throw_and_handle(self.device, self.exception_slot, self.launch_index, code, self.exception_call)
        }

        /// Runs the callable at `sbt_index` of the SBT's callable region with
        /// `data` (a `#[call_data]` parameter) (`optixDirectCall` /
        /// `optixContinuationCall`).
        #[doc(alias("optixDirectCall", "optixContinuationCall", "executeCallableEXT"))]
        pub fn call<T>(&mut self, sbt_index: u32, data: &mut T) {
            super::execute_callable(self.device, sbt_index, data)
        }

        /// Reads element `index` of `buffer`.
        pub fn load<T: $crate::Element>(&self, buffer: $crate::Buffer<T>, index: u32) -> T {
            super::load(self.device, buffer, index)
        }

        /// Writes element `index` of `buffer`.
        pub fn store<T: $crate::Element>(&mut self, buffer: $crate::Buffer<T>, index: u32, value: T) {
            super::store(self.device, buffer, index, value)
        }
    };
}
pub(crate) use launch_accessors;

/// The trace of the stages that run for a traced ray and may trace again (miss
/// and closest-hit; fields `depth`, `max_trace_depth`), which stops at the
/// pipeline's `max_trace_depth`, and the depth the macros hand them.
macro_rules! recursive_trace {
    () => {
        #[doc(hidden)]
        pub fn __with_trace_depth(mut self, depth: u32, max_trace_depth: u32) -> Self {
            self.depth = depth;
            self.max_trace_depth = max_trace_depth;
            self
        }

        /// The trace depth of the ray this program runs for: 1 for a ray raygen
        /// traced, one more per level of recursion. Known when the program's ray
        /// type has [`RayType::CHECK_DEPTH`](crate::RayType::CHECK_DEPTH); 1 otherwise.
        pub fn trace_depth(&self) -> u32 {
            self.depth
        }

        /// Traces `ray` of ray type `R` into `scene` (`optixTrace`); `payload` is a
        /// `#[trace_payload]` parameter of this program. A trace that would go past
        /// the pipeline's `max_trace_depth` is not made: it throws
        /// [`TRACE_DEPTH_EXCEEDED`](crate::exception::TRACE_DEPTH_EXCEEDED) and
        /// leaves `payload` as it was (see [`RayType::CHECK_DEPTH`](crate::RayType::CHECK_DEPTH)).
        #[doc(alias("optixTrace", "traceRayEXT", "OpTraceRayKHR"))]
        pub fn trace<R: $crate::RayType>(
            &mut self,
            scene: $crate::Traversable,
            ray: $crate::Ray,
            payload: &mut R::Payload,
        ) {
            if self.depth >= self.max_trace_depth {
                self.throw_exception($crate::exception::TRACE_DEPTH_EXCEEDED);
                return;
            }
            if R::CHECK_DEPTH {
                R::set_depth(payload, self.depth + 1);
            }
            super::trace::<R>(self.device, scene, ray, payload)
        }
    };
}
pub(crate) use recursive_trace;

/// `OpExecuteCallableKHR` with a run-time SBT index (spirv-std's
/// `execute_callable` takes it as a const generic). `data` must be a
/// `CallableDataKHR` variable: the macros only hand out `#[call_data]` ones.
#[cfg(target_arch = "spirv")]
fn execute_callable<T>(_device: DeviceAccess<'_>, sbt_index: u32, data: &mut T) {
    // SAFETY: `data` is the entry point's callable-data variable; the index is
    // checked by the driver against the callable region.
    unsafe {
        core::arch::asm!("OpExecuteCallableKHR {id} {data}", id = in(reg) sbt_index, data = in(reg) data);
    }
}

/// The callable at `sbt_index`, run by the CPU backend with `data`.
#[cfg(not(target_arch = "spirv"))]
fn execute_callable<T>(device: DeviceAccess<'_>, sbt_index: u32, data: &mut T) {
    device.call(sbt_index, crate::cpu::Erased::of(data))
}

/// Records user exception `code` thrown at `launch_index` in the exception
/// buffer at `slot` of the table (see [`crate::exception`](mod@crate::exception)); returns the
/// exception program's callable index ([`crate::exception::NO_EXCEPTION_PROGRAM`]
/// when the pipeline has none).
#[cfg(target_arch = "spirv")]
fn record_exception(table: &mut crate::BufferTable, slot: u32, launch_index: spirv_std::glam::UVec3, code: u32) -> u32 {
    use crate::exception::{
        EXCEPTION_CAPACITY, EXCEPTION_HANDLER_WORD, EXCEPTION_RECORDS_WORD, EXCEPTION_RECORD_WORDS,
    };
    // SAFETY: raykit fills `slot` with the pipeline's exception buffer of
    // EXCEPTION_BUFFER_WORDS words before every launch.
    let words: &mut [u32] = unsafe { table.index_mut(slot as usize) };
    // SAFETY: an atomic increment of the counter; queue-family scope covers
    // every invocation of the launch (device scope would need
    // VulkanMemoryModelDeviceScope), and no ordering is needed.
    let index = unsafe {
        spirv_std::arch::atomic_i_increment::<u32, { spirv_std::memory::Scope::QueueFamily as u32 }, 0>(&mut words[0])
    };
    if index < EXCEPTION_CAPACITY {
        let base = (EXCEPTION_RECORDS_WORD + index * EXCEPTION_RECORD_WORDS) as usize;
        words[base] = code;
        words[base + 1] = launch_index.x;
        words[base + 2] = launch_index.y;
        words[base + 3] = launch_index.z;
    }
    words[EXCEPTION_HANDLER_WORD as usize]
}

/// Records user exception `code` thrown at `launch_index` (any-hit and
/// intersection programs, which may not call the exception program).
#[cfg(target_arch = "spirv")]
fn throw_exception(table: DeviceAccess<'_>, slot: u32, launch_index: spirv_std::glam::UVec3, code: u32) {
    record_exception(table, slot, launch_index, code);
}

/// Records user exception `code` thrown at `launch_index` with the CPU backend.
#[cfg(not(target_arch = "spirv"))]
fn throw_exception(device: DeviceAccess<'_>, _slot: u32, launch_index: spirv_std::glam::UVec3, code: u32) {
    device.throw_exception(launch_index, code, false)
}

/// Records the exception, then runs the exception program, if the pipeline
/// has one, with the details through `call` (the entry point's hidden
/// callable-data variable).
#[cfg(target_arch = "spirv")]
fn throw_and_handle(
    table: DeviceAccess<'_>,
    slot: u32,
    launch_index: spirv_std::glam::UVec3,
    code: u32,
    call: &mut crate::exception::ExceptionDetails,
) {
    let handler = record_exception(&mut *table, slot, launch_index, code);
    if handler != crate::exception::NO_EXCEPTION_PROGRAM {
        *call = crate::exception::ExceptionDetails { code, launch_index };
        execute_callable(table, handler, call);
    }
}

/// Records the exception and runs the exception program with the CPU backend.
#[cfg(not(target_arch = "spirv"))]
fn throw_and_handle(
    device: DeviceAccess<'_>,
    _slot: u32,
    launch_index: spirv_std::glam::UVec3,
    code: u32,
    _call: &mut crate::exception::ExceptionDetails,
) {
    device.throw_exception(launch_index, code, true)
}

/// Reads element `index` of `buffer` from the bindless table.
///
/// No bounds check in the program: raykit creates every device with
/// `robustBufferAccess2` and `nullDescriptor`, under which a read past the end
/// of the buffer, or through a null or emptied slot, returns zero (see
/// [`Buffer`] for every case). (A check per access, `OpArrayLength` and a
/// branch, made the path tracer run at half the speed of its GLSL twin on an
/// NVIDIA H100.)
#[cfg(target_arch = "spirv")]
fn load<T: Element>(table: &crate::BufferTable, buffer: Buffer<T>, index: u32) -> T {
    // SAFETY: `table_index` is below the table's size; every slot holds a
    // buffer or a null descriptor, and an index past a buffer's end is
    // defined under robustBufferAccess2 (above).
    unsafe {
        let words: &[u32] = table.index(buffer.table_index() as usize);
        T::read_unchecked(words, (index * T::WORDS) as usize)
    }
}

/// Reads element `index` of `buffer` through the CPU backend, with the
/// device's rules for accesses out of bounds (see [`Buffer`]).
#[cfg(not(target_arch = "spirv"))]
#[inline]
fn load<T: Element>(device: &dyn crate::cpu::Runtime, buffer: Buffer<T>, index: u32) -> T {
    crate::cpu::with_words::<T, _>(|words| {
        crate::cpu::read_words(device.buffer(buffer.raw()), u64::from(index) * u64::from(T::WORDS), words);
        T::read(words, 0)
    })
}

/// Writes element `index` of `buffer` in the bindless table. A write past the
/// end, or through a null slot, is discarded (`robustBufferAccess2`, see [`load`]).
#[cfg(target_arch = "spirv")]
fn store<T: Element>(table: &mut crate::BufferTable, buffer: Buffer<T>, index: u32, value: T) {
    // SAFETY: as in `load`.
    unsafe {
        let words: &mut [u32] = table.index_mut(buffer.table_index() as usize);
        value.write_unchecked(words, (index * T::WORDS) as usize)
    }
}

/// Writes element `index` of `buffer` through the CPU backend.
#[cfg(not(target_arch = "spirv"))]
#[inline]
fn store<T: Element>(device: &dyn crate::cpu::Runtime, buffer: Buffer<T>, index: u32, value: T) {
    crate::cpu::with_words::<T, _>(|words| {
        value.write(words, 0);
        crate::cpu::write_words(device.buffer(buffer.raw()), u64::from(index) * u64::from(T::WORDS), words)
    })
}

/// `OpTraceRayKHR` for ray type `R`.
#[cfg(target_arch = "spirv")]
fn trace<R: RayType>(_device: DeviceAccess<'_>, scene: Traversable, ray: Ray, payload: &mut R::Payload) {
    // SAFETY: `payload` is the entry point's `RayPayloadKHR` variable (the
    // macros only hand such payloads to tracing stages), and the SBT offsets
    // come from the ray-type declaration the host also uses.
    unsafe {
        scene.acceleration_structure().trace_ray(
            R::FLAGS,
            R::CULL_MASK as i32,
            R::SBT_OFFSET as i32,
            R::SBT_STRIDE as i32,
            R::MISS_INDEX as i32,
            ray.origin,
            ray.t_min,
            ray.direction,
            ray.t_max,
            payload,
        );
    }
}

/// A trace of ray type `R`, run by the CPU backend's traversal.
#[cfg(not(target_arch = "spirv"))]
fn trace<R: RayType>(device: DeviceAccess<'_>, scene: Traversable, ray: Ray, payload: &mut R::Payload) {
    let call = crate::cpu::TraceCall {
        flags: R::FLAGS.bits(),
        cull_mask: R::CULL_MASK,
        sbt_offset: R::SBT_OFFSET,
        sbt_stride: R::SBT_STRIDE,
        miss_index: R::MISS_INDEX,
    };
    device.trace(scene, ray, call, crate::cpu::Erased::of(payload))
}
