//! User exceptions: OptiX's `optixThrowException` on Vulkan.
//!
//! Vulkan has no exception programs. raykit gives each pipeline a small buffer
//! in the bindless table; a program that calls `ctx.throw_exception(code)`
//! appends `(code, launch index)` to it with an atomic counter, and the host's
//! launch returns what was thrown as `LaunchError::UserExceptions`. The
//! buffer's slot reaches the programs as a specialization constant
//! ([`EXCEPTION_SLOT_SPEC_ID`]) that raykit sets when it links the pipeline.
//!
//! **Trace depth.** A miss or closest-hit program declared for a ray type with
//! [`RayType::CHECK_DEPTH`](crate::RayType::CHECK_DEPTH) knows its trace depth
//! from its incoming payload; when a trace of its would go past the pipeline's
//! `max_trace_depth` (a specialization constant raykit sets,
//! [`MAX_TRACE_DEPTH_SPEC_ID`]), the trace is not made: the program throws
//! [`TRACE_DEPTH_EXCEEDED`] and goes on with the payload as it was, and the
//! host's launch returns `LaunchError::RecursionTooDeep` with the launch
//! indices. Raygen traces at depth 1, which linking checks; callables count as
//! depth 0 (they do not learn their caller's depth), and programs of ray types
//! without the opt-in count as depth 1, so recursion through them is not bounded
//! by this check.
//!
//! What is *not* caught, unlike OptiX: stack overflow, trace-depth overflow
//! through ray types without [`RayType::CHECK_DEPTH`](crate::RayType::CHECK_DEPTH),
//! invalid traversables and out-of-range SBT indices are not observable on
//! Vulkan (they are undefined behaviour there, and validation layers do not see
//! them at run time; raykit checks the SBT indices a scene can reach before each
//! launch instead); and throwing does not end the program — it records the
//! exception and returns, so the program should return after it (in an any-hit
//! program, follow it with `ignore_intersection` or `terminate_ray`).
//!
//! An `#[exception]` program (OptiX's `__exception__`), when the pipeline has
//! one, runs right after each throw from raygen, miss, closest-hit and callable
//! programs, with the [`ExceptionDetails`]: it is a callable program that raykit
//! places at the end of the SBT's callable region. Vulkan forbids calls from
//! any-hit and intersection programs, so their exceptions are only recorded.

pub use raykit_abi::{EXCEPTION_SLOT_SPEC_ID, MAX_TRACE_DEPTH_SPEC_ID};

/// The exception code a miss or closest-hit program throws instead of tracing
/// past the pipeline's `max_trace_depth` (see the [module docs](self)). Codes from
/// [`RESERVED_EXCEPTION_CODES`] up are raykit's: user programs throw codes below.
pub const TRACE_DEPTH_EXCEEDED: u32 = 0xFFFF_FF00;

/// The first exception code reserved by raykit.
pub const RESERVED_EXCEPTION_CODES: u32 = 0xFFFF_FF00;

/// How many exceptions a launch records (later ones are counted, not stored).
pub const EXCEPTION_CAPACITY: u32 = 64;

/// 32-bit words per recorded exception: code, launch index x, y, z.
pub const EXCEPTION_RECORD_WORDS: u32 = 4;

/// Word of the exception buffer holding the exception program's index in the
/// SBT's callable region ([`NO_EXCEPTION_PROGRAM`] when the pipeline has none);
/// word 0 is the counter.
pub const EXCEPTION_HANDLER_WORD: u32 = 1;

/// The first word of the records.
pub const EXCEPTION_RECORDS_WORD: u32 = 2;

/// [`EXCEPTION_HANDLER_WORD`] when there is no exception program.
pub const NO_EXCEPTION_PROGRAM: u32 = u32::MAX;

/// Words of the exception buffer: the counter, the handler, then the records.
pub const EXCEPTION_BUFFER_WORDS: u32 = EXCEPTION_RECORDS_WORD + EXCEPTION_CAPACITY * EXCEPTION_RECORD_WORDS;

/// What an `#[exception]` program is called with: the exception thrown.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct ExceptionDetails {
    /// The code given to `throw_exception`.
    pub code: u32,
    /// The launch index of the invocation that threw it.
    pub launch_index: spirv_std::glam::UVec3,
}
