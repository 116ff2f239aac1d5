#![allow(unexpected_cfgs)] // spirv-std's entry-point attribute tests target_arch = "spirv"
use raykit_device::glam::Vec3;
use raykit_device::{direct_callable, intersection, DirectCallable, Intersection};

// A direct callable may not trace rays.
#[direct_callable]
fn dc(_ctx: &mut DirectCallable, #[trace_payload] _p: &mut Vec3) {}

// An intersection program has no payload.
#[intersection]
fn is(_ctx: &mut Intersection, #[payload] _p: &mut Vec3) {}

fn main() {}
