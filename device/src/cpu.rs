//! The device programs' side of raykit's CPU backend (host targets only).
//!
//! On SPIR-V a program reaches buffers, tracing, callables and exceptions
//! through SPIR-V instructions. Compiled for the host, the same program reaches
//! them through a [`Runtime`]: the CPU backend of the `raykit` crate implements
//! it (its traversal, its buffer table, its exception records) and calls each
//! program through the [`CpuProgram`] the macros emit beside the SPIR-V entry
//! point. Programs and device crates carry no backend `cfg`: the stage contexts
//! ([`crate::Raygen`], …) hold a [`crate::stage::DeviceAccess`], which is this
//! runtime on the host.
//!
//! Values cross the runtime with their type erased ([`Erased`]) and described by
//! a [`TypeInfo`]; the backend hands a payload, record, attribute or callable
//! data only to a program that declared the same type, which is what makes the
//! pointer casts of the generated entry points sound.

use core::marker::PhantomData;
use core::sync::atomic::{AtomicU32, Ordering};

use spirv_std::glam::{UVec3, Vec2, Vec3};

use crate::exception::ExceptionDetails;
use crate::stage::HitBuiltins;
use crate::{Ray, Traversable};

/// The name, size and alignment of a type crossing the runtime: what the CPU
/// backend compares before it hands a value to a program.
#[derive(Copy, Clone)]
pub struct TypeInfo {
    /// `core::any::type_name` of the type (a function: `type_name` is not yet
    /// callable in constants).
    type_name: fn() -> &'static str,
    /// `size_of` of the type.
    pub size: usize,
    /// `align_of` of the type.
    pub align: usize,
}

impl TypeInfo {
    /// The description of `T`.
    pub const fn of<T>() -> TypeInfo {
        TypeInfo {
            type_name: core::any::type_name::<T>,
            size: core::mem::size_of::<T>(),
            align: core::mem::align_of::<T>(),
        }
    }

    /// The type's name.
    pub fn name(&self) -> &'static str {
        (self.type_name)()
    }

    /// An identity of the description: equal identities are the same type
    /// (different ones may still be, when the compiler made several copies of
    /// the name function). What a checker may remember a successful comparison by.
    pub fn identity(&self) -> usize {
        self.type_name as usize
    }
}

impl PartialEq for TypeInfo {
    fn eq(&self, other: &Self) -> bool {
        // The same name function is the same type; else compare the names
        // (one type may have several copies of the function).
        self.size == other.size
            && self.align == other.align
            && (core::ptr::fn_addr_eq(self.type_name, other.type_name) || self.name() == other.name())
    }
}
impl Eq for TypeInfo {}

impl core::fmt::Debug for TypeInfo {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{} ({} bytes, aligned to {})", self.name(), self.size, self.align)
    }
}

/// A `&mut T` with its type erased: a payload or callable data on its way to
/// the program that receives it.
#[derive(Debug)]
pub struct Erased<'a> {
    /// The value's address.
    pub ptr: *mut u8,
    /// The value's type.
    pub ty: TypeInfo,
    _borrow: PhantomData<&'a mut ()>,
}

impl<'a> Erased<'a> {
    /// Erases `value`'s type.
    pub fn of<T>(value: &'a mut T) -> Erased<'a> {
        Erased { ptr: (value as *mut T).cast(), ty: TypeInfo::of::<T>(), _borrow: PhantomData }
    }
}

/// The constants of one `trace::<R>` call: its ray type's flags, cull mask and
/// SBT placement (`OpTraceRayKHR`'s operands).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct TraceCall {
    /// `RayType::FLAGS` as bits.
    pub flags: u32,
    /// `RayType::CULL_MASK`.
    pub cull_mask: u32,
    /// `RayType::SBT_OFFSET`.
    pub sbt_offset: u32,
    /// `RayType::SBT_STRIDE`.
    pub sbt_stride: u32,
    /// `RayType::MISS_INDEX`.
    pub miss_index: u32,
}

