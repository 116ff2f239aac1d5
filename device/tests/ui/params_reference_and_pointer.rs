use raykit_device::LaunchParams;

#[repr(C)]
#[derive(Copy, Clone, LaunchParams)]
struct Params {
    data: &'static [f32; 4],
}

#[repr(C)]
#[derive(Copy, Clone, LaunchParams)]
struct Raw {
    data: *const f32,
    count: usize,
}

fn main() {}
