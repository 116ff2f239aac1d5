use raykit_device::glam::Vec4;
use raykit_device::{Buffer, SbtRecordData};

// Deriving both: `Pod` already makes the type record data, without handle checks.
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, SbtRecordData)]
struct Material {
    colors: Buffer<Vec4>,
    index: u32,
}

fn main() {}