/// What a program compiled for the host calls instead of SPIR-V instructions:
/// implemented by raykit's CPU backend, one value per running program.
pub trait Runtime {
    /// The words of the buffer that handle `buffer` names (its slot in the
    /// launch's buffer table): empty for a handle naming no buffer. Programs
    /// read and write them in place, with relaxed atomic accesses; accesses
    /// past the end read zeros and discard writes (the device's
    /// `robustBufferAccess2` rules, see [`crate::Buffer`]).
    fn buffer(&self, buffer: u32) -> &[AtomicU32];
    /// Reads `words.len()` words of buffer handle `buffer` from word
    /// `first_word`: zeros past its end or for a handle naming no buffer.
    fn load(&self, buffer: u32, first_word: u64, words: &mut [u32]) {
        read_words(self.buffer(buffer), first_word, words)
    }
    /// Writes `words` into buffer handle `buffer` from word `first_word`;
    /// words past its end, or for a handle naming no buffer, are discarded.
    fn store(&self, buffer: u32, first_word: u64, words: &[u32]) {
        write_words(self.buffer(buffer), first_word, words)
    }
    /// Traces `ray` into `scene` (`OpTraceRayKHR`); the miss or hit programs
    /// selected by `call` receive `payload`.
    fn trace(&self, scene: Traversable, ray: Ray, call: TraceCall, payload: Erased<'_>);
    /// Runs the callable at `sbt_index` of the callable region with `data`.
    fn call(&self, sbt_index: u32, data: Erased<'_>);
    /// Records user exception `code` at `launch_index`; with
    /// `run_exception_program`, runs the pipeline's exception program too.
    fn throw_exception(&self, launch_index: UVec3, code: u32, run_exception_program: bool);
    /// Reports a hit at `t` with `hit_kind` from an intersection program
    /// (`OpReportIntersectionKHR`); whether it was accepted.
    fn report_intersection(&self, t: f32, hit_kind: u32) -> bool;
    /// Rejects the candidate hit of the running any-hit program; does not return.
    fn ignore_intersection(&self) -> !;
    /// Accepts the candidate hit and ends the traversal; does not return.
    fn terminate_ray(&self) -> !;
    /// Samples texture handle `texture` at `uv` and mip level `lod`
    /// (`OpImageSampleExplicitLod`).
    fn sample_texture(&self, texture: u32, uv: Vec2, lod: f32) -> spirv_std::glam::Vec4;
}

/// The words `first..first + len` of `words`, when all of them exist.
#[inline(always)]
fn whole(words: &[AtomicU32], first: u64, len: usize) -> Option<&[AtomicU32]> {
    let first = usize::try_from(first).ok()?;
    words.get(first..first.checked_add(len)?)
}

/// Reads `out.len()` words of `words` from word `first`: zeros past the end.
#[inline(always)]
pub fn read_words(words: &[AtomicU32], first: u64, out: &mut [u32]) {
    if let Some(inside) = whole(words, first, out.len()) {
        for (o, w) in out.iter_mut().zip(inside) {
            *o = w.load(Ordering::Relaxed);
        }
        return;
    }
    for (i, o) in out.iter_mut().enumerate() {
        *o = usize::try_from(first + i as u64)
            .ok()
            .and_then(|at| words.get(at))
            .map_or(0, |w| w.load(Ordering::Relaxed));
    }
}

/// Writes `data` into `words` from word `first`: words past the end are discarded.
#[inline(always)]
pub fn write_words(words: &[AtomicU32], first: u64, data: &[u32]) {
    if let Some(inside) = whole(words, first, data.len()) {
        for (w, d) in inside.iter().zip(data) {
            w.store(*d, Ordering::Relaxed);
        }
        return;
    }
    for (i, d) in data.iter().enumerate() {
        if let Some(w) = usize::try_from(first + i as u64).ok().and_then(|at| words.get(at)) {
            w.store(*d, Ordering::Relaxed);
        }
    }
}

/// Runs `f` with a zeroed scratch of `T::WORDS` words, for reading or writing
/// one buffer element. The scratch is the smallest of a few sizes that holds
/// them (`T::WORDS` is a constant: the other branches fold away), so a scalar
/// or vector element does not clear a large one.
pub fn with_words<T: crate::Element, R>(f: impl FnOnce(&mut [u32]) -> R) -> R {
    let words = T::WORDS as usize;
    if words <= 4 {
        let mut scratch = [0u32; 4];
        f(&mut scratch[..words])
    } else if words <= 16 {
        let mut scratch = [0u32; 16];
        f(&mut scratch[..words])
    } else if words <= 64 {
        let mut scratch = [0u32; 64];
        f(&mut scratch[..words])
    } else {
        let mut scratch = vec![0u32; words];
        f(&mut scratch)
    }
}

/// One call of a program by the CPU backend: the built-ins of its stage and the
/// addresses of what it receives. Fields that a stage does not have are zero.
pub struct Invocation<'a> {
    /// What the program reaches resources through.
    pub runtime: &'a dyn Runtime,
    /// `launch_id`.
    pub launch_index: UVec3,
    /// `launch_size`.
    pub launch_dimensions: UVec3,
    /// The ray's world origin (miss programs).
    pub world_ray_origin: Vec3,
    /// The ray's world direction (miss programs).
    pub world_ray_direction: Vec3,
    /// The ray and the hit (hit stages; [`HitBuiltins::ZERO`] in others).
    pub hit: &'a HitBuiltins,
    /// The launch params, of the type [`CpuProgram::params`] names.
    pub params: *const u8,
    /// The program's SBT record data, of the type [`CpuProgram::record`] names
    /// (at least that many bytes, aligned to 16).
    pub record: *const u8,
    /// The incoming payload, of the type [`CpuProgram::payload`] names.
    pub payload: *mut u8,
    /// The hit attributes, of the type [`CpuProgram::attributes`] names (the
    /// barycentrics, a `Vec2`, for triangle hits of closest-hit programs that
    /// declare none).
    pub attributes: *mut u8,
    /// A callable's incoming data, of the type [`CpuProgram::callable_data`] names.
    pub callable_data: *mut u8,
    /// The exception (exception programs).
    pub exception: ExceptionDetails,
    /// The trace depth of the ray the program runs for.
    pub depth: u32,
    /// The pipeline's `max_trace_depth`.
    pub max_trace_depth: u32,
    /// The pipeline's specialization constants, by id.
    pub specialization: &'a [(u32, u32)],
}

impl Invocation<'_> {
    /// The value of specialization constant `id`, or `default` when the
    /// pipeline does not set it.
    pub fn spec_constant(&self, id: u32, default: u32) -> u32 {
        self.specialization.iter().find(|(i, _)| *i == id).map_or(default, |(_, v)| *v)
    }

