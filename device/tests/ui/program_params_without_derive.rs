#![allow(unexpected_cfgs)] // spirv-std's entry-point attribute tests target_arch = "spirv"
use raykit_device::{raygen, Raygen};

#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
}

#[raygen]
fn rg(_ctx: &mut Raygen, #[params] _p: &Params) {}

fn main() {}
