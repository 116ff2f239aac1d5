//! User exceptions: OptiX's `optixThrowException` on Vulkan.
//!
//! Vulkan has no exception programs. raykit gives each pipeline a small buffer
//! in the bindless table; a program that calls `ctx.throw_exception(code)`
//! appends `(code, launch index)` to it with an atomic counter, and the host's
//! launch returns what was thrown as `raykit::Error::UserExceptions`. The
//! buffer's slot reaches the programs as a specialization constant
//! ([`EXCEPTION_SLOT_SPEC_ID`]) that raykit sets when it links the pipeline.
//!
//! What is *not* caught, unlike OptiX: stack overflow, trace-depth overflow,
//! invalid traversables and out-of-range SBT indices are not observable on
//! Vulkan (they are undefined behaviour there, and validation layers do not see
//! them at run time); and throwing does not end the program — it records the
//! exception and returns, so the program should return after it (in an any-hit
//! program, follow it with `ignore_intersection` or `terminate_ray`).
//!
//! An `#[exception]` program (OptiX's `__exception__`), when the pipeline has
//! one, runs right after each throw from raygen, miss, closest-hit and callable
//! programs, with the [`ExceptionDetails`]: it is a callable program that raykit
//! places at the end of the SBT's callable region. Vulkan forbids calls from
//! any-hit and intersection programs, so their exceptions are only recorded.

pub use raykit_abi::EXCEPTION_SLOT_SPEC_ID;

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
