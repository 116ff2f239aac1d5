use raykit_device::LaunchParams;

#[repr(C)]
#[derive(Copy, Clone, LaunchParams)]
struct Params {
    width: u32,
}

fn main() {}