    /// The barycentrics of a triangle hit.
    ///
    /// # Safety
    /// `attributes` points at a `Vec2` (the backend's attribute storage holds one
    /// for every triangle hit, and zeros otherwise).
    pub unsafe fn barycentrics(&self) -> Vec2 {
        // SAFETY: the caller's; the storage is aligned to 16.
        unsafe { *(self.attributes as *const Vec2) }
    }
}

/// A zeroed value of `T`: the CPU backend's stand-in for a payload or callable
/// data variable, which SPIR-V leaves undefined until written.
///
/// # Safety
/// All-zero bytes must be a valid `T` (true of everything a SPIR-V variable can
/// hold: numbers, vectors, arrays and structs of them).
pub unsafe fn zeroed<T>() -> T {
    // SAFETY: the caller's.
    unsafe { core::mem::zeroed() }
}

/// A program compiled for the host, as the CPU backend calls it: the entry
/// function the macros generate and the types it receives.
#[derive(Copy, Clone)]
pub struct CpuProgram {
    /// Calls the program with one invocation's built-ins and data.
    pub run: fn(&mut Invocation<'_>),
    /// The entry-point name, e.g. `__raygen__rg`.
    pub name: &'static str,
    /// The device crate the program is in (`CARGO_PKG_NAME`).
    pub crate_name: &'static str,
    /// The launch params type, for programs with `#[params]`.
    pub params: Option<TypeInfo>,
    /// The SBT record data type, for programs with `#[record]`.
    pub record: Option<TypeInfo>,
    /// The incoming payload type (miss, closest-hit, any-hit).
    pub payload: Option<TypeInfo>,
    /// The hit attributes type, for programs with `#[attributes]`.
    pub attributes: Option<TypeInfo>,
    /// The incoming callable data type (callables).
    pub callable_data: Option<TypeInfo>,
}

impl core::fmt::Debug for CpuProgram {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("CpuProgram")
            .field("name", &self.name)
            .field("crate_name", &self.crate_name)
            .field("params", &self.params)
            .field("record", &self.record)
            .field("payload", &self.payload)
            .field("attributes", &self.attributes)
            .field("callable_data", &self.callable_data)
            .finish_non_exhaustive()
    }
}
