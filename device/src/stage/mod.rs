//! Stage contexts: what each program kind may call.
//!
//! Vulkan allows each ray-tracing stage a different set of built-ins and
//! instructions (a miss program has no barycentrics; only raygen, miss and
//! closest-hit may trace). Each context type exposes exactly its stage's share.
//! The macros build the context from the entry point's built-ins and hand it to
//! the user's function, so programs never touch free-standing globals: that keeps
//! the door open for running the same programs on a CPU backend.

mod closest_hit;
mod miss;
mod raygen;

pub use closest_hit::ClosestHit;
pub use miss::Miss;
pub use raygen::Raygen;

use crate::{Buffer, BufferTable, Element, Ray, RayType, Traversable};

/// Reads element `index` of `buffer` from the bindless table.
#[allow(unused_variables)]
fn load<T: Element>(table: &BufferTable, buffer: Buffer<T>, index: u32) -> T {
    #[cfg(target_arch = "spirv")]
    {
        // SAFETY: the host fills every slot that a live `Buffer` handle names.
        let words: &[u32] = unsafe { table.index(buffer.table_index() as usize) };
        T::read(words, (index * T::WORDS) as usize)
    }
    #[cfg(not(target_arch = "spirv"))]
    unreachable!("device buffers are only reachable on the device")
}

/// Writes element `index` of `buffer` in the bindless table.
#[allow(unused_variables)]
fn store<T: Element>(table: &mut BufferTable, buffer: Buffer<T>, index: u32, value: T) {
    #[cfg(target_arch = "spirv")]
    {
        // SAFETY: the host fills every slot that a live `Buffer` handle names.
        let words: &mut [u32] = unsafe { table.index_mut(buffer.table_index() as usize) };
        value.write(words, (index * T::WORDS) as usize);
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
