use raykit_device::LaunchParams;

/// Pod, but not a device type: it does not derive LaunchParams.
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
struct Material {
    albedo: [f32; 3],
}

#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
struct Params {
    material: Material,
    scale: f64,
}

fn main() {}
