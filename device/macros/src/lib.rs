//! Attribute macros for raykit device programs.
//!
//! Each macro wraps a plain Rust function and emits the SPIR-V entry point with
//! OptiX's prefixed name (`__raygen__<name>`, `__miss__<name>`,
//! `__closesthit__<name>`), plus a constant `<NAME>: raykit_device::EntryPoint`
//! through which the host names the program. Use them through `raykit-device`
//! or `raykit` (as `raykit::device`), which re-export them: the generated code
//! names whichever of the two the calling crate depends on.
//!
//! The function's parameters are matched by role:
//! * one parameter without a raykit attribute: the stage context
//!   (`&mut Raygen`, `&mut Miss`, `&mut ClosestHit`, or by value);
//! * `#[params] p: &P`: the launch params (push constants);
//! * `#[record] r: &R`: the program's SBT record data;
//! * `#[payload] p: &mut T`: the ray payload (raygen may have several, one per
//!   ray type it traces; miss, closest-hit and any-hit have one incoming);
//! * `#[trace_payload] p: &mut T`: an outgoing payload, for `trace` in miss,
//!   closest-hit and continuation-callable programs;
//! * `#[call_data] d: &mut T`: outgoing data for `call` (callables);
//! * `#[callable_data] d: &mut T`: a callable program's incoming data;
//! * `#[attributes] a: &mut T` (intersection) / `a: &T` (any-hit, closest-hit):
//!   typed hit attributes;
//! * `#[spec_constant(id = N, default = D)] x: u32`: a specialization constant
//!   (OptiX's bound launch-params values), set per pipeline by the host.
//!
//! `#[miss(ray = R)]`, `#[closest_hit(ray = R)]` and `#[any_hit(ray = R)]` check at
//! compile time that the payload is `<R as RayType>::Payload`. A role a stage
//! cannot have (a payload in an intersection program, tracing from a direct
//! callable) is a compile error that says so.

#![forbid(unsafe_code)]

mod launch_params;
mod program;
mod root;

use proc_macro::TokenStream;
use raykit_abi::ProgramPrefix;

/// Marks a ray-generation program (`__raygen__<name>`).
#[proc_macro_attribute]
pub fn raygen(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::Raygen, attr.into(), item.into())).into()
}

/// Marks a miss program (`__miss__<name>`). Optional `ray = RayType`.
#[proc_macro_attribute]
pub fn miss(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::Miss, attr.into(), item.into())).into()
}

/// Marks a closest-hit program (`__closesthit__<name>`). Optional `ray = RayType`.
#[proc_macro_attribute]
pub fn closest_hit(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::ClosestHit, attr.into(), item.into())).into()
}

/// Marks an any-hit program (`__anyhit__<name>`). Optional `ray = RayType`.
#[proc_macro_attribute]
pub fn any_hit(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::AnyHit, attr.into(), item.into())).into()
}

/// Marks an intersection program (`__intersection__<name>`).
#[proc_macro_attribute]
pub fn intersection(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::Intersection, attr.into(), item.into())).into()
}

/// Marks a direct callable (`__direct_callable__<name>`): may not trace.
#[proc_macro_attribute]
pub fn direct_callable(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::DirectCallable, attr.into(), item.into())).into()
}

/// Marks a continuation callable (`__continuation_callable__<name>`): may trace.
#[proc_macro_attribute]
pub fn continuation_callable(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::ContinuationCallable, attr.into(), item.into())).into()
}

/// Marks an exception program (`__exception__<name>`), run after a user
/// exception is thrown (see `raykit_device::exception`).
#[proc_macro_attribute]
pub fn exception(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::Exception, attr.into(), item.into())).into()
}

/// Records the layout of a launch-params struct (`#[repr(C)]`, `Copy`,
/// `bytemuck::Pod`) so the host can check it against the SPIR-V. Fields that
/// cannot cross to the device (references, pointers, `bool`, `usize`) are
/// compile errors.
#[proc_macro_derive(LaunchParams)]
pub fn derive_launch_params(item: TokenStream) -> TokenStream {
    root::resolve(launch_params::derive(item.into())).into()
}

/// Records the layout of an SBT record data struct (`#[repr(C)]`, `Copy`, every
/// field a device type, no padding) and makes it `raykit_device::SbtRecordData`:
/// every launch then checks the `Buffer<T>` and `Traversable` fields of records of
/// this type against the context's live objects. Derive it *instead of*
/// `bytemuck::Pod` (every `Pod` type is record data already, unchecked).
#[proc_macro_derive(SbtRecordData)]
pub fn derive_sbt_record_data(item: TokenStream) -> TokenStream {
    root::resolve(launch_params::derive_record(item.into())).into()
}
