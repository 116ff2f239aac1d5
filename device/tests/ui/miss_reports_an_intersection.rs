#![allow(unexpected_cfgs)] // spirv-std's entry-point attribute tests target_arch = "spirv"
use raykit_device::glam::Vec3;
use raykit_device::{miss, Miss};

#[miss]
fn ms(ctx: &mut Miss, #[payload] color: &mut Vec3) {
    *color = Vec3::ZERO;
    ctx.report_intersection(1.0, 0);
}

fn main() {}
