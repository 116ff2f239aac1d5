//! Stage contexts: what each program kind may call.
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

use crate::{Buffer, BufferTable, Element, Ray, RayType, Traversable};

/// The methods of the stages that may call callables and have no hit:
/// raygen, miss and the callables (fields `launch_index`, `launch_dimensions`,
/// `buffers`, `exception_slot`, `exception_call`).
macro_rules! launch_accessors {
    () => {
        /// This invocation's index in the launch grid (`optixGetLaunchIndex`).
        pub fn launch_index(&self) -> spirv_std::glam::UVec3 {
            self.launch_index
        }

        /// The launch grid's size (`optixGetLaunchDimensions`).
        pub fn launch_dimensions(&self) -> spirv_std::glam::UVec3 {
            self.launch_dimensions
        }

        /// Throws user exception `code` (OptiX's `optixThrowException`): the
        /// launch returns it to the host with this launch index, and the
        /// pipeline's `#[exception]` program, if any, runs now. The program goes
        /// on: return after it (see [`crate::exception`](mod@crate::exception)).
        pub fn throw_exception(&mut self, code: u32) {
            super::throw_and_handle(self.buffers, self.exception_slot, self.launch_index, code, self.exception_call)
        }

        /// Runs the callable at `sbt_index` of the SBT's callable region with
        /// `data` (a `#[call_data]` parameter) (`optixDirectCall` /
        /// `optixContinuationCall`).
        pub fn call<T>(&mut self, sbt_index: u32, data: &mut T) {
            super::execute_callable(sbt_index, data)
        }

        /// Reads element `index` of `buffer`.
        pub fn load<T: $crate::Element>(&self, buffer: $crate::Buffer<T>, index: u32) -> T {
            super::load(self.buffers, buffer, index)
        }

        /// Writes element `index` of `buffer`.
        pub fn store<T: $crate::Element>(&mut self, buffer: $crate::Buffer<T>, index: u32, value: T) {
            super::store(self.buffers, buffer, index, value)
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
            super::trace::<R>(scene, ray, payload)
        }
    };
}
pub(crate) use recursive_trace;

/// `OpExecuteCallableKHR` with a run-time SBT index (spirv-std's
/// `execute_callable` takes it as a const generic). `data` must be a
/// `CallableDataKHR` variable: the macros only hand out `#[call_data]` ones.
#[allow(unused_variables)]
fn execute_callable<T>(sbt_index: u32, data: &mut T) {
    #[cfg(target_arch = "spirv")]
    // SAFETY: `data` is the entry point's callable-data variable; the index is
    // checked by the driver against the callable region.
    unsafe {
        core::arch::asm!("OpExecuteCallableKHR {id} {data}", id = in(reg) sbt_index, data = in(reg) data);
    }
    #[cfg(not(target_arch = "spirv"))]
    unreachable!("device programs run on the device")
}

/// Records user exception `code` thrown at `launch_index` in the exception
/// buffer at `slot` of the table (see [`crate::exception`](mod@crate::exception)); returns the
/// exception program's callable index ([`crate::exception::NO_EXCEPTION_PROGRAM`]
/// when the pipeline has none).
#[allow(unused_variables)]
fn throw_exception(table: &mut BufferTable, slot: u32, launch_index: spirv_std::glam::UVec3, code: u32) -> u32 {
    #[cfg(target_arch = "spirv")]
    {
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
            spirv_std::arch::atomic_i_increment::<u32, { spirv_std::memory::Scope::QueueFamily as u32 }, 0>(
                &mut words[0],
            )
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
    #[cfg(not(target_arch = "spirv"))]
    unreachable!("device programs run on the device")
}

/// [`throw_exception`], then the exception program, if the pipeline has one,
/// called with the details through `call` (the entry point's hidden
/// callable-data variable).
fn throw_and_handle(
    table: &mut BufferTable,
    slot: u32,
    launch_index: spirv_std::glam::UVec3,
    code: u32,
    call: &mut crate::exception::ExceptionDetails,
) {
    let handler = throw_exception(table, slot, launch_index, code);
    if handler != crate::exception::NO_EXCEPTION_PROGRAM {
        *call = crate::exception::ExceptionDetails { code, launch_index };
        execute_callable(handler, call);
    }
}

/// Reads element `index` of `buffer` from the bindless table.
///
/// No bounds check in the program: raykit creates every device with
/// `robustBufferAccess2` and `nullDescriptor`, under which a read past the end
/// of the buffer, or through a null or emptied slot, returns zero (see
/// [`Buffer`] for every case). (A check per access, `OpArrayLength` and a
/// branch, made the path tracer run at half the speed of its GLSL twin on an
/// NVIDIA H100.)
#[allow(unused_variables)]
fn load<T: Element>(table: &BufferTable, buffer: Buffer<T>, index: u32) -> T {
    #[cfg(target_arch = "spirv")]
    {
        // SAFETY: `table_index` is below the table's size; every slot holds a
        // buffer or a null descriptor, and an index past a buffer's end is
        // defined under robustBufferAccess2 (above).
        unsafe {
            let words: &[u32] = table.index(buffer.table_index() as usize);
            T::read_unchecked(words, (index * T::WORDS) as usize)
        }
    }
    #[cfg(not(target_arch = "spirv"))]
    unreachable!("device buffers are only reachable on the device")
}

/// Writes element `index` of `buffer` in the bindless table. A write past the
/// end, or through a null slot, is discarded (`robustBufferAccess2`, see [`load`]).
#[allow(unused_variables)]
fn store<T: Element>(table: &mut BufferTable, buffer: Buffer<T>, index: u32, value: T) {
    #[cfg(target_arch = "spirv")]
    {
        // SAFETY: as in `load`.
        unsafe {
            let words: &mut [u32] = table.index_mut(buffer.table_index() as usize);
            value.write_unchecked(words, (index * T::WORDS) as usize)
        }
    }
    #[cfg(not(target_arch = "spirv"))]
    unreachable!("device buffers are only reachable on the device")
}

/// `OpTraceRayKHR` for ray type `R`.
#[allow(unused_variables)]
fn trace<R: RayType>(scene: Traversable, ray: Ray, payload: &mut R::Payload) {
    #[cfg(target_arch = "spirv")]
    {
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
    #[cfg(not(target_arch = "spirv"))]
    unreachable!("tracing needs the device (a CPU backend is future work)")
}
