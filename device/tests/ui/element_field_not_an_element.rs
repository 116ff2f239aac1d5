use raykit_device::glam::Vec3A;
use raykit_device::Element;

#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, Element)]
struct Light {
    position: Vec3A,
}

#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, Element)]
struct Flag {
    on: bool,
}

#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, Element)]
#[repr(transparent)]
struct NotReprC {
    value: u32,
}

fn main() {}
