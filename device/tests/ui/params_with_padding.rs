use raykit_device::LaunchParams;

#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
struct Params {
    count: u32,
    handle: u64,
}

fn main() {}
