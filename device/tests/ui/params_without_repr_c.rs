use raykit_device::LaunchParams;

#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
struct Params {
    width: u32,
}

fn main() {}
