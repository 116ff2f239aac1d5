//! Attribute macros for raykit device programs.
//!
//! Each macro wraps a plain Rust function and emits the SPIR-V entry point with
//! OptiX's prefixed name (`__raygen__<name>`, `__miss__<name>`,
//! `__closesthit__<name>`), plus a constant `<NAME>: raykit_device::EntryPoint`
//! through which the host names the program. Use them through `raykit-device`,
//! which re-exports them.
//!
//! The function's parameters are matched by role:
//! * one parameter without a raykit attribute: the stage context
//!   (`&mut Raygen`, `&mut Miss`, `&mut ClosestHit`, or by value);
//! * `#[params] p: &P`: the launch params (push constants);
//! * `#[record] r: &R`: the program's SBT record data;
//! * `#[payload] p: &mut T`: the ray payload (raygen may have several, one per
//!   ray type it traces; miss and closest-hit have at most one).
//!
//! `#[miss(ray = R)]` and `#[closest_hit(ray = R)]` check at compile time that the
//! payload is `<R as RayType>::Payload`.

mod launch_params;
mod program;

use proc_macro::TokenStream;

/// Marks a ray-generation program (`__raygen__<name>`).
#[proc_macro_attribute]
pub fn raygen(attr: TokenStream, item: TokenStream) -> TokenStream {
    program::expand(program::Stage::Raygen, attr.into(), item.into()).into()
}

/// Marks a miss program (`__miss__<name>`). Optional `ray = RayType`.
#[proc_macro_attribute]
pub fn miss(attr: TokenStream, item: TokenStream) -> TokenStream {
    program::expand(program::Stage::Miss, attr.into(), item.into()).into()
}

/// Marks a closest-hit program (`__closesthit__<name>`). Optional `ray = RayType`.
#[proc_macro_attribute]
pub fn closest_hit(attr: TokenStream, item: TokenStream) -> TokenStream {
    program::expand(program::Stage::ClosestHit, attr.into(), item.into()).into()
}

/// Records the layout of a launch-params struct (`#[repr(C)]`, `Copy`,
/// `bytemuck::Pod`) so the host can check it against the SPIR-V. Fields that
/// cannot cross to the device (references, pointers, `bool`, `usize`) are
/// compile errors.
#[proc_macro_derive(LaunchParams)]
pub fn derive_launch_params(item: TokenStream) -> TokenStream {
    launch_params::derive(item.into()).into()
}
