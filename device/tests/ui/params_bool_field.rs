use raykit_device::LaunchParams;

#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
struct Params {
    enabled: bool,
}

fn main() {}
