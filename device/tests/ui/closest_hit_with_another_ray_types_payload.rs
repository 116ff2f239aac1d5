#![allow(unexpected_cfgs)] // spirv-std's entry-point attribute tests target_arch = "spirv"
use raykit_device::glam::Vec3;
use raykit_device::{closest_hit, ClosestHit, RayType};

struct Radiance;
impl RayType for Radiance {
    type Payload = Vec3;
    const SBT_OFFSET: u32 = 0;
    const SBT_STRIDE: u32 = 2;
    const MISS_INDEX: u32 = 0;
}

struct Shadow;
impl RayType for Shadow {
    type Payload = u32;
    const SBT_OFFSET: u32 = 1;
    const SBT_STRIDE: u32 = 2;
    const MISS_INDEX: u32 = 1;
}

// A radiance program that takes the shadow ray type's payload.
#[closest_hit(ray = Radiance)]
fn shade(_ctx: &mut ClosestHit, #[payload] visible: &mut <Shadow as RayType>::Payload) {
    *visible = 0;
}

fn main() {}
